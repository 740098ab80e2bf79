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

#include "analytic/kinematics/dyads.h"
#include "analytic/kinematics/newton.h"
#include "analytic/model/loader.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/sweep.h"
#include "analytic/reference/trust.h"
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
      EXPECT_GT(t.along(k), t.along(k - 1)) << what << ": sample " << k << " not after the last";
    }
    if (!has_position(t.status[static_cast<size_t>(k)])) continue;
    ++placed;
    const FourBarPose p = open_pose(t.along(k));
    const double at = t.along(k) / kDeg;
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
      EXPECT_NEAR(std::abs(t.along(k)), kLimit, 1e-9) << what;
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
      if (std::abs(t.along(k) - kLimit) < 1e-9) at_limit = k;
    ASSERT_GE(at_limit, 1) << what;
    EXPECT_EQ(t.status[static_cast<size_t>(at_limit)], PoseStatus::singular) << what;
    EXPECT_TRUE(t.beside_singular(at_limit - 1)) << what;
    for (int k = at_limit + 1; k < t.samples(); ++k) {
      EXPECT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::cannot_assemble) << what;
      EXPECT_GT(t.along(k), kLimit) << what;
    }
    if (upper == "85") {
      EXPECT_NEAR(t.along(t.samples() - 1), 85 * kDeg, 1e-12);
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
  for (int k = 1; k < t.samples(); ++k) travel += std::abs(t.along(k) - t.along(k - 1));
  EXPECT_NEAR(travel, 2.0 * (upper - lower), 1e-9);
  EXPECT_NEAR(t.along(0), lower, 1e-9);
  EXPECT_NEAR(t.along(t.samples() - 1), lower, 1e-9);
  for (const Trajectory::Event& e : t.events)
    EXPECT_EQ(e.message.find("did not close"), std::string::npos) << e.message;
  for (int k = 1; k < t.samples(); ++k) EXPECT_GT(t.time(k), t.time(k - 1)) << k;
}

// The file with its driver's start replaced (each edges file writes it as start = "...").
Mechanism edge_file_started(const std::string& name, const std::string& start) {
  const std::string path = "tests/analytic/data/edges/" + name;
  std::string text = test::source_text(path);
  const size_t at = text.find("\nstart = \"");
  const size_t end = text.find('"', at + 10);
  text.replace(at + 10, end - at - 10, start);
  return parse_mechanism(text, path);
}

// Drawn 1e-6 deg after a change point (a Grashof-equality four-bar): the start was planned on
// both sides of the located change point and written twice, and every engine refused the
// reference ("the reference's times do not increase"). From 1e-4 deg it is one sample, the
// driver increasing; at 1e-6 deg the start is the change point to working precision (below).
TEST(Edges, AStartBesideAChangePointIsOneSample) {
  const Mechanism m = edge_file_started("grashof_eq_start_1e-6_after_change_point.toml", "1e-4");
  const Trajectory t = sweep(m);
  ASSERT_GE(t.samples(), 361);
  for (int k = 1; k < t.samples(); ++k) {
    EXPECT_GT(t.time(k), t.time(k - 1)) << k;
    EXPECT_GT(t.along(k), t.along(k - 1)) << k;
  }
}

// A kite four-bar (crank = ground = 30, coupler = rocker = 65 mm) drawn beside its change point,
// where B falls on D and coupler and rocker turn freely together. Its smooth branch is C = r
// (cos q/2, sin q/2), r = a cos(q/2) + sqrt(b^2 - a^2 sin^2(q/2)) (C on the bisector of BAD, the
// file's closed form). Drawn 1e-7 deg before, `check` reported a false toggle at 2e-9 deg and a
// range of -360.97 to 0 deg, and the sweep ran backwards: the start, within the solver's
// tolerance, lay on the held-driver branch (a residual of 5e-13) and its tangent mixed the two.
// Settled to round-off, a start from 1e-5 deg (drawn folded) or 1e-4 deg on turns fully on the
// smooth branch; nearer, round-off cannot tell the branches apart and the start is refused at
// the driver's line, as a change point.
TEST(Edges, AKiteDrawnBesideItsChangePointTurnsOnItsSmoothBranchOrIsRefused) {
  const double a = 0.030, b = 0.065;
  for (const std::string file : {"kite_start_1e-7_before_change_point.toml",
                                 "kite_start_1e-7_before_change_point_folded.toml"}) {
    for (const std::string start : {"-1e-9", "-1e-7", "-1e-6"}) {
      const Mechanism m = edge_file_started(file, start);
      const std::string text = test::source_text("tests/analytic/data/edges/" + file);
      const auto line = std::count(text.begin(), text.begin() + text.find("[driver]"), '\n') + 1;
      try {
        assembling_range(m);
        ADD_FAILURE() << file << " from " << start << " deg: not refused";
      } catch (const DefinitionError& e) {
        EXPECT_NE(std::string(e.what()).find(fmt::format(".toml:{}:", line)), std::string::npos)
            << e.what();
        EXPECT_NE(std::string(e.what()).find("change point to working precision"),
                  std::string::npos)
            << e.what();
      }
      EXPECT_THROW(sweep(m), DefinitionError) << file << " from " << start;
    }
    const bool folded = file.find("folded") != std::string::npos;
    for (const std::string start : {"-1e-4", "-1e-5"}) {
      if (start == "-1e-5" && !folded) continue;  // 1e-5 deg: a ratio of 1.2e-8, refused
      const Mechanism m = edge_file_started(file, start);
      const std::string what = file + " from " + start + " deg";
      EXPECT_TRUE(assembling_range(m).full_cycle) << what;
      SweepOptions options;
      options.step = 5 * kDeg;
      const Trajectory t = sweep(m, options);
      const auto named = std::find(t.point_names.begin(), t.point_names.end(), "C");
      const auto C = static_cast<Eigen::Index>(named - t.point_names.begin());
      ASSERT_GE(t.samples(), 72) << what;
      int ok = 0;
      for (int k = 0; k < t.samples(); ++k) {
        if (k > 0) {
          EXPECT_GT(t.along(k), t.along(k - 1)) << what << " " << k;
          EXPECT_GT(t.time(k), t.time(k - 1)) << what << " " << k;
        }
        if (t.status[static_cast<size_t>(k)] != PoseStatus::ok) continue;
        ++ok;
        // The smooth branch through the drawing: at q = 0 drawn open C = (a + b, 0), folded
        // C = (a - b, 0), which the branch reaches at q = 360 deg (half-angle q/2 + 180 deg).
        const double half = 0.5 * t.along(k) + (folded ? kPi : 0.0);
        const double sh = std::sin(half), ch = std::cos(half);
        const double r = a * ch + std::sqrt(b * b - a * a * sh * sh);
        EXPECT_NEAR(t.x(k, C), r * ch, 1e-9 * (a + b)) << what << " at " << t.along(k) / kDeg;
        EXPECT_NEAR(t.y(k, C), r * sh, 1e-9 * (a + b)) << what << " at " << t.along(k) / kDeg;
      }
      EXPECT_GE(ok, 60) << what;
    }
  }
}

