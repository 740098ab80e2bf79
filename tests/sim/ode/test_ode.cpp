// ODE engine against the exact answers: the driven motion of bundled linkages against the exact
// sweep, the driver torque and pin forces of the crank-rocker against the exact kinetostatics and
// their second order in the step, forward dynamics against the exact simulation with its energy
// balance, and ODE's own hazards: input that would make it abort is refused and an internal
// error fails the run, never the process; two worlds in two threads do not interfere.
#include <gtest/gtest.h>
#include <ode/ode.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <thread>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/forces.h"
#include "sim/ode/ode_engine.h"
#include "tests/sim/bullet/agreement.h"
#include "tests/sim/dynamics_cases.h"

// LeakSanitizer (scripts/test-sanitizers.sh): the step an ODE error interrupts
// (Ode.AnInvalidMassFailsTheRunNotTheProcess) abandons its job record in the world's threading
// implementation, which the engine keeps unfreed on purpose (freeing it asserts: ode_engine.cpp,
// ~OdeScene); what hangs from that record is that one world's.
extern "C" const char* __lsan_default_suppressions() {
  return "leak:PreallocateJobInfos\n";
}

namespace crosslink::sim {
namespace {

Mechanism bundled(const std::string& name) {
  return load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + name + ".toml");
}

TEST(Ode, IsTheDoublePrecisionBuild) {
  ode_start();
  EXPECT_EQ(dCheckConfiguration("ODE_double_precision"), 1);
}

class OdeDefaults : public ::testing::TestWithParam<std::string> {};

// Positions within 1e-4 of the mechanism's size, velocities within 0.1 % and accelerations within
// 1 % of each quantity's peak over the cycle, as Bullet's (the same kind of scene). Revolutes,
// prismatics, pin-in-slots, and a floating link's angle driven (the polycentric hinge).
TEST_P(OdeDefaults, AgreesWithTheAnalyticSweep) {
  const Mechanism m = bundled(GetParam());
  const auto engine = make_ode_engine();
  std::string why;
  ASSERT_TRUE(engine->supports(m, &why)) << why;
  const Trajectory ref = sweep(m);
  const EngineRun run = engine->run(m, ref, {});
  ASSERT_TRUE(run.ok) << run.message;
  EXPECT_EQ(run.trajectory.method, "ode");
  // As the comparator: a sample next to a singular one is not in the verdict (the polycentric
  // hinge's range ends at two toggles, where the rates grow without bound).
  Trajectory judged = run.trajectory;
  for (int i = 0; i < ref.samples(); ++i)
    for (int j : {i - 1, i + 1})
      if (j >= 0 && j < ref.samples() && ref.status[static_cast<size_t>(j)] == PoseStatus::singular)
        judged.status[static_cast<size_t>(i)] = PoseStatus::singular;
  const test::Agreement a = test::agreement(m, ref, judged);
  EXPECT_GT(a.compared, ref.samples() * 9 / 10) << "too many flagged samples: " << run.message;
  EXPECT_LT(a.position, 1e-4);
  EXPECT_LT(a.velocity, 1e-3) << a.worst_velocity;
  EXPECT_LT(a.acceleration, 1e-2) << a.worst_acceleration;
  std::printf(
      "%s: position %.2e of size, velocity %.3f %% (%s), acceleration %.3f %% (%s), %ld "
      "steps\n",
      GetParam().c_str(), a.position, 100 * a.velocity, a.worst_velocity.c_str(),
      100 * a.acceleration, a.worst_acceleration.c_str(), run.cost.steps);
}

INSTANTIATE_TEST_SUITE_P(Bundled, OdeDefaults,
                         ::testing::Values("fourbar_crank_rocker", "slider_crank_offset",
                                           "quick_return", "sixbar_slider_guide", "watt_sixbar",
                                           "polycentric_hinge"));

// The crank-rocker under gravity at `steps` steps per sample interval: its driver torque's and pin
// forces' worst error against the exact kinetostatics (fractions of each channel's peak).
ForceAgreement crank_rocker_forces(int steps) {
  Mechanism m = bundled("fourbar_crank_rocker");
  m.gravity = Eigen::Vector2d(0.0, -9.81);
  const Trajectory exact = sweep(m);
  const EngineRun run = make_ode_engine()->run(
      m, exact, {{"steps_per_sample", std::to_string(steps)}, {"max_step_angle", "0"}});
  EXPECT_TRUE(run.ok) << run.message;
  return force_agreement(m, exact, run.trajectory);
}

// Maximal coordinates with an exact LCP solve: the driver torque and the pin forces are second
// order in the step (engine notes: 0.26 % at 8.3e-4 s, 0.0027 % at 8.3e-5 s), so a tenth of the
// step is at least 50 times closer to the exact kinetostatics (a first-order reading, the
// reduced-coordinate engines', would be 10 times).
TEST(Ode, DriverTorqueAndPinForcesAreSecondOrderInTheStep) {
  const ForceAgreement coarse = crank_rocker_forces(2), fine = crank_rocker_forces(20);
  std::printf("crank-rocker: driver torque %.2e -> %.2e, reactions %.2e -> %.2e (%s)\n",
              coarse.effort, fine.effort, coarse.reaction, fine.reaction, fine.worst_joint.c_str());
  EXPECT_GT(coarse.effort / fine.effort, 50.0);
  EXPECT_GT(coarse.reaction / fine.reaction, 50.0);
  EXPECT_LT(coarse.effort, 3e-3);
}

// Forward dynamics (IFToMM A02, N = 2, 10 s through seven singular positions) at the defaults:
// within the benchmark's high-precision limit (1e-3 m), the energy balance closed to 1e-3 of the
// 70 J the motion moves, flags only at the passages, nothing NaN.
TEST(Ode, DynamicsFollowsTheExactMotionAndBalancesEnergy) {
  using namespace dynamics_testing;
  const Trajectory& ref = exact();
  const EngineRun r = make_ode_engine()->run(a02(), ref, {});
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_TRUE(r.trajectory.has_energy);
  ASSERT_TRUE(r.trajectory.has_forces);
  EXPECT_TRUE(all_finite(r.trajectory));
  const Errors e = errors(ref, r.trajectory);
  std::printf(
      "A02 N=2, ODE defaults: positions %.2e m, velocities %.2e, accelerations %.2e of "
      "peak, energy %.2e J, %d flagged, %.3f s\n",
      e.position, e.velocity, e.acceleration, e.energy, e.flagged, r.cost.wall_seconds);
  EXPECT_LT(e.position, 1e-3);
  EXPECT_LT(e.energy, 0.07);
  expect_flags_only_at_passages(ref, r.trajectory, "ode defaults");
}

// CFM 0 leaves the loops' redundant out-of-plane rows singular (ODE aborts), ERP outside [0, 1]
// is no error reduction: refused as settings, before any run.
TEST(Ode, SettingsThatWouldAbortAreRefused) {
  const Mechanism m = bundled("fourbar_crank_rocker");
  const auto engine = make_ode_engine();
  for (const char* cfm : {"0", "-1e-10", "nan"})
    EXPECT_THROW(engine->check_settings(m, {{"cfm", cfm}}), std::invalid_argument) << cfm;
  EXPECT_THROW(engine->check_settings(m, {{"erp", "1.5"}}), std::invalid_argument);
  EXPECT_NO_THROW(engine->check_settings(m, {{"cfm", "1e-6"}, {"stepper", "quick"}}));
}

// A mass or inertia ODE's dBodySetMass would abort on (NaN: the scene's mass model keeps it) is
// refused before the scene is built; a link whose inertia the mass model replaces by its
// negligible one (a negative inertia, built by hand: the loader refuses it) makes ODE's step
// produce a NaN rotation, on which ODE aborts (dNormalize4): the run fails with ODE's reason.
// The process goes on, and ODE with it.
TEST(Ode, AnInvalidMassFailsTheRunNotTheProcess) {
  const Mechanism good = bundled("fourbar_crank_rocker");
  const Trajectory ref = sweep(good);
  const auto run_with = [&](double mass, double inertia) {
    Mechanism m = good;
    const int crank = m.drivers[0].link;
    if (mass != 0.0) m.links[static_cast<size_t>(crank)].mass.mass = mass;
    if (inertia != 0.0) m.links[static_cast<size_t>(crank)].mass.inertia = inertia;
    return make_ode_engine()->run(m, ref, {});
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const auto& [mass, inertia] : {std::pair{nan, 0.0}, std::pair{0.0, nan}}) {
    const EngineRun run = run_with(mass, inertia);
    EXPECT_FALSE(run.ok);
    EXPECT_NE(run.message.find("must be positive and finite for ODE"), std::string::npos)
        << run.message;
  }
  const EngineRun inside = run_with(0.0, -1.0);
  EXPECT_FALSE(inside.ok);
  EXPECT_NE(inside.message.find("a step failed inside ODE"), std::string::npos) << inside.message;
  EXPECT_TRUE(make_ode_engine()->run(good, ref, {}).ok);
}

// ODE's internal errors (here dBodySetMass with the centre of mass off the body's origin, which
// calls dDebug and then abort()) become exceptions.
TEST(Ode, AnInternalErrorThrowsInsteadOfAborting) {
  ode_start();
  dWorldID world = dWorldCreate();
  dBodyID body = dBodyCreate(world);
  dMass mass;
  dMassSetParameters(&mass, 1.0, 0.5, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0);
  EXPECT_THROW(dBodySetMass(body, &mass), std::runtime_error);
  dWorldDestroy(world);
}

// Every sample's values bit for bit (NaN equal to NaN).
bool identical(const Trajectory& a, const Trajectory& b) {
  if (a.channel_names() != b.channel_names() || a.status != b.status) return false;
  for (const std::string& ch : a.channel_names()) {
    const auto x = *a.channel(ch), y = *b.channel(ch);
    for (Eigen::Index i = 0; i < x.size(); ++i)
      if (!(x(i) == y(i) || (std::isnan(x(i)) && std::isnan(y(i))))) return false;
  }
  return true;
}

// Two ODE worlds stepping at once in two threads (compare --jobs): each has its own threading
// implementation, so both runs are bit-identical to a lone run (with one process-wide
// implementation, two worlds aborted 5 times in 20: engine notes).
TEST(Ode, TwoWorldsInTwoThreadsDoNotInterfere) {
  Mechanism m = bundled("fourbar_crank_rocker");
  m.gravity = Eigen::Vector2d(0.0, -9.81);
  const Trajectory ref = sweep(m);
  const EngineRun lone = make_ode_engine()->run(m, ref, {});
  ASSERT_TRUE(lone.ok) << lone.message;
  for (int trial = 0; trial < 5; ++trial) {
    EngineRun one, two;
    std::thread a([&] { one = make_ode_engine()->run(m, ref, {}); });
    std::thread b([&] { two = make_ode_engine()->run(m, ref, {}); });
    a.join();
    b.join();
    EXPECT_TRUE(identical(one.trajectory, lone.trajectory)) << trial;
    EXPECT_TRUE(identical(two.trajectory, lone.trajectory)) << trial;
  }
}

// dWorldQuickStep orders its rows at random by ODE's process-wide generator: a quick-step run
// gives a lone run's numbers after other runs and beside another in a second thread (a sweep over
// `--jobs` threads writes the serial run's CSV). Before each run started from the seed where the
// last left it, the second of two runs in a row differed from the first.
TEST(Ode, AQuickStepRunIsTheSameAfterAndBesideOthers) {
  const Mechanism m = bundled("fourbar_crank_rocker");
  const Trajectory ref = sweep(m);
  const Settings quick = {{"stepper", "quick"}, {"iterations", "100"}};  // 20 lose the driver
  const EngineRun lone = make_ode_engine()->run(m, ref, quick);
  ASSERT_TRUE(lone.ok) << lone.message;
  const EngineRun again = make_ode_engine()->run(m, ref, quick);
  EXPECT_TRUE(identical(again.trajectory, lone.trajectory));
  EngineRun one, two;
  std::thread a([&] { one = make_ode_engine()->run(m, ref, quick); });
  std::thread b([&] { two = make_ode_engine()->run(m, ref, quick); });
  a.join();
  b.join();
  EXPECT_TRUE(identical(one.trajectory, lone.trajectory));
  EXPECT_TRUE(identical(two.trajectory, lone.trajectory));
}

}  // namespace
}  // namespace crosslink::sim
