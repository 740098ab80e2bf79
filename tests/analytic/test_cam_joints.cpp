// Cam joints (issue 37, slice 3): a follower held on a profile synthesised from its motion law,
// solved by Newton on the one constraint row, against what is known without that row: the
// laws' closed forms (Norton, Design of Machinery, ch. 8: cycloidal eq. 8.6, 3-4-5 eq. 8.9,
// 4-5-6-7 eq. 8.10), written out here; the cam-follower instant centre, where the cam's velocity
// is the follower's; and the follower's equations of motion, which give the contact force and
// the driver's torque by power. Each channel is held to 1e-9 of its peak.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "analytic/derived/derived.h"
#include "analytic/derived/golden.h"
#include "analytic/derived/jump.h"
#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/model/planar.h"
#include "analytic/reference/sweep.h"
#include "tests/common/changed.h"
#include "tests/common/cli.h"
#include "tests/common/diagnostics.h"
#include "tests/common/jet.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// One segment of a bundled program: a law over [begin, begin + span) degrees of cam angle,
// from `from` to `to`.
struct Piece {
  std::string law;  // "dwell", "shm", "cycloidal", "345", "4567"
  double begin, span, from, to;
};

// The follower's displacement and its first three derivatives in the cam angle [rad]. Where two
// segments meet the third derivative may step (a 3-4-5 rise from a dwell): `ddds_after` is the
// later segment's there, either side's the exact one (ddds elsewhere).
struct Expected {
  double s, ds, dds, ddds, ddds_after;
  // The side of a step nearer to `jerk` (w^3 times it: a follower's jerk at cam speed w).
  double jerk_nearer(double jerk, double w) const {
    const double a = w * w * w * ddds, b = w * w * w * ddds_after;
    return std::abs(jerk - a) <= std::abs(jerk - b) ? a : b;
  }
};

Expected closed_form(const std::vector<Piece>& program, double theta) {
  theta = std::fmod(theta, 2 * kPi);
  if (theta < 0) theta += 2 * kPi;
  std::optional<Expected> found;
  // A turn on too: the last segment ends where the first begins.
  for (const double at : {theta, theta + 2 * kPi})
    for (const Piece& p : program) {
      const double beta = p.span * kDeg, u = (at - p.begin * kDeg) / beta;
      if (u < 0.0 || u > 1.0) continue;
      const double h = p.to - p.from;
      double y = 0, dy = 0, ddy = 0, dddy = 0;
      if (p.law == "shm") {
        y = (1 - std::cos(kPi * u)) / 2;
        dy = kPi / 2 * std::sin(kPi * u);
        ddy = kPi * kPi / 2 * std::cos(kPi * u);
        dddy = -kPi * kPi * kPi / 2 * std::sin(kPi * u);
      } else if (p.law == "cycloidal") {
        y = u - std::sin(2 * kPi * u) / (2 * kPi);
        dy = 1 - std::cos(2 * kPi * u);
        ddy = 2 * kPi * std::sin(2 * kPi * u);
        dddy = 4 * kPi * kPi * std::cos(2 * kPi * u);
      } else if (p.law == "345") {
        y = 10 * std::pow(u, 3) - 15 * std::pow(u, 4) + 6 * std::pow(u, 5);
        dy = 30 * u * u - 60 * std::pow(u, 3) + 30 * std::pow(u, 4);
        ddy = 60 * u - 180 * u * u + 120 * std::pow(u, 3);
        dddy = 60 - 360 * u + 360 * u * u;
      } else if (p.law == "4567") {
        y = 35 * std::pow(u, 4) - 84 * std::pow(u, 5) + 70 * std::pow(u, 6) - 20 * std::pow(u, 7);
        dy = 140 * std::pow(u, 3) - 420 * std::pow(u, 4) + 420 * std::pow(u, 5) -
             140 * std::pow(u, 6);
        ddy = 420 * u * u - 1680 * std::pow(u, 3) + 2100 * std::pow(u, 4) - 840 * std::pow(u, 5);
        dddy = 840 * u - 5040 * u * u + 8400 * std::pow(u, 3) - 4200 * std::pow(u, 4);
      }
      const double ddds = h * dddy / (beta * beta * beta);
      if (found)  // the other segment at a junction
        found->ddds_after = ddds;
      else
        found = Expected{p.from + h * y, h * dy / beta, h * ddy / (beta * beta), ddds, ddds};
    }
  if (!found) ADD_FAILURE() << "no segment at " << theta;
  return found.value_or(Expected{});
}

// The bundled programs, as their files write them.
const std::vector<Piece> kTranslatingRoller = {{"345", 0, 100, 0, 0.02},
                                               {"dwell", 100, 80, 0.02, 0.02},
                                               {"4567", 180, 100, 0.02, 0},
                                               {"dwell", 280, 80, 0, 0}};
const std::vector<Piece> kFlatFaced = {{"cycloidal", 0, 90, 0, 0.02},
                                       {"dwell", 90, 90, 0.02, 0.02},
                                       {"cycloidal", 180, 90, 0.02, 0},
                                       {"dwell", 270, 90, 0, 0}};
const std::vector<Piece> kOscillating = {{"cycloidal", 0, 120, 0, 15 * kDeg},
                                         {"dwell", 120, 60, 15 * kDeg, 15 * kDeg},
                                         {"345", 180, 120, 15 * kDeg, 0},
                                         {"dwell", 300, 60, 0, 0}};

Mechanism bundled(const std::string& stem) {
  return load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/cams/" + stem + ".toml");
}

// A bundled law-cut cam as analytic/model/cam.h synthesises it from its law and follower, apart
// from the joint's row: its program and follower as its file writes them.
struct LawCut {
  std::string stem;
  cam::MotionProgram program;
  cam::Follower follower;
};
LawCut law_cut_cam(const std::string& stem) {
  using cam::Law;
  if (stem == "translating_roller_345")
    return {stem,
            cam::MotionProgram(0.0, {{Law::polynomial_345, 100 * kDeg, 0.02},
                                     {Law::dwell, 80 * kDeg, 0.02},
                                     {Law::polynomial_4567, 100 * kDeg, 0.0},
                                     {Law::dwell, 80 * kDeg, 0.0}}),
            {cam::FollowerKind::roller, false, 0.04, 0.01, 0.01}};
  if (stem == "cycloidal_flat_faced")
    return {stem,
            cam::MotionProgram(0.0, {{Law::cycloidal, 90 * kDeg, 0.02},
                                     {Law::dwell, 90 * kDeg, 0.02},
                                     {Law::cycloidal, 90 * kDeg, 0.0},
                                     {Law::dwell, 90 * kDeg, 0.0}}),
            {cam::FollowerKind::flat_faced, false, 0.05}};
  return {stem,
          cam::MotionProgram(0.0, {{Law::cycloidal, 120 * kDeg, 15 * kDeg},
                                   {Law::dwell, 60 * kDeg, 15 * kDeg},
                                   {Law::polynomial_345, 120 * kDeg, 0.0},
                                   {Law::dwell, 60 * kDeg, 0.0}}),
          {cam::FollowerKind::roller, true, 0.04, 0.01, 0.0, {0.1, 0.0}, 0.08}};
}

// Compares `actual(row)` with `expected(row)` over every sample, to 1e-9 of the expected peak;
// an angle's difference is taken modulo a turn.
template <class A, class F>
void expect_close(const Trajectory& t, const std::string& what, A actual, F expected,
                  bool angle = false) {
  double peak = 0.0, apart = 0.0;
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << k;
    const double v = actual(k), e = expected(k);
    peak = std::max(peak, std::abs(e));
    apart = std::max(apart, std::abs(angle ? std::remainder(v - e, 2 * kPi) : v - e));
  }
  EXPECT_GT(peak, 0.0) << what;
  EXPECT_LE(apart, 1e-9 * peak) << what << ": " << apart << " from the closed form, peak " << peak;
  std::printf("  %-16s within %.2e of its peak %.6g over %d samples\n", what.c_str(), apart / peak,
              peak, t.samples());
}

