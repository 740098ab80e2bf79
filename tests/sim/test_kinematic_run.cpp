// The kinematic run loop every engine shares (sim/kinematic_run.h), driven by a scene that is
// not an engine: each step closes the chain exactly at the driver's law (Newton), so the loop's
// own parts are checked against the exact sweep: the samples it differences, the statuses it
// judges, the stop it makes, the cost it counts. The engines run through the same loop in
// tests/sim/mujoco and tests/sim/bullet.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "analytic/kinematics/newton.h"
#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "sim/kinematic_run.h"
#include "tests/common/crank_rocker.h"

namespace crosslink::sim {
namespace {

// A scene whose every step is the exact pose at each driver's law's value; from step `open_from`
// on one link is moved by `shift` [m] (a loop that opens), at step `nan_at` the pose is lost, and
// from step `lag_from` on driver `lagging` is held `lag` behind its law.
class ExactScene final : public KinematicScene {
 public:
  ExactScene(const Mechanism& m, const KinematicPlan& plan)
      : solver_(m), state_(m), offset_(plan.driver_offset) {
    state_.q = plan.q;
  }
  void drive(const std::vector<double>& driver_values) override {
    for (int d = 0; d < state_.driver_count(); ++d) {
      double value = driver_values[static_cast<size_t>(d)] + offset_[static_cast<size_t>(d)];
      if (d == lagging && evaluations_ + 1 >= lag_from) value -= lag;
      state_.drivers[static_cast<size_t>(d)] = DriverState{0.0, value, 0.0, 0.0};
    }
  }
  void apply(const std::vector<BodyLoad>&) override {}
  std::string step(double, ForceReading*) override {
    ++evaluations_;
    if (solver_.solve_position(state_).status != PoseStatus::ok) return "Newton failed";
    return "";
  }
  void read_pose(Eigen::VectorXd& q) override {
    q = state_.q;
    if (evaluations_ >= open_from) q(0) += shift;
    if (evaluations_ == nan_at) q(0) = std::numeric_limits<double>::quiet_NaN();
  }
  long evaluations() const override { return evaluations_; }
  long open_from = std::numeric_limits<long>::max(), nan_at = -1;
  double shift = 0.0;
  int lagging = -1;
  long lag_from = std::numeric_limits<long>::max();
  double lag = 0.0;

