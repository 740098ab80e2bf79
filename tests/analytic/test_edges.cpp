// The edges of the assembling range and odd starts (issue 35): a `range` that starts or ends at a
// limit, a start a whole turn from the drawing, the self-check's scale from a sweep of one sample.
// Expected values come from closed forms written here (the four-bar's law of cosines), not from
// either exact method.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "analytic/dyads.h"
#include "analytic/loader.h"
#include "analytic/sweep.h"
#include "analytic/trust.h"
#include "tests/common/mechanisms.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// mechanisms/singular/fourbar_non_grashof.toml: crank a = 40, coupler b = 30, rocker c = 35,
// ground d = 60 mm, drawn open (C left of B -> D, i.e. above the line BD). Its limits are
// +-acos(0.203125), where coupler and rocker are in line.
constexpr double a = 0.040, b = 0.030, c = 0.035, d = 0.060;
const double kLimit = std::acos(0.203125);

struct FourBarPose {
  Eigen::Vector2d C;
  double coupler, rocker;  // absolute angles of B -> C and D -> C
};

// The open assembly at crank angle theta (crossed: -1): C on the circles (B, b) and (D, c),
// left of B -> D (right of it).
FourBarPose open_pose(double theta, double side = 1.0) {
  const Eigen::Vector2d B(a * std::cos(theta), a * std::sin(theta)), D(d, 0.0);
  const Eigen::Vector2d u = D - B;
  const double f = u.norm();
  const double along = (b * b - c * c + f * f) / (2.0 * f);
  const double across = std::sqrt(std::max(0.0, b * b - along * along));
  const Eigen::Vector2d e = u / f, n(-e.y(), e.x());
  FourBarPose p;
  p.C = B + along * e + side * across * n;
  p.coupler = std::atan2(p.C.y() - B.y(), p.C.x() - B.x());
  p.rocker = std::atan2(p.C.y(), p.C.x() - d);
  return p;
}

Mechanism non_grashof(const std::string& driver_extra) {
  std::string text = test::source_text("mechanisms/singular/fourbar_non_grashof.toml");
  const std::string key = "speed_unit = \"rpm\"";
  text.replace(text.find(key), key.size(), std::string(key) + "\n" + driver_extra);
  return parse_mechanism(text, "non_grashof.toml");
}

// Every sample with a pose lies on the open branch (to 1e-9 of the size, 1e-9 rad), and the
// driver values are monotone and distinct. Returns the samples with positions.
int expect_on_open_branch(const Trajectory& t, const std::string& what) {
  const auto named = std::find(t.point_names.begin(), t.point_names.end(), "C");
  const auto C = static_cast<Eigen::Index>(named - t.point_names.begin());
  int placed = 0;
  for (int k = 0; k < t.samples(); ++k) {
    if (k > 0) {
      EXPECT_GT(t.driver(k), t.driver(k - 1)) << what << ": sample " << k << " not after the last";
    }
    if (!has_position(t.status[static_cast<size_t>(k)])) continue;
    ++placed;
    const FourBarPose p = open_pose(t.driver(k));
    const double at = t.driver(k) / kDeg;
    EXPECT_NEAR(t.x(k, C), p.C.x(), 1e-9 * d) << what << " at " << at << " deg";
    EXPECT_NEAR(t.y(k, C), p.C.y(), 1e-9 * d) << what << " at " << at << " deg";
    EXPECT_NEAR(std::remainder(t.angle(k, 1) - p.coupler, 2 * kPi), 0.0, 1e-9)
        << what << " at " << at << " deg";
    EXPECT_NEAR(std::remainder(t.angle(k, 2) - p.rocker, 2 * kPi), 0.0, 1e-9)
        << what << " at " << at << " deg";
    // An angle is a link's, a few turns at most: 7e9 rad was the sign of a lost start.
    EXPECT_LT(std::abs(t.angle(k, 1)), 8 * kPi) << what;
  }
  return placed;
}

