// Branches and singular positions over a sweep: toggles (dead points) that bound the assembling
// range, change points where branches cross, and four-bar Grashof classes and transmission
// angles. Every expected value is closed-form geometry from the definitions' dimensions (the
// law of cosines, collinear pivots), never the program's own output.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>

#include <fmt/format.h>

#include "analytic/kinematics/newton.h"
#include "analytic/model/fourbar.h"
#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;

// A point of a link in its own frame [m].
Eigen::Vector2d local(const Mechanism& m, const char* link, const char* point) {
  const Link& l = m.links[static_cast<size_t>(m.find_link(link))];
  return l.points[static_cast<size_t>(l.find_point(point))].local;
}
double length(const Mechanism& m, const char* link, const char* p, const char* q) {
  return (local(m, link, p) - local(m, link, q)).norm();
}

std::vector<double> events_of(const std::vector<SingularPosition>& s, SingularKind kind) {
  std::vector<double> out;
  for (const SingularPosition& p : s)
    if (p.kind == kind) out.push_back(p.driver);
  return out;
}

double channel(const Trajectory& t, const std::string& name, int row) {
  return (*t.channel(name))(row);
}

// z of (C - B) x (D - B): which side of BD the coupler-rocker joint C lies on (assembly mode).
double side_of_c(const Trajectory& t, int row) {
  const Eigen::Vector2d b(channel(t, "x.B", row), channel(t, "y.B", row));
  const Eigen::Vector2d c(channel(t, "x.C", row), channel(t, "y.C", row));
  const Eigen::Vector2d d(channel(t, "x.D", row), channel(t, "y.D", row));
  const Eigen::Vector2d u = c - b, v = d - b;
  return u.x() * v.y() - u.y() * v.x();
}

// The bundled parallelogram: its change points are where all four pivots are collinear, i.e.
// B on the line AD with |BD| = b + c or |b - c|; the sweep must keep to the parallelogram
// branch (the smooth one: rocker parallel to crank, coupler parallel to ground) through them.
TEST(ChangePoint, ParallelogramAtCollinearPivotsStaysOnSmoothBranch) {
  const Mechanism m = load_mechanism("mechanisms/fourbar_change_point.toml");
  const double a = length(m, "crank", "A", "B"), b = length(m, "coupler", "B", "C"),
               c = length(m, "rocker", "D", "C");
  const Eigen::Vector2d A = local(m, "ground", "A"), D = local(m, "ground", "D");
  const double ad_angle = std::atan2((D - A).y(), (D - A).x());
  std::vector<double> expected;
  for (double theta : {ad_angle, ad_angle + kPi}) {
    const Eigen::Vector2d B = A + a * Eigen::Vector2d(std::cos(theta), std::sin(theta));
    const double bd = (D - B).norm();
    if (std::abs(bd - (b + c)) < 1e-12 || std::abs(bd - std::abs(b - c)) < 1e-12) {
      // The sweep turns the crank once from its start, so each angle appears once in it.
      const double start = m.drivers[0].start;
      expected.push_back(start + std::fmod(std::fmod(theta - start, 2 * kPi) + 2 * kPi, 2 * kPi));
    }
  }
  std::sort(expected.begin(), expected.end());
  ASSERT_EQ(expected.size(), 2u);  // a parallelogram has both

  std::vector<SingularPosition> singular;
  const Trajectory t = sweep(m, {}, singular);
  const std::vector<double> found = events_of(singular, SingularKind::change_point);
  ASSERT_EQ(found.size(), expected.size());
  for (size_t i = 0; i < found.size(); ++i) EXPECT_NEAR(found[i], expected[i], 1e-9);
  // Parallelogram branch on every sample, before and after each change point.
  int usable = 0;
  for (int r = 0; r < t.samples(); ++r) {
    if (t.status[static_cast<size_t>(r)] != PoseStatus::ok) continue;
    ++usable;
    EXPECT_NEAR(
        std::remainder(channel(t, "angle.rocker", r) - channel(t, "angle.crank", r), 2 * kPi), 0.0,
        1e-9)
        << "row " << r;
    EXPECT_NEAR(std::remainder(channel(t, "angle.coupler", r), 2 * kPi), 0.0, 1e-9);
  }
  EXPECT_GE(usable, t.samples() - 2);  // only the samples at the change points are singular
}

