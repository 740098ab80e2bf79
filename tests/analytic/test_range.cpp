// A sweep over an explicit range samples the grid inside it and the range's own two ends: a
// range between two grid values gave 0 samples, status ok, exit 0, and a range's off-grid ends
// were dropped without a note. The bundled crank-rocker (drawn at crank angle 0, 1-degree grid)
// is a full-turn crank, so every sample assembles; each is checked against the closed-form
// dyads at the same driver value, a second method.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "analytic/kinematics/dyads.h"
#include "analytic/model/loader.h"
#include "analytic/reference/budget.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/sweep.h"
#include "tests/common/mechanisms.h"

namespace crosslink {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
// Newton and the dyads agree to this (test_dyads: Newton closes the chain to 1e-12 of its size).
constexpr double kAgreement = 1e-10;

// The crank-rocker with `range` (degrees) and `speed` (rpm) in its [driver] table.
Mechanism crank_rocker(const std::string& range, const std::string& speed = "240") {
  std::string text = test::source_text("mechanisms/fourbar_crank_rocker.toml");
  const size_t at = text.find("speed = 240");
  text.replace(at, 11, "speed = " + speed + "\nrange = " + range);
  return parse_mechanism(text, "range.toml");
}

// The sweep's driver values in degrees; every sample ok and equal to the dyads' closed form.
std::vector<double> swept_degrees(const Mechanism& m) {
  const Trajectory t = sweep(m);
  const Trajectory closed = dyad_sweep(m, t);
  std::vector<double> degrees;
  for (int k = 0; k < t.samples(); ++k) {
    EXPECT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << "sample " << k;
    for (int l = 0; l < t.angle.cols(); ++l)
      EXPECT_NEAR(t.angle(k, l), closed.angle(k, l), kAgreement) << "sample " << k << " link " << l;
    degrees.push_back(t.along(k) / kDeg);
  }
  // The work bound counts the same samples (it counts them first, before the continuation).
  try {
    check_sweep_work(m, {}, WorkLimits{t.samples() - 1});
    ADD_FAILURE() << "not refused at " << t.samples() - 1 << " samples";
  } catch (const DefinitionError& e) {
    EXPECT_NE(std::string(e.what()).find(fmt::format("asks for {} samples", t.samples())),
              std::string::npos)
        << e.what();
  }
  return degrees;
}

TEST(Range, ARangeBetweenTwoGridValuesIsSampledAtItsEnds) {
  const std::vector<double> degrees = swept_degrees(crank_rocker("[10.2, 10.8]"));
  ASSERT_EQ(degrees.size(), 2u);
  EXPECT_NEAR(degrees[0], 10.2, 1e-12);
  EXPECT_NEAR(degrees[1], 10.8, 1e-12);
}

TEST(Range, OffGridEndsAreSampledBesideTheGridInside) {
  // 10.5, then 11 .. 50 on the grid, then 50.5: 42 samples.
  const std::vector<double> degrees = swept_degrees(crank_rocker("[10.5, 50.5]"));
  ASSERT_EQ(degrees.size(), 42u);
  EXPECT_NEAR(degrees.front(), 10.5, 1e-12);
  EXPECT_NEAR(degrees.back(), 50.5, 1e-12);
  for (size_t k = 1; k + 1 < degrees.size(); ++k)
    EXPECT_NEAR(degrees[k], 10.0 + static_cast<double>(k), 1e-9) << k;
}

TEST(Range, EndsOnTheGridAreNotSampledTwice) {
  const std::vector<double> degrees = swept_degrees(crank_rocker("[10, 50]"));
  ASSERT_EQ(degrees.size(), 41u);
  for (size_t k = 0; k < degrees.size(); ++k)
    EXPECT_NEAR(degrees[k], 10.0 + static_cast<double>(k), 1e-9) << k;
}

TEST(Range, ANegativeSpeedSweepsTheRangeDownward) {
  const std::vector<double> degrees = swept_degrees(crank_rocker("[10.5, 12.5]", "-240"));
  ASSERT_EQ(degrees.size(), 4u);
  EXPECT_NEAR(degrees[0], 12.5, 1e-12);
  EXPECT_NEAR(degrees[1], 12.0, 1e-9);
  EXPECT_NEAR(degrees[2], 11.0, 1e-9);
  EXPECT_NEAR(degrees[3], 10.5, 1e-12);
}

// A range that starts outside the assembling range. The crank-rocker driven at its rocker DC
// turns back where crank and coupler lie in line, the rocker at psi = 180 deg - angle ADC with
// cos ADC = (d^2 + c^2 - (a + b)^2) / (2 d c): 54.90 deg. Over [40, 100] the samples below that
// are flagged and the ones above solved, equal to the dyads' closed form (every sample was
// flagged: the continuation from the start to 40 deg stopped at the limit and gave up).
TEST(Range, ARangeStartingOutsideTheAssemblingRangeSolvesTheSamplesInside) {
  std::string text = test::source_text("mechanisms/fourbar_crank_rocker.toml");
  const std::string driver = "joint = \"A\"\nto = \"B\"\nstart = 0\n";
  text.replace(text.find(driver), driver.size(),
               "joint = \"D\"\nto = \"C\"\nstart = 62.72\nrange = [40, 100]\n");
  const Mechanism m = parse_mechanism(text, "rocker_driven.toml");
  const double a = 0.04, b = 0.12, c = 0.08, d = 0.10;
  const double limit =
      std::numbers::pi - std::acos((d * d + c * c - (a + b) * (a + b)) / (2 * d * c));
  const Trajectory t = sweep(m);
  const Trajectory closed = dyad_sweep(m, t);
  int solved = 0, flagged = 0, at_limit = 0;
  for (int k = 0; k < t.samples(); ++k) {
    const PoseStatus s = t.status[static_cast<size_t>(k)];
    if (t.along(k) < limit - 1e-9) {
      EXPECT_EQ(s, PoseStatus::cannot_assemble) << t.along(k) / kDeg;
      ++flagged;
      continue;
    }
    ASSERT_TRUE(has_position(s)) << t.along(k) / kDeg << " " << to_string(s);
    if (std::abs(t.along(k) - limit) < 1e-9) {  // the limit is its toggle: a sample, flagged
      EXPECT_EQ(s, PoseStatus::singular);
      ++at_limit;
      continue;
    }
    for (int l = 0; l < t.angle.cols(); ++l)
      EXPECT_NEAR(t.angle(k, l), closed.angle(k, l), kAgreement) << t.along(k) / kDeg;
    ++solved;
  }
  EXPECT_EQ(flagged, 16);  // 40, 40.72, ..., 54.72
  EXPECT_EQ(at_limit, 1);  // the toggle, as every traced sweep samples it
  EXPECT_EQ(solved, 46);   // 55.72, ..., 99.72 and 100
}

}  // namespace
}  // namespace crosslink
