// Each engine's driver effort, joint reactions and shaking force against the exact
// kinetostatics (analytic/physics/kinetostatics.h, itself checked by power balance and
// Newton-Euler), on every bundled mechanism at the engine's defaults: as defined, under gravity,
// and loaded with gravity, a spring and damper, a force at a point and a torque.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <tuple>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "analytic/reference/trust.h"
#include "methods/engines.h"
#include "sim/forces.h"
#include "sim/mujoco/mujoco_engine.h"
#include "tests/common/mechanisms.h"

namespace crosslink::sim {
namespace {

// Worst % of peak, measured at the defaults by bench/force_accuracy (docs/engines-measured.md,
// "Forces"), over every sample the reference trusts (analytic/reference/trust.h): MuJoCo at most
// 0.029 % (the Jansen leg's pin E); Bullet at most 0.21 % (the polycentric hinge's pin H, near the
// ends of its range, which the absolute conditioning limit of 1e-2 kept out until the trust issue:
// 0.091 % was measured without them) and 0.09 % on the linkages that never near a singular
// position; the Jansen leg at half Bullet's default step (below); ODE as Bullet; Simbody at most
// 5.3e-5 % on the bundled linkages (Khurmi's slider-crank under gravity, pin O) and 3.4e-4 %
// loaded (the quick return's pin B; 2026-12-02). Every engine of the engine table has one: a new
// engine is measured before it is held to a number.
double tolerance(const std::string& engine) {
  if (engine == "mujoco") return 0.05e-2;
  if (engine == "bullet" || engine == "ode") return 0.25e-2;
  if (engine == "simbody") return 1e-5;
  ADD_FAILURE() << engine << ": no force tolerance measured (bench/force_accuracy)";
  return 0.0;
}

// Bullet's default step leaves the Jansen leg's reactions 0.34 % off at pin E (its peak force,
// 192 degrees); half the step, 0.12 % (docs/engines-measured.md): measured, so run there.
Settings settings_for(const std::string& engine, const std::string& name) {
  if ((engine == "bullet" || engine == "ode") && name == "jansen_leg")
    return {{"max_step_angle", "0.005"}};
  return {};
}

std::unique_ptr<Engine> make(const std::string& engine) {
  return methods::find_engine(engine)->make();
}

void expect_forces_agree(const std::string& engine, const Mechanism& m,
                         const Settings& settings = {}) {
  const auto e = make(engine);
  std::string why;
  if (!e->supports(m, &why)) GTEST_SKIP() << why;
  const Trajectory exact = sweep(m);
  const EngineRun run = e->run(m, exact, settings);
  ASSERT_TRUE(run.ok) << run.message;
  // Both engines read forces on every bundled definition (MuJoCo drives a floating link's angle
  // through a tendon, the polycentric hinge's DE).
  ASSERT_TRUE(run.trajectory.has_forces) << run.message;
  const ForceAgreement a = force_agreement(m, exact, run.trajectory);
  // Flags may only mark a few samples: nearly every sample the exact forces are judged on counts.
  int eligible = 0;
  const double force_rcond = kForceConditioning * typical_rcond(exact);
  for (int i = 0; i < exact.samples(); ++i) eligible += untrusted(exact, i, force_rcond).empty();
  EXPECT_GE(a.compared, eligible * 9 / 10);
  EXPECT_GT(a.compared, 0);
  const double limit = tolerance(engine);
  EXPECT_LE(a.effort, limit);
  EXPECT_LE(a.reaction, limit) << "worst joint " << a.worst_joint;
  EXPECT_LE(a.couple, limit);
  EXPECT_LE(a.shaking, limit);
}

using Param = std::tuple<std::string, std::string>;  // engine, mechanism
class Bundled : public ::testing::TestWithParam<Param> {};

TEST_P(Bundled, AgreeWithExactKinetostaticsAtDefaults) {
  const auto& [engine, name] = GetParam();
  // Simbody's integrator cannot advance through a change point, where the loops' Jacobian loses
  // rank: this one's is the cycle's last sample, 360 deg (docs/engines.md, "Simbody").
  if (engine == "simbody" && name == "fourbar_change_point")
    GTEST_SKIP() << "Simbody stops at the change point at 360 deg";
  Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + name + ".toml");
  expect_forces_agree(engine, m, settings_for(engine, name));
  m.gravity = Eigen::Vector2d(0.0, -9.81);
  expect_forces_agree(engine, m, settings_for(engine, name));
}

INSTANTIATE_TEST_SUITE_P(Engines, Bundled,
                         ::testing::Combine(::testing::ValuesIn(methods::engine_names()),
                                            ::testing::ValuesIn(test::bundled_stems())),
                         [](const ::testing::TestParamInfo<Param>& info) {
                           return std::get<0>(info.param) + "_" + std::get<1>(info.param);
                         });

class Loaded : public ::testing::TestWithParam<Param> {};

TEST_P(Loaded, GravitySpringDamperForceAndTorque) {
  const auto& [engine, name] = GetParam();
  expect_forces_agree(engine, test::loaded(load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                                          "/mechanisms/" + name + ".toml")));
}