// A change point of a crank-rocker (a + d = b + c, all lengths distinct): the smooth branch
// crosses to the other side of BD (the assembly mode flips) at theta2 = 180 deg.
TEST(ChangePoint, CrankRockerFlipsAssemblyModeOnSmoothBranch) {
  const Mechanism m = load_mechanism("mechanisms/singular/fourbar_change_point_crank_rocker.toml");
  std::vector<SingularPosition> singular;
  const Trajectory t = sweep(m, {}, singular);
  const std::vector<double> found = events_of(singular, SingularKind::change_point);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_NEAR(found[0], kPi, 1e-9);
  for (int r = 0; r + 1 < t.samples(); ++r) {
    if (t.along(r) < kPi - 1e-9 && t.along(r + 1) > kPi - 1e-9) {
      const int after = t.along(r + 1) > kPi + 1e-9 ? r + 1 : r + 2;  // skip a sample at pi
      EXPECT_LT(side_of_c(t, r) * side_of_c(t, after), 0.0);
    }
  }
}

// Law of cosines: the crank of a non-Grashof four-bar stops where coupler and rocker are in
// line, |BD| = b + c:  cos(theta0) = (a^2 + d^2 - (b + c)^2) / (2 a d).
TEST(Toggle, NonGrashofLimitsAndReverse) {
  const Mechanism m = load_mechanism("mechanisms/singular/fourbar_non_grashof.toml");
  const double a = length(m, "crank", "A", "B"), b = length(m, "coupler", "B", "C"),
               c = length(m, "rocker", "D", "C"), d = length(m, "ground", "A", "D");
  const double theta0 = std::acos((a * a + d * d - (b + c) * (b + c)) / (2 * a * d));

  const AssemblingRange range = assembling_range(m);
  EXPECT_FALSE(range.full_cycle);
  EXPECT_NEAR(range.lower, -theta0, 1e-9);
  EXPECT_NEAR(range.upper, theta0, 1e-9);

  // Stop: the sweep covers [-theta0, theta0] on the drawn branch, ending on flagged toggles.
  std::vector<SingularPosition> stop_events;
  const Trajectory stop = sweep(m, {}, stop_events);
  EXPECT_NEAR(stop.along(0), -theta0, 1e-9);
  EXPECT_NEAR(stop.along(stop.samples() - 1), theta0, 1e-9);
  EXPECT_EQ(stop.status.front(), PoseStatus::singular);
  EXPECT_EQ(stop.status.back(), PoseStatus::singular);
  const double drawn_side = side_of_c(stop, stop.samples() / 2);
  for (int r = 1; r + 1 < stop.samples(); ++r) {
    EXPECT_EQ(stop.status[static_cast<size_t>(r)], PoseStatus::ok);
    EXPECT_GT(side_of_c(stop, r) * drawn_side, 0.0);  // the drawn (open) mode throughout
  }

  // Reverse: up to +theta0, back down on the other assembly mode to -theta0, up to the start.
  SweepOptions reverse;
  reverse.at_limit = SweepOptions::AtLimit::reverse;
  std::vector<SingularPosition> events;
  const Trajectory t = sweep(m, reverse, events);
  const std::vector<double> toggles = events_of(events, SingularKind::toggle);
  ASSERT_EQ(toggles.size(), 2u);
  EXPECT_NEAR(toggles[0], theta0, 1e-9);
  EXPECT_NEAR(toggles[1], -theta0, 1e-9);
  int first = -1, second = -1;
  for (int r = 0; r < t.samples(); ++r) {
    if (first < 0 && std::abs(t.along(r) - theta0) < 1e-12) first = r;
    if (first >= 0 && second < 0 && std::abs(t.along(r) + theta0) < 1e-12) second = r;
  }
  ASSERT_GT(first, 0);
  ASSERT_GT(second, first);
  for (int r = 0; r < t.samples(); ++r) {
    if (r == first || r == second) continue;
    const bool other_side = r > first && r < second;
    EXPECT_EQ(side_of_c(t, r) * side_of_c(t, 0) < 0, other_side) << "row " << r;
    if (r > 0 && r != first + 1 && r != second + 1) {  // driver direction per leg
      EXPECT_EQ(t.along(r) < t.along(r - 1), other_side) << "row " << r;
    }
    if (r > 0) {
      EXPECT_GT(t.time(r), t.time(r - 1));
    }
  }
  // The loop closes on the drawn position.
  EXPECT_NEAR(t.along(t.samples() - 1), m.drivers[0].start, 1e-12);
  EXPECT_NEAR(channel(t, "angle.rocker", t.samples() - 1), channel(t, "angle.rocker", 0), 1e-9);
}

