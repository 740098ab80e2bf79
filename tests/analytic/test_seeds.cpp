// The seed mechanisms against the values printed in the course notes, and the classics against
// closed-form geometry derived here by hand. Expected values never come from crosslink.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"

namespace crosslink {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// Angle difference in degrees, wrapped to (-180, 180].
double angle_error_deg(double a_rad, double b_deg) {
  return std::remainder(a_rad / kDeg - b_deg, 360.0);
}

// World position of a named point at one trajectory row.
Eigen::Vector2d point(const Trajectory& t, const std::string& name, int row = 0) {
  return {(*t.channel("x." + name))(row), (*t.channel("y." + name))(row)};
}

// The intersection of the circles (p, rp) and (q, rq) on the left of the direction p -> q.
Eigen::Vector2d circle_circle_left(const Eigen::Vector2d& p, double rp, const Eigen::Vector2d& q,
                                   double rq) {
  const Eigen::Vector2d u = q - p;
  const double d = u.norm();
  const double along = (rp * rp - rq * rq + d * d) / (2 * d);
  const double off = std::sqrt(rp * rp - along * along);
  return p + (along / d) * u + (off / d) * Eigen::Vector2d(-u.y(), u.x());
}

// Polycentric knee hinge (notes 000): the table's vectors at theta4 = 99.38 deg.
//
//   B wrt A 181.61 | C wrt B 36.95 | D wrt E 99.38 | E wrt F -15.87 | F wrt H 146.31
//   G wrt H 171.56 (22.03 mm) | G wrt A 92.21 | C wrt H 151.64 | D wrt C 15.36 | H wrt A 0
//
// The table prints angles to 0.01 deg from hand-rounded data; 0.05 deg allows for that rounding
// carried through the loops. Each angle is measured from the solved positions, so it checks the
// geometry, not the link frames.
TEST(PolycentricHinge, ReproducesTheNotesTableAt9938) {
  const Mechanism m = load_mechanism("mechanisms/polycentric_hinge.toml");
  const Trajectory t = solve_at(m, 99.38 * kDeg);
  ASSERT_EQ(t.status[0], PoseStatus::ok);
  struct Vector {
    const char* tip;
    const char* tail;
    double angle_deg;
  };
  const Vector table[] = {{"H", "A", 0.00},   {"B", "A", 181.61}, {"C", "B", 36.95},
                          {"D", "E", 99.38},  {"E", "F", -15.87}, {"F", "H", 146.31},
                          {"G", "H", 171.56}, {"G", "A", 92.21},  {"C", "H", 151.64},
                          {"D", "C", 15.36}};
  double worst = 0.0;
  for (const Vector& v : table) {
    const Eigen::Vector2d r = point(t, v.tip) - point(t, v.tail);
    const double error = angle_error_deg(std::atan2(r.y(), r.x()), v.angle_deg);
    EXPECT_LT(std::abs(error), 0.05) << v.tip << " wrt " << v.tail;
    worst = std::max(worst, std::abs(error));
  }
  RecordProperty("max_angle_error_deg", std::to_string(worst));
  // Vector 7's variable length, printed to 0.01 mm: 0.05 deg on the 26 mm links moves G by
  // 0.023 mm, so 0.03 mm.
  EXPECT_NEAR((point(t, "G") - point(t, "H")).norm(), 22.03e-3, 0.03e-3);
}

// The whole assembling range of theta4, swept on the drawn branch: no sample lost, no jump.
TEST(PolycentricHinge, SweepsItsWholeAssemblingRangeOnOneBranch) {
  const Mechanism m = load_mechanism("mechanisms/polycentric_hinge.toml");
  const AssemblingRange range = assembling_range(m);
  ASSERT_FALSE(range.full_cycle);
  EXPECT_LT(range.lower, 99.38 * kDeg);
  EXPECT_GT(range.upper, 99.38 * kDeg);

  const Trajectory t = sweep(m);
  const double step = kDeg;  // the default sweep step
  ASSERT_GT(t.samples(), 2);
  const int last = t.samples() - 1;
  // The samples cover the range to within one step at each end.
  const double first_d = std::min(t.along(0), t.along(last));
  const double last_d = std::max(t.along(0), t.along(last));
  EXPECT_GE(first_d, range.lower - 1e-9);
  EXPECT_LT(first_d - range.lower, step + 1e-9);
  EXPECT_LE(last_d, range.upper + 1e-9);
  EXPECT_LT(range.upper - last_d, step + 1e-9);
  EXPECT_NEAR(std::abs(t.along(last) - t.along(0)), range.upper - range.lower, 2 * step);

  // Every interior sample is usable; the end samples may sit exactly on a limit (a toggle),
  // where the Jacobian is singular by definition.
  for (int r = 0; r <= last; ++r) {
    const PoseStatus s = t.status[static_cast<size_t>(r)];
    if (r == 0 || r == last)
      EXPECT_TRUE(s == PoseStatus::ok || s == PoseStatus::singular) << to_string(s);
    else
      EXPECT_EQ(s, PoseStatus::ok) << "sample " << r << " at " << t.along(r) / kDeg;
  }

  // No branch jump. (1) Link angles change by a bounded amount per step: 30 steps allows the
  // square-root growth next to a limit (about 17 deg for the first degree here) and refuses a
  // jump between turns. (2) Each step agrees with the derivatives at its two ends: the cubic
  // Hermite rule  d(theta) = (w0 + w1) h / 2 + (a0 - a1) h^2 / 12  (h the driver step; omega
  // and alpha are d/d(theta4) at the file's 1 rad/s) errs by h^5 theta^(5) / 720, a small
  // fraction of the step's change, while a jump to another solution of the closure at the same
  // theta4 changes the angle by the separation of the two solutions, which the derivatives do
  // not predict. 10 % of the step's change (plus 1e-9 rad) separates the two.
  double worst_hermite = 0.0;
  for (int r = 1; r <= last; ++r) {
    const double h = t.along(r) - t.along(r - 1);
    const double rate = m.drivers[0].law.speed;
    for (Eigen::Index c = 0; c < t.angle.cols(); ++c) {
      const double change = t.angle(r, c) - t.angle(r - 1, c);
      EXPECT_LT(std::abs(change), 30 * step)
          << t.link_names[static_cast<size_t>(c)] << " at " << t.along(r) / kDeg;
      if (!usable(t.status[static_cast<size_t>(r)]) ||
          !usable(t.status[static_cast<size_t>(r - 1)]))
        continue;
      const double w0 = t.omega(r - 1, c) / rate, w1 = t.omega(r, c) / rate;
      const double a0 = t.alpha(r - 1, c) / (rate * rate), a1 = t.alpha(r, c) / (rate * rate);
      const double hermite = 0.5 * (w0 + w1) * h + (a0 - a1) * h * h / 12.0;
      const double miss = std::abs(change - hermite);
      worst_hermite = std::max(worst_hermite, miss / (std::abs(change) + 1e-9));
      EXPECT_LT(miss, 0.1 * std::abs(change) + 1e-9)
          << t.link_names[static_cast<size_t>(c)] << " between " << t.along(r - 1) / kDeg << " and "
          << t.along(r) / kDeg << " deg";
    }
  }
  RecordProperty("worst_hermite_miss_of_change", std::to_string(worst_hermite));
}

// Wanzer needle bar (notes 002, wanzer_geom.m) at disk angle 0: the notes' Newton-Raphson
// positions, printed to 1e-4 mm.
TEST(WanzerNeedleBar, ReproducesTheNotesGeometryAtDiskAngle0) {
  const Mechanism m = load_mechanism("mechanisms/wanzer_needle_bar.toml");
  const Trajectory t = solve_at(m, 0.0);
  ASSERT_EQ(t.status[0], PoseStatus::ok);
  const double mm = 1e-3, tol = 1e-3 * mm;
  EXPECT_NEAR(point(t, "E").x(), 10 * mm, tol);
  EXPECT_NEAR(point(t, "E").y(), 19.9279 * mm, tol);
  EXPECT_NEAR(point(t, "F").x(), 22.5473 * mm, tol);
  EXPECT_NEAR(point(t, "F").y(), 10 * mm, tol);
  EXPECT_NEAR(point(t, "G").x(), 0 * mm, tol);
  EXPECT_NEAR(point(t, "G").y(), -41.2603 * mm, tol);
}

// Six-bar with a slider on a moving guide (seed section 4), over its whole sweep. Loop closure
// from the positions, and positions from a hand construction: C is the intersection of the
// circles (B, BC) and (D, CD) on the left of B -> D (the drawn assembly: C above BD); F is where
// the guide (through C, perpendicular to BC, direction n = BC turned +90 deg) meets the circle
// (A, AF): |C + s n| = AF, s = -C.n + sqrt((C.n)^2 - |C|^2 + AF^2) (the drawn root, F above A).
// Tolerance 1e-9 m: the solver closes the loops to 1e-12 of the 0.42 m size.
TEST(SixbarSliderGuide, MatchesAHandConstructionOverTheSweep) {
  const Mechanism m = load_mechanism("mechanisms/sixbar_slider_guide.toml");
  const Trajectory t = sweep(m);
  const Eigen::Vector2d A(0, 0), D(0.2, -0.1);
  const double AB = 0.1, BC = 0.2, CD = 0.2, AF = 0.35, tol = 1e-9;
  int checked = 0;
  for (int r = 0; r < t.samples(); ++r) {
    ASSERT_EQ(t.status[static_cast<size_t>(r)], PoseStatus::ok) << "sample " << r;
    const Eigen::Vector2d B = point(t, "B", r), C = point(t, "C", r), F = point(t, "F", r),
                          E = point(t, "E", r);
    // Loop closure: link lengths, the guide's right angle, the block on the guide.
    EXPECT_NEAR((B - A).norm(), AB, tol);
    EXPECT_NEAR((C - B).norm(), BC, tol);
    EXPECT_NEAR((C - D).norm(), CD, tol);
    EXPECT_NEAR((F - A).norm(), AF, tol);
    EXPECT_NEAR((F - C).dot(C - B), 0.0, tol * BC);
    EXPECT_NEAR((E - C).dot(C - B), 0.0, tol * BC);  // E is a coupler point on the guide
    // Hand construction from the driver value alone.
    const double phi = t.along(r);
    const Eigen::Vector2d B_hand(AB * std::cos(phi), AB * std::sin(phi));
    const Eigen::Vector2d C_hand = circle_circle_left(B_hand, BC, D, CD);
    const Eigen::Vector2d u = (C_hand - B_hand) / BC, n(-u.y(), u.x());
    const double b = C_hand.dot(n);
    const double s = -b + std::sqrt(b * b - C_hand.squaredNorm() + AF * AF);
    const Eigen::Vector2d F_hand = C_hand + s * n;
    EXPECT_NEAR((B - B_hand).norm(), 0.0, tol);
    EXPECT_NEAR((C - C_hand).norm(), 0.0, tol) << "at phi2 = " << phi / kDeg;
    EXPECT_NEAR((F - F_hand).norm(), 0.0, tol) << "at phi2 = " << phi / kDeg;
    // The drawn instant: the coupler point E coincides with F.
    if (r == 0) {
      EXPECT_NEAR((E - F).norm(), 0.0, 1e-6);
    }
    ++checked;
  }
  EXPECT_EQ(checked, 361);  // a full turn at 1 degree, both ends included
}

// Crank-rocker (a 0.04, b 0.12, c 0.08, d 0.10 m): C from the circles (B, b) and (D, c), open
// assembly (C on the left of B -> D).
TEST(FourbarCrankRocker, MatchesCircleIntersectionOverTheSweep) {
  const Mechanism m = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  const Trajectory t = sweep(m);
  const Eigen::Vector2d D(0.10, 0);
  for (int r = 0; r < t.samples(); ++r) {
    ASSERT_EQ(t.status[static_cast<size_t>(r)], PoseStatus::ok);
    const double th = t.along(r);
    const Eigen::Vector2d B(0.04 * std::cos(th), 0.04 * std::sin(th));
    EXPECT_NEAR((point(t, "C", r) - circle_circle_left(B, 0.12, D, 0.08)).norm(), 0.0, 1e-9)
        << "at theta2 = " << th / kDeg;
  }
}

// Offset slider-crank (a 0.04, b 0.12, offset c 0.01 m; slider on y = c): closed form
//   x_C = a cos t + sqrt(b^2 - (c - a sin t)^2)
//   dx_C/dt = -a w sin t + a w cos t (c - a sin t) / sqrt(b^2 - (c - a sin t)^2).
// Velocity tolerance 1e-9 of a w (the exact velocity solve is a linear solve at 1e-12 closure).
TEST(SliderCrankOffset, MatchesClosedFormOverTheSweep) {
  const Mechanism m = load_mechanism("mechanisms/slider_crank_offset.toml");
  const Trajectory t = sweep(m);
  const double a = 0.04, b = 0.12, c = 0.01, w = m.drivers[0].law.speed;
  EXPECT_NEAR(w, 8 * std::numbers::pi, 1e-12);
  for (int r = 0; r < t.samples(); ++r) {
    ASSERT_EQ(t.status[static_cast<size_t>(r)], PoseStatus::ok);
    const double th = t.along(r), rise = c - a * std::sin(th);
    const double root = std::sqrt(b * b - rise * rise);
    EXPECT_NEAR(point(t, "C", r).x(), a * std::cos(th) + root, 1e-9);
    EXPECT_NEAR(point(t, "C", r).y(), c, 1e-9);
    const double v = -a * w * std::sin(th) + a * w * std::cos(th) * rise / root;
    EXPECT_NEAR((*t.channel("vx.C"))(r), v, 1e-9 * a * w) << "at theta2 = " << th / kDeg;
  }
}

}  // namespace
}  // namespace crosslink