// A channel's value at a sample (the test fails where it has none).
double value(const Trajectory& t, const std::string& name, int k) {
  const std::optional<double> v = t.sample(name, k);
  EXPECT_TRUE(v) << "no value of " << name << " at " << k;
  return v.value_or(std::nan(""));
}

template <class F>
void expect_channel(const Trajectory& t, const std::string& name, F expected, bool angle = false) {
  expect_close(
      t, name, [&](int k) { return value(t, name, k); }, expected, angle);
}

// A translating follower rises by its law: s, w s' and w^2 s'' at constant cam speed w.
void expect_translating(const std::string& stem, const std::vector<Piece>& program, double s0) {
  const Mechanism m = bundled(stem);
  const Trajectory t = sweep(m);
  const double w = m.drivers[0].law.speed;
  ASSERT_GE(t.samples(), 360);
  EXPECT_NEAR(t.swept(t.samples() - 1) - t.swept(0), 2 * kPi, 1e-12);
  auto at = [&](int k) { return closed_form(program, t.swept(k)); };
  std::printf("[ %s ]\n", stem.c_str());
  expect_channel(t, "s.follower", [&](int k) { return s0 + at(k).s; });
  expect_channel(t, "sdot.follower", [&](int k) { return w * at(k).ds; });
  expect_channel(t, "sddot.follower", [&](int k) { return w * w * at(k).dds; });
  expect_channel(t, "jerk.contact",
                 [&](int k) { return at(k).jerk_nearer(value(t, "jerk.contact", k), w); });
}

TEST(CamJoints, TranslatingRollerRisesByThePolynomials) {
  expect_translating("translating_roller_345", kTranslatingRoller,
                     std::sqrt(0.05 * 0.05 - 0.01 * 0.01));  // sqrt(Rp^2 - e^2)
  // The design summary's jerk extremes: the 3-4-5 rise's largest, 60 h / beta^3 (w^3 times),
  // at either end of it; the 4-5-6-7 return's, where y'''' = 840 (1 - 12u + 30u^2 - 20u^3) =
  // 840 (2u - 1)(10u^2 - 10u + 1) vanishes, u = (1 - sqrt(0.6)) / 2, found by hand.
  const Mechanism m = bundled("translating_roller_345");
  const std::vector<DerivedValue> summary = derived_exact(m, sweep(m));
  const double w = m.drivers[0].law.speed, beta = 100 * kDeg, h = 0.02;
  const double rise = 60 * h / std::pow(beta, 3) * std::pow(w, 3);
  const double u = (1 - std::sqrt(0.6)) / 2;
  const double fall = -h *
                      (840 * u - 5040 * u * u + 8400 * std::pow(u, 3) - 4200 * std::pow(u, 4)) /
                      std::pow(beta, 3) * std::pow(w, 3);
  EXPECT_NEAR(*derived_value(summary, "jerk_contact.max"), rise, 1e-9 * rise);
  const double at_max = *derived_value(summary, "jerk_contact.at_max") / kDeg;
  EXPECT_TRUE(std::abs(at_max) < 1e-6 || std::abs(at_max - 100) < 1e-6 ||
              std::abs(at_max - 360) < 1e-6)
      << at_max;
  EXPECT_NEAR(*derived_value(summary, "jerk_contact.min"), fall, 1e-9 * rise);
  EXPECT_NEAR(*derived_value(summary, "jerk_contact.at_min"), (180 + 100 * u) * kDeg, 1e-6);
  std::printf("  jerk from %.6g (closed form %.6g) to %.6g m/s^3 (%.6g)\n",
              *derived_value(summary, "jerk_contact.min"), fall,
              *derived_value(summary, "jerk_contact.max"), rise);
}

// A cam that speeds up, theta = c1 t + c2 t^2 + c3 t^3 (the driver's polynomial law): the
// follower's jerk is the chain rule's s''' theta'^3 + 3 s'' theta' theta'' + s' theta''', the
// driver's own jerk 6 c3 in the last term.
TEST(CamJoints, JerkIsTheChainRuleUnderACamThatSpeedsUp) {
  const Mechanism m = test::changed(
      "mechanisms/cams/translating_roller_345.toml",
      {{"speed = 300\nspeed_unit = \"rpm\"", "polynomial = [1800, 900, 300]\nduration = 0.2"}});
  const Trajectory t = sweep(m);
  ASSERT_GE(t.samples(), 360);
  std::printf("[ translating_roller_345, a polynomial driver ]\n");
  expect_channel(t, "jerk.contact", [&](int k) {
    const double time = t.time(k);
    const double theta = (1800 * time + 900 * time * time + 300 * time * time * time) * kDeg;
    EXPECT_NEAR(theta, t.swept(k), 1e-12) << k;
    const double w = (1800 + 1800 * time + 900 * time * time) * kDeg,
                 dw = (1800 + 1800 * time) * kDeg, ddw = 1800 * kDeg;
    const Expected e = closed_form(kTranslatingRoller, theta);
    const double rest = 3 * e.dds * w * dw + e.ds * ddw;
    const double jerk = value(t, "jerk.contact", k) - rest;
    return e.jerk_nearer(jerk, w) + rest;
  });
}

TEST(CamJoints, FlatFacedFollowerRisesByTheCycloid) {
  expect_translating("cycloidal_flat_faced", kFlatFaced, 0.05);  // the base circle
}

// The arm turns from gamma0 = -acos((Rp^2 - d^2 - l^2) / (2 l d)), its roller's centre on the
// prime circle, by the program's angle.
TEST(CamJoints, OscillatingArmTurnsByItsLaws) {
  const Mechanism m = bundled("oscillating_roller");
  const Trajectory t = sweep(m);
  const double w = m.drivers[0].law.speed, prime = 0.05, d = 0.1, l = 0.08;
  const double gamma0 = -std::acos((prime * prime - d * d - l * l) / (2 * l * d));
  auto at = [&](int k) { return closed_form(kOscillating, t.swept(k)); };
  std::printf("[ oscillating_roller ]\n");
  expect_channel(
      t, "angle.arm", [&](int k) { return gamma0 + at(k).s; }, true);
  expect_channel(t, "omega.arm", [&](int k) { return w * at(k).ds; });
  expect_channel(t, "alpha.arm", [&](int k) { return w * w * at(k).dds; });
  expect_channel(t, "angular_jerk.contact",
                 [&](int k) { return at(k).jerk_nearer(value(t, "angular_jerk.contact", k), w); });
}

// The cam-follower centre is where the cam's velocity is the follower's. A translating follower
// along y: on the line through the cam's centre O square to its motion, at x = s' (so v = w s');
// an oscillating one about P = (d, 0): on the line OP, at x = s' d / (s' - 1). Found by Kennedy
// from the common normal at the contact, and the velocities from the centres are the exact ones.
TEST(CamJoints, CamFollowerCentreIsWhereTheirVelocitiesAgree) {
  struct Case {
    std::string stem, follower;
    const std::vector<Piece>* program;
  };
  for (const Case& c : {Case{"translating_roller_345", "follower", &kTranslatingRoller},
                        Case{"cycloidal_flat_faced", "follower", &kFlatFaced},
                        Case{"oscillating_roller", "arm", &kOscillating}}) {
    SCOPED_TRACE(c.stem);
    const Mechanism m = bundled(c.stem);
    const Trajectory t = sweep(m);
    const int cam = m.find_link("cam"), follower = m.find_link(c.follower);
    double worst = 0.0;
    for (int k = 0; k < t.samples(); k += 7) {
      const double ds = closed_form(*c.program, t.swept(k)).ds;
      const InstantCentres ic = instant_centres(m, t, k);
      const InstantCentre& centre = ic.at(cam, follower);
      ASSERT_EQ(centre.found, InstantCentre::Found::kennedy) << k << " " << centre.how;
      ASSERT_FALSE(centre.at_infinity()) << k;
      const double x = c.follower == "arm" ? ds * 0.1 / (ds - 1.0) : ds;
      EXPECT_NEAR(centre.position().x(), x, 1e-12) << k;
      EXPECT_NEAR(centre.position().y(), 0.0, 1e-12) << k;
      const CentreVelocities v = centre_velocities(m, ic, t, k);
      ASSERT_TRUE(v.complete) << v.message;
      double peak = 0.0;
      for (int p = 0; p < static_cast<int>(t.point_names.size()); ++p)
        peak = std::max(peak, std::hypot(t.vx(k, p), t.vy(k, p)));
      for (int p = 0; p < static_cast<int>(t.point_names.size()); ++p)
        worst = std::max(
            worst, std::hypot(v.point[p].x() - t.vx(k, p), v.point[p].y() - t.vy(k, p)) / peak);
    }
    EXPECT_LE(worst, 1e-9);
  }
}

