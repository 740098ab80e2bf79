// Engines on a forward-dynamics case against its exact simulation: per engine setting and time
// step, the worst % of each quantity class over the run and at its end (the comparator's own
// metrics, compare_methods()), the worst position difference in metres, the energy balance's
// drift, flagged samples, the wall time (median of --repeat runs) and the CPU time per step of
// the stepping thread (median). Prints CSV
// (docs/dynamics.md, "Engines"). Run from the source root:
//   build/bench/dynamics_accuracy [FILE] [--repeat N] [--engine mujoco|bullet] [--variant NAME]
//                                 [--dt DT]
// FILE defaults to mechanisms/iftomm_a02_double_fourbar.toml.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "analytic/model/loader.h"
#include "compare/comparison.h"
#include "compare/tolerance.h"
#include "methods/engines.h"
#include "methods/registry.h"

namespace {

using namespace crosslink;
using crosslink::sim::Settings;

struct Case {
  std::string engine, variant;
  Settings settings;
};

std::vector<Case> cases() {
  std::vector<Case> out;
  for (const char* integrator : {"Euler", "implicit", "RK4"})
    out.push_back({"mujoco", integrator, {{"integrator", integrator}}});
  out.push_back({"mujoco", "Euler, start exact", {{"start", "exact"}}});
  out.push_back({"bullet", "rigid", {}});
  out.push_back({"bullet", "rigid, start exact", {{"start", "exact"}}});
  out.push_back({"bullet", "multibody", {{"formulation", "multibody"}}});
  return out;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  std::string file = "mechanisms/iftomm_a02_double_fourbar.toml";
  int repeat = 1;
  std::string only, variant;
  std::vector<std::string> dts = {"auto", "2e-3", "1e-3", "5e-4", "2.5e-4", "1.25e-4"};
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--repeat") && i + 1 < argc)
      repeat = std::stoi(argv[++i]);
    else if (!std::strcmp(argv[i], "--engine") && i + 1 < argc)
      only = argv[++i];
    else if (!std::strcmp(argv[i], "--variant") && i + 1 < argc)
      variant = argv[++i];
    else if (!std::strcmp(argv[i], "--dt") && i + 1 < argc)
      dts = {argv[++i]};
    else
      file = argv[i];
  }
  const Mechanism m = load_mechanism(file);
  const compare::MethodRun reference = methods::run_reference(m);
  const compare::Tolerances tolerances = methods::default_tolerances(m);
  const int last = reference.trajectory.samples() - 1;
  fmt::print(
      "engine,variant,dt,ok,flagged,wall_s,max_pct_position,max_pct_velocity,"
      "max_pct_acceleration,max_pct_force,max_pct_energy,end_pct_position,max_position_m,"
      "max_energy_error_J,cpu_us_per_step,steps,message\n");
  for (const Case& c : cases()) {
    if ((!only.empty() && c.engine != only) || (!variant.empty() && c.variant != variant)) continue;
    for (const std::string& dt : dts) {
      Settings settings = c.settings;
      if (dt != "auto") settings.push_back({"dt", dt});
      std::vector<double> walls, step_cpus;
      compare::MethodRun run;
      for (int r = 0; r < repeat; ++r) {
        run = methods::run_method(c.engine, m, reference, settings);
        walls.push_back(run.cost.wall_seconds);
        if (run.cost.steps > 0)
          step_cpus.push_back(run.cost.cpu_seconds_per_cycle * run.cost.simulated_seconds /
                              static_cast<double>(run.cost.steps));
      }
      int flagged = 0;
      for (PoseStatus s : run.trajectory.status) flagged += usable(s) ? 0 : 1;
      std::string dt_used = dt;
      for (const auto& [k, v] : run.settings)
        if (k == "dt") dt_used = v;
      const compare::Comparison cmp = methods::compare_runs(m, {reference, run}, tolerances);
      double worst[7] = {0, 0, 0, 0, 0, 0, 0};
      double end_position = 0.0, metres = 0.0;
      for (const compare::ChannelResult& ch : cmp.channels) {
        const auto q = static_cast<size_t>(ch.metrics.quantity);
        worst[q] = std::max(worst[q], ch.metrics.max_pct_of_peak);
        if (ch.metrics.quantity == Quantity::position) {
          metres = std::max(metres, ch.metrics.max_abs);
          if (ch.metrics.in_verdict[static_cast<size_t>(last)])
            end_position = std::max(end_position, std::abs(ch.metrics.pct_of_peak(last)));
        }
      }
      const double energy_error =
          run.trajectory.has_energy ? run.trajectory.energy.col(3).cwiseAbs().maxCoeff() : 0.0;
      std::string message = run.message;
      std::replace(message.begin(), message.end(), ',', ';');
      fmt::print(
          "{},{},{},{},{},{:.4f},{:.3g},{:.3g},{:.3g},{:.3g},{:.3g},{:.3g},{:.3g},{:.3g},{:.4g},{},"
          "{}\n",
          c.engine, c.variant, dt_used, run.ok ? 1 : 0, flagged, median(walls),
          std::max(worst[0], worst[1]), worst[2], worst[3], std::max(worst[4], worst[5]), worst[6],
          end_position, metres, energy_error, 1e6 * median(step_cpus), run.cost.steps,
          message.substr(0, 120));
      std::fflush(stdout);
    }
  }
}
