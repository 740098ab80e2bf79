// The metric definitions of compare/metrics.h, checked on hand-made columns.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "compare/comparison.h"
#include "compare/metrics.h"
#include "compare/tolerance.h"
#include "methods/engines.h"

namespace crosslink::compare {
namespace {

TEST(PercentDifference, CourseExample) {
  // Notes 002: Working Model 365 mm/s against the IC check 370 mm/s, "1.4 % difference".
  EXPECT_NEAR(percent_difference(365.0, 370.0), 1.3514, 1e-4);
  EXPECT_TRUE(std::isinf(percent_difference(1.0, 0.0)));
  EXPECT_EQ(percent_difference(0.0, 0.0), 0.0);
}

TEST(WrapAngle, ComparesModuloTwoPi) {
  const double pi = std::numbers::pi;
  EXPECT_NEAR(wrap_angle(2 * pi + 0.1), 0.1, 1e-15);
  EXPECT_NEAR(wrap_angle(-0.1 - 4 * pi), -0.1, 1e-14);
  EXPECT_NEAR(wrap_angle(-pi), pi, 1e-15);  // (-pi, pi]
  EXPECT_NEAR(wrap_positive_angle(-0.5 * pi), 1.5 * pi, 1e-15);
}

TEST(CompareChannel, PeakWorstSampleAndExclusion) {
  Eigen::VectorXd ref(5), m(5);
  ref << 1.0, -4.0, 2.0, 0.01, 3.0;
  m << 1.1, -4.0, 2.0, 0.02, 9.0;  // sample 4 is far off but flagged
  const std::vector<bool> usable = {true, true, true, true, false};
  const ChannelMetrics c = compare_channel("v.B", ref, m, usable, 1.0, 0.0);
  EXPECT_EQ(c.usable, 4);
  EXPECT_DOUBLE_EQ(c.peak, 4.0);
  EXPECT_EQ(c.worst_sample, 0);  // the flagged sample 4 does not count
  EXPECT_NEAR(c.max_pct_of_peak, 100.0 * 0.1 / 4.0, 1e-12);
  EXPECT_NEAR(c.rms_pct_of_peak, 100.0 * std::sqrt((0.01 + 1e-4) / 4.0) / 4.0, 1e-12);
  EXPECT_NEAR(c.local_pct(0), 10.0, 1e-12);
  EXPECT_TRUE(std::isnan(c.local_pct(3)));      // |r| = 0.01 < 1 % of the peak 4: masked
  EXPECT_NEAR(c.pct_of_peak(4), 150.0, 1e-12);  // shown per sample all the same
  EXPECT_FALSE(c.in_verdict[4]);
}

TEST(CompareChannel, AnglesWrapAndUsePi) {
  Eigen::VectorXd ref(2), m(2);
  ref << 0.1, 7.0;
  m << 0.1 + 2 * std::numbers::pi, 7.0 - 2 * std::numbers::pi + 1e-3;
  const ChannelMetrics c = compare_channel("angle.crank", ref, m, {true, true}, 1.0, 0.0);
  EXPECT_NEAR(c.max_abs, 1e-3, 1e-12);
  EXPECT_NEAR(c.peak_used, std::numbers::pi, 0.0);
  EXPECT_EQ(c.worst_sample, 1);
}

TEST(CompareChannel, PeakFloorForChannelsThatStayAtZero) {
  Eigen::VectorXd ref = Eigen::VectorXd::Zero(3), m(3);
  m << 1e-9, -2e-9, 0.0;
  const ChannelMetrics c = compare_channel("alpha.crank", ref, m, {true, true, true}, 1.0, 10.0);
  EXPECT_DOUBLE_EQ(c.peak_used, 10.0);
  EXPECT_NEAR(c.max_pct_of_peak, 2e-8, 1e-20);
  EXPECT_EQ(channel_kind("alpha.crank"), "acceleration/angular");
  EXPECT_EQ(channel_kind("sddot.needle"), "acceleration/linear");
}

// Positions are judged against the mechanism's size, whatever the coordinate's own peak: a
// needle sliding on x = 0 has x.F ~ 0, and 1e-6 m off is 1e-4 % of a 1 m mechanism.
TEST(CompareChannel, PositionsUseTheMechanismSize) {
  Eigen::VectorXd ref(2), m(2);
  ref << 1e-17, -2e-17;
  m << 1e-6, 0.0;
  const ChannelMetrics c = compare_channel("x.F", ref, m, {true, true}, 1.0, 0.0);
  EXPECT_DOUBLE_EQ(c.peak, 1.0);
  EXPECT_NEAR(c.max_pct_of_peak, 1e-4, 1e-12);  // less the reference's 1e-17 m
}

// The floor: a component against its vector's magnitude; zero-by-design channels against the
// mechanism's characteristic rates (W = 2 or 20 rad/s, L = 0.5 m).
TEST(CompareChannel, FloorFromMagnitudeKindAndCharacteristic) {
  const Scales slow{0.5, 2.0}, fast{0.5, 20.0};
  EXPECT_DOUBLE_EQ(peak_floor("vx.B", 3.0, 5.0, slow), 5.0);            // |v.B| peak
  EXPECT_DOUBLE_EQ(peak_floor("alpha.crank", 900.0, 0.0, slow), 9.0);   // 1 % of kind
  EXPECT_DOUBLE_EQ(peak_floor("alpha.crank", 1e-9, 0.0, fast), 400.0);  // W^2
  EXPECT_DOUBLE_EQ(peak_floor("a.C", 1e-9, 0.0, fast), 200.0);          // W^2 L
  EXPECT_DOUBLE_EQ(peak_floor("omega.C", 1e-9, 0.0, fast), 20.0);       // W
  EXPECT_DOUBLE_EQ(peak_floor("x.C", 1.0, 0.0, fast), 0.0);             // positions: L
}

// A torque that is zero by design (a free pendulum's driver; a shaking moment about the only
// pivot) is scaled by the forces at the size, not by its round-off: with joint forces of 30 N
// peak on a 1 m pendulum, 1 % of 30 N m; and a force that is zero by design by the torques.
TEST(CompareChannel, ForceAndTorqueFloorsFromEachOther) {
  const Scales pendulum{1.0, 4.4, 30.0, 4e-14};
  EXPECT_DOUBLE_EQ(peak_floor("torque.driver", 4e-14, 0.0, pendulum), 0.3);
  EXPECT_DOUBLE_EQ(peak_floor("shaking_moment.ground", 4e-14, 0.0, pendulum), 0.3);
  EXPECT_DOUBLE_EQ(peak_floor("fx.O", 30.0, 30.0, pendulum), 30.0);  // its vector: unchanged
  const Scales rotor{0.5, 4.0, 1e-15, 2.0};  // a balanced rotor under a torque
  EXPECT_DOUBLE_EQ(peak_floor("fy.O", 1e-15, 1e-15, rotor), 0.04);
  // Round-off against round-off stays round-off: 1e-13 N m off is 3e-11 % of the floor.
  Eigen::VectorXd ref(2), m(2);
  ref << 3.8e-14, 0.0;
  m << 0.0, 1e-13;
  const ChannelMetrics c = compare_channel("torque.driver", ref, m, {true, true}, 1.0,
                                           peak_floor("torque.driver", 3.8e-14, 0.0, pendulum));
  EXPECT_LT(c.max_pct_of_peak, 1e-10);
}

TEST(Tolerances, DefaultsDefinitionAndCommandLine) {
  ToleranceOverrides file;
  file.velocity = 0.2;
  Tolerances t(methods::engine_tolerances(false), file);
  EXPECT_DOUBLE_EQ(t.of("mujoco", Quantity::position), 1e-2);
  EXPECT_DOUBLE_EQ(t.of("bullet", Quantity::velocity), 0.2);
  EXPECT_DOUBLE_EQ(t.of("mujoco", Quantity::acceleration), 1.0);
  EXPECT_DOUBLE_EQ(t.of("dyads", Quantity::velocity), 1e-8);  // the file does not loosen exact
  t.apply("velocity=0.5");
  t.apply("bullet:acceleration=2");
  t.apply("dyads:position=1e-6");
  EXPECT_DOUBLE_EQ(t.of("mujoco", Quantity::velocity), 0.5);
  EXPECT_DOUBLE_EQ(t.of("bullet", Quantity::acceleration), 2.0);
  EXPECT_DOUBLE_EQ(t.of("mujoco", Quantity::acceleration), 1.0);
  EXPECT_DOUBLE_EQ(t.of("dyads", Quantity::position), 1e-6);
  EXPECT_THROW(t.apply("speed=1"), std::invalid_argument);
  EXPECT_THROW(t.apply("velocity=abc"), std::invalid_argument);
  EXPECT_THROW(t.apply("velocity"), std::invalid_argument);
  EXPECT_THROW(t.apply("working_model:velocity=1"), std::invalid_argument);
}

// A reference at rest: every sample 0 or subnormal (below 2.2e-308), and no floor (a 1 ns case
// with an effort of 1e-300).
// A % of such a peak is not a number: no sample's % of peak, no max or RMS % (never 1e308 % or
// inf %), though the differences themselves exist.
TEST(CompareChannel, APeakOfZeroOrSubnormalGivesNoPercent) {
  for (const double tiny : {0.0, 1e-310, 4.9e-324}) {
    Eigen::VectorXd ref(3), m(3);
    ref << 0.0, tiny, -tiny;
    m << 0.0, 2.0 * tiny, 0.0;
    const ChannelMetrics c = compare_channel("torque.driver", ref, m, {true, true, true}, 1.0, 0.0);
    EXPECT_EQ(c.usable, 3);
    EXPECT_TRUE(std::isnan(c.max_pct_of_peak)) << tiny << ": " << c.max_pct_of_peak;
    EXPECT_TRUE(std::isnan(c.rms_pct_of_peak)) << tiny;
    for (Eigen::Index k = 0; k < 3; ++k) {
      EXPECT_TRUE(std::isnan(c.pct_of_peak(k))) << tiny << " sample " << k;
      EXPECT_TRUE(std::isnan(c.local_pct(k))) << tiny << " sample " << k;
    }
    EXPECT_EQ(c.max_abs, tiny);  // a difference is a difference
  }
}

// The step probe's order is log2 of the ratio of two % of peak: not a number when either is 0.
TEST(StepProbe, AnOrderOfLogZeroIsNotANumber) {
  StepProbe p;
  p.pct = 0.0;
  p.half_pct = 0.5;
  EXPECT_TRUE(std::isnan(p.order()));  // log2(0) = -inf before
  p.pct = 0.5;
  p.half_pct = 0.0;
  EXPECT_TRUE(std::isnan(p.order()));
  p.half_pct = 0.125;
  EXPECT_DOUBLE_EQ(p.order(), 2.0);
}

}  // namespace
}  // namespace crosslink::compare