// The slider-driven offset slider-crank toggles where crank and rod are collinear:
// |AC| = r + l or l - r with C = (s, e):  s = sqrt((r + l)^2 - e^2), sqrt((l - r)^2 - e^2).
TEST(Toggle, SliderCrankDrivenFromSlider) {
  const Mechanism m = load_mechanism("mechanisms/singular/slider_crank_from_slider.toml");
  const double r = length(m, "crank", "A", "B"), l = length(m, "rod", "B", "C");
  const double e = local(m, "ground", "P").y() - local(m, "ground", "A").y();
  const double s_max = std::sqrt((r + l) * (r + l) - e * e);
  const double s_min = std::sqrt((l - r) * (l - r) - e * e);

  const AssemblingRange range = assembling_range(m);
  EXPECT_NEAR(range.lower, s_min, 1e-12);  // [m]: 1e-9 mm
  EXPECT_NEAR(range.upper, s_max, 1e-12);

  SweepOptions reverse;
  reverse.at_limit = SweepOptions::AtLimit::reverse;
  std::vector<SingularPosition> events;
  const Trajectory t = sweep(m, reverse, events);
  const std::vector<double> toggles = events_of(events, SingularKind::toggle);
  ASSERT_EQ(toggles.size(), 2u);
  EXPECT_NEAR(toggles[0], s_max, 1e-12);  // the slider starts moving out (speed > 0)
  EXPECT_NEAR(toggles[1], s_min, 1e-12);
  // Passing both dead points the crank makes one full turn and the loop closes.
  const int last = t.samples() - 1;
  EXPECT_NEAR(t.along(last), m.drivers[0].start, 1e-12);
  EXPECT_NEAR(std::abs(channel(t, "angle.crank", last) - channel(t, "angle.crank", 0)), 2 * kPi,
              1e-9);
}

// The polycentric hinge assembles over a limited range of theta4: the sweep's ends are its
// limits, flagged singular, and the chain closes just inside them but not just outside (by
// the driver-parametrised Follower, an independent continuation).
TEST(Toggle, PolycentricHingeLimits) {
  const Mechanism m = load_mechanism("mechanisms/polycentric_hinge.toml");
  std::vector<SingularPosition> events;
  const Trajectory t = sweep(m, {}, events);
  const AssemblingRange range = assembling_range(m);
  ASSERT_FALSE(range.full_cycle);
  EXPECT_NEAR(t.along(0), range.lower, 1e-12);
  EXPECT_NEAR(t.along(t.samples() - 1), range.upper, 1e-12);
  EXPECT_EQ(t.status.front(), PoseStatus::singular);
  EXPECT_EQ(t.status.back(), PoseStatus::singular);
  EXPECT_LT(t.rcond(0), 1e-6);
  EXPECT_LT(t.rcond(t.samples() - 1), 1e-6);
  EXPECT_GT(t.rcond(1), 1e-6);
  EXPECT_EQ(events_of(events, SingularKind::toggle).size(), 2u);
  EXPECT_TRUE(range.lower < m.drivers[0].start && m.drivers[0].start < range.upper);
  for (const double limit : {range.lower, range.upper}) {
    const double inward = limit == range.lower ? 1.0 : -1.0;
    EXPECT_TRUE(usable(solve_at(m, limit + inward * 1e-7).status[0])) << limit;
    EXPECT_FALSE(usable(solve_at(m, limit - inward * 1e-7).status[0])) << limit;
  }
}