// A range equal to the assembling range: Newton was started on the fold (its free angles went
// to 7e9 rad) and 66 of 225 samples at a 0.7 degree step came out ok on the other assembly.
TEST(Edges, ARangeEqualToTheAssemblingRangeFollowsTheDrawnBranch) {
  const Mechanism m = non_grashof("range = [\"-acos(0.203125)\", \"acos(0.203125)\"]");
  for (const double step : {0.7, 1.0, 5.0, 15.0, 45.0, 90.0}) {
    SweepOptions options;
    options.step = step * kDeg;
    const Trajectory t = sweep(m, options);
    const std::string what = fmt::format("step {} deg", step);
    ASSERT_GE(t.samples(), 2) << what;
    expect_on_open_branch(t, what);
    // Both ends are the limits, flagged as the toggles they are, each with its event.
    for (const int k : {0, t.samples() - 1}) {
      EXPECT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::singular) << what;
      EXPECT_NEAR(std::abs(t.driver(k)), kLimit, 1e-9) << what;
    }
    int toggles = 0;
    for (const Trajectory::Event& e : t.events)
      if (e.kind == PoseStatus::singular && e.message.rfind("toggle", 0) == 0) ++toggles;
    EXPECT_EQ(toggles, 2) << what;
    // The dyads, started from the drawing, agree with every ok sample (the self-check).
    Trajectory checked = t;
    const CrossCheck check = cross_check(m, checked, dyad_sweep(m, t));
    EXPECT_EQ(check.disagree, 0) << what;
  }
}

// A range ending on a limit, or beyond it: the sample at the limit is the toggle (singular, with
// its event), its neighbour is kept out beside it, and the values beyond have no pose.
TEST(Edges, ARangeToOrBeyondALimitFlagsTheToggleAndHasNoPoseBeyond) {
  for (const std::string upper : {"\"acos(0.203125)\"", "85"}) {
    const Mechanism m = non_grashof(fmt::format("range = [0, {}]", upper));
    const Trajectory t = sweep(m);
    const std::string what = "range to " + upper;
    expect_on_open_branch(t, what);
    int at_limit = -1;
    for (int k = 0; k < t.samples(); ++k)
      if (std::abs(t.driver(k) - kLimit) < 1e-9) at_limit = k;
    ASSERT_GE(at_limit, 1) << what;
    EXPECT_EQ(t.status[static_cast<size_t>(at_limit)], PoseStatus::singular) << what;
    EXPECT_TRUE(t.beside_singular(at_limit - 1)) << what;
    for (int k = at_limit + 1; k < t.samples(); ++k) {
      EXPECT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::cannot_assemble) << what;
      EXPECT_GT(t.driver(k), kLimit) << what;
    }
    if (upper == "85") {
      EXPECT_NEAR(t.driver(t.samples() - 1), 85 * kDeg, 1e-12);
    }
  }
}

Mechanism edge_file(const std::string& name) {
  const std::string path = "tests/analytic/data/edges/" + name;
  return parse_mechanism(test::source_text(path), path);
}

// The rocker of a Grashof crank-rocker (a = 30, b = 70, c = 50, d = 80 mm) drives it from its
// lower toggle, psi = acos(0.1375), to its upper, acos(-0.9125) (rocker_from_toggle.toml's
// closed form): with --at-limit reverse the loop closes after one round trip. It ran 48.9 crank
// turns (7,229 samples) and never closed: the driver turns back at the start, never passing it.
TEST(Edges, ARockerStartedOnItsToggleClosesItsLoopAfterOneRoundTrip) {
  const Mechanism m = edge_file("rocker_from_toggle.toml");
  SweepOptions options;
  options.at_limit = SweepOptions::AtLimit::reverse;
  const Trajectory t = sweep(m, options);
  const double lower = std::acos(0.1375), upper = std::acos(-0.9125);
  ASSERT_GE(t.samples(), 2);
  double travel = 0.0;
  for (int k = 1; k < t.samples(); ++k) travel += std::abs(t.driver(k) - t.driver(k - 1));
  EXPECT_NEAR(travel, 2.0 * (upper - lower), 1e-9);
  EXPECT_NEAR(t.driver(0), lower, 1e-9);
  EXPECT_NEAR(t.driver(t.samples() - 1), lower, 1e-9);
  for (const Trajectory::Event& e : t.events)
    EXPECT_EQ(e.message.find("did not close"), std::string::npos) << e.message;
  for (int k = 1; k < t.samples(); ++k) EXPECT_GT(t.time(k), t.time(k - 1)) << k;
}

// Drawn 1e-6 deg after a change point (a Grashof-equality four-bar): the start was planned on
// both sides of the located change point and written twice, and every engine refused the
// reference ("the reference's times do not increase").
TEST(Edges, AStartBesideAChangePointIsOneSample) {
  const Mechanism m = edge_file("grashof_eq_start_1e-6_after_change_point.toml");
  const Trajectory t = sweep(m);
  ASSERT_GE(t.samples(), 361);
  for (int k = 1; k < t.samples(); ++k) {
    EXPECT_GT(t.time(k), t.time(k - 1)) << k;
    EXPECT_GT(t.driver(k), t.driver(k - 1)) << k;
  }
}

