// Engine forces against the exact kinetostatics: the driver's effort, every joint's reaction and
// the shaking force of each engine, worst % of the exact value's peak (sim::force_agreement), and
// the wall time per simulated cycle, for every kinematic mechanisms/*.toml and
// mechanisms/published/*.toml without and with gravity, at the
// defaults and over the stabilisation and the step. Prints CSV (docs/engines-measured.md,
// "Forces"). Run from the source root:
//   build/bench/force_accuracy            defaults only
//   build/bench/force_accuracy --sweep    also the stabilisation and step series
//   build/bench/force_accuracy --sweep fourbar_crank_rocker
//                                         one mechanism (the four engines' chart,
//                                         docs/engines-measured.md)
#include <fmt/format.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/bullet/bullet_engine.h"
#include "sim/forces.h"
#include "sim/mujoco/mujoco_engine.h"
#include "sim/ode/ode_engine.h"
#include "sim/simbody/simbody_engine.h"

namespace {

using crosslink::Mechanism;
using crosslink::Trajectory;
using crosslink::sim::Settings;

struct Case {
  std::string engine, label;
  Settings settings;
};

std::vector<Case> cases(bool sweep) {
  std::vector<Case> out = {{"mujoco", "default", {}},
                           {"bullet", "default", {}},
                           {"ode", "default", {}},
                           {"simbody", "default", {}}};
  if (!sweep) return out;
  // Simbody: the spacing of its reported poses (max_step_angle; its integrator steps to each,
  // with steps of its own in between under its error control): its error falls at fourth order
  // in it (measured: docs/engines-measured.md, "Four engines side by side").
  for (const char* angle : {"0.01", "0.005", "0.00125"})
    out.push_back(
        {"simbody", fmt::format("max_step_angle {}", angle), {{"max_step_angle", angle}}});
  // ODE: the step, its iterative solver, the ODE defaults it departs from (watches opened).
  for (const char* steps : {"1", "4", "8", "16"})
    out.push_back(
        {"ode", fmt::format("steps_per_sample {}", steps), {{"steps_per_sample", steps}}});
  const Settings open_ode = {{"driver_threshold", "1"}, {"gap_threshold", "1"}};
  for (const auto& [label, setting] : std::vector<std::pair<std::string, Settings>>{
           {"quick 20", {{"stepper", "quick"}}},
           {"quick 100", {{"stepper", "quick"}, {"iterations", "100"}}},
           {"erp 0.2", {{"erp", "0.2"}}},
           {"cfm 1e-5", {{"cfm", "1e-5"}}},
           {"finite_rotation 0", {{"finite_rotation", "0"}}}}) {
    Settings s = open_ode;
    s.insert(s.end(), setting.begin(), setting.end());
    out.push_back({"ode", label, s});
  }
  out.push_back({"mujoco", "force_read raw", {{"force_read", "raw"}}});
  for (const char* angle : {"0.01", "0.005", "0.00125", "0.000625"}) {
    out.push_back({"mujoco", fmt::format("max_step_angle {}", angle), {{"max_step_angle", angle}}});
    out.push_back({"mujoco",
                   fmt::format("raw; max_step_angle {}", angle),
                   {{"max_step_angle", angle}, {"force_read", "raw"}}});
  }
  // Stabilisation: the watch thresholds opened so that a soft run goes on and is measured.
  const Settings open_mj = {{"driver_threshold", "1"}, {"gap_threshold", "1"}};
  for (const char* solref : {"@2dt", "@4dt", "0.02 1"}) {
    Settings s = open_mj;
    s.push_back({"solref", solref});
    s.push_back({"driver_solref", solref});
    out.push_back({"mujoco", fmt::format("solref {}", solref), s});
  }
  for (const char* solimp : {"0.99 0.99 0.001", "0.999 0.999 0.001", "0.99999 0.99999 0.001"}) {
    Settings s = open_mj;
    s.push_back({"solimp", solimp});
    s.push_back({"driver_solimp", solimp});
    out.push_back({"mujoco", fmt::format("solimp {}", solimp), s});
  }
  for (const char* steps : {"1", "4", "8", "16"})
    out.push_back(
        {"bullet", fmt::format("steps_per_sample {}", steps), {{"steps_per_sample", steps}}});
  const Settings open_bt = {{"driver_threshold", "1"}, {"gap_threshold", "1"}};
  for (const char* steps : {"2", "8"}) {
    for (const char* erp : {"0.2", "0.5", "0.8", "0.95"}) {
      Settings s = open_bt;
      s.push_back({"erp", erp});
      s.push_back({"steps_per_sample", steps});
      out.push_back({"bullet", fmt::format("erp {}; steps_per_sample {}", erp, steps), s});
      s.push_back({"split_impulse", "1"});
      out.push_back(
          {"bullet", fmt::format("erp {} split impulse; steps_per_sample {}", erp, steps), s});
    }
    Settings si = open_bt;
    si.push_back({"solver", "sequential_impulse"});
    si.push_back({"iterations", "100"});
    si.push_back({"steps_per_sample", steps});
    out.push_back(
        {"bullet", fmt::format("sequential impulse 100; steps_per_sample {}", steps), si});
  }
  return out;
}

std::string setting(const Settings& s, const std::string& name) {
  for (const auto& [n, v] : s)
    if (n == name) return v;
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  const bool sweep = argc > 1 && std::strcmp(argv[1], "--sweep") == 0;
  const std::string only = argc > 2 ? argv[2] : "";  // one mechanism's stem
  // The kinematic definitions (a dynamics case's forces are compared along its forward
  // dynamics: bench/dynamics_accuracy), bundled and published.
  std::vector<std::pair<std::filesystem::path, Mechanism>> files;
  for (const char* folder : {"mechanisms", "mechanisms/published"})
    for (const auto& e : std::filesystem::directory_iterator(folder))
      if (e.path().extension() == ".toml" && (only.empty() || e.path().stem() == only))
        if (Mechanism m = crosslink::load_mechanism(e.path().string()); !m.dynamics)
          files.emplace_back(e.path(), std::move(m));
  std::sort(files.begin(), files.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  fmt::print(
      "engine,mechanism,gravity,setting,dt,steps,effort_pct,reaction_pct,worst_joint,couple_pct,"
      "shaking_pct,s_per_cycle,note,cpu_s_per_cycle\n");
  for (const auto& [path, defined] : files)
    for (const bool gravity : {false, true}) {
      Mechanism m = defined;
      if (gravity) m.gravity = Eigen::Vector2d(0.0, -9.81);
      const Trajectory exact = crosslink::sweep(m);
      for (const Case& c : cases(sweep)) {
        // The series on one mechanism, with gravity.
        if (c.label != "default" && (path.stem() != "fourbar_crank_rocker" || !gravity)) continue;
        const auto engine = c.engine == "mujoco"    ? crosslink::sim::make_mujoco_engine()
                            : c.engine == "ode"     ? crosslink::sim::make_ode_engine()
                            : c.engine == "simbody" ? crosslink::sim::make_simbody_engine()
                                                    : crosslink::sim::make_bullet_engine();
        if (!engine->supports(m, nullptr)) continue;
        Settings settings = c.settings;
        // "@2dt", "@4dt": MuJoCo's time-constant solref (n dt, 1) at the default step.
        for (auto& [name, value] : settings)
          if (value[0] == '@') {
            const crosslink::sim::EngineRun probe = engine->run(m, exact, {});
            value = fmt::format(
                "{:.9g} 1", std::stod(value.substr(1)) * std::stod(setting(probe.settings, "dt")));
          }
        const crosslink::sim::EngineRun run = engine->run(m, exact, settings);
        const crosslink::sim::ForceAgreement a =
            crosslink::sim::force_agreement(m, exact, run.trajectory);
        std::string note = run.ok ? "" : "not ok";
        if (!run.trajectory.has_forces) note = "no forces";
        fmt::print("{},{},{},{},{},{},{:.3g},{:.3g},{},{:.3g},{:.3g},{:.4f},{},{:.4g}\n", c.engine,
                   path.stem().string(), gravity ? 1 : 0, c.label, setting(run.settings, "dt"),
                   run.cost.steps, 100 * a.effort, 100 * a.reaction, a.worst_joint, 100 * a.couple,
                   100 * a.shaking, run.cost.wall_seconds_per_cycle, note,
                   run.cost.cpu_seconds_per_cycle);
        std::fflush(stdout);
      }
    }
}
