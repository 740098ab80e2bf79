// The forward-dynamics run loop every engine shares (sim/dynamics_run.h), driven by a scene that
// is not an engine: it replays the exact motion of IFToMM A02 (N = 2, under gravity through its
// change points) at every step, so the loop's own parts are checked against the exact reference:
// the samples it differences (one-sided at the start, as for an engine without a pose before
// it), the energy balance it keeps, the stop it makes, the cost it counts. The engines run
// through the same loop in tests/sim/mujoco and tests/sim/bullet.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "sim/dynamics_run.h"
#include "tests/sim/dynamics_cases.h"

namespace crosslink::sim {
namespace {

using dynamics_testing::a02;
using dynamics_testing::exact;

constexpr double kInterval = 1e-2, kDuration = 1.0;

// Step k is the exact pose at k kStep (a reference sampled every step, one step past the end);
// at step `nan_at` the pose is lost.
class ReplayScene final : public DynamicsScene {
 public:
  explicit ReplayScene(const Trajectory& fine) : fine_(fine) {}
  bool evaluates_loads() const override { return true; }  // gravity alone: nothing applied
  std::string step(double, double, ForceReading*) override {
    ++k_;
    return "";
  }
  void read_pose(Eigen::VectorXd& q) override {
    q = reference_coordinates(a02(), fine_, static_cast<int>(k_));
    if (k_ == nan_at) q(0) = std::numeric_limits<double>::quiet_NaN();
  }
  long evaluations() const override { return k_; }
  long nan_at = -1;

 private:
  const Trajectory& fine_;
  long k_ = 0;
};

// Steps of `step` seconds between samples kInterval apart.
struct Case {
  explicit Case(double step = 1e-3) : step(step) {}
  double step;
  const Trajectory& reference = exact(kDuration, kInterval);
  const Trajectory& fine = exact(kDuration + 2 * step, step);
  DynamicsPlan plan =
      plan_dynamics(a02(), a02(), reference, step, InnerTimes::step_multiples, 1'000'000, false);
  DynamicsWatch watch{
      1e-4 * a02().size(), a02().size(), 0.03, reference_energy_scale(a02(), reference), 1e-3, 1.0};
  EngineRun run_with(ReplayScene& scene) {
    EngineRun run;
    run_dynamics(a02(), a02(), reference, plan, watch, false, scene, Clock::now(), run);
    return run;
  }
};

// The exact motion replayed: every usable sample is the reference's, positions to the
// integrators' tolerance, velocities and accelerations to the differences' O(h^2) ((h omega)^2 / 6
// is 8e-6 of the peak at h = 1 ms, omega up to 6.8 rad/s), and the energy balance (kinetic energy
// from differenced velocities) second order too: a quarter with half the step. The cost counts
// the steps, one past the last sample.
TEST(DynamicsRun, TheExactMotionGivesTheReferenceSamples) {
  double energy[2];
  for (int halved = 0; halved < 2; ++halved) {
    Case c(halved ? 5e-4 : 1e-3);
    ASSERT_EQ(c.plan.grid.time.size(), static_cast<size_t>(kDuration / c.step + 0.5) + 2);
    ReplayScene scene(c.fine);
    const EngineRun run = c.run_with(scene);
    ASSERT_TRUE(run.ok) << run.message;
    // Only what the exact motion itself has: the change points' samples, conditioned worse than
    // the watch's fraction of the chain's own, are singular.
    for (PoseStatus s : run.trajectory.status) EXPECT_TRUE(usable(s) || s == PoseStatus::singular);
    const dynamics_testing::Errors e = dynamics_testing::errors(c.reference, run.trajectory);
    EXPECT_LT(e.position, 1e-8);
    EXPECT_LT(e.velocity, 1e-4);
    EXPECT_LT(e.acceleration, 1e-2);
    energy[halved] = e.energy;
    EXPECT_EQ(run.cost.steps, static_cast<long>(c.plan.grid.time.size()) - 1);
    EXPECT_EQ(run.cost.model_evaluations, run.cost.steps);
  }
  EXPECT_GT(energy[0] / energy[1], 3.0) << energy[0] << " J, then " << energy[1] << " J";
  EXPECT_LT(energy[0] / energy[1], 5.0) << energy[0] << " J, then " << energy[1] << " J";
}

// A pose lost (NaN) stops the run there: not ok, the message says when, the samples before it
// keep their values and the samples after it are diverged.
TEST(DynamicsRun, ALostPoseStopsTheRunWhereItHappens) {
  Case c;
  ReplayScene scene(c.fine);
  scene.nan_at = static_cast<long>(c.plan.grid.time.size()) / 2;
  const EngineRun run = c.run_with(scene);
  EXPECT_FALSE(run.ok);
  EXPECT_EQ(run.message.rfind("diverged at t = ", 0), 0u) << run.message;
  EXPECT_NE(run.message.find("NaN in the state"), std::string::npos) << run.message;
  EXPECT_EQ(run.cost.steps, scene.nan_at);
  for (int i = 0; i < c.reference.samples(); ++i) {
    const long S = c.plan.grid.sample_step[static_cast<size_t>(i)];
    const PoseStatus s = run.trajectory.status[static_cast<size_t>(i)];
    if (S + 1 < scene.nan_at) {
      EXPECT_TRUE(usable(s) || s == PoseStatus::singular) << i;
    }
    if (S >= scene.nan_at) {
      EXPECT_EQ(s, PoseStatus::diverged) << i;
    }
  }
}

}  // namespace
}  // namespace crosslink::sim