// The contact force and the driver's torque from the follower's own equations of motion. A
// translating follower of mass m along y: the cam pushes it along the common normal with
// F_y = m (s'' - g_y) (the guide takes only the side force), at the pressure angle phi, so
// F_x = -F_y tan phi with tan phi = (s' - e) / (s + sqrt(Rp^2 - e^2)) for a roller (Norton, ch.
// 8, the offset roller follower's pressure angle) and 0 for a flat face. The cam turns at a
// constant speed about its centre of mass, so the driver's power is the follower's: T w =
// m s'' sdot - m g . v. An oscillating arm: T w = (I_P alpha - moment of gravity) omega, and the
// contact force's moment about the pivot P, at the roller's centre C, is I_P alpha less gravity's.
TEST(CamJoints, ContactForceAndTorqueAreTheFollowersEquationsOfMotion) {
  for (const std::string stem : {"translating_roller_345", "cycloidal_flat_faced"}) {
    SCOPED_TRACE(stem);
    const Mechanism m = bundled(stem);
    const Trajectory t = sweep(m);
    ASSERT_TRUE(t.has_forces);
    const double w = m.drivers[0].law.speed;
    const MassProperties& follower = m.links[static_cast<size_t>(m.find_link("follower"))].mass;
    const double mass = follower.mass, gy = m.gravity.y();
    const bool roller = stem == "translating_roller_345";
    const double e = 0.01, base = std::sqrt(0.05 * 0.05 - e * e);
    auto fy = [&](int k) { return mass * (value(t, "sddot.follower", k) - gy); };
    std::printf("[ %s ]\n", stem.c_str());
    expect_channel(t, "fy.contact", fy);
    if (roller) {
      expect_channel(t, "fx.contact", [&](int k) {
        const Expected x = closed_form(kTranslatingRoller, t.swept(k));
        return -fy(k) * (x.ds - e) / (x.s + base);
      });
    } else {  // square to the face: no side force
      double side = 0.0, peak = 0.0;
      for (int k = 0; k < t.samples(); ++k) {
        side = std::max(side, std::abs(value(t, "fx.contact", k)));
        peak = std::max(peak, std::abs(fy(k)));
      }
      EXPECT_LE(side, 1e-12 * peak);
    }
    expect_channel(t, "torque.driver",
                   [&](int k) { return fy(k) * value(t, "sdot.follower", k) / w; });
  }
  const Mechanism m = bundled("oscillating_roller");
  const Trajectory t = sweep(m);
  ASSERT_TRUE(t.has_forces);
  const double w = m.drivers[0].law.speed;
  const MassProperties& arm = m.links[static_cast<size_t>(m.find_link("arm"))].mass;
  const double ip = arm.inertia + arm.mass * arm.com.squaredNorm();  // about the pivot
  auto held = [&](int k) {  // I_P alpha less gravity's moment about P
    const double angle = value(t, "angle.arm", k);
    const Eigen::Vector2d com = Eigen::Rotation2Dd(angle) * arm.com;
    return ip * value(t, "alpha.arm", k) - cross(com, arm.mass * m.gravity);
  };
  std::printf("[ oscillating_roller ]\n");
  expect_channel(t, "torque.driver", [&](int k) { return held(k) * value(t, "omega.arm", k) / w; });
  expect_close(
      t, "moment of the contact force about P",
      [&](int k) {
        const Eigen::Vector2d arm_to_c(value(t, "x.C", k) - 0.1, value(t, "y.C", k));
        return cross(arm_to_c,
                     Eigen::Vector2d(value(t, "fx.contact", k), value(t, "fy.contact", k)));
      },
      held);
}

// The tangent cam's two phases in closed form (tangent_cam_roller.toml's comment): the follower's
// rise x above the prime circle, its velocity and acceleration at cam angle theta [rad] and speed
// w, the lift starting at theta = 0.5 deg, the apex an ascent later, the fall its mirror.
struct TangentPhase {
  double x, v, a, phi;  // phi: the pressure angle
};
TangentPhase tangent_closed_form(double theta, double w) {
  const double rb = 30e-3, rr = 17.5e-3, lift = 17.5e-3, alpha = 75 * kDeg;
  const double rn = (rb - (rb + lift) * std::cos(alpha)) / (1 - std::cos(alpha));
  const double c = rb + lift - rn, l = rn + rr, prime = rb + rr;
  // Where the roller leaves the flank for the nose, from the apex: the nose's normal at alpha.
  const double delta = std::atan2(l * std::sin(alpha), c + l * std::cos(alpha));
  theta = std::remainder(theta - 0.5 * kDeg, 2 * kPi);
  double sign = 1.0;  // the fall is the rise's mirror about the apex: v changes sign
  if (theta > alpha) {
    theta = 2 * alpha - theta;
    sign = -1.0;
  }
  if (theta <= 0.0) return {0.0, 0.0, 0.0, 0.0};  // on the base circle
  if (theta <= alpha - delta) {  // on a flank, whose normal has turned with the cam by theta
    const double cs = std::cos(theta), sn = std::sin(theta);
    return {prime * (1 - cs) / cs, sign * w * prime * sn / (cs * cs),
            w * w * prime * (2 - cs * cs) / (cs * cs * cs), sign * theta};
  }
  // On the nose, phi before the apex: r(phi) = c cos phi + sqrt(l^2 - c^2 sin^2 phi), and
  // dphi/dt = -w.
  const double phi = alpha - theta, cp = std::cos(phi), sp = std::sin(phi);
  const double root = std::sqrt(l * l - c * c * sp * sp);
  const double r = c * cp + root;
  const double dr = -c * sp - c * c * sp * cp / root;
  const double ddr = -c * cp - c * c * (cp * cp - sp * sp) / root -
                     std::pow(c, 4) * sp * sp * cp * cp / std::pow(root, 3);
  // The normal through the nose's centre: in the triangle of the cam's centre, the nose's and
  // the roller's, sin(pressure angle) / c = sin(phi) / (Rn + Rr).
  return {r - prime, -sign * w * dr, w * w * ddr, sign * std::asin(c * sp / l)};
}

// The same rise in a jet of the cam angle (flank and nose written again in its arithmetic): its
// derivatives to round-off, the follower's jerk w^3 x''' at constant speed w.
test::Jet tangent_rise(double theta) {
  using test::Jet;
  const double rb = 30e-3, rr = 17.5e-3, lift = 17.5e-3, alpha = 75 * kDeg;
  const double rn = (rb - (rb + lift) * std::cos(alpha)) / (1 - std::cos(alpha));
  const double c = rb + lift - rn, l = rn + rr, prime = rb + rr;
  const double delta = std::atan2(l * std::sin(alpha), c + l * std::cos(alpha));
  Jet t(std::remainder(theta - 0.5 * kDeg, 2 * kPi), 1.0);
  if (t.v > alpha) t = 2 * alpha - t;  // the fall, the rise's mirror
  if (t.v <= 0.0) return 0.0;
  if (t.v <= alpha - delta) return prime * (1.0 / cos(t) - 1.0);
  const Jet phi = alpha - t, sp = sin(phi);
  return c * cos(phi) + sqrt(l * l - c * c * sp * sp) - prime;
}