// Grashof class and transmission angle of the bundled crank-rocker: the extremes of
// cos(mu) = (b^2 + c^2 - |BD|^2) / (2 b c) are at theta2 = 0 and 180 deg (|BD| = d - a, d + a).
TEST(FourBar, CrankRockerGrashofAndTransmissionAngle) {
  const Mechanism m = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  const auto fb = four_bar(m);
  ASSERT_TRUE(fb.has_value());
  EXPECT_EQ(fb->grashof, Grashof::grashof);
  EXPECT_EQ(fb->inversion, "crank-rocker");
  const double a = length(m, "crank", "A", "B"), b = length(m, "coupler", "B", "C"),
               c = length(m, "rocker", "D", "C"), d = length(m, "ground", "A", "D");
  const double mu_min = std::acos((b * b + c * c - (d - a) * (d - a)) / (2 * b * c));
  const double mu_max = std::acos((b * b + c * c - (d + a) * (d + a)) / (2 * b * c));
  const Trajectory t = sweep(m);
  const auto mu = transmission_range(*fb, t);
  ASSERT_TRUE(mu.has_value());
  // The 1 degree grid starts at 0, so it holds both extremes.
  EXPECT_NEAR(mu->min, mu_min, 1e-9);
  EXPECT_NEAR(mu->max, mu_max, 1e-9);
  EXPECT_NEAR(std::remainder(mu->min_at, 2 * kPi), 0.0, 1e-9);
  EXPECT_NEAR(std::remainder(mu->max_at - kPi, 2 * kPi), 0.0, 1e-9);
  // The channel mu.C at every sample: the law of cosines in triangle BCD, |BD| from the crank
  // angle theta (triangle ABD): |BD|^2 = a^2 + d^2 - 2 a d cos(theta - angle of AD).
  const std::optional<Eigen::VectorXd> channel_mu = t.channel("mu." + fb->c);
  ASSERT_TRUE(channel_mu.has_value());
  const Eigen::Vector2d ad = local(m, "ground", "D") - local(m, "ground", "A");
  for (int k = 0; k < t.samples(); ++k) {
    const double theta = channel(t, "angle.crank", k) - std::atan2(ad.y(), ad.x());
    const double bd2 = a * a + d * d - 2 * a * d * std::cos(theta);
    EXPECT_NEAR((*channel_mu)(k), std::acos((b * b + c * c - bd2) / (2 * b * c)), 1e-9) << k;
  }
  EXPECT_FALSE(four_bar(load_mechanism("mechanisms/sewing_machine.toml")).has_value());
}

// Norton ch. 2, Grashof special cases: a parallelogram (opposite links equal) is a double crank
// on its parallelogram branch, whichever link is the ground; a kite with its short crank and
// coupler adjacent turns its crank fully and rocks its long rocker (C the mirror image of A).
TEST(FourBar, ChangePointInversions) {
  const auto parallelogram = four_bar(load_mechanism("tests/analytic/singular/parallelogram.toml"));
  ASSERT_TRUE(parallelogram.has_value());
  EXPECT_EQ(parallelogram->grashof, Grashof::change_point);
  EXPECT_EQ(parallelogram->inversion, "parallelogram double-crank");
  const auto bundled = four_bar(load_mechanism("mechanisms/fourbar_change_point.toml"));
  ASSERT_TRUE(bundled.has_value());
  EXPECT_EQ(bundled->inversion, "parallelogram double-crank");
  const auto kite = four_bar(load_mechanism("tests/analytic/singular/kite.toml"));
  ASSERT_TRUE(kite.has_value());
  EXPECT_EQ(kite->grashof, Grashof::change_point);
  EXPECT_EQ(kite->inversion, "crank-rocker");
}

