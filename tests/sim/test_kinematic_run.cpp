// The kinematic run loop every engine shares (sim/kinematic_run.h), driven by a scene that is
// not an engine: each step closes the chain exactly at the driver's law (Newton), so the loop's
// own parts are checked against the exact sweep: the samples it differences, the statuses it
// judges, the stop it makes, the cost it counts. The engines run through the same loop in
// tests/sim/mujoco and tests/sim/bullet.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "analytic/loader.h"
#include "analytic/newton.h"
#include "analytic/sweep.h"
#include "sim/kinematic_run.h"
#include "tests/common/crank_rocker.h"

namespace crosslink::sim {
namespace {

// A scene whose every step is the exact pose at the law's value; from step `open_from` on one
// link is moved by `shift` [m] (a loop that opens), and at step `nan_at` the pose is lost.
class ExactScene final : public KinematicScene {
 public:
  ExactScene(const Mechanism& m, const KinematicPlan& plan)
      : solver_(m), state_(m), offset_(plan.driver_offset) {
    state_.q = plan.q;
  }
  void drive(double driver_value) override {
    state_.driver = DriverState{0.0, driver_value + offset_, 0.0, 0.0};
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

 private:
  const NewtonSolver solver_;
  KinematicState state_;
  double offset_;
  long evaluations_ = 0;
};

struct Case {
  Mechanism m = parse_mechanism(test::crank_rocker().text(), "crank_rocker.toml");
  Trajectory reference = sweep(m);
  KinematicWatch watch{1e-4 * m.size(), m.size(), 1e-3, 1e-5, 1e-4};
  // Steps of at most 0.0025 rad of the fastest link, pre-roll of 8 (MuJoCo's numbers).
  KinematicPlan plan =
      plan_kinematic(m, reference, 0.0025 / fastest_rate(reference, usable_span(reference)),
                     InnerTimes::step_multiples, 8, 1'000'000, watch.singular_rcond, false);
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

}  // namespace
}  // namespace crosslink::sim