// The tangent cam's follower, solved by Newton on the profile's pitch curve, against the
// textbook's closed forms of its flank and nose phases. At the start of lift the acceleration is
// w^2 (Rb + Rr) = 187.52 m/s^2 at 600 rpm; the print's 187.6 is that value with pi = 3.142.
TEST(CamJoints, TangentCamFollowsItsFlankAndNoseClosedForms) {
  const Mechanism m = bundled("tangent_cam_roller");
  const Trajectory t = sweep(m);
  const double w = m.drivers[0].law.speed, prime = 47.5e-3;
  auto at = [&](int k) { return tangent_closed_form(t.swept(k), w); };
  std::printf("[ tangent_cam_roller ]\n");
  expect_channel(t, "s.follower", [&](int k) { return prime + at(k).x; });
  expect_channel(t, "sdot.follower", [&](int k) { return at(k).v; });
  expect_channel(t, "sddot.follower", [&](int k) { return at(k).a; });
  expect_channel(
      t, "phi.contact", [&](int k) { return at(k).phi; }, true);
  expect_channel(t, "jerk.contact", [&](int k) {
    const test::Jet x = tangent_rise(t.swept(k));
    EXPECT_NEAR(x.dd * w * w, at(k).a, 1e-9 * w * w * 0.05) << k;  // the jet is the closed form
    return w * w * w * x.ddd;
  });
  // The apex: a slider-crank at its dead centre, a = -w^2 c (1 + c / (Rn + Rr)).
  const double cos_ascent = std::cos(75 * kDeg);
  const double rn = (30e-3 - 47.5e-3 * cos_ascent) / (1 - cos_ascent), c = 47.5e-3 - rn;
  const double apex = value(solve_at(m, 75.5 * kDeg), "sddot.follower", 0);
  EXPECT_NEAR(apex, -w * w * c * (1 + c / (rn + 17.5e-3)), 1e-9 * std::abs(apex));
  // Just after the start of lift.
  const double a0 = value(solve_at(m, 0.5 * kDeg + 1e-10), "sddot.follower", 0);
  EXPECT_NEAR(a0, w * w * prime, 1e-9 * a0);
  const double print_pi = 3.142, printed = 187.6;
  const double with_print_pi = std::pow(2 * print_pi * 600 / 60, 2) * prime;
  EXPECT_NEAR(std::round(with_print_pi * 10) / 10, printed, 1e-12);
  std::printf(
      "  acceleration at the start of lift %.4f m/s^2; printed %.1f (%+.3f %%), which is "
      "%.4f with pi = 3.142; at the apex %.4f m/s^2\n",
      a0, printed, 100 * (printed - a0) / a0, with_print_pi, apex);
}

// The pressure angle phi.<cam>, read from positions alone, against what fixes it without the
// profile's row. A translating roller: tan phi = (s' - e) / (s + sqrt(Rp^2 - e^2)) (Norton, Design
// of Machinery, ch. 8); a flat face square to its motion: 0; an oscillating roller: the common
// normal runs through the cam-follower centre I = (s' d / (s' - 1), 0) (as found above) and the
// roller's centre C, which moves square to the arm PC. The design summary's extremes of the
// channel (pressure_angle_contact) are located on exact poses; here golden-section search on the
// closed form over each of the rise and the return finds them independently.
TEST(CamJoints, PressureAngleIsTheClosedFormsAndItsExtremesAreLocated) {
  const double e = 0.01, rp = 0.05, d = 0.1, l = 0.08;
  const double gamma0 = -std::acos((rp * rp - d * d - l * l) / (2 * l * d));
  const auto translating = [&](double theta) {
    const Expected x = closed_form(kTranslatingRoller, theta);
    return std::atan((x.ds - e) / (x.s + std::sqrt(rp * rp - e * e)));
  };
  const auto oscillating = [&](double theta) {
    const Expected x = closed_form(kOscillating, theta);
    const Eigen::Vector2d pivot(d, 0.0), centre(x.ds * d / (x.ds - 1.0), 0.0);
    const Eigen::Vector2d c =
        pivot + l * Eigen::Vector2d(std::cos(gamma0 + x.s), std::sin(gamma0 + x.s));
    Eigen::Vector2d n = (c - centre).normalized();
    if (n.dot(c) < 0.0) n = -n;  // away from the cam: the pitch curve is star-shaped about O
    Eigen::Vector2d motion = perp(c - pivot);
    if (motion.dot(n) < 0.0) motion = -motion;
    return std::atan2(cross(motion, n), motion.dot(n));
  };
  struct Case {
    std::string stem;
    std::function<double(double)> phi;
    // The cam angles [deg] of the rise and the return, each holding one extreme.
    std::pair<double, double> rise, fall;
  };
  for (const Case& c :
       {Case{"translating_roller_345", translating, {0, 100}, {180, 280}},
        Case{"cycloidal_flat_faced", [](double) { return 0.0; }, {0, 90}, {180, 270}},
        Case{"oscillating_roller", oscillating, {0, 120}, {180, 300}}}) {
    SCOPED_TRACE(c.stem);
    const Mechanism m = bundled(c.stem);
    const Trajectory t = sweep(m);
    std::printf("[ %s ]\n", c.stem.c_str());
    if (c.stem == "cycloidal_flat_faced") {
      for (int k = 0; k < t.samples(); ++k) EXPECT_NEAR(value(t, "phi.contact", k), 0.0, 1e-15);
      continue;
    }
    expect_channel(
        t, "phi.contact", [&](int k) { return c.phi(t.swept(k)); }, true);
    const std::vector<DerivedValue> derived = derived_exact(m, t);
    const auto extreme = [&](std::pair<double, double> span, double sign) {
      return golden_section_max([&](double v) { return std::optional(sign * c.phi(v)); },
                                span.first * kDeg, span.second * kDeg);
    };
    const double at_max = extreme(c.rise, 1.0), at_min = extreme(c.fall, -1.0);
    const double max = *derived_value(derived, "pressure_angle_contact.max");
    const double min = *derived_value(derived, "pressure_angle_contact.min");
    EXPECT_NEAR(max, c.phi(at_max), 1e-12);
    EXPECT_NEAR(min, c.phi(at_min), 1e-12);
    // A flat extreme's place is found to about the square root of round-off.
    EXPECT_NEAR(*derived_value(derived, "pressure_angle_contact.at_max"), at_max, 1e-6);
    EXPECT_NEAR(*derived_value(derived, "pressure_angle_contact.at_min"), at_min, 1e-6);
    std::printf("  pressure angle from %.6f deg at %.4f deg to %.6f deg at %.4f deg\n", min / kDeg,
                at_min / kDeg, max / kDeg, at_max / kDeg);
  }
}

// The profile as the report draws it (CamReading::outline, from the joint's row) is the one the
// follower's law cuts: at each pitch or normal angle, the contact profile_at finds at the cam
// angle that puts the follower there (analytic/model/cam.h, synthesised from the law, not the
// row); and the tangent cam's outline lies on its base circle, its nose circle or its flanks.
TEST(CamJoints, OutlineIsTheProfileTheLawCuts) {
  const std::vector<LawCut> cases = {law_cut_cam("translating_roller_345"),
                                     law_cut_cam("cycloidal_flat_faced")};
  for (const LawCut& c : cases) {
    SCOPED_TRACE(c.stem);
    const CamReading reading = cam_readings(bundled(c.stem)).at(0);
    const std::vector<Eigen::Vector2d> outline = reading.outline(360);
    ASSERT_EQ(outline.size(), 360u);
    double worst = 0.0;
    for (size_t k = 0; k < outline.size(); ++k) {
      const double theta = reading.rows.contour->cam_angle(2 * kPi * static_cast<double>(k) / 360);
      const cam::ProfilePoint p = cam::profile_at(c.program, c.follower, theta);
      worst = std::max(worst, (outline[k] - p.contact).norm());
    }
    EXPECT_LE(worst, 1e-12);
    std::printf("  %s: outline within %.1e m of the law's profile at 360 angles\n", c.stem.c_str(),
                worst);
  }
  const Mechanism m = bundled("tangent_cam_roller");
  const CamReading reading = cam_readings(m).at(0);
  const double rb = 30e-3, nose_angle = 14.5 * kDeg, alpha = 75 * kDeg;
  const double rn = (rb - 47.5e-3 * std::cos(alpha)) / (1 - std::cos(alpha)), c = 47.5e-3 - rn;
  const Eigen::Vector2d nose = c * Eigen::Vector2d(std::cos(nose_angle), std::sin(nose_angle));
  int on_nose = 0, on_base = 0;
  for (const Eigen::Vector2d& u : reading.outline(360)) {
    const double base = std::abs(u.norm() - rb), tip = std::abs((u - nose).norm() - rn);
    double flank = 1.0;
    for (const double side : {-1.0, 1.0}) {  // a flank: n . u = Rb, n at the nose axis +- alpha
      const double b = nose_angle + side * alpha;
      flank = std::min(flank, std::abs(std::cos(b) * u.x() + std::sin(b) * u.y() - rb));
    }
    EXPECT_LE(std::min({base, tip, flank}), 1e-12) << u.transpose();
    on_nose += tip <= 1e-12;
    on_base += base <= 1e-12;
  }
  EXPECT_GT(on_nose, 0);
  EXPECT_GT(on_base, 0);
}