// The non-Grashof four-bar drawn open at crank angle `drawn`, its driver started at `start`.
Mechanism non_grashof_drawn(double drawn, double start) {
  Mechanism m = non_grashof("");
  m.drivers[0].start = start;
  const FourBarPose p = open_pose(drawn);
  const Eigen::Vector2d B(a * std::cos(drawn), a * std::sin(drawn));
  for (Link& link : m.links) {
    if (link.name == "crank") link.pose = Eigen::Vector3d(0, 0, drawn);
    if (link.name == "coupler") link.pose = Eigen::Vector3d(B.x(), B.y(), p.coupler);
    if (link.name == "rocker") link.pose = Eigen::Vector3d(d, 0, p.rocker);
  }
  return m;
}

// Starts 1e-9 deg either side of the upper toggle, acos(0.203125), drawn half a degree inside
// it. Within the solver's tolerance the chain can close 1e-9 deg beyond a toggle (the polycentric
// hinge did, with a residual of 6.5e-13, and swept the other assembly from there): beyond, the
// start is refused at the driver's line or does not assemble, and no sample has a pose; inside,
// it sweeps on the open branch.
TEST(Edges, AStartJustBeyondAToggleHasNoPose) {
  for (const double offset : {1e-9, -1e-9}) {
    const Mechanism m = non_grashof_drawn(kLimit - 0.5 * kDeg, kLimit + offset * kDeg);
    const std::string what = fmt::format("{:+g} deg from the toggle", offset);
    SweepOptions options;
    options.step = 5 * kDeg;
    if (offset < 0) {
      EXPECT_GE(expect_on_open_branch(sweep(m, options), what), 30);
      continue;
    }
    try {
      const Trajectory t = sweep(m, options);
      EXPECT_EQ(expect_on_open_branch(t, what), 0) << what;
    } catch (const DefinitionError& e) {
      EXPECT_NE(std::string(e.what()).find("only to the solver's tolerance"), std::string::npos)
          << e.what();
    }
  }
}

// Drawn on the toggle itself, with the driver started elsewhere: the drawn pose is where the
// open and crossed assemblies meet, so it does not say which one the chain takes at the start.
// Newton's first step leapt along J's null direction there (started 1e-9 deg inside, the coupler
// went to 1.3e5 rad and the sweep ran on the crossed assembly); now the start does not assemble,
// with the reason, and no sample has a pose (1e-9 deg inside, Levenberg–Marquardt stops short of
// closing the chain, and says so). Started on the toggle, the drawing is the start.
TEST(Edges, ADrawingOnAToggleSaysNothingOfAnotherStart) {
  for (const double start : {77.0, 0.0, kLimit / kDeg - 1e-5, kLimit / kDeg - 1e-9}) {
    const Mechanism m = non_grashof_drawn(kLimit, start * kDeg);
    const std::string what = fmt::format("drawn on the toggle, started at {} deg", start);
    KinematicState state(m);
    const SolveReport assembled = NewtonSolver(m).assemble(state);
    EXPECT_EQ(assembled.status, PoseStatus::cannot_assemble) << what;
    const bool toggle = assembled.message.find("the drawing is on a toggle") != std::string::npos;
    EXPECT_TRUE(toggle || start == kLimit / kDeg - 1e-9) << what << ": " << assembled.message;
    EXPECT_EQ(expect_on_open_branch(sweep(m), what), 0) << what;
  }
  SweepOptions options;
  options.step = 5 * kDeg;
  const Mechanism on = non_grashof_drawn(kLimit, kLimit);
  EXPECT_GE(expect_on_open_branch(sweep(on, options), "drawn and started on the toggle"), 30);
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
        std::abs(std::abs(t.along(k - 1)) - kLimit) < 1e-9)
      side = -side;
    if (!usable(closed.status[static_cast<size_t>(k)])) continue;
    const FourBarPose p = open_pose(closed.along(k), side);
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
