// The engines' gear couplings (sim/scene_graph.h, SceneCoupling) on the bundled gear definitions
// against the exact solution (analytic/kinematics/newton.h holds each coupling to its tolerance;
// the mesh force is the exact kinetostatics' tooth force, checked by power balance and Newton-Euler
// in test_kinetostatics): how far each engine holds the ratio, and its mesh force, at its defaults.
// Measured by bench/gear_accuracy (docs/engines-measured.md, "Gear couplings: drift and mesh force
// against the step").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numbers>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/bullet/bullet_engine.h"
#include "sim/forces.h"
#include "sim/mujoco/mujoco_engine.h"
#include "sim/ode/ode_engine.h"
#include "sim/simbody/simbody_engine.h"
#include "tests/common/mechanisms.h"

namespace crosslink::sim {
namespace {

// The default force tolerance of `crosslink compare` (0.05 % of peak).
constexpr double kForceTolerance = 0.05e-2;
// MuJoCo's default step turns the fastest link by max_step_angle = 0.0025 rad. Its coupling is a
// deadbeat equality, which takes out a position error in one step, so the drift cannot build up:
// it stays within one Euler step's local error of each of the coupling's angles, (omega dt)^2 / 2
// weighted by 1 and |ratio| (a rack: by the pinion's radius, the ratio, in metres).
constexpr double kMaxStepAngle = 0.0025;
double mujoco_drift_bound(const Joint& j) {
  const double local = 0.5 * kMaxStepAngle * kMaxStepAngle;
  return j.type == JointType::gear ? (1.0 + std::abs(j.ratio)) * local : std::abs(j.ratio) * local;
}
// Simbody projects every constraint, the coupler too, onto its constraint_tolerance (1e-10, a
// coupling's own unit) after each step.
constexpr double kSimbodyConstraintTolerance = 1e-10;

void expect_couplings_hold(Engine& engine, const std::string& file, double (*bound)(const Joint&)) {
  SCOPED_TRACE(engine.name() + " on " + file);
  const Mechanism m = load_mechanism(file);
  std::string why;
  ASSERT_TRUE(engine.supports(m, &why)) << why;
  const Trajectory exact = sweep(m);
  const EngineRun run = engine.run(m, exact, {});
  ASSERT_TRUE(run.ok) << run.message;
  for (size_t ji = 0; ji < m.joints.size(); ++ji) {
    const Joint& j = m.joints[ji];
    if (!j.is_gearing()) continue;
    SCOPED_TRACE(j.name);
    const GearingAgreement g = gearing_agreement(m, exact, run.trajectory, static_cast<int>(ji));
    EXPECT_EQ(g.compared, exact.samples());
    EXPECT_LE(g.drift, bound(j));
    ASSERT_TRUE(g.mesh.has_value());
    EXPECT_LE(*g.mesh, kForceTolerance);
  }
  // The driver's effort, which the coupling's own force must not reach, and a rack's slide's
  // couple, which the tooth force's offset changes. (The joints' reactions, the bearings the
  // tooth force passes through among them, are compared by crossval.gears.*: a planetary's sun
  // carries no load, so its bearing's exact force is zero by design and force_agreement's ratio
  // to its own peak is no measure there.)
  const ForceAgreement f = force_agreement(m, exact, run.trajectory);
  EXPECT_LE(f.effort, kForceTolerance);
  EXPECT_LE(f.couple, kForceTolerance);
}

TEST(GearCouplings, MuJoCoHoldsEachRatioAndReadsTheMeshForce) {
  const auto engine = make_mujoco_engine();
  for (const std::string& file : test::gear_files())
    expect_couplings_hold(*engine, file, mujoco_drift_bound);
}

// The drift is the step's local error, not an accumulation: halving the step quarters it
// (second order), where a coupling held at the velocity level alone would drift with the number
// of steps.
TEST(GearCouplings, MuJoCoDriftFallsAtSecondOrderInTheStep) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/geared_fivebar.toml");
  const Trajectory exact = sweep(m);
  const auto engine = make_mujoco_engine();
  const int mesh = m.find_joint("mesh");
  double drift[2];
  for (int k = 0; k < 2; ++k) {
    const EngineRun run = engine->run(m, exact, {{"max_step_angle", k == 0 ? "0.005" : "0.0025"}});
    ASSERT_TRUE(run.ok) << run.message;
    drift[k] = gearing_agreement(m, exact, run.trajectory, mesh).drift;
  }
  ASSERT_GT(drift[1], 0.0);
  EXPECT_GT(drift[0] / drift[1], 3.0);  // 4 at second order
}

// On the geared five-bar (1.4 s; the other two run in crossval.simbody.gears.*, label slow).
TEST(GearCouplings, SimbodyHoldsTheRatioToItsConstraintTolerance) {
  const auto engine = make_simbody_engine();
  expect_couplings_hold(*engine,
                        std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/geared_fivebar.toml",
                        [](const Joint&) { return kSimbodyConstraintTolerance; });
}

// Bullet's rigid formulation: btGearConstraint's row omega_a + ratio omega_b = 0, solved exactly
// by the MLCP, and the rigid bodies' angle update, linear in the rate, move the coupling by
// rounding alone: at most 4 eps of a turn, times 1 + |ratio|, per step.
double bullet_drift_bound(const Joint& j) {
  constexpr double kSteps = 2528;  // at its default step on the geared five-bar (gear_accuracy)
  return kSteps * 4.0 * std::numeric_limits<double>::epsilon() * 2.0 * std::numbers::pi *
         (1.0 + std::abs(j.ratio));
}

TEST(GearCouplings, BulletHoldsAGearPairAboutTheGroundToRounding) {
  const auto engine = make_bullet_engine();
  expect_couplings_hold(*engine,
                        std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/geared_fivebar.toml",
                        bullet_drift_bound);
}

// Bullet's multibody formulation: btMultiBodyGearConstraint's row qdot_a + ratio qdot_b = 0 over
// two joints' coordinates, which the rigid formulation takes for a rack (its btGearConstraint
// couples two bodies' rotation rates, no slide). The MLCP solves the row exactly and Featherstone
// moves each coordinate by its rate times the step, so the coupling s - r theta moves by rounding
// alone: at most 4 eps of each coordinate's largest magnitude, weighted by its coefficient, per
// step. (Its forces are not read: btMultiBodyJointFeedback is wrong in 3.24.)
TEST(GearCouplings, BulletHoldsARackInItsMultibodyToRounding) {
  const auto engine = make_bullet_engine();
  for (const char* name : {"rack_pinion_slider_crank.toml", "ryan_rack_and_pinion.toml"}) {
    SCOPED_TRACE(name);
    const Mechanism m =
        load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/" + name);
    std::string why;
    ASSERT_TRUE(engine->supports(m, &why)) << why;
    const Trajectory exact = sweep(m);
    const EngineRun run = engine->run(m, exact, {});
    ASSERT_TRUE(run.ok) << run.message;
    EXPECT_NE(run.message.find("the rigid formulation cannot realise it (joint 'mesh' is a rack "
                               "and pinion"),
              std::string::npos)
        << run.message;
    EXPECT_NE(run.message.find("multibody used"), std::string::npos) << run.message;
    const int mesh = m.find_joint("mesh");
    const Joint& rack = m.joints[static_cast<size_t>(mesh)];
    // The coordinates' largest magnitudes: any slide's travel, the pinion's r theta among any
    // link's.
    const double largest = std::max(exact.s.cwiseAbs().maxCoeff(),
                                    std::abs(rack.ratio) * exact.angle.cwiseAbs().maxCoeff());
    const double bound = static_cast<double>(run.cost.steps) * 4.0 *
                         std::numeric_limits<double>::epsilon() * 2.0 * largest;
    const GearingAgreement g = gearing_agreement(m, exact, run.trajectory, mesh);
    EXPECT_EQ(g.compared, exact.samples());
    EXPECT_LE(g.drift, bound);
    EXPECT_FALSE(g.mesh.has_value());
  }
}

// ODE's transmission joint (an external pair of moving gears): its row holds the pitch point's
// tangential velocity equal on both gears, the phase error taken out in one step (ERP 1) but for
// what CFM lets through. Measured (bench/gear_accuracy): the drift falls at first order in the
// step, 6.0e-12 rad on the geared five-bar and 2.4e-10 rad on Constans and Dyer's at the default.
// Held here to what compare's angle tolerance needs (0.01 % of a turn: a coupling off by more
// would show as an angle error), with the mesh force and the driver's effort within 0.05 %.
TEST(GearCouplings, OdeHoldsAnExternalGearPairAndReadsTheMeshForce) {
  const auto engine = make_ode_engine();
  for (const char* name : {"geared_fivebar.toml", "constans_dyer_geared_fivebar.toml"})
    expect_couplings_hold(*engine, std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/" + name,
                          [](const Joint&) { return 1e-4 * 2.0 * std::numbers::pi; });
}

// On equal gears the drift is CFM's alone: a hundredth of the CFM, a hundredth of the drift
// (the rotation update is exact, finite_rotation; with unequal gears another part, 3.6e-11 rad on
// Constans and Dyer's, stays at CFM 1e-12: docs/engines-measured.md).
TEST(GearCouplings, OdeDriftOnEqualGearsIsItsConstraintForceMixing) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/geared_fivebar.toml");
  const Trajectory exact = sweep(m);
  const auto engine = make_ode_engine();
  double drift[2];
  for (int k = 0; k < 2; ++k) {
    const EngineRun run = engine->run(m, exact, {{"cfm", k == 0 ? "1e-10" : "1e-12"}});
    ASSERT_TRUE(run.ok) << run.message;
    drift[k] = gearing_agreement(m, exact, run.trajectory, m.find_joint("mesh")).drift;
  }
  ASSERT_GT(drift[1], 0.0);
  EXPECT_GT(drift[0] / drift[1], 50.0);  // 100 when CFM is the only cause
}