// An eccentric cam given by its shape (shape = "eccentric"). A roller on it, as a cam joint, moves
// and loads exactly as the same roller held R + r from the disc's centre by a pin in an arc
// (eccentric_cam_roller.toml, itself the offset slider-crank: CurvedSlots.*). A flat face on it
// (eccentric_flat_faced.toml) moves by simple harmonic motion, s = R - e cos(theta), with the
// contact force N = m e w^2 cos(theta) + k (0.01 + e (1 - cos(theta))) along +y and none across,
// a zero pressure angle, and the jump speed sqrt(k (0.01 + 2 e) / (m e)) at theta = 180 deg.
TEST(CamJoints, EccentricShapeIsThePinInItsArcAndTheScotchYoke) {
  const std::string arc =
      "type = \"pin_in_slot\"      # the roller on the disc: C stays R + r from B\n"
      "name = \"roller\"\nguide = \"cam\"\narc = { centre = \"B\", radius = 0.12 }\n"
      "slider = \"follower\"\npoint = \"C\"\n";
  const std::string disc =
      "type = \"cam\"\nname = \"roller\"\nclosure = \"form\"\ncam = \"cam\"\ncentre = \"A\"\n"
      "follower = \"follower\"\npoint = \"C\"\n\n[joint.profile]\nshape = \"eccentric\"\n"
      "radius = 0.09\neccentricity = 0.04\nroller_radius = 0.03\n";
  const Trajectory pinned = sweep(bundled("eccentric_cam_roller"));
  const Trajectory cammed =
      sweep(test::changed("mechanisms/cams/eccentric_cam_roller.toml", {{arc, disc}}));
  std::printf("[ eccentric_cam_roller, the pin in an arc as a cam joint ]\n");
  for (const std::string channel : {"x.C", "vx.C", "ax.C", "s.follower", "torque.driver",
                                    "fx.roller", "fy.roller", "fx.A", "fy.A"})
    expect_channel(cammed, channel, [&](int k) { return value(pinned, channel, k); });
  // The roller's jerk: the offset slider-crank's x = e cos t + sqrt((R + r)^2 - (f - e sin t)^2),
  // f = 0.01 the line's offset, differentiated in a jet of the cam angle.
  const double speed = bundled("eccentric_cam_roller").drivers[0].law.speed;
  expect_channel(cammed, "jerk.roller", [&](int k) {
    const test::Jet a(cammed.swept(k), 1.0);
    const test::Jet x =
        0.04 * cos(a) + sqrt(0.12 * 0.12 - (0.01 - 0.04 * sin(a)) * (0.01 - 0.04 * sin(a)));
    EXPECT_NEAR(x.v, value(pinned, "x.C", k), 1e-12) << k;  // the jet is the slider-crank
    return speed * speed * speed * x.ddd;
  });

  const Mechanism m = bundled("eccentric_flat_faced");
  const Trajectory t = sweep(m);
  const double w = m.drivers[0].law.speed, e = 0.01, mass = 0.08, k = 200.0;
  const auto n = [&](double theta, double speed) {
    return mass * e * speed * speed * std::cos(theta) + k * (0.01 + e * (1 - std::cos(theta)));
  };
  std::printf("[ eccentric_flat_faced ]\n");
  expect_channel(t, "s.follower", [&](int s) { return 0.04 - e * std::cos(t.swept(s)); });
  expect_channel(t, "sdot.follower", [&](int s) { return e * w * std::sin(t.swept(s)); });
  expect_channel(t, "sddot.follower", [&](int s) { return e * w * w * std::cos(t.swept(s)); });
  expect_channel(t, "jerk.contact", [&](int s) { return -e * w * w * w * std::sin(t.swept(s)); });
  expect_channel(t, "fy.contact", [&](int s) { return n(t.swept(s), w); });
  for (int s = 0; s < t.samples(); ++s) {
    EXPECT_NEAR(value(t, "fx.contact", s), 0.0, 1e-12);
    EXPECT_NEAR(value(t, "phi.contact", s), 0.0, 1e-15);
  }
  const double jump = std::sqrt(k * (0.01 + 2 * e) / (mass * e));
  const std::vector<DerivedValue> summary = derived_exact(m, t);
  EXPECT_NEAR(*derived_value(summary, "jump_speed_contact.speed"), jump, 1e-9 * jump);
  EXPECT_NEAR(*derived_value(summary, "jump_speed_contact.at"), kPi, 1e-6);
  EXPECT_NEAR(n(kPi, jump), 0.0, 1e-12);
  std::printf("  jump speed %.9f rad/s (closed form %.9f) at %.6f deg\n",
              *derived_value(summary, "jump_speed_contact.speed"), jump,
              *derived_value(summary, "jump_speed_contact.at") / kDeg);
}

// A profile given by its points (shape = "points"): a periodic cubic spline through them. Points
// of the eccentric disc, r(phi) = e cos t + sqrt(R^2 - e^2 sin^2 t) (t = phi - lobe), give the
// disc back as they grow denser, a spline's error falling with the fourth power of the spacing:
// the roller's centre (and a knife edge's, on the disc of radius R + r) against the pin in the
// arc (eccentric_cam_roller.toml), the flat face's travel against simple harmonic motion
// (eccentric_flat_faced.toml). Each error halves its spacing 16-fold, within [10, 24].
TEST(CamJoints, PointsProfileConvergesToTheDiscItSamples) {
  const auto points = [](double radius, double e, double lobe, int n) {
    std::string text = "points = [";
    for (int i = 0; i < n; ++i) {
      const double phi = 360.0 * i / n, t = phi * kDeg - lobe;
      const double r = e * std::cos(t) + std::sqrt(radius * radius - std::pow(e * std::sin(t), 2));
      text += fmt::format("{}[{:.17g}, {:.17g}]", i ? ", " : "", phi, r);
    }
    return text + "]\n";
  };
  const std::string arc =
      "type = \"pin_in_slot\"      # the roller on the disc: C stays R + r from B\n"
      "name = \"roller\"\nguide = \"cam\"\narc = { centre = \"B\", radius = 0.12 }\n"
      "slider = \"follower\"\npoint = \"C\"\n";
  const std::string cam =
      "type = \"cam\"\nname = \"roller\"\nclosure = \"form\"\ncam = \"cam\"\ncentre = \"A\"\n"
      "follower = \"follower\"\npoint = \"C\"\n\n[joint.profile]\nshape = \"points\"\n";
  const Trajectory pinned = sweep(bundled("eccentric_cam_roller"));
  const Mechanism yoke = bundled("eccentric_flat_faced");
  const Trajectory shm = sweep(yoke);
  // The worst difference over the sweep in % of the channel's peak.
  const auto worst = [](const Trajectory& t, const Trajectory& exact, const std::string& name) {
    double peak = 0.0, apart = 0.0;
    for (int k = 0; k < t.samples(); ++k) {
      peak = std::max(peak, std::abs(*exact.sample(name, k)));
      apart = std::max(apart, std::abs(*t.sample(name, k) - *exact.sample(name, k)));
    }
    return apart / peak;
  };
  struct Case {
    std::string what;
    std::function<Trajectory(int)> run;
    const Trajectory* exact;
    std::string channel;
  };
  const std::vector<Case> cases = {
      {"roller",
       [&](int n) {
         return sweep(
             test::changed("mechanisms/cams/eccentric_cam_roller.toml",
                           {{arc, cam + points(0.09, 0.04, 0.0, n) + "roller_radius = 0.03\n"}}));
       },
       &pinned, "x.C"},
      {"knife edge",
       [&](int n) {
         return sweep(test::changed("mechanisms/cams/eccentric_cam_roller.toml",
                                    {{arc, cam + points(0.12, 0.04, 0.0, n)}}));
       },
       &pinned, "x.C"},
      {"flat face",
       [&](int n) {
         return sweep(test::changed(
             "mechanisms/cams/eccentric_flat_faced.toml",
             {{"shape = \"eccentric\"\nradius = 0.04\neccentricity = 0.01\nlobe_angle = -90",
               "shape = \"points\"\n" + points(0.04, 0.01, -kPi / 2, n)}}));
       },
       &shm, "s.follower"}};
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    const double coarse = worst(c.run(24), *c.exact, c.channel);
    const double fine = worst(c.run(48), *c.exact, c.channel);
    EXPECT_GT(coarse / fine, 10.0);
    EXPECT_LT(coarse / fine, 24.0);
    EXPECT_LT(fine, 1e-5);
    std::printf(
        "  %-10s %s from the disc: %.2e of peak through 24 points, %.2e through 48 "
        "(ratio %.1f)\n",
        c.what.c_str(), c.channel.c_str(), coarse, fine, coarse / fine);
  }
}

