// Both engines on a loaded dynamics case against the exact simulation: IFToMM A02 with N = 2
// (docs/dynamics.md) plus an applied effort growing over time on the first crank, a spring and
// damper from the ground to the first coupler, a torque table over the coordinate on the last
// crank and a constant force on the last coupler. What the free A02 cannot check: the effort's
// sign and lever (DynamicsLoads: effort times the driver's row of the constraint Jacobian), the
// loads evaluated at the engine's own state (MuJoCo's control callback, Bullet before each step),
// and the work in the energy balance (the engine's energy.error stays small only if the work of
// the effort, loads and damper is counted right).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "sim/bullet/bullet_engine.h"
#include "sim/mujoco/mujoco_engine.h"
#include "sim/ode/ode_engine.h"

namespace crosslink::sim {
namespace {

std::string source_text(const std::string& relative) {
  std::ifstream in(std::string(CROSSLINK_SOURCE_DIR) + "/" + relative);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

Mechanism load_text(const std::string& text, const char* name) {
  const std::filesystem::path path = std::filesystem::temp_directory_path() / name;
  std::ofstream(path) << text;
  return load_mechanism(path.string());
}

Mechanism loaded_a02() {
  std::stringstream text;
  text << source_text("mechanisms/iftomm_a02_double_fourbar.toml")
       << "effort_table = [[0, 0], [2, 6]]   # N m on crank0, growing (the [dynamics] table)\n"
          "\n[[spring]]\nlinks = [\"ground\", \"coupler1\"]\npoints = [\"A2\", \"B0\"]\n"
          "stiffness = 20\nfree_length = 1.5\ndamping = 0.8\n"
          "\n[[load]]\nlink = \"crank2\"\ntorque_table = [[0, 1], [180, -1], [360, 1]]\n"
          "\n[[load]]\nlink = \"coupler2\"\npoint = \"B2\"\nforce = [2, -1]\n";
  return load_text(text.str(), "crosslink_loaded_a02.toml");
}

struct Agreement {
  double position = 0.0, work = 0.0, balance = 0.0, work_scale = 0.0;
};

// The exact simulation's trajectory with its energy balance as the engines write theirs.
Trajectory reference_of(const Simulation& exact) {
  Trajectory ref = exact.trajectory;
  ref.add_energy();
  for (int k = 0; k < ref.samples(); ++k)
    ref.energy.row(k) << exact.kinetic(k), exact.potential(k), exact.work(k),
        exact.kinetic(k) + exact.potential(k) - exact.work(k) - exact.initial_energy;
  return ref;
}

std::unique_ptr<Engine> engine_named(const std::string& name) {
  return name == "mujoco" ? make_mujoco_engine()
         : name == "ode"  ? make_ode_engine()
                          : make_bullet_engine();
}

Agreement agreement(const Trajectory& ref, const Trajectory& run) {
  Agreement a;
  for (int i = 0; i < ref.samples(); ++i) {
    if (!usable(ref.status[static_cast<size_t>(i)]) || !usable(run.status[static_cast<size_t>(i)]))
      continue;
    for (Eigen::Index p = 0; p < ref.x.cols(); ++p)
      a.position =
          std::max(a.position, std::hypot(run.x(i, p) - ref.x(i, p), run.y(i, p) - ref.y(i, p)));
    a.work = std::max(a.work, std::abs(run.energy(i, 2) - ref.energy(i, 2)));
    a.balance = std::max(a.balance, std::abs(run.energy(i, 3)));
  }
  a.work_scale = run.energy.col(2).cwiseAbs().maxCoeff();
  return a;
}

TEST(EngineDynamicsLoads, EffortLoadsSpringsAndWorkAgreeWithTheExactSimulation) {
  const Mechanism m = loaded_a02();
  const Simulation exact = simulate(m, {.duration = 2.0});
  ASSERT_TRUE(exact.ok) << exact.message;
  const Trajectory ref = reference_of(exact);
  // Bounds: 3 times what was measured over 2 s at each engine's default step (positions [m], the
  // work channel's difference and the engine's own balance [J], of 21 J of work): MuJoCo Euler
  // 8.1e-5, 7.5e-4, 1.6e-3; RK4 8.7e-7, 2.2e-5, 3.7e-5 (its stages see their own loads: held
  // over the step it would be first order, as Euler); Bullet rigid 1.9e-4, 7.4e-4, 2.6e-3;
  // multibody 2.0e-4, 7.7e-4, 2.6e-3 (loads held over each step); ODE 1.9e-4, 7.3e-4, 2.6e-3 (as
  // Bullet's rigid bodies: the same discretisation).
  struct Case {
    const char* engine;
    Settings settings;
    double position, work, balance;
  };
  for (const Case& c : {Case{"mujoco", {}, 2.5e-4, 2.3e-3, 5e-3},
                        Case{"mujoco", {{"integrator", "RK4"}}, 2.6e-6, 6.6e-5, 1.1e-4},
                        Case{"bullet", {}, 5.7e-4, 2.2e-3, 7.7e-3},
                        Case{"bullet", {{"formulation", "multibody"}}, 6e-4, 2.3e-3, 7.9e-3},
                        Case{"ode", {}, 5.7e-4, 2.2e-3, 7.7e-3}}) {
    const EngineRun r = engine_named(c.engine)->run(m, exact.trajectory, c.settings);
    ASSERT_TRUE(r.ok) << c.engine << ": " << r.message;
    const Agreement a = agreement(ref, r.trajectory);
    std::printf("[ loaded A02, %s %s ] positions %.2e m, work %.2e J of %.3g J, balance %.2e J\n",
                c.engine, c.settings.empty() ? "" : c.settings[0].second.c_str(), a.position,
                a.work, a.work_scale, a.balance);
    EXPECT_LT(a.position, c.position) << c.engine;
    EXPECT_LT(a.work, c.work) << c.engine;
    EXPECT_LT(a.balance, c.balance) << c.engine;
    EXPECT_GT(a.work_scale, 10.0);  // the effort and loads do work: the case tests something
  }
}

// Several free coordinates: Constans and Dyer's five-bar falling under gravity with a torque
// table on each crank ([dynamics.left], [dynamics.right]). Each engine's scene leaves both cranks
// free and the run loop puts each coordinate's effort along its own driver's row: with only the
// first applied (the one-coordinate loop's), the second effort's work (about a third of the
// total) would be missing from the motion and from the work channel.
TEST(EngineDynamicsLoads, EveryFreeCoordinateTakesItsOwnEffort) {
  std::string text = source_text("mechanisms/dynamics/constans_dyer_fivebar_falling.toml");
  for (const auto& [table, effort] :
       {std::pair{"[dynamics.left]\nrate = 0\n", "effort_table = [[0, 60], [1, -40], [2, 30]]\n"},
        std::pair{"[dynamics.right]\nrate = 0\n", "effort_table = [[0, -30], [1.2, 50]]\n"}}) {
    const size_t at = text.find(table);
    ASSERT_NE(at, std::string::npos) << table;
    text.insert(at + std::string(table).size(), effort);
  }
  const Mechanism m = load_text(text, "crosslink_fivebar_two_efforts.toml");
  const Simulation exact = simulate(m);
  ASSERT_TRUE(exact.ok) << exact.message;
  const Trajectory ref = reference_of(exact);
  // The second effort alone does a share of the work the test can see (its power integrated
  // over the exact motion by the trapezoid rule).
  double second = 0.0;
  for (int k = 1; k < ref.samples(); ++k) {
    // The right driver turns crank2 against the ground: its rate is crank2's omega.
    const auto crank2 =
        std::find(ref.link_names.begin(), ref.link_names.end(), "crank2") - ref.link_names.begin();
    const auto power = [&](int i) {
      return m.dynamics->coordinate(1).effort_at(ref.time(i)) * ref.omega(i, crank2);
    };
    second += 0.5 * (ref.time(k) - ref.time(k - 1)) * (power(k) + power(k - 1));
  }
  struct Case {
    const char* engine;
    Settings settings;
    double position, work, balance;
  };
  // Bounds: 3 times what was measured at each engine's default step (positions [m], the work
  // channel's difference and the engine's own balance [J], of 0.038 J of work): MuJoCo RK4
  // 4.4e-6, 2.5e-6, 4.2e-6; Bullet rigid and ODE 1.9e-6, 1.2e-6, 7.0e-6. The second effort's
  // work is about 0.012 J, three orders of magnitude above the work bounds.
  EXPECT_GT(std::abs(second), 1e3 * 7.5e-6);
  for (const Case& c :
       {Case{"mujoco", {{"integrator", "RK4"}}, 1.3e-5, 7.5e-6, 1.3e-5},
        Case{"bullet", {}, 6e-6, 3.7e-6, 2.1e-5}, Case{"ode", {}, 6e-6, 3.7e-6, 2.1e-5}}) {
    const EngineRun r = engine_named(c.engine)->run(m, exact.trajectory, c.settings);
    ASSERT_TRUE(r.ok) << c.engine << ": " << r.message;
    const Agreement a = agreement(ref, r.trajectory);
    std::printf(
        "[ five-bar, two efforts, %s ] positions %.2e m, work %.2e J of %.3g J (second effort "
        "%.3g J), balance %.2e J\n",
        c.engine, a.position, a.work, a.work_scale, second, a.balance);
    // Each driver's effort channel is its own coordinate's applied effort.
    for (int d = 0; d < 2; ++d)
      for (int i = 0; i < ref.samples(); i += 20)
        EXPECT_DOUBLE_EQ(r.trajectory.effort(i, d),
                         m.dynamics->coordinate(d).effort_at(ref.time(i)))
            << c.engine << " driver " << d << " sample " << i;
    EXPECT_LT(a.position, c.position) << c.engine;
    EXPECT_LT(a.work, c.work) << c.engine;
    EXPECT_LT(a.balance, c.balance) << c.engine;
  }
}

}  // namespace
}  // namespace crosslink::sim