 private:
  const NewtonSolver solver_;
  KinematicState state_;
  std::vector<double> offset_;
  long evaluations_ = 0;
};

struct Case {
  Mechanism m;
  Trajectory reference = sweep(m);
  KinematicWatch watch{1e-4 * m.size(), m.size(), 1e-3, 1e-5, 1e-4};
  // Steps of at most 0.0025 rad of the fastest link, pre-roll of 8 (MuJoCo's numbers).
  KinematicPlan plan =
      plan_kinematic(m, reference, 0.0025 / fastest_rate(reference, usable_span(reference)),
                     InnerTimes::step_multiples, 8, 1'000'000, watch.singular_rcond, false);
  explicit Case(Mechanism mechanism = parse_mechanism(test::crank_rocker().text(),
                                                      "crank_rocker.toml"))
      : m(std::move(mechanism)) {}
  EngineRun run_with(ExactScene& scene) {
    EngineRun run;
    run_kinematic(m, m, reference, plan, watch, false, scene, Clock::now(), run);
    return run;
  }
};

// Exact poses: the samples are the reference's, positions to Newton's tolerance, rates to the
// difference stencil's O(h^2) (h = 0.0025 rad of the fastest link: (h omega)^2 / 6 of the peak);
// every sample ok, no note; a whole cycle is periodic, so the pre-roll's 2 x 8 steps are run and
// counted.
TEST(KinematicRun, ExactPosesGiveTheReferenceSamples) {
  Case c;
  ASSERT_EQ(c.plan.preroll, 8);
  ExactScene scene(c.m, c.plan);
  const EngineRun run = c.run_with(scene);
  ASSERT_TRUE(run.ok) << run.message;
  EXPECT_EQ(run.message, "");
  const Trajectory& out = run.trajectory;
  const double omega_peak = c.reference.omega.cwiseAbs().maxCoeff();
  const double alpha_peak = c.reference.alpha.cwiseAbs().maxCoeff();
  for (int i = 0; i < c.reference.samples(); ++i) {
    EXPECT_EQ(out.status[static_cast<size_t>(i)], PoseStatus::ok) << i;
    EXPECT_NEAR((out.angle.row(i) - c.reference.angle.row(i)).cwiseAbs().maxCoeff(), 0.0, 1e-9);
    EXPECT_LT((out.omega.row(i) - c.reference.omega.row(i)).cwiseAbs().maxCoeff(),
              1e-5 * omega_peak)
        << i;
    EXPECT_LT((out.alpha.row(i) - c.reference.alpha.row(i)).cwiseAbs().maxCoeff(),
              1e-4 * alpha_peak)
        << i;
  }
  EXPECT_EQ(run.cost.steps, static_cast<long>(c.plan.grid.time.size()) - 1);
  EXPECT_EQ(run.cost.model_evaluations, run.cost.steps);
}

// A loop that opens by 10 times the flag's threshold from the middle of the run on: those samples
// (and no earlier one) are loop_gap, with the note and an event where the run of them starts.
TEST(KinematicRun, AnOpenLoopIsFlaggedFromWhereItOpens) {
  Case c;
  ExactScene scene(c.m, c.plan);
  const long middle = static_cast<long>(c.plan.grid.time.size()) / 2;
  scene.open_from = middle;
  scene.shift = 10.0 * c.watch.gap;
  const EngineRun run = c.run_with(scene);
  ASSERT_TRUE(run.ok) << run.message;
  int first_flag = -1;
  for (int i = 0; i < c.reference.samples(); ++i)
    if (run.trajectory.status[static_cast<size_t>(i)] == PoseStatus::loop_gap && first_flag < 0)
      first_flag = i;
  ASSERT_GE(first_flag, 0);
  // The first flagged sample is the one whose interval holds the step that opened the loop.
  EXPECT_GE(c.plan.grid.sample_step[static_cast<size_t>(first_flag)], middle);
  EXPECT_LT(c.plan.grid.sample_step[static_cast<size_t>(first_flag - 1)], middle);
  for (int i = first_flag; i < c.reference.samples(); ++i)
    EXPECT_EQ(run.trajectory.status[static_cast<size_t>(i)], PoseStatus::loop_gap) << i;
  EXPECT_NE(run.message.find("flagged loop_gap"), std::string::npos) << run.message;
}

// A pose lost (NaN) stops the run there: not ok, the message says when, the samples before it
// keep their values and the samples after are diverged; the cost counts the steps taken.
TEST(KinematicRun, ALostPoseStopsTheRunWhereItHappens) {
  Case c;
  ExactScene scene(c.m, c.plan);
  const long at = static_cast<long>(c.plan.grid.time.size()) / 3;
  scene.nan_at = at;
  const EngineRun run = c.run_with(scene);
  EXPECT_FALSE(run.ok);
  EXPECT_EQ(run.message.rfind("diverged at t = ", 0), 0u) << run.message;
  EXPECT_NE(run.message.find("NaN in the state"), std::string::npos) << run.message;
  EXPECT_EQ(run.cost.steps, at);
  for (int i = 0; i < c.reference.samples(); ++i) {
    const long S = c.plan.grid.sample_step[static_cast<size_t>(i)];
    const PoseStatus s = run.trajectory.status[static_cast<size_t>(i)];
    if (S + 2 < at) {
      EXPECT_EQ(s, PoseStatus::ok) << i;
    }
    if (S >= at) {
      EXPECT_EQ(s, PoseStatus::diverged) << i;
    }
  }
}

// The two-crank five-bar (mechanisms/drivers/fivebar_two_cranks.toml), swept in time: the loop
// drives each crank to its own law at every step's end, so exact poses give the reference's
// samples (positions to Newton's tolerance, rates to the stencil's O(h^2)) and each driver's
// channel its law's value; over a whole cycle the plan pre-rolls before t = 0, the grid's samples
// at the reference's times.
TEST(KinematicRun, EveryDriverIsDrivenToItsOwnLaw) {
  Case c(load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                        "/mechanisms/drivers/fivebar_two_cranks.toml"));
  ASSERT_EQ(c.m.drivers.size(), 2u);
  ASSERT_EQ(c.plan.preroll, 8);
  for (int i = 0; i < c.reference.samples(); ++i)
    EXPECT_NEAR(
        c.plan.grid.time[static_cast<size_t>(c.plan.grid.sample_step[static_cast<size_t>(i)])],
        c.reference.time(i), 1e-12)
        << i;
  ExactScene scene(c.m, c.plan);
  const EngineRun run = c.run_with(scene);
  ASSERT_TRUE(run.ok) << run.message;
  const Trajectory& out = run.trajectory;
  const double omega_peak = c.reference.omega.cwiseAbs().maxCoeff();
  int compared = 0;
  for (int i = 0; i < c.reference.samples(); ++i) {
    if (!usable(c.reference.status[static_cast<size_t>(i)])) continue;
    ++compared;
    EXPECT_EQ(out.status[static_cast<size_t>(i)], PoseStatus::ok) << i;
    EXPECT_NEAR((out.angle.row(i) - c.reference.angle.row(i)).cwiseAbs().maxCoeff(), 0.0, 1e-9);
    EXPECT_LT((out.omega.row(i) - c.reference.omega.row(i)).cwiseAbs().maxCoeff(),
              1e-5 * omega_peak)
        << i;
    for (int d = 0; d < 2; ++d)  // each driver at its own law at the sample's time
      EXPECT_NEAR(out.driver_values(i, d),
                  c.m.drivers[static_cast<size_t>(d)].at_time(c.reference.time(i)).value, 1e-12)
          << i;
  }
  EXPECT_GT(compared, 100);
}

// The second crank held 10 times the watch's threshold behind its law from the middle of the run:
// the run stops there, losing that driver by name.
TEST(KinematicRun, ARunThatLosesOneOfSeveralDriversNamesIt) {
  Case c(load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                        "/mechanisms/drivers/fivebar_two_cranks.toml"));
  ExactScene scene(c.m, c.plan);
  scene.lagging = 1;
  scene.lag_from = static_cast<long>(c.plan.grid.time.size()) / 2;
  scene.lag = 10.0 * c.watch.driver;
  const EngineRun run = c.run_with(scene);
  EXPECT_FALSE(run.ok);
  EXPECT_EQ(run.message.rfind("lost the driver 'right' at t = ", 0), 0u) << run.message;
  EXPECT_EQ(run.cost.steps, scene.lag_from);
}

}  // namespace
}  // namespace crosslink::sim