// The least radius of curvature where the follower touches the profile (least_radius_<cam> in
// the design summary), located on exact poses from the joint's row, against profile_at's radius
// (synthesised from the law, analytic/model/cam.h) minimised by golden-section search over the
// cam angle; a tangent cam's is its nose's radius, a disc's its own.
TEST(CamJoints, LeastRadiusOfCurvatureIsLocated) {
  for (const LawCut& c :
       {law_cut_cam("translating_roller_345"), law_cut_cam("oscillating_roller")}) {
    SCOPED_TRACE(c.stem);
    const auto radius = [&](double theta) {
      const double r = cam::profile_at(c.program, c.follower, theta).radius_of_curvature;
      return r > 0.0 ? r : INFINITY;
    };
    double best = 0.0;
    for (double theta = 0.0; theta < 2 * kPi; theta += 0.1 * kDeg)
      if (radius(theta) < radius(best)) best = theta;
    const double at = golden_section_max([&](double v) { return std::optional(-radius(v)); },
                                         best - 0.2 * kDeg, best + 0.2 * kDeg);
    const Mechanism m = bundled(c.stem);
    const std::vector<DerivedValue> summary = derived_exact(m, sweep(m));
    EXPECT_NEAR(*derived_value(summary, "least_radius_contact.radius"), radius(at),
                1e-9 * radius(at));
    EXPECT_NEAR(*derived_value(summary, "least_radius_contact.at"), at, 1e-6);
    std::printf("  %s: least radius %.9g m at %.4f deg (by the law: %.9g at %.4f)\n",
                c.stem.c_str(), *derived_value(summary, "least_radius_contact.radius"),
                *derived_value(summary, "least_radius_contact.at") / kDeg, radius(at), at / kDeg);
  }
  const Mechanism tangent = bundled("tangent_cam_roller");
  const double cos_ascent = std::cos(75 * kDeg);
  const double nose = (30e-3 - 47.5e-3 * cos_ascent) / (1 - cos_ascent);
  EXPECT_NEAR(*derived_value(derived_exact(tangent, sweep(tangent)), "least_radius_contact.radius"),
              nose, 1e-12);
  const Mechanism disc = bundled("eccentric_flat_faced");
  EXPECT_NEAR(*derived_value(derived_exact(disc, sweep(disc)), "least_radius_contact.radius"), 0.04,
              1e-15);
}

// A printed exercise (valve_cam_shm.toml): simple harmonic rise of 50 mm over 120 deg, dwell 30,
// fall over 60, at 100 rpm. The sweep against the closed form (the acceleration away from the
// segments' ends, where it jumps); the four printed maxima against the exact values at their
// [[reference]] rows: three within their printed rounding, and the falling velocity's 0.78 m/s
// not (exact 0.7854): it is twice the rising velocity's rounded 0.39.
TEST(CamJoints, ValveCamPrintsAgainstTheExactValues) {
  const std::vector<Piece> program = {{"shm", 0, 120, 0, 0.05},
                                      {"dwell", 120, 30, 0.05, 0.05},
                                      {"shm", 150, 60, 0.05, 0},
                                      {"dwell", 210, 150, 0, 0}};
  const Mechanism m = bundled("valve_cam_shm");
  const Trajectory t = sweep(m);
  const double w = m.drivers[0].law.speed;
  auto at = [&](int k) { return closed_form(program, t.swept(k)); };
  std::printf("[ valve_cam_shm ]\n");
  expect_channel(t, "s.valve", [&](int k) { return 0.035 + at(k).s; });
  expect_channel(t, "sdot.valve", [&](int k) { return w * at(k).ds; });
  double peak = 0.0, apart = 0.0;
  for (int k = 0; k < t.samples(); ++k) {
    const double degrees = std::remainder(t.swept(k) / kDeg, 360.0);
    if (std::abs(degrees) < 1e-9 || std::abs(degrees - 120) < 1e-9 ||
        std::abs(degrees - 150) < 1e-9 || std::abs(degrees + 150) < 1e-9)
      continue;  // a segment's end: either one-sided value
    peak = std::max(peak, std::abs(w * w * at(k).dds));
    apart = std::max(apart, std::abs(value(t, "sddot.valve", k) - w * w * at(k).dds));
  }
  EXPECT_LE(apart, 1e-9 * peak);
  ASSERT_EQ(m.references.size(), 4u);
  // The maxima: pi h w / (2 beta) and pi^2 h w^2 / (2 beta^2) rising (beta = 120 deg), twice
  // and four times those falling (beta = 60 deg), the fall's of the other sign.
  const double beta = 120 * kDeg, rise = kPi * 0.05 * w / (2 * beta);
  const double lift = kPi * kPi * 0.05 * w * w / (2 * beta * beta);
  const std::vector<double> exact = {rise, -2 * rise, lift, -4 * lift};
  for (size_t i = 0; i < m.references.size(); ++i) {
    const Reference& ref = m.references[i];
    const double solved = value(solve_at(m, ref.driver_value), ref.quantity, 0);
    // The closed form at the row's angle (the accelerations just inside a stroke's start).
    const Expected x = closed_form(program, ref.driver_value);
    const double closed = ref.quantity == "sdot.valve" ? w * x.ds : w * w * x.dds;
    EXPECT_NEAR(solved, closed, 1e-9 * std::abs(closed)) << ref.quantity;
    EXPECT_NEAR(closed, exact[i], 1e-6 * std::abs(exact[i])) << ref.quantity;
    EXPECT_EQ(ref.within_rounding(solved), i != 1) << ref.quantity << " " << solved;
    std::printf("  %-12s at %7.2f deg: exact %10.4f, printed %s (%+.3f %%)%s\n",
                ref.quantity.c_str(), ref.driver_value / kDeg, solved, ref.printed.c_str(),
                100 * (ref.value - solved) / solved,
                ref.within_rounding(solved) ? ", within rounding" : "");
  }
  // The falling velocity's print: twice the rising one's rounded to 0.01 m/s.
  EXPECT_NEAR(m.references[1].value, -2 * std::round(rise * 100) / 100, 1e-12);
}