// A driver's start a whole turn from its drawn link: the start is the drawn pose (every link as
// drawn, the driven one a turn on), not another assembly reached by a 2 pi Newton step (the
// platform at 72.6 deg for the drawn -23.0), nor the drawn pose with links unwound by turns.
TEST(Edges, AStartATurnFromTheDrawingIsTheDrawnPose) {
  for (const std::string file :
       {"rrr3_start_a_turn_from_drawing.toml", "rrr3_start_a_turn_from_drawing_b.toml"}) {
    const Mechanism m = edge_file(file);
    const Trajectory t = solve_at(m, 0.0);
    ASSERT_TRUE(usable(t.status[0])) << file;
    for (size_t l = 0, k = 0; l < m.links.size(); ++l) {
      if (m.moving_index(static_cast<int>(l)) < 0) continue;
      const double drawn = (*m.links[l].pose)(2);
      const double angle = t.angle(0, static_cast<Eigen::Index>(k++));
      // The file draws to 1e-6 deg; within a turn of the drawing (the driven link is a turn on).
      EXPECT_NEAR(std::remainder(angle - drawn, 2 * kPi), 0.0, 1e-6)
          << file << " " << m.links[l].name;
      EXPECT_LE(std::abs(angle - drawn), 2 * kPi + 1e-6) << file << " " << m.links[l].name;
    }
  }
}

// The self-check's scales come from the mechanism: a sweep of one sample (Andrews' squeezer,
// `solve --step 120`: its driver rate taken by differences of one sample, zero) flagged two
// equal values as 6.9e7 of the scale; one pose 0.001 deg from a toggle was its own conditioning,
// and two methods agreeing to 9 digits were flagged.
TEST(Edges, TheSelfCheckJudgesOnePoseOnTheMechanismsScales) {
  {
    const Mechanism m = parse_mechanism(test::source_text("mechanisms/andrews_squeezer.toml"),
                                        "andrews_squeezer.toml");
    SweepOptions options;
    options.step = 120.0;  // rad, the file's unit: one sample in the turn
    Trajectory t = sweep(m, options);
    ASSERT_EQ(t.samples(), 1);
    EXPECT_GT(driver_peak_rate(m, t), 0.5);  // kinematic commands drive it at 1 rad/s
    const CrossCheck check = cross_check(m, t, dyad_sweep(m, t));
    EXPECT_EQ(check.disagree, 0);
    EXPECT_EQ(t.status[0], PoseStatus::ok);
  }
  {
    const Mechanism m = non_grashof("");
    const double at = kLimit - 0.001 * kDeg;
    Trajectory t = solve_at(m, at);
    ASSERT_TRUE(usable(t.status[0]));
    expect_on_open_branch(t, "0.001 deg from the toggle");
    const CrossCheck check = cross_check(m, t, dyad_sweep(m, t));
    EXPECT_EQ(check.disagree, 0);
    EXPECT_TRUE(usable(t.status[0]));
  }
}

// --method dyads --at-limit reverse: past a toggle the chain comes back on the other assembly
// mode; the dyads kept the first, so every reversed sample was flagged as disagreeing with
// Newton. Each sample is checked against the closed form of the mode it must be on.
TEST(Edges, TheDyadsTurnBackThroughAToggleOntoTheOtherAssembly) {
  const Mechanism m = non_grashof("");
  SweepOptions options;
  options.at_limit = SweepOptions::AtLimit::reverse;
  options.step = 5 * kDeg;
  Trajectory t = sweep(m, options);
  const Trajectory closed = dyad_sweep(m, t);
  const auto named = std::find(t.point_names.begin(), t.point_names.end(), "C");
  const auto C = static_cast<Eigen::Index>(named - t.point_names.begin());
  // From 30 deg up to the upper toggle open, back down crossed, up again open to 30 deg.
  double side = 1.0;
  int crossed = 0;
  for (int k = 0; k < closed.samples(); ++k) {
    if (k > 0 && t.status[static_cast<size_t>(k - 1)] == PoseStatus::singular &&
        std::abs(std::abs(t.driver(k - 1)) - kLimit) < 1e-9)
      side = -side;
    if (!usable(closed.status[static_cast<size_t>(k)])) continue;
    const FourBarPose p = open_pose(closed.driver(k), side);
    EXPECT_NEAR(closed.x(k, C), p.C.x(), 1e-9 * d) << "sample " << k;
    EXPECT_NEAR(closed.y(k, C), p.C.y(), 1e-9 * d) << "sample " << k;
    crossed += side < 0;
  }
  EXPECT_GT(crossed, 20);
  const CrossCheck check = cross_check(m, t, closed);
  EXPECT_EQ(check.disagree, 0);
}

}  // namespace
}  // namespace crosslink