// The stability catalogue: every definition in mechanisms/singular/ states its expected
// singular behaviour in [expect] (derived by hand in its comments); the sweep must match it.
// A degenerate drawing (kept from fuzzing): the Wanzer triangle with a point a million metres
// away turns on its slots with the disk held. The tracer must say that the driver does not set
// the pose, not trace ten turns after ten turns and call the ends of that a range.
TEST(HeldDriver, ChainTurningWithTheDriverHeldIsFlagged) {
  const Mechanism m =
      load_mechanism("tests/fuzz/regressions/wanzer_triangle_spins_driver_locked.toml");
  const AssemblingRange range = assembling_range(m);
  EXPECT_FALSE(range.full_cycle);
  EXPECT_NE(range.unknown.find("driver held"), std::string::npos) << range.unknown;
  EXPECT_EQ(range.explain(m).rfind("unknown: ", 0), 0u) << range.explain(m);

  std::vector<SingularPosition> events;
  const Trajectory t = sweep(m, {}, events);
  EXPECT_TRUE(std::any_of(events.begin(), events.end(), [](const SingularPosition& p) {
    return p.kind == SingularKind::branch_jump &&
           p.message.find("driver held") != std::string::npos;
  }));
  // The evidence, independent of the tracer: closed poses at the same driver value (to 1e-6
  // rad) with the triangle turned by over a radian from each other. Their rates are not
  // determined (the driver does not set the pose), so they may be flagged; positions exist.
  double lo = 1e300, hi = -1e300;
  for (int k = 0; k < t.samples(); ++k) {
    if (!has_position(t.status[static_cast<size_t>(k)])) continue;
    EXPECT_NEAR(t.along(k), m.drivers[0].start, 1e-6);
    lo = std::min(lo, channel(t, "angle.triangle", k));
    hi = std::max(hi, channel(t, "angle.triangle", k));
  }
  EXPECT_GT(hi - lo, 1.0);
}

// The tracer's Newton stops at round-off: a triangle turned by -25,667 rad with a point 1e6 m
// out has a residual floor above the tolerance. Each leg spent its 400,000 steps (17 s for
// check) and the last pose was taken for a limit: "-173.8 to 174.8 deg, limits: toggles".
TEST(Tracer, ConvergesAtTheRoundOffOfAFarDrawnPoint) {
  const Mechanism m = load_mechanism("tests/fuzz/regressions/wanzer_disk_pivot_1e6_round_off.toml");
  const AssemblingRange range = assembling_range(m);
  EXPECT_EQ(range.unknown, "");
  EXPECT_TRUE(range.full_cycle) << range.explain(m);
  // The evidence, without the tracer: the chain assembles from its drawing (Newton, else
  // Levenberg-Marquardt) at every 15 degrees of the turn, beyond the limits once reported too.
  for (double degrees = -180.0; degrees <= 180.0; degrees += 15.0) {
    Mechanism at = m;
    at.drivers[0].start = degrees * std::numbers::pi / 180.0;
    const NewtonSolver solver(at);
    KinematicState state(at);
    const PoseStatus status = solver.assemble(state).status;
    EXPECT_TRUE(status == PoseStatus::ok || status == PoseStatus::singular)
        << degrees << " deg: " << to_string(status);
  }
}

// A leg that spends the tracer's budget is flagged and the range unknown; its last pose is not
// a limit of the assembling range.
TEST(Tracer, ALegThatSpendsItsBudgetLeavesTheRangeUnknown) {
  const Mechanism m = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  SweepOptions options;
  EXPECT_TRUE(assembling_range(m, options).full_cycle);
  options.tracer_steps = 20;
  const AssemblingRange range = assembling_range(m, options);
  EXPECT_FALSE(range.full_cycle);
  EXPECT_NE(range.unknown.find("budget of 20 steps"), std::string::npos) << range.explain(m);
}