// The spring-held flat face (spring_cam_jump.toml): along +y the cam pushes the follower with
// N = m w^2 s'' + k (0.01 + s), and a force-closed contact cannot pull. The follower leaves where
// N < 0: those samples, and only those, are flagged contact_lost with an event naming the cam;
// elsewhere the contact force is N. The jump speed, the least w at which N reaches zero, is
// min sqrt(k (0.01 + s) / (m |s''|)) over the decelerating stretches, found here on the closed
// form; at its angle the follower stays on at 0.999 of it and leaves at 1.001. A grooved cam
// (closure = "form") holds the follower both ways: nothing is flagged and N changes side.
TEST(CamJoints, SpringHeldFollowerLeavesTheCamPastItsJumpSpeed) {
  const double mass = 0.08, k = 200.0;
  auto push = [&](double theta, double w) {
    const Expected x = closed_form(kFlatFaced, theta);
    return mass * w * w * x.dds + k * (0.01 + x.s);
  };
  // The jump: on the return (cam angle 180 to 270 deg, s'' < 0 over its first half), the least
  // speed that makes N zero, by a grid and golden-section refinement.
  auto speed_at = [&](double theta) {
    const Expected x = closed_form(kFlatFaced, theta);
    return std::sqrt(k * (0.01 + x.s) / (mass * -x.dds));
  };
  double lo = 180.5 * kDeg, hi = 224.5 * kDeg, best = lo;
  for (double theta = lo; theta < hi; theta += 0.01 * kDeg)
    if (speed_at(theta) < speed_at(best)) best = theta;
  lo = best - 0.01 * kDeg;
  hi = best + 0.01 * kDeg;
  for (int i = 0; i < 100; ++i) {
    const double a = hi - 0.618 * (hi - lo), b = lo + 0.618 * (hi - lo);
    (speed_at(a) < speed_at(b) ? hi : lo) = speed_at(a) < speed_at(b) ? b : a;
  }
  const double at = (lo + hi) / 2, jump = speed_at(at);
  std::printf("  jump speed %.6f rad/s (%.4f rpm) at cam angle %.4f deg\n", jump, jump * 30 / kPi,
              at / kDeg);

  const Mechanism m = bundled("spring_cam_jump");
  const double w = m.drivers[0].law.speed;
  ASSERT_GT(w, jump);
  const Trajectory t = sweep(m);
  int lost = 0;
  double peak = 0.0, apart = 0.0;
  for (int s = 0; s < t.samples(); ++s) {
    const double n = push(t.swept(s), w);
    const PoseStatus status = t.status[static_cast<size_t>(s)];
    EXPECT_EQ(status, n < 0.0 ? PoseStatus::contact_lost : PoseStatus::ok) << t.swept(s) / kDeg;
    if (status == PoseStatus::contact_lost) {
      ++lost;
      // Nothing of the sample exists: written null, empty or as a gap.
      EXPECT_FALSE(value_exists(status, Quantity::position));
      EXPECT_FALSE(value_exists(status, Quantity::force));
      continue;
    }
    peak = std::max(peak, std::abs(n));
    apart = std::max(apart, std::abs(value(t, "fy.contact", s) - n));
  }
  EXPECT_GT(lost, 0);
  EXPECT_LE(apart, 1e-9 * peak);
  const auto event = std::find_if(t.events.begin(), t.events.end(),
                                  [](const auto& e) { return e.kind == PoseStatus::contact_lost; });
  ASSERT_NE(event, t.events.end());
  EXPECT_NE(event->message.find("the follower leaves cam 'contact'"), std::string::npos)
      << event->message;
  std::printf("  at %.0f rpm: %d of %d samples contact_lost; N within %.1e of its peak elsewhere\n",
              w * 30 / kPi, lost, t.samples(), apart / peak);

  // crosslink's own: the least root of N = A + C w + B w^2 over the sweep's poses, refined.
  const JumpSpeed located = jump_speed(m, m.find_joint("contact"));
  ASSERT_TRUE(located.speed.has_value()) << located.reason;
  EXPECT_NEAR(*located.speed, jump, 1e-9 * jump);
  // The cycloid's rise mirrors its return: s and |s''| at 270 - theta on the rise are those at
  // theta on the return, so the jump comes at both at once; either is the place.
  const double mirror = 3 * kPi / 2 - at;
  EXPECT_LT(std::min(std::abs(located.at - at), std::abs(located.at - mirror)), 1e-6);
  std::printf("  located: %.9f rad/s at %.6f deg (closed form %.9f at %.6f and %.6f)\n",
              *located.speed, located.at / kDeg, jump, at / kDeg, mirror / kDeg);
  // The design summary's jump_speed_contact is the same; read off a method's samples (one
  // speed) it has no value.
  const std::vector<DerivedValue> summary = derived_exact(m, t);
  EXPECT_NEAR(*derived_value(summary, "jump_speed_contact.speed"), jump, 1e-9 * jump);
  const double summary_at = *derived_value(summary, "jump_speed_contact.at");
  EXPECT_LT(std::min(std::abs(summary_at - at), std::abs(summary_at - mirror)), 1e-6);
  EXPECT_FALSE(derived_value(derived_sampled(m, t), "jump_speed_contact.speed").has_value());
  // In the CSV, the pressure angle of a sample the follower leaves has no value: an empty field
  // exactly where the status is contact_lost, a number elsewhere.
  const test::CommandRun csv =
      test::crosslink("solve mechanisms/cams/spring_cam_jump.toml --format csv");
  ASSERT_EQ(csv.exit_code, 0) << csv.err;
  std::istringstream lines(csv.out);
  std::string line;
  std::getline(lines, line);
  const auto fields = [](const std::string& row) {
    std::vector<std::string> out(1);
    for (const char c : row) {
      if (c == ',')
        out.emplace_back();
      else
        out.back().push_back(c);
    }
    return out;
  };
  const std::vector<std::string> header = fields(line);
  const auto column = std::find(header.begin(), header.end(), "phi.contact");
  ASSERT_NE(column, header.end()) << line;
  int empty = 0, rows = 0;
  while (std::getline(lines, line)) {
    const std::vector<std::string> f = fields(line);
    const bool left = f[3] == "contact_lost";
    EXPECT_EQ(f[static_cast<size_t>(column - header.begin())].empty(), left) << line;
    empty += left;
    ++rows;
  }
  EXPECT_EQ(empty, lost);
  EXPECT_EQ(rows, t.samples());
  const test::CommandRun check = test::crosslink("check mechanisms/cams/spring_cam_jump.toml");
  EXPECT_NE(check.out.find("jump speed of cam contact: 37.0593 rad/s (353.89 rpm) at driver = "),
            std::string::npos)
      << check.out;

  Mechanism near = m;
  near.drivers[0].law.speed = 0.999 * jump;
  EXPECT_EQ(solve_at(near, at).status[0], PoseStatus::ok);
  near.drivers[0].law.speed = 1.001 * jump;
  EXPECT_EQ(solve_at(near, at).status[0], PoseStatus::contact_lost);

  const Trajectory grooved =
      sweep(test::changed("mechanisms/cams/spring_cam_jump.toml",
                          {{"name = \"contact\"", "name = \"contact\"\nclosure = \"form\""}}));
  double least = 0.0, most = 0.0;
  for (int s = 0; s < grooved.samples(); ++s) {
    ASSERT_EQ(grooved.status[static_cast<size_t>(s)], PoseStatus::ok);
    least = std::min(least, value(grooved, "fy.contact", s));
    most = std::max(most, value(grooved, "fy.contact", s));
  }
  EXPECT_LT(least, 0.0);
  EXPECT_GT(most, 0.0);
  const Mechanism form =
      test::changed("mechanisms/cams/spring_cam_jump.toml",
                    {{"name = \"contact\"", "name = \"contact\"\nclosure = \"form\""}});
  EXPECT_NE(jump_speed(form, form.find_joint("contact")).reason.find("cannot jump"),
            std::string::npos);
  EXPECT_TRUE(std::none_of(form.derived.begin(), form.derived.end(), [](const DerivedSpec& d) {
    return d.kind == DerivedSpec::Kind::jump_speed;
  }));
}