INSTANTIATE_TEST_SUITE_P(Engines, Loaded,
                         ::testing::Combine(::testing::ValuesIn(methods::engine_names()),
                                            ::testing::Values("fourbar_crank_rocker",
                                                              "slider_crank_offset", "quick_return",
                                                              "watt_sixbar")),
                         [](const ::testing::TestParamInfo<Param>& info) {
                           return std::get<0>(info.param) + "_" + std::get<1>(info.param);
                         });

// Khurmi's slider-crank (mechanisms/published/): a massless crank drives a 250 kg piston against
// 69 kN. MuJoCo holds its driver only with the driven joint's armature (driver_armature,
// docs/engines.md); without it the driver is lost.
TEST(EngineForces, MasslessCrankOnAHeavyPistonAgrees) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/published/khurmi_slider_crank_gas_force.toml");
  for (const std::string& engine : methods::engine_names()) expect_forces_agree(engine, m);
  const EngineRun bare = make_mujoco_engine()->run(m, sweep(m), {{"driver_armature", "0"}});
  EXPECT_FALSE(bare.ok) << "MuJoCo held the driver without an armature";
}

// The armature's share of the driver's effort (armature x the driven joint's acceleration) is
// taken back out: the crank-rocker accelerating at 100 rad/s^2 with an armature of 0.01 kg m^2
// (a share of 1 N m against a peak effort of 0.34 N m: 300 % of peak if left in) reads the
// exact effort.
TEST(EngineForces, DriverArmatureIsTakenOutOfTheEffort) {
  std::string text = test::source_text("mechanisms/fourbar_crank_rocker.toml");
  const std::string speed = "speed_unit = \"rpm\"";
  text.replace(text.find(speed), speed.size(), speed + "\nacceleration = 100");
  const Mechanism m = parse_mechanism(text, "fourbar_crank_rocker_accelerating.toml");
  ASSERT_EQ(m.drivers[0].law.kind, MotionLaw::Kind::constant_acceleration);
  const Trajectory exact = sweep(m);
  const EngineRun run = make_mujoco_engine()->run(m, exact, {{"driver_armature", "0.01"}});
  ASSERT_TRUE(run.ok) << run.message;
  EXPECT_LE(force_agreement(m, exact, run.trajectory).effort, tolerance("mujoco"));
}

// A model error shows: a scene with a 10 % heavier coupler reads forces off the exact ones.
TEST(EngineForces, CanFail) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/fourbar_crank_rocker.toml");
  Mechanism heavy = m;
  heavy.links[static_cast<size_t>(heavy.find_link("coupler"))].mass.mass *= 1.1;
  const Trajectory exact = sweep(m);
  for (const std::string& engine : methods::engine_names()) {
    const EngineRun run = make(engine)->run(heavy, exact, {});
    ASSERT_TRUE(run.ok) << run.message;
    EXPECT_GT(force_agreement(m, exact, run.trajectory).reaction, 10 * tolerance(engine)) << engine;
  }
}

}  // namespace
}  // namespace crosslink::sim
