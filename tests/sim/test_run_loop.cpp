// The run loop both engines share (sim/run_loop.h): the time grid between the reference's
// samples and the cost a run reports, against properties any grid and cost must have (the
// engines' outputs are held bit-identical by scripts/behaviour-diff.py).
#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "sim/run_loop.h"

namespace crosslink::sim {
namespace {

// A reference of samples at `times`, every one usable.
Trajectory samples_at(const std::vector<double>& times) {
  Trajectory t;
  t.time = Eigen::Map<const Eigen::VectorXd>(times.data(), static_cast<Eigen::Index>(times.size()));
  t.status.assign(times.size(), PoseStatus::ok);
  return t;
}

// Each interval gets the fewest equal steps no longer than the wanted step (ceil(interval /
// wanted), at least one), the samples fall on step boundaries at their exact times, and the
// longest step (here the short interval's single step) is reported with its interval's count;
// under both placements of inner times.
TEST(RunLoop, SampleGridSplitsEachIntervalIntoTheFewestStepsNoLongerThanWanted) {
  // A short interval (a sweep's extra sample at a toggle) between regular ones.
  const Trajectory reference = samples_at({0.0, 0.1, 0.2, 0.23, 0.33, 0.4});
  const Span span{1, 5};  // sample 0 outside the usable span
  const double wanted = 0.03;
  const std::vector<double> per_interval = steps_per_interval(reference, span, wanted);
  EXPECT_EQ(per_interval, (std::vector<double>{4, 1, 4, 3}));  // ceil(0.1/0.03) = 4, ...
  for (InnerTimes inner : {InnerTimes::step_multiples, InnerTimes::interval_fractions}) {
    const TimeGrid g = sample_grid(reference, span, per_interval, inner);
    ASSERT_EQ(g.time.size(), 1u + 4 + 1 + 4 + 3);
    EXPECT_EQ(g.sample_step, (std::vector<long>{-1, 0, 4, 5, 9, 12}));
    for (int i = span.first; i <= span.last; ++i)
      EXPECT_EQ(g.time[static_cast<size_t>(g.sample_step[static_cast<size_t>(i)])],
                reference.time(i));
    for (size_t k = 1; k < g.time.size(); ++k) {
      EXPECT_GT(g.time[k], g.time[k - 1]);
      EXPECT_LE(g.time[k] - g.time[k - 1], wanted * (1 + 1e-12));
    }
    EXPECT_EQ(g.dt, reference.time(3) - reference.time(2));
    EXPECT_EQ(g.steps_per_sample, 1);
  }
}

// A pre-roll adds `roll` steps of `roll_dt` before the first sample and after the last; the
// samples keep their times, one roll later in steps.
TEST(RunLoop, SampleGridPrerollRunsBeforeTheFirstSampleAndAfterTheLast) {
  const Trajectory reference = samples_at({0.0, 0.1, 0.2});
  const Span span{0, 2};
  const TimeGrid g = sample_grid(reference, span, steps_per_interval(reference, span, 0.05),
                                 InnerTimes::interval_fractions, 3, 0.05);
  ASSERT_EQ(g.time.size(), 3u + 1 + 2 + 2 + 3);
  EXPECT_DOUBLE_EQ(g.time.front(), -0.15);
  EXPECT_DOUBLE_EQ(g.time.back(), 0.35);
  EXPECT_EQ(g.sample_step, (std::vector<long>{3, 5, 7}));
  EXPECT_EQ(g.time[3], 0.0);
  EXPECT_EQ(g.time[7], 0.2);
}

// The cost: the steps and evaluations as given, the stepping time per simulated cycle (time x
// cycle / simulated), none when nothing was simulated, and the wall time since the start
// covering the stepping.
TEST(RunLoop, RecordCostScalesTheSteppingTimeToACycle) {
  const Clock::time_point begin = Clock::now();
  SteppingClock stepping;
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  stepping.stop();
  EXPECT_GE(stepping.wall_seconds, 0.02);
  EXPECT_GE(stepping.cpu_seconds, 0.0);
  EXPECT_LT(stepping.cpu_seconds, stepping.wall_seconds);  // asleep: no CPU
  RunCost cost;
  record_cost(400, 1600, 2.0, 0.5, stepping, begin, cost);
  EXPECT_EQ(cost.steps, 400);
  EXPECT_EQ(cost.model_evaluations, 1600);
  EXPECT_EQ(cost.simulated_seconds, 2.0);
  EXPECT_DOUBLE_EQ(cost.wall_seconds_per_cycle, stepping.wall_seconds / 4);
  EXPECT_DOUBLE_EQ(cost.cpu_seconds_per_cycle, stepping.cpu_seconds / 4);
  EXPECT_GE(cost.wall_seconds, stepping.wall_seconds);
  RunCost none;
  record_cost(0, 0, 0.0, 1.0, stepping, begin, none);
  EXPECT_EQ(none.wall_seconds_per_cycle, 0.0);
  EXPECT_EQ(none.cpu_seconds_per_cycle, 0.0);
}

}  // namespace
}  // namespace crosslink::sim