// A planetary train in Bullet's rigid formulation: its pair on the moving carrier spans three
// bodies (sun, planet, carrier) and btGearConstraint couples two, so the pair's row is
// recombined with the other pair's (planet to carrier, the ring being the ground): the sun to the
// carrier alone, by Willis' formula (reduce_couplings). The MLCP holds each recombined row
// exactly at the velocity level, so both physical pairs drift by rounding alone, as a pair about
// the ground (at most 4 eps of a turn per step, times the rows' coefficients, over at most one
// turn of the carrier's 2,880 steps at the default step); the mesh forces are the constraints'
// multipliers mixed back (Plan::rigid_mix), each within the force tolerance of the exact one.
// The multibody formulation does not take it (its coupling spans three joints of the tree):
// recombined it diverges (sim/bullet/bullet_engine.cpp, make_plan), so Bullet falls back to rigid
// bodies, naming why.
TEST(GearCouplings, BulletHoldsAPlanetaryTrainByRecombiningItsPairs) {
  const auto engine = make_bullet_engine();
  for (const char* file : {"planetary_fixed_ring.toml", "epicyclic_ring72_sun32.toml"})
    expect_couplings_hold(*engine, std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/" + file,
                          [](const Joint& j) {
                            constexpr double kSteps = 2880;
                            return kSteps * 4.0 * std::numeric_limits<double>::epsilon() * 2.0 *
                                   std::numbers::pi * (2.0 + 2.0 * std::abs(j.ratio));
                          });
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/gears/planetary_fixed_ring.toml");
  const EngineRun run = engine->run(m, sweep(m), {{"formulation", "multibody"}});
  ASSERT_TRUE(run.ok) << run.message;
  EXPECT_NE(run.message.find("the multibody formulation cannot realise it (joint 'sun_planet' is "
                             "a gear pair: its coupling spans 3 joints of the multibody tree"),
            std::string::npos)
      << run.message;
  EXPECT_NE(run.message.find("rigid used"), std::string::npos) << run.message;
}

// What an engine does not build it refuses, naming the gearing and why, rather than run the
// mechanism with its gears left out: a rack in ODE (no coupling built).
TEST(GearCouplings, OdeRefusesARackNamingIt) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/gears/rack_pinion_slider_crank.toml");
  std::string why;
  EXPECT_FALSE(make_ode_engine()->supports(m, &why));
  EXPECT_NE(why.find("joint 'mesh' is a rack and pinion"), std::string::npos) << why;
}

}  // namespace
}  // namespace crosslink::sim
