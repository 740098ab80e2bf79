// Gear couplings in the engines against the exact solution: for each gear pair or rack of
// mechanisms/gears/*.toml, how far each engine that realises it holds the coupling (the drift,
// sim::gearing_agreement) and reads its mesh force (% of the exact peak), with the driver's
// effort and the worst joint reaction (sim::force_agreement), against the step. Prints CSV
// (docs/engines-measured.md, "Gear couplings: drift and mesh force against the step"). Run from the
// source root, optionally with the engines to run (default: all four):
//   build/bench/gear_accuracy > docs/data/gear_accuracy.csv
//   build/bench/gear_accuracy bullet
// A run whose forces are not read (Bullet's multibody) has its force columns empty.
#include <fmt/format.h>

#include <algorithm>
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

std::string setting(const Settings& s, const std::string& name) {
  for (const auto& [n, v] : s)
    if (n == name) return v;
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> engines(argv + 1, argv + argc);
  if (engines.empty()) engines = {"mujoco", "simbody", "bullet", "ode"};
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator("mechanisms/gears"))
    if (e.path().extension() == ".toml") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  fmt::print(
      "engine,mechanism,gearing,max_step_angle,dt,steps,drift,drift_unit,mesh_pct,effort_pct,"
      "reaction_pct,worst_joint,cpu_s_per_cycle,note\n");
  // The step through max_step_angle, the most a link turns in a step [rad] (the default 0.0025),
  // over a decade and a half either way.
  const std::vector<std::string> angles = {"0.02",   "0.01",    "0.005",
                                           "0.0025", "0.00125", "0.000625"};
  for (const auto& path : files) {
    const Mechanism m = crosslink::load_mechanism(path.string());
    const Trajectory exact = crosslink::sweep(m);
    for (const std::string& name : engines) {
      const auto engine = name == "mujoco"    ? crosslink::sim::make_mujoco_engine()
                          : name == "ode"     ? crosslink::sim::make_ode_engine()
                          : name == "simbody" ? crosslink::sim::make_simbody_engine()
                                              : crosslink::sim::make_bullet_engine();
      std::string why;
      if (!engine->supports(m, &why)) {
        fmt::print("{},{},,,,,,,,,,,,\"refused: {}\"\n", name, path.stem().string(), why);
        continue;
      }
      // The step series, and for MuJoCo the coupling's stabilisation at the default step: the
      // loop constraints' deadbeat solref it shares (the default) against a time constant of two
      // steps, (2 dt, 1), with the watches opened so that a soft run goes on and is measured.
      std::vector<std::pair<std::string, Settings>> cases;
      for (const std::string& angle : angles) cases.push_back({angle, {{"max_step_angle", angle}}});
      if (name == "mujoco") {
        const crosslink::sim::EngineRun probe = engine->run(m, exact, {});
        const std::string dt = setting(probe.settings, "dt");
        cases.push_back({"0.0025 solref 2dt",
                         {{"solref", fmt::format("{:.9g} 1", 2 * std::stod(dt))},
                          {"gap_threshold", "1"},
                          {"driver_threshold", "1"}}});
      }
      for (const auto& [angle, settings] : cases) {
        const crosslink::sim::EngineRun run = engine->run(m, exact, settings);
        const crosslink::sim::ForceAgreement f =
            crosslink::sim::force_agreement(m, exact, run.trajectory);
        for (size_t ji = 0; ji < m.joints.size(); ++ji) {
          const crosslink::Joint& j = m.joints[ji];
          if (!j.is_gearing()) continue;
          const crosslink::sim::GearingAgreement g =
              crosslink::sim::gearing_agreement(m, exact, run.trajectory, static_cast<int>(ji));
          const auto pct = [&](double v) {
            return f.compared > 0 ? fmt::format("{:.3g}", 100 * v) : std::string();
          };
          fmt::print("{},{},{},{},{},{},{:.3g},{},{},{},{},{},{:.4g},{}\n", name,
                     path.stem().string(), j.name, angle, setting(run.settings, "dt"),
                     run.cost.steps, g.drift, j.type == crosslink::JointType::gear ? "rad" : "m",
                     g.mesh ? fmt::format("{:.3g}", 100 * *g.mesh) : "", pct(f.effort),
                     pct(f.reaction), f.worst_joint, run.cost.cpu_seconds_per_cycle,
                     run.ok ? "" : "not ok");
          std::fflush(stdout);
        }
      }
    }
  }
}