// The tracer's step bounds each coordinate's move (0.02 rad of a link's turn), not the arclength
// over all of them, so a chain of N loops turning together takes the steps of one loop: a crank
// turn of 2 pi in steps of 0.02 rad is 315, within a budget of 400 for A02 with N = 2 and with
// N = 10 alike (an arclength cap took 580 and 1,047 steps, the budget running out).
TEST(Tracer, ItsStepsPerTurnDoNotGrowWithTheLoops) {
  for (const std::string file : {"mechanisms/iftomm_a02_double_fourbar.toml",
                                 "mechanisms/scaling/iftomm_a02_nfourbar_10.toml"}) {
    const Mechanism m = load_mechanism(file);
    SweepOptions options;
    options.tracer_steps = 400;
    std::vector<SingularPosition> events;
    const Trajectory t = sweep(m, options, events);
    ASSERT_GT(t.samples(), 300) << file;
    for (const SingularPosition& e : events)
      EXPECT_NE(e.kind, SingularKind::branch_jump) << file << ": " << e.message;
  }
}

// Two slots turning parallel send the triangle off along them as the disk nears 90 degrees.
// The held-driver rule ended each leg after 15,700 steps (160 s under the sanitizers, the fuzz
// minute's seeds); a point's flight beyond the chain's reach ends it in a few hundred.
TEST(Tracer, AChainRunningOffToInfinityIsFlagged) {
  const Mechanism m = load_mechanism("tests/fuzz/regressions/wanzer_parallel_slots_runaway.toml");
  const AssemblingRange range = assembling_range(m);
  EXPECT_NE(range.unknown.find("runs off to infinity"), std::string::npos) << range.explain(m);
  std::vector<SingularPosition> events;
  sweep(m, {}, events);
  const auto runaway = std::find_if(events.begin(), events.end(), [](const SingularPosition& p) {
    return p.message.find("runs off to infinity") != std::string::npos;
  });
  ASSERT_NE(runaway, events.end());
  // The evidence, by continuation from the drawn pose: E's distance from the drawn E grows as
  // 1 / cos of the disk angle, beyond any closed chain of the drawing's size.
  const double asymptote = std::copysign(std::numbers::pi / 2.0, runaway->driver);
  EXPECT_NEAR(runaway->driver, asymptote, 0.05);
  std::vector<double> reach;
  for (double gap : {0.2, 0.05, 0.0125}) {
    const Trajectory pose = solve_at(m, asymptote - std::copysign(gap, asymptote));
    ASSERT_TRUE(has_position(pose.status[0])) << gap;
    reach.push_back(std::hypot(channel(pose, "x.E", 0), channel(pose, "y.E", 0)));
  }
  EXPECT_GT(reach[1], 3.0 * reach[0]);
  EXPECT_GT(reach[2], 3.0 * reach[1]);
  EXPECT_GT(reach[2], 20.0 * m.size());
}

// No drawn chain of the catalogue is taken for one whose driver is held.
TEST(HeldDriver, EveryBundledRangeIsKnown) {
  for (const auto& entry : std::filesystem::recursive_directory_iterator("mechanisms")) {
    // scaling/ holds copies of one chain, tens of bodies long: A02's four-bar is enough.
    if (entry.path().extension() != ".toml" || entry.path().parent_path().filename() == "scaling")
      continue;
    const Mechanism m = load_mechanism(entry.path().string());
    if (m.drivers[0].law.kind != MotionLaw::Kind::constant_speed) continue;
    // A lone block on its line (friction/block_sliding_to_rest) assembles at every value: its
    // point moves with the driver without bound, which the range's runaway rule (a point 4 times
    // the drawing's size away) reads as an asymptote. Not a held driver.
    if (m.moving_count() == 1 && m.swept().type == DriverType::slider) continue;
    // Several drivers have no range of one driver's value (it read past the one driver's row
    // before: AddressSanitizer's stack-buffer-overflow in ConstraintLayout::residual).
    if (m.drivers.size() > 1) {
      EXPECT_NE(assembling_range(m).unknown.find("the sweep runs in time"), std::string::npos);
      continue;
    }
    EXPECT_EQ(assembling_range(m).unknown, "") << entry.path();
  }
}

class Catalogue : public ::testing::TestWithParam<std::string> {};

