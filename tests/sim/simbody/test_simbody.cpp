// Simbody 3.7 (docs/engines.md, "Simbody") against the exact references: the driven four-bar's
// motion, driver torque and pin forces against the exact sweep and kinetostatics (themselves
// checked by power balance and Newton-Euler); forward dynamics of IFToMM A02 against the exact
// simulation, with its energy balance against Simbody's own energy; two runs in two threads
// bit-identical to a lone run; and a Simbody exception made a flagged run, not a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <thread>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/forces.h"
#include "sim/simbody/simbody_engine.h"
#include "tests/sim/dynamics_cases.h"

namespace crosslink::sim {
namespace {

Mechanism crank_rocker_under_gravity() {
  Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/fourbar_crank_rocker.toml");
  m.gravity = Eigen::Vector2d(0.0, -9.81);
  return m;
}

// Worst distance of any named point from the exact sweep's [m], over the samples both call usable.
double worst_position(const Trajectory& exact, const Trajectory& run) {
  double worst = 0.0;
  for (int i = 0; i < exact.samples(); ++i) {
    if (!usable(exact.status[static_cast<size_t>(i)]) ||
        !usable(run.status[static_cast<size_t>(i)]))
      continue;
    for (Eigen::Index p = 0; p < exact.x.cols(); ++p)
      worst = std::max(worst, std::hypot(run.x(i, p) - exact.x(i, p), run.y(i, p) - exact.y(i, p)));
  }
  return worst;
}

// The driven crank-rocker under gravity at the defaults: the driver's law is prescribed exactly
// and Simbody projects onto the loop, so positions are exact to its constraint tolerance (1e-10:
// measured 1.5e-10 % of the size), and the forces read at each state are the exact ones (measured
// 1.4e-9 % of peak; Bullet and MuJoCo, stepping, are held to 0.25 % and 0.05 %). The bounds are
// a thousand times what was measured, far below any stepping engine's error: a sign or a frame
// wrong in the readout is a 100 % error (the cut pin D's sign was: 180 %).
TEST(SimbodyEngine, FourBarForcesMatchTheExactReference) {
  const Mechanism m = crank_rocker_under_gravity();
  const Trajectory exact = sweep(m);
  const EngineRun run = make_simbody_engine()->run(m, exact, {});
  ASSERT_TRUE(run.ok) << run.message;
  ASSERT_TRUE(run.trajectory.has_forces);
  EXPECT_LT(worst_position(exact, run.trajectory), 1e-9 * m.size());
  const ForceAgreement a = force_agreement(m, exact, run.trajectory);
  EXPECT_GT(a.compared, exact.samples() * 9 / 10);
  EXPECT_LT(a.effort, 1e-8);
  EXPECT_LT(a.reaction, 1e-8) << "worst joint " << a.worst_joint;
  EXPECT_LT(a.shaking, 1e-8);
}

// IFToMM A02 with N = 2 (five bars under gravity) released from the exact start, over its first
// 0.6 s, before the first passage through its singular position: Simbody integrates with error
// control and projects onto the loops, so the motion follows the exact one to round-off
// (measured: positions 7.3e-11 m, velocities and accelerations 1.8e-10 and 3.1e-10 of their
// peaks, energy balance 5.3e-9 J of the 70 J the motion moves; Bullet at its defaults is 8.5e-5 m
// off over 10 s). The bounds are a hundred times that. Through the singular passages Simbody does
// not keep its branch (docs/engines.md, "Simbody"): that is the compare verdict's to show.
TEST(SimbodyEngine, DynamicsFollowsTheExactMotionAndKeepsItsEnergy) {
  using namespace dynamics_testing;
  const Trajectory& ref = exact(0.6);
  const EngineRun r = make_simbody_engine()->run(a02(), ref, {});
  ASSERT_TRUE(r.ok) << r.message;
  ASSERT_TRUE(r.trajectory.has_energy);
  ASSERT_TRUE(r.trajectory.has_forces);
  EXPECT_TRUE(all_finite(r.trajectory));
  const Errors e = errors(ref, r.trajectory);
  EXPECT_LT(e.position, 1e-8);
  EXPECT_LT(e.velocity, 2e-8);
  EXPECT_LT(e.acceleration, 3e-8);
  EXPECT_LT(e.energy, 5e-7);
  EXPECT_EQ(e.flagged, 0);
}

// Simbody's worlds are separate objects: two runs at once in two threads give, bit for bit, what
// one run alone gives.
TEST(SimbodyEngine, TwoThreadsGiveALoneRunsResultsBitForBit) {
  const Mechanism m = crank_rocker_under_gravity();
  SweepOptions options;
  options.step = 5.0 * std::numbers::pi / 180.0;
  const Trajectory exact = sweep(m, options);
  const Settings settings = {{"max_step_angle", "0.01"}};
  const EngineRun alone = make_simbody_engine()->run(m, exact, settings);
  ASSERT_TRUE(alone.ok) << alone.message;
  EngineRun first, second;
  std::thread a([&] { first = make_simbody_engine()->run(m, exact, settings); });
  std::thread b([&] { second = make_simbody_engine()->run(m, exact, settings); });
  a.join();
  b.join();
  for (const EngineRun* r : {&first, &second}) {
    ASSERT_TRUE(r->ok) << r->message;
    EXPECT_TRUE(r->trajectory.x == alone.trajectory.x);
    EXPECT_TRUE(r->trajectory.y == alone.trajectory.y);
    EXPECT_TRUE(r->trajectory.vx == alone.trajectory.vx);
    EXPECT_TRUE(r->trajectory.fx == alone.trajectory.fx);
    EXPECT_TRUE(r->trajectory.fy == alone.trajectory.fy);
    EXPECT_TRUE(r->trajectory.effort == alone.trajectory.effort);
  }
}

// A constraint tolerance no projection can reach makes Simbody throw (its projection fails): the
// run is flagged, with Simbody's message, every sample diverged, no value passed on as a number.
TEST(SimbodyEngine, ASimbodyExceptionIsAFlaggedRunNotACrash) {
  const Mechanism m = crank_rocker_under_gravity();
  SweepOptions options;
  options.step = 10.0 * std::numbers::pi / 180.0;
  const Trajectory exact = sweep(m, options);
  const EngineRun run = make_simbody_engine()->run(m, exact, {{"constraint_tolerance", "1e-300"}});
  EXPECT_FALSE(run.ok);
  EXPECT_NE(run.message.find("Simbody"), std::string::npos) << run.message;
  for (PoseStatus s : run.trajectory.status) EXPECT_FALSE(usable(s));
  // Away from any singular position the loops are well conditioned: the message does not say so.
  EXPECT_EQ(run.message.find("singular position"), std::string::npos) << run.message;
}

// A change-point four-bar (a + c = b + d) folds flat once a turn, where its loop's position
// Jacobian loses rank (every link on one line: the joints' velocity directions are parallel).
// Driven through it, Simbody's projection cannot be solved and its integrator stops there; the
// run's message names the reason with the loop's conditioning where it stopped.
TEST(SimbodyEngine, AStopAtAChangePointIsNamedAsASingularPosition) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/singular/fourbar_change_point_crank_rocker.toml");
  const Trajectory exact = sweep(m);
  const EngineRun run = make_simbody_engine()->run(m, exact, {});
  EXPECT_FALSE(run.ok);
  EXPECT_NE(run.message.find("a singular position of the loops"), std::string::npos) << run.message;
}

// CPodes (BDF) driven into the change point cuts its step until t + h = t (5.6e-18 s at 1/3 s) and,
// before, stepped on there for as long as one let it (IFToMM A02 N = 40: over 12 minutes): control
// comes back every 1,000 internal steps, and a call that leaves the time where it was stops the
// run with the step it fell to and the loops' conditioning there.
TEST(SimbodyEngine, AStepThatCollapsesStopsTheRunWithItsReason) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/singular/fourbar_change_point_crank_rocker.toml");
  SweepOptions options;
  options.step = 10.0 * std::numbers::pi / 180.0;
  const Trajectory exact = sweep(m, options);
  const EngineRun run = make_simbody_engine()->run(m, exact, {{"integrator", "cpodes"}});
  EXPECT_FALSE(run.ok);
  EXPECT_NE(run.message.find("does not advance: its step fell to"), std::string::npos)
      << run.message;
  EXPECT_NE(run.message.find("a singular position of the loops"), std::string::npos) << run.message;
}

}  // namespace
}  // namespace crosslink::sim
