// A sample holding a value that is not finite is flagged, never written as NaN or infinity
// (Trajectory::flag_non_finite; docs/json.md).
#include <gtest/gtest.h>

#include <bit>
#include <cstdint>
#include <limits>
#include <optional>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"

namespace crosslink {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Three solved samples of the sewing machine's sweep (every value finite, status ok).
Trajectory three_samples() {
  const Mechanism m = load_mechanism("mechanisms/sewing_machine.toml");
  SweepOptions options;
  options.range = {m.drivers[0].start,
                   m.drivers[0].start + 0.02};  // samples at start + 0, 0.01, 0.02
  options.step = 0.01;
  Trajectory t = sweep(m, options);
  EXPECT_EQ(t.samples(), 3);
  for (PoseStatus s : t.status) EXPECT_EQ(s, PoseStatus::ok);
  return t;
}

// A channel's value at one sample (Trajectory::sample, which derived quantities read sample by
// sample) is that row of its column (Trajectory::channel), bit for bit, for every channel a
// sweep with forces, friction, sliders and a transmission angle names.
TEST(Trajectory, OneSampleOfAChannelIsThatRowOfItsColumn) {
  for (const char* file :
       {"mechanisms/sewing_machine.toml", "mechanisms/friction/slider_crank_friction.toml",
        "mechanisms/friction/fourbar_friction_circles.toml"}) {
    const Mechanism m = load_mechanism(file);
    SweepOptions options;
    options.step = 0.25;
    const Trajectory t = sweep(m, options);
    ASSERT_GT(t.samples(), 3) << file;
    ASSERT_TRUE(t.has_forces) << file;
    for (const std::string& name : t.channel_names()) {
      const std::optional<Eigen::VectorXd> column = t.channel(name);
      ASSERT_TRUE(column) << name;
      for (int r = 0; r < t.samples(); ++r) {
        const std::optional<double> one = t.sample(name, r);
        ASSERT_TRUE(one) << name << " row " << r;
        EXPECT_EQ(std::bit_cast<uint64_t>(*one), std::bit_cast<uint64_t>((*column)(r)))
            << name << " row " << r;
      }
      EXPECT_FALSE(t.sample(name, -1)) << name;
      EXPECT_FALSE(t.sample(name, t.samples())) << name;
    }
    EXPECT_FALSE(t.sample("x.no_such_point", 0));
    EXPECT_FALSE(t.sample("no_dot", 0));
  }
}

TEST(Trajectory, ASolvedSampleWithANonFiniteValueIsFlaggedAndZeroed) {
  Trajectory t = three_samples();
  const Trajectory before = t;
  t.omega(1, 2) = kNaN;
  t.ax(1, 0) = -kInf;
  EXPECT_EQ(t.flag_non_finite(), 1);
  EXPECT_EQ(t.status[0], PoseStatus::ok);
  EXPECT_EQ(t.status[1], PoseStatus::not_finite);
  EXPECT_EQ(t.status[2], PoseStatus::ok);
  EXPECT_EQ(t.omega(1, 2), 0.0);
  EXPECT_EQ(t.ax(1, 0), 0.0);
  // Nothing else moved: the other values of the row and the other rows.
  EXPECT_EQ(t.omega(1, 1), before.omega(1, 1));
  EXPECT_EQ(t.x(1, 0), before.x(1, 0));
  EXPECT_TRUE(t.omega.row(0) == before.omega.row(0));
  // One event, at the flagged sample's driver value.
  ASSERT_EQ(t.events.size(), 1u);
  EXPECT_EQ(t.events[0].kind, PoseStatus::not_finite);
  EXPECT_EQ(t.events[0].driver, t.along(1));
  EXPECT_EQ(to_string(PoseStatus::not_finite), "not_finite");
  // Again: nothing new to flag, and no second event.
  EXPECT_EQ(t.flag_non_finite(), 0);
  EXPECT_EQ(t.events.size(), 1u);
}

TEST(Trajectory, AnUnsolvedSampleKeepsItsStatusButNoNonFiniteValue) {
  Trajectory t = three_samples();
  t.status[2] = PoseStatus::no_convergence;
  t.sddot(2, 0) = kInf;
  t.time(2) = kNaN;
  EXPECT_EQ(t.flag_non_finite(), 0);
  EXPECT_EQ(t.status[2], PoseStatus::no_convergence);
  EXPECT_EQ(t.sddot(2, 0), 0.0);
  EXPECT_EQ(t.time(2), 0.0);
  EXPECT_TRUE(t.events.empty());
}

TEST(Trajectory, AFiniteSweepIsLeftAsItIs) {
  Trajectory t = three_samples();
  const Trajectory before = t;
  EXPECT_EQ(t.flag_non_finite(), 0);
  EXPECT_TRUE(t.alpha == before.alpha && t.sddot == before.sddot && t.time == before.time);
  EXPECT_TRUE(t.events.empty());
}

}  // namespace
}  // namespace crosslink