// Each fault of a cam joint is refused at its key, with what is wrong.
TEST(CamJoints, EachFaultIsLocatedAtItsKey) {
  struct Case {
    std::string file, from, to, key, says;
  };
  const std::string roller = "mechanisms/cams/translating_roller_345.toml",
                    flat = "mechanisms/cams/cycloidal_flat_faced.toml",
                    swinging = "mechanisms/cams/oscillating_roller.toml",
                    tangent = "mechanisms/cams/tangent_cam_roller.toml",
                    jumping = "mechanisms/cams/spring_cam_jump.toml",
                    eccentric = "mechanisms/cams/eccentric_flat_faced.toml";
  const std::string derived_jump = "[[derived]]\nname = \"jump\"\nquantity = \"jump_speed\"\n";
  const std::string last_rise = "{ law = \"polynomial_4567\", span = 100, to = 0 }";
  const std::vector<Case> cases = {
      {roller, "roller_radius = 0.01", "roller_radius = 0", "roller_radius",
       "the roller's radius must be positive"},
      // 20 mm in 20 degrees: the pitch curve turns tighter than the roller.
      {roller, "span = 100, to = 0.02 },\n  { law = \"dwell\", span = 80 }",
       "span = 20, to = 0.02 },\n  { law = \"dwell\", span = 160 }", "roller_radius",
       "the profile undercuts"},
      {roller, "offset = 0.01", "offset = 0.06", "offset = 0.06",
       "offset must be less than the prime circle's radius"},
      {roller, last_rise, "{ law = \"polynomial_4567\", span = 100, to = 0.001 }",
       "{ law = \"polynomial_4567\"", "segment 3: the rise does not close"},
      {roller, "law = \"polynomial_345\"", "law = \"parabolic\"", "law = \"parabolic\"",
       "unknown law 'parabolic'"},
      {roller, "law = \"polynomial_345\", span = 100", "law = \"polynomial_345\", span = 90",
       "motion = [", "make 350 deg, not a turn"},
      {roller, "point = \"C\"\n\n[joint", "point = \"C\"\nface = \"axis\"\n\n[joint",
       "face = \"axis\"", "gives both 'point' and 'face'"},
      {roller, "offset = 0.01", "offset = 0.01\npivot = [0.1, 0]",
       "pivot =", "is an oscillating follower's"},
      {roller, "offset = 0.01", "offset = 0.01\nlift = 1", "lift", "unknown key 'lift'"},
      {roller, "follower = \"translating\"", "follower = \"rotating\"", "follower = \"rotating\"",
       "must be \"translating\" or \"oscillating\""},
      {roller, "follower = \"follower\"", "follower = \"cam\"", "follower = \"cam\"",
       "the cam and its follower are the same link"},
      {flat, "base_radius = 0.05", "base_radius = 0.02", "base_radius", "has a cusp"},
      {flat, "face = { through = \"F\", angle = 0 }", "face = { through = \"F\", angle = 180 }",
       "face = \"face\"", "must point away from the cam"},
      {flat, "base_radius = 0.05", "base_radius = 0.05\nroller_radius = 0.01", "roller_radius",
       "gives 'roller_radius' for a flat face"},
      {flat, "follower = \"translating\"",
       "follower = \"oscillating\"\npivot = [0.1, 0]\narm = 0.08", "face = \"face\"",
       "an oscillating flat-faced follower is not supported"},
      {tangent, "shape = \"tangent\"", "shape = \"heart\"", "shape",
       "unknown shape 'heart' (valid shapes: tangent, eccentric, points)"},
      {tangent, "ascent = 75", "ascent = 95", "ascent = 95", "must lie between 0 and 90 deg"},
      {tangent, "ascent = 75", "ascent = 40", "ascent = 40", "leaves no nose"},
      {tangent, "ascent = 75", "nose_radius = 35", "nose_radius", "less than the base circle's"},
      {tangent, "ascent = 75", "ascent = 75\nnose_radius = 20", "nose_radius",
       "needs one of 'ascent' (the angle of ascent) or 'nose_radius'"},
      {tangent, "lift = 17.5", "lift = 0", "lift = 0", "must be positive"},
      {tangent, "lift = 17.5", "lift = 17.5\noffset = 1", "offset", "unknown key 'offset'"},
      {eccentric, "radius = 0.04", "radius = 0.01", "radius = 0.01",
       "the disc's radius 0.01 must exceed its eccentricity 0.01"},
      {eccentric, "eccentricity = 0.01", "eccentricity = 0.01\nlift = 1", "lift",
       "unknown key 'lift'"},
      // Points: a radius that is not positive, angles that do not rise, a concave flat face.
      {eccentric, "shape = \"eccentric\"\nradius = 0.04\neccentricity = 0.01\nlobe_angle = -90",
       "shape = \"points\"\npoints = [[0, 0.04], [120, -0.01], [240, 0.04]]", "points = [[0",
       "the profile's radius is not positive"},
      {eccentric, "shape = \"eccentric\"\nradius = 0.04\neccentricity = 0.01\nlobe_angle = -90",
       "shape = \"points\"\npoints = [\n  [0, 0.04],\n  [120, 0.04],\n  [100, 0.04],\n]",
       "[100, 0.04]", "point 3: its angle must exceed the one before"},
      {eccentric, "shape = \"eccentric\"\nradius = 0.04\neccentricity = 0.01\nlobe_angle = -90",
       "shape = \"points\"\npoints = [[0, 0.04], [90, 0.02], [180, 0.04], [270, 0.02]]",
       "points = [[0", "a flat face bridges a concave stretch"},
      {eccentric, "shape = \"eccentric\"", "shape = \"heart\"", "shape = \"heart\"",
       "unknown shape 'heart' (valid shapes: tangent, eccentric, points)"},
      {roller, "closure = \"form\"", "closure = \"glue\"", "closure",
       "'closure' of joint #3 (cam) must be \"force\""},
      {swinging, "arm = 0.08", "arm = 0.01", "arm = 0.01", "cannot reach the prime circle"},
      {swinging, "arm = 0.08", "arm = 0.08\noffset = 0.01", "offset",
       "is a translating follower's"},
      // [[derived]] jump_speed: a cam joint's, force-closed, over the whole cycle.
      {jumping, "[driver]", derived_jump + "cam = \"follower\"\n\n[driver]", "cam = \"follower\"",
       "'follower' is no cam joint (force-closed cams: contact)"},
      {roller, "[driver]", derived_jump + "cam = \"contact\"\n\n[driver]", "cam = \"contact\"",
       "cam 'contact' is form-closed"},
      {jumping, "[driver]", derived_jump + "cam = \"contact\"\nrange = [0, 90]\n\n[driver]",
       "range = [0, 90]", "takes no 'range'"},
      {jumping, "[driver]",
       "[[derived]]\nname = \"bend\"\nquantity = \"least_radius\"\ncam = \"spring\"\n\n[driver]",
       "cam = \"spring\"", "'spring' is no cam joint (cams: contact)"},
      {jumping, "[driver]", derived_jump + "channel = \"s.follower\"\n\n[driver]",
       "channel = \"s.follower\"", "takes no 'channel'"},
  };
  for (const Case& c : cases) {
    const std::string text = test::replaced(test::source_text(c.file), c.from, c.to);
    const std::string error = test::error_of(text, "cam.toml");
    EXPECT_NE(error.find(c.says), std::string::npos) << c.to << "\n" << error;
    EXPECT_NE(error.find("cam.toml:" + std::to_string(test::line_of(text, c.key)) + ":"),
              std::string::npos)
        << c.to << " at '" << c.key << "'\n"
        << error;
  }
}

// `check` counts a cam as a half joint (Kutzbach's j2) and describes it; the dyads have no
// closed form for it and say so; MuJoCo, which meshes a profile that is not a disc but holds no
// groove round one, refuses the grooved oscillating roller with the reason, before any run
// (tests/sim/test_engine_cams.cpp).
TEST(CamJoints, CheckCountsItsMobilityAndTheEnginesRefuseIt) {
  const test::CommandRun check =
      test::crosslink("check mechanisms/cams/translating_roller_345.toml");
  EXPECT_EQ(check.exit_code, 0) << check.err;
  const std::string out = test::flattened(check.out);
  for (const char* says :
       {"M = 3(n-1) - 2 j1 - j2 = 3(3-1) - 2*2 - 1 = 1", "no closed form for cam 'contact'",
        "cam translating roller follower on cam about O (base circle 0.04 m, "
        "roller 0.01 m; least radius of curvature"})
    EXPECT_NE(out.find(says), std::string::npos) << says << "\n" << check.out;
  const test::CommandRun mujoco =
      test::crosslink("compare mechanisms/cams/oscillating_roller.toml --engines mujoco");
  EXPECT_NE(mujoco.out.find("joint 'contact': a groove round a profile that is not a disc holds "
                            "the follower both ways"),
            std::string::npos)
      << mujoco.out << mujoco.err;
}

}  // namespace
}  // namespace crosslink