TEST_P(Catalogue, MatchesExpectTable) {
  const Mechanism m = load_mechanism(GetParam());
  ASSERT_TRUE(m.expect.has_value()) << GetParam() << " has no [expect] table";
  const Expectations& e = *m.expect;
  const double tol = m.drivers[0].angular() ? 1e-9 : 1e-9 * m.units.length;  // 1e-9 file units
  const AssemblingRange range = assembling_range(m);
  if (e.limits) {
    EXPECT_FALSE(range.full_cycle);
    EXPECT_NEAR(range.lower, e.limits->first, tol);
    EXPECT_NEAR(range.upper, e.limits->second, tol);
  }
  std::vector<SingularPosition> singular;
  sweep(m, {}, singular);
  auto check = [&](std::vector<double> expected, SingularKind kind) {
    std::vector<double> found = events_of(singular, kind);
    std::sort(expected.begin(), expected.end());
    std::sort(found.begin(), found.end());
    ASSERT_EQ(found.size(), expected.size()) << to_string(kind);
    for (size_t i = 0; i < found.size(); ++i)
      EXPECT_NEAR(found[i], expected[i], tol) << to_string(kind);
  };
  check(e.toggles, SingularKind::toggle);
  check(e.change_points, SingularKind::change_point);
  EXPECT_TRUE(events_of(singular, SingularKind::branch_jump).empty());
  if (!e.grashof.empty()) {
    const auto fb = four_bar(m);
    ASSERT_TRUE(fb.has_value());
    EXPECT_EQ(to_string(fb->grashof), e.grashof);
  }
}

std::vector<std::string> catalogue_files() {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator("mechanisms/singular"))
    if (entry.path().extension() == ".toml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

INSTANTIATE_TEST_SUITE_P(Singular, Catalogue, ::testing::ValuesIn(catalogue_files()),
                         [](const auto& info) {
                           return std::filesystem::path(info.param).stem().string();
                         });

// Past 8 moving links the tracer factorises [C; e_m] and puts its tangent row back by
// Sherman–Morrison, and takes its start from sparse factors instead of an SVD. IFToMM A02 with
// N = 10 (21 bars, 63 coordinates) is a chain of parallelograms, so its closed form is known:
// every crank turns with the first, every coupler stays level, B_k = (k + cos d, sin d) m. Where
// the bars lie level (d = 0 and 180 deg) all ten loops reach a change point at once; the samples
// there are flagged singular (their poses resolved only to round-off over J's condition), and
// every other sample follows the closed form.
TEST(Singular, ALongParallelogramChainFollowsItsClosedForm) {
  const Mechanism m = load_mechanism("mechanisms/scaling/iftomm_a02_nfourbar_10.toml");
  ASSERT_GT(m.coordinate_count(), 24);  // the bordered path
  const Trajectory t = sweep(m);
  ASSERT_GT(t.samples(), 300);
  double worst = 0.0;
  int flagged = 0;
  for (int i = 0; i < t.samples(); ++i) {
    const double d = t.along(i);
    const bool level = std::abs(std::remainder(d, std::numbers::pi)) < 1e-9;
    const PoseStatus status = t.status[static_cast<size_t>(i)];
    ASSERT_EQ(status, level ? PoseStatus::singular : PoseStatus::ok) << "driver " << d;
    if (level) {
      ++flagged;
      continue;
    }
    for (size_t k = 0; k < t.link_names.size(); ++k) {
      const double expected = t.link_names[k].rfind("crank", 0) == 0 ? d : 0.0;
      worst = std::max(worst, std::abs(std::remainder(t.angle(i, static_cast<int>(k)) - expected,
                                                      2.0 * std::numbers::pi)));
    }
    for (int k = 0; k <= 10; ++k) {
      const auto b = std::find(t.point_names.begin(), t.point_names.end(), fmt::format("B{}", k));
      ASSERT_NE(b, t.point_names.end());
      const int c = static_cast<int>(b - t.point_names.begin());
      worst = std::max(worst, std::hypot(t.x(i, c) - (k + std::cos(d)), t.y(i, c) - std::sin(d)));
    }
  }
  EXPECT_LT(worst, 1e-10);
  EXPECT_EQ(flagged, 2);
}

}  // namespace
}  // namespace crosslink
