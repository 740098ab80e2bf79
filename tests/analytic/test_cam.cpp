// Cam motion laws, programs and profiles (analytic/model/cam.h) against their closed forms and
// against differences of their own values and points.
#include "analytic/model/cam.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

namespace crosslink::cam {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

constexpr std::array kLaws = {Law::uniform, Law::simple_harmonic, Law::cycloidal,
                              Law::polynomial_345, Law::polynomial_4567};

// The largest |f| over [0, 1]: a grid, then golden-section refinement around its best point.
template <class F>
double peak(F f) {
  constexpr int n = 2000;
  int best = 0;
  for (int i = 1; i <= n; ++i)
    if (std::abs(f(static_cast<double>(i) / n)) > std::abs(f(static_cast<double>(best) / n)))
      best = i;
  double a = std::max(0.0, (best - 1.0) / n), b = std::min(1.0, (best + 1.0) / n);
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  for (int k = 0; k < 100; ++k) {
    const double c = b - g * (b - a), d = a + g * (b - a);
    if (std::abs(f(c)) > std::abs(f(d)))
      b = d;
    else
      a = c;
  }
  return std::abs(f((a + b) / 2.0));
}

// Each law rises from 0 to 1, and its peak velocity and acceleration factors are the maxima of
// its closed form found by hand: SHM pi/2 and pi^2/2; cycloidal 2 (at u = 1/2) and 2 pi (at
// u = 1/4); 3-4-5 15/8 and 10/sqrt(3) (at u = 1/2 - sqrt(3)/6); 4-5-6-7 35/16 and
// 84 sqrt(5)/25 (at u = 1/2 - sqrt(5)/10). Norton's table of them (Design of Machinery, ch. 8,
// Table 8-2, "Factors for peak velocity and acceleration") prints the velocities to its four
// digits (1.571, 2.000, 1.875, 2.188) but accelerations above the exact maxima: SHM 4.945
// against 4.9348 (0.2 %), 3-4-5 5.777 against 5.7735, 4-5-6-7 7.526 against 7.5132 (0.17 %);
// cycloidal 6.283 is 2 pi. The checks here are the exact values.
TEST(CamLaws, EachRisesFromZeroToOneWithItsPeakFactors) {
  struct Expected {
    Law law;
    double velocity, acceleration;
  };
  const Expected expected[] = {
      {Law::simple_harmonic, kPi / 2.0, kPi * kPi / 2.0},
      {Law::cycloidal, 2.0, 2.0 * kPi},
      {Law::polynomial_345, 15.0 / 8.0, 10.0 / std::sqrt(3.0)},
      {Law::polynomial_4567, 35.0 / 16.0, 84.0 * std::sqrt(5.0) / 25.0},
  };
  for (const Expected& e : expected) {
    SCOPED_TRACE(to_string(e.law));
    EXPECT_EQ(normalised(e.law, 0.0).y, 0.0);
    EXPECT_NEAR(normalised(e.law, 1.0).y, 1.0, 1e-14);
    EXPECT_NEAR(peak([&](double u) { return normalised(e.law, u).dy; }), e.velocity, 1e-12);
    EXPECT_NEAR(peak([&](double u) { return normalised(e.law, u).ddy; }), e.acceleration, 1e-11);
  }
}

// Which derivatives vanish where a segment starts and ends: the cycloidal and 3-4-5 laws start
// and end at rest with no acceleration, 4-5-6-7 with no jerk either; simple harmonic motion
// starts and ends at rest but with acceleration pi^2/2 (the jump a dwell next to it makes).
TEST(CamLaws, EndConditionsAreTheLawsOwn) {
  for (double u : {0.0, 1.0}) {
    SCOPED_TRACE(u);
    for (Law law : {Law::cycloidal, Law::polynomial_345, Law::polynomial_4567}) {
      EXPECT_NEAR(normalised(law, u).dy, 0.0, 1e-12) << to_string(law);
      EXPECT_NEAR(normalised(law, u).ddy, 0.0, 1e-11) << to_string(law);
    }
    EXPECT_NEAR(normalised(Law::polynomial_4567, u).dddy, 0.0, 1e-10);
    EXPECT_NEAR(normalised(Law::simple_harmonic, u).dy, 0.0, 1e-15);
    EXPECT_NEAR(std::abs(normalised(Law::simple_harmonic, u).ddy), kPi * kPi / 2.0, 1e-14);
  }
  EXPECT_EQ(normalised(Law::uniform, 0.3).dy, 1.0);
}

// Each derivative is the central difference of the one before, across the segment.
TEST(CamLaws, DerivativesAreTheDifferencesOfTheValues) {
  const double h = 1e-5;
  for (Law law : kLaws) {
    SCOPED_TRACE(to_string(law));
    for (int i = 1; i < 20; ++i) {
      const double u = i / 20.0;
      const Normalised a = normalised(law, u - h), b = normalised(law, u + h),
                       c = normalised(law, u);
      EXPECT_NEAR((b.y - a.y) / (2 * h), c.dy, 1e-8);
      EXPECT_NEAR((b.dy - a.dy) / (2 * h), c.ddy, 1e-7);
      EXPECT_NEAR((b.ddy - a.ddy) / (2 * h), c.dddy, 1e-5);
      EXPECT_NEAR((b.dddy - a.dddy) / (2 * h), c.ddddy, 1e-4);
    }
  }
}

// Rise 20 mm cycloidal over 120 deg, dwell 60, return 3-4-5 over 120, dwell 60.
MotionProgram rise_dwell_return_dwell() {
  return MotionProgram(0.0, {{Law::cycloidal, 120 * kDeg, 0.020},
                             {Law::dwell, 60 * kDeg, 0.020},
                             {Law::polynomial_345, 120 * kDeg, 0.0},
                             {Law::dwell, 60 * kDeg, 0.0}});
}

// A program scales each law by its rise and span (ds = h dy / beta, ...), repeats every turn,
// and joins its segments with displacement, velocity and acceleration continuous (these laws
// start and end at rest): the differences of s across a junction are those of a smooth curve.
TEST(CamProgram, SegmentsScaleTheirLawsAndJoinSmoothly) {
  const MotionProgram p = rise_dwell_return_dwell();
  const double beta = 120 * kDeg, rise = 0.020;
  for (double u : {0.1, 0.25, 0.5, 0.8}) {
    const Normalised y = normalised(Law::cycloidal, u);
    const Motion m = p.at(u * beta);
    EXPECT_NEAR(m.s, rise * y.y, 1e-15);
    EXPECT_NEAR(m.ds, rise * y.dy / beta, 1e-15);
    EXPECT_NEAR(m.dds, rise * y.ddy / (beta * beta), 1e-14);
    EXPECT_NEAR(m.ddds, rise * y.dddy / (beta * beta * beta), 1e-13);
    const Motion back = p.at(180 * kDeg + u * beta);  // the return: 20 mm down
    const Normalised r = normalised(Law::polynomial_345, u);
    EXPECT_NEAR(back.s, rise - rise * r.y, 1e-15);
    EXPECT_NEAR(back.dds, -rise * r.ddy / (beta * beta), 1e-14);
  }
  for (double theta : {0.3, 2.0, 4.0, 5.9}) {
    const Motion a = p.at(theta), b = p.at(theta + 2 * kPi), c = p.at(theta - 4 * kPi);
    EXPECT_NEAR(a.s, b.s, 1e-15);
    EXPECT_NEAR(a.dds, c.dds, 1e-13);
  }
  const double h = 1e-6;
  for (double junction : {0.0, 120.0, 180.0, 300.0}) {
    SCOPED_TRACE(junction);
    const Motion left = p.at(junction * kDeg - h), right = p.at(junction * kDeg + h);
    EXPECT_NEAR(left.s, right.s, 1e-12);
    EXPECT_NEAR(left.ds, right.ds, 1e-9);
    EXPECT_NEAR(left.dds, right.dds, 1e-4);  // the jerk's size times 2h
  }
}

void expect_refused(double start, std::vector<Segment> segments, const std::string& says) {
  try {
    MotionProgram(start, std::move(segments));
    ADD_FAILURE() << "accepted; expected: " << says;
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
  }
}

TEST(CamProgram, RefusesAProgramThatDoesNotCloseOrMakeATurn) {
  expect_refused(0.0, {{Law::cycloidal, 180 * kDeg, 0.01}, {Law::cycloidal, 170 * kDeg, 0.0}},
                 "make 350 deg, not a turn");
  expect_refused(0.0, {{Law::cycloidal, 180 * kDeg, 0.01}, {Law::cycloidal, 180 * kDeg, 0.002}},
                 "segment 2: the rise does not close: the program ends at 0.002");
  expect_refused(0.0,
                 {{Law::cycloidal, 180 * kDeg, 0.01},
                  {Law::cycloidal, 90 * kDeg, 0.002},
                  {Law::dwell, 90 * kDeg, 0.002}},
                 "segment 2: the rise does not close");
  expect_refused(0.0, {{Law::cycloidal, 180 * kDeg, 0.01}, {Law::dwell, 180 * kDeg, 0.0}},
                 "segment 2: a dwell holds the follower at 0.01");
  expect_refused(0.0, {{Law::cycloidal, -10 * kDeg, 0.01}, {Law::cycloidal, 370 * kDeg, 0.0}},
                 "segment 1: its span must be positive");
  expect_refused(0.0, {}, "needs a segment");
}

// A table through a periodic cubic spline passes through its points, is continuous to the
// acceleration across them, and approaches the motion it samples at the fourth order: the
// harmonic s = h (1 - cos theta) / 2 sampled at N points, its largest error over a turn falls
// 16 times as N doubles.
TEST(CamTable, PeriodicSplineIsSmoothAndConvergesAtTheFourthOrder) {
  const double h = 0.01;
  const auto exact = [&](double t) { return h * (1.0 - std::cos(t)) / 2.0; };
  std::vector<double> errors;
  for (int n : {12, 24, 48}) {
    std::vector<std::pair<double, double>> points;
    for (int i = 0; i < n; ++i) {
      const double t = 2 * kPi * i / n;
      points.push_back({t, exact(t)});
    }
    const MotionProgram p = MotionProgram::table(points);
    for (const auto& [t, s] : points) {
      EXPECT_NEAR(p.at(t).s, s, 1e-16);
      const Motion left = p.at(t - 1e-9), right = p.at(t + 1e-9);
      EXPECT_NEAR(left.ds, right.ds, 1e-10);
      EXPECT_NEAR(left.dds, right.dds, 1e-9);
    }
    double worst = 0.0;
    for (int k = 0; k < 2000; ++k) {
      const double t = 2 * kPi * (k + 0.5) / 2000, d = 1e-6;
      const Motion m = p.at(t), before = p.at(t - d), after = p.at(t + d);
      worst = std::max(worst, std::abs(m.s - exact(t)));
      // Each derivative the central difference of the one before (no knot is this close).
      EXPECT_NEAR((after.s - before.s) / (2 * d), m.ds, 1e-10);
      EXPECT_NEAR((after.ds - before.ds) / (2 * d), m.dds, 1e-9);
      EXPECT_NEAR((after.dds - before.dds) / (2 * d), m.ddds, 1e-8);
    }
    errors.push_back(worst);
  }
  for (size_t i = 1; i < errors.size(); ++i) {
    EXPECT_GT(errors[i - 1] / errors[i], 14.0) << errors[i - 1] << " -> " << errors[i];
    EXPECT_LT(errors[i - 1] / errors[i], 18.0) << errors[i - 1] << " -> " << errors[i];
  }
}

TEST(CamTable, RefusesPointsOutOfOrderOrBeyondATurn) {
  EXPECT_THROW(MotionProgram::table({{0.0, 0.0}, {1.0, 0.1}}), std::invalid_argument);
  EXPECT_THROW(MotionProgram::table({{0.0, 0.0}, {2.0, 0.1}, {1.0, 0.0}}), std::invalid_argument);
  EXPECT_THROW(MotionProgram::table({{0.0, 0.0}, {2.0, 0.1}, {2 * kPi, 0.0}}),
               std::invalid_argument);
}

// The radius of the circle through three points.
double circumradius(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  const double ab = (b - a).norm(), bc = (c - b).norm(), ca = (a - c).norm();
  const double area2 = std::abs((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
  return ab * bc * ca / (2.0 * area2);
}

struct Case {
  std::string name;
  Follower follower;
};

std::vector<Case> followers() {
  Follower roller;
  roller.kind = FollowerKind::roller;
  roller.base_radius = 0.04;
  roller.roller_radius = 0.01;
  roller.offset = 0.008;
  Follower knife = roller;
  knife.kind = FollowerKind::knife_edge;
  knife.offset = 0.0;
  Follower flat;
  flat.kind = FollowerKind::flat_faced;
  flat.base_radius = 0.05;
  flat.offset = 0.005;
  Follower swinging = roller;
  swinging.oscillating = true;
  swinging.offset = 0.0;
  swinging.pivot = {0.09, 0.03};
  swinging.arm = 0.08;
  return {{"offset_roller", roller},
          {"knife_edge", knife},
          {"flat_face", flat},
          {"oscillating_roller", swinging}};
}

// For an oscillating follower the same rise as an angle: 20 mm over the 80 mm arm.
MotionProgram program_for(const Follower& f) {
  if (!f.oscillating) return rise_dwell_return_dwell();
  const double lift = 0.020 / f.arm;
  return MotionProgram(0.0, {{Law::cycloidal, 120 * kDeg, lift},
                             {Law::dwell, 60 * kDeg, lift},
                             {Law::polynomial_345, 120 * kDeg, 0.0},
                             {Law::dwell, 60 * kDeg, 0.0}});
}

// The profile's geometry against its own points: the radius of curvature is the radius of the
// circle through three nearby contact points; the normal is square to the chord of two nearby
// points; a roller's centre stays its radius from the contact along the normal; the follower
// seen from the cam is the pitch point.
TEST(CamProfile, CurvatureAndNormalAreThoseOfTheProfilesPoints) {
  const double d = 1e-4;
  for (const Case& c : followers()) {
    SCOPED_TRACE(c.name);
    const MotionProgram p = program_for(c.follower);
    for (int k = 0; k < 72; ++k) {
      const double theta = (k + 0.37) * 5 * kDeg;
      const ProfilePoint a = profile_at(p, c.follower, theta - d);
      const ProfilePoint b = profile_at(p, c.follower, theta);
      const ProfilePoint e = profile_at(p, c.follower, theta + d);
      const double rho = circumradius(a.contact, b.contact, e.contact);
      EXPECT_NEAR(rho, std::abs(b.radius_of_curvature), 1e-6 * std::max(1.0, rho / 0.01))
          << theta / kDeg;
      EXPECT_NEAR((e.contact - a.contact).normalized().dot(b.normal), 0.0, 1e-7) << theta / kDeg;
      EXPECT_NEAR((b.pitch - b.contact).norm(),
                  c.follower.roller_radius * (c.follower.kind == FollowerKind::roller), 1e-15);
      if (c.follower.kind != FollowerKind::flat_faced) {
        const Eigen::Vector2d seen = Eigen::Rotation2Dd(theta) * b.pitch;
        EXPECT_NEAR((seen - b.follower).norm(), 0.0, 1e-15);
      }
      EXPECT_GT(b.normal.dot(b.contact), 0.0);  // outward, the cam's centre inside
    }
  }
}

// Where the follower rests, the cam is its base circle, and an offset translating roller meets
// it at the pressure angle -asin(e / (Rb + Rr)); over the rise the pressure angle is Norton's
// closed form for a translating roller, tan phi = (ds - e) / (s + sqrt(Rp^2 - e^2)) (Design of
// Machinery, ch. 8, "pressure angle", the offset follower).
TEST(CamProfile, TranslatingRollerPressureAngleIsTheClosedForm) {
  const Follower f = followers()[0].follower;
  const MotionProgram p = rise_dwell_return_dwell();
  const double prime = f.base_radius + f.roller_radius;
  const ProfilePoint rest = profile_at(p, f, 330 * kDeg);
  EXPECT_NEAR(rest.contact.norm(), f.base_radius, 1e-15);
  EXPECT_NEAR(rest.radius_of_curvature, f.base_radius, 1e-12);
  EXPECT_NEAR(rest.pressure_angle, -std::asin(f.offset / prime), 1e-15);
  for (int k = 0; k <= 24; ++k) {
    const double theta = k * 5 * kDeg;
    const Motion m = p.at(theta);
    const double s0 = std::sqrt(prime * prime - f.offset * f.offset);
    EXPECT_NEAR(profile_at(p, f, theta).pressure_angle, std::atan((m.ds - f.offset) / (s0 + m.s)),
                1e-14)
        << k;
  }
}

// A flat face perpendicular to its motion: no pressure angle, the contact ds from the axis
// through the cam's centre, and the radius of curvature base + s + d2s/dtheta2 (Norton, ch. 8,
// the flat-faced follower).
TEST(CamProfile, FlatFaceRadiusIsBasePlusDisplacementPlusItsSecondDerivative) {
  const Follower f = followers()[2].follower;
  const MotionProgram p = rise_dwell_return_dwell();
  for (int k = 0; k < 72; ++k) {
    const double theta = (k + 0.5) * 5 * kDeg;
    const Motion m = p.at(theta);
    const ProfilePoint q = profile_at(p, f, theta);
    EXPECT_EQ(q.pressure_angle, 0.0);
    EXPECT_NEAR(q.radius_of_curvature, f.base_radius + m.s + m.dds, 1e-15);
    EXPECT_NEAR(q.contact.norm(), std::hypot(m.ds, f.base_radius + m.s), 1e-15);
  }
}

// An oscillating follower's arm keeps its length, rests with its roller on the prime circle, and
// turns by the program's angle.
TEST(CamProfile, OscillatingArmTurnsByTheProgramAboutItsPivot) {
  const Follower f = followers()[3].follower;
  const MotionProgram p = program_for(f);
  const ProfilePoint rest = profile_at(p, f, 0.0);
  EXPECT_NEAR(rest.follower.norm(), f.base_radius + f.roller_radius, 1e-15);
  for (double theta : {0.2, 1.0, 2.5, 4.0}) {
    const ProfilePoint q = profile_at(p, f, theta);
    EXPECT_NEAR((q.follower - f.pivot).norm(), f.arm, 1e-15);
    EXPECT_NEAR(q.arm_angle - rest.arm_angle, p.at(theta).s, 1e-15);
  }
  Follower unreachable = f;
  unreachable.arm = 0.01;
  EXPECT_THROW(profile_at(p, unreachable, 0.0), std::invalid_argument);
}

// A contour's polar radius is the pitch point's distance from the centre at the polar angle the
// pitch point is seen at, and the cam angle it names is the one the follower stands at there
// (knife edge, roller); a flat face's support function is the face's distance Rb + s at the
// normal angle pi/2 - theta. Its derivatives are the differences of its values.
TEST(CamContour, RadiusAtThePitchPointsAngleIsItsDistance) {
  for (const Case& c : followers()) {
    SCOPED_TRACE(c.name);
    const MotionProgram p = program_for(c.follower);
    const Contour contour(p, c.follower);
    const bool flat = c.follower.kind == FollowerKind::flat_faced;
    EXPECT_EQ(contour.flat_faced(), flat);
    for (int k = 0; k < 90; ++k) {
      const double theta = (k + 0.29) * 4 * kDeg;
      const FollowerPath f = follower_path(p, c.follower, theta);
      const double angle =
          flat ? kPi / 2 - theta : std::atan2(f.F.y(), f.F.x()) - theta + 2 * kPi * (k % 3 - 1);
      const double expected = flat ? c.follower.base_radius + p.at(theta).s : f.F.norm();
      EXPECT_NEAR(contour.at(angle).value, expected, 1e-12) << theta / kDeg;
      EXPECT_NEAR(std::remainder(contour.cam_angle(angle) - theta, 2 * kPi), 0.0, 1e-12)
          << theta / kDeg;
      const double h = 1e-4;
      const Polar a = contour.at(angle - h), b = contour.at(angle), e = contour.at(angle + h);
      EXPECT_NEAR(b.d, (e.value - a.value) / (2 * h), 1e-8) << theta / kDeg;
      EXPECT_NEAR(b.dd, (e.d - a.d) / (2 * h), 1e-6) << theta / kDeg;
      EXPECT_NEAR(b.ddd, (e.dd - a.dd) / (2 * h), 1e-6) << theta / kDeg;
    }
  }
}

// A profile that cannot be cut is refused, saying why: a roller larger than the pitch curve's
// radius of curvature where it is convex (the profile undercuts), a flat face whose radius of
// curvature turns negative (a cusp), a follower path that turns about the centre faster than the
// cam (a ray would cross the pitch curve twice).
TEST(CamContour, RefusesAProfileThatCannotBeCut) {
  const auto refused = [](const MotionProgram& p, const Follower& f, const std::string& says) {
    try {
      const Contour contour(p, f);
      ADD_FAILURE() << "accepted; expected: " << says;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
  };
  const MotionProgram p = rise_dwell_return_dwell();
  // 20 mm in 40 degrees on a 10 mm base circle: the pitch curve's least convex radius is 6.8 mm,
  // under the 10 mm roller. On a 20 mm knife-edge cam offset 19 mm, 20 mm in 60 degrees: the
  // path's moment about the centre, e s', passes e^2 + y^2 = |F|^2 halfway up.
  const auto steep = [](double span) {
    return MotionProgram(0.0, {{Law::cycloidal, span * kDeg, 0.02},
                               {Law::dwell, (180 - span) * kDeg, 0.02},
                               {Law::cycloidal, span * kDeg, 0.0},
                               {Law::dwell, (180 - span) * kDeg, 0.0}});
  };
  Follower undercut = followers()[0].follower;
  undercut.base_radius = 0.01;
  undercut.offset = 0.0;
  refused(steep(40), undercut, "the profile undercuts");
  Follower cusp = followers()[2].follower;
  cusp.base_radius = 0.01;
  refused(p, cusp, "has a cusp");
  Follower knife = followers()[1].follower;
  knife.base_radius = 0.02;
  knife.offset = 0.019;
  refused(steep(60), knife, "not star-shaped");
  Follower swinging_face = followers()[2].follower;
  swinging_face.oscillating = true;
  swinging_face.pivot = {0.09, 0.03};
  swinging_face.arm = 0.08;
  refused(p, swinging_face, "oscillating flat-faced");
}

// A tangent cam's pitch curve, in polar form, is continuous with its slope across each junction
// of flank and circle (its curvature jumps there), passes through the base circle, the nose's
// apex and the flanks' tangent points, and its derivatives are the differences of its values
// inside each piece. The base 30, lift 17.5 over 75 degrees make the nose 23.889 about a point
// 23.611 from the centre.
TEST(CamContour, TangentCamIsPiecewiseCirclesAndLines) {
  const TangentCam cam = TangentCam::from_lift(0.03, 0.0175, 75 * kDeg, std::nan(""), 0.3);
  EXPECT_NEAR(cam.nose_radius, 0.023889031741350376, 1e-15);
  EXPECT_NEAR(cam.distance, 0.023610968258649624, 1e-15);
  EXPECT_NEAR(cam.ascent(), 75 * kDeg, 1e-14);
  EXPECT_NEAR(cam.lift(), 0.0175, 1e-15);
  Follower roller;
  roller.roller_radius = 0.0175;
  const Contour contour(cam, roller);
  const double rb = 0.03 + 0.0175, l = cam.nose_radius + 0.0175;
  EXPECT_NEAR(contour.at(0.3).value, cam.distance + l, 1e-15);  // the apex
  EXPECT_NEAR(contour.at(0.3 + kPi).value, rb, 1e-15);          // the base circle
  EXPECT_NEAR(contour.at(0.3 + 75 * kDeg).value, rb, 1e-15);    // where a flank begins
  // Where the roller leaves the flank: its centre l from the nose's, along the flank's normal.
  const Eigen::Vector2d leaves = cam.distance * Eigen::Vector2d(1, 0) +
                                 l * Eigen::Vector2d(std::cos(75 * kDeg), std::sin(75 * kDeg));
  const double delta = std::atan2(leaves.y(), leaves.x());
  EXPECT_NEAR(contour.at(0.3 - delta).value, leaves.norm(), 1e-15);
  EXPECT_NEAR(contour.at(0.3 + delta).value, leaves.norm(), 1e-15);
  ASSERT_NE(contour.tangent(), nullptr);
  EXPECT_TRUE(std::isnan(contour.largest_pressure_angle()));
  EXPECT_EQ(contour.least_radius_of_curvature(), cam.nose_radius);
  const double h = 1e-6;
  for (double junction : {delta, 75 * kDeg, -delta, -75 * kDeg}) {
    const Polar before = contour.at(0.3 + junction - h), after = contour.at(0.3 + junction + h);
    EXPECT_NEAR(before.value + h * before.d, after.value - h * after.d, 1e-12) << junction;
    EXPECT_NEAR(before.d, after.d, 1e-6) << junction;
  }
  for (int k = 0; k < 180; ++k) {
    const double angle = 0.3 + (k + 0.37) * 2 * kDeg - kPi, d = 1e-5;  // no junction within d
    const Polar a = contour.at(angle - d), b = contour.at(angle), e = contour.at(angle + d);
    EXPECT_NEAR(b.d, (e.value - a.value) / (2 * d), 1e-9) << k;
    EXPECT_NEAR(b.dd, (e.d - a.d) / (2 * d), 1e-7) << k;
    EXPECT_NEAR(b.ddd, (e.dd - a.dd) / (2 * d), 1e-6) << k;
  }
  Follower flat;
  flat.kind = FollowerKind::flat_faced;
  EXPECT_THROW(Contour(cam, flat), std::invalid_argument);
  EXPECT_THROW(TangentCam::from_lift(0.03, 0.0175, 40 * kDeg, std::nan(""), 0.0),
               std::invalid_argument);  // no nose
  EXPECT_THROW(TangentCam::from_lift(0.03, 0.0175, std::nan(""), 0.035, 0.0),
               std::invalid_argument);  // a nose larger than the base
}

// The third derivative in the angle (the follower's jerk) of an eccentric cam's contour and of a
// profile given by its points is the difference of the second, for every follower: the disc's
// circle and support function in closed form, the points' spline inside its pieces (its third
// derivative steps at the knots, every 30 degrees here; the samples keep 9 degrees from them,
// more than a roller's or a face's angle strays from the point it touches).
TEST(CamContour, ThirdDerivativeIsTheDifferenceOfTheSecond) {
  Follower knife;
  knife.kind = FollowerKind::knife_edge;
  Follower roller;
  roller.roller_radius = 0.01;
  Follower flat;
  flat.kind = FollowerKind::flat_faced;
  std::vector<std::pair<double, double>> points;
  for (int k = 0; k < 12; ++k) {
    const double phi = k * 30 * kDeg;
    points.emplace_back(phi, 0.04 + 0.004 * std::cos(phi) + 0.002 * std::sin(2 * phi));
  }
  const double h = 1e-5;
  for (const Follower& f : {knife, roller, flat}) {
    SCOPED_TRACE(static_cast<int>(f.kind));
    const Contour disc(EccentricCam{0.05, 0.012, 0.4}, f);
    const Contour shape = Contour::from_points(MotionProgram::table(points), f);
    for (int k = 0; k < 12; ++k) {
      for (double off : {-6.0, 0.0, 6.0}) {
        const double angle = (k * 30 + 15 + off) * kDeg;
        for (const Contour* c : {&disc, &shape}) {
          const Polar a = c->at(angle - h), b = c->at(angle), e = c->at(angle + h);
          EXPECT_NEAR(b.ddd, (e.dd - a.dd) / (2 * h), 1e-7 * std::max(1.0, std::abs(b.ddd)))
              << angle / kDeg << (c == &disc ? " disc" : " points");
        }
      }
    }
  }
}

}  // namespace
}  // namespace crosslink::cam
