// Planar parallel manipulators (issue 20, items 4 and 6): the bundled 3-RRR
// (mechanisms/drivers/three_rrr_rose.toml, three_rrr_turning.toml; dimensions from
// nopour/3RRR-mechanism, RIGID/Inv2.m), its drivers' tables from the inverse kinematics
// (scripts/reference/three_rrr.py), against independent expected values:
//   - on the rose path, the platform's pose (centre P and angle) equals the commanded path, the
//     path's own formula, to 1e-9 of peak at every sample, and each driver's value equals the
//     inverse kinematics computed here;
//   - on the turning path, the direct singularity where the three distal links' lines meet is
//     flagged, located in time, and every sample after it is the commanded pose or flagged.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>

#include "analytic/loader.h"
#include "analytic/sweep.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;
const double kRoot3 = std::sqrt(3.0);

// Inv2.m's manipulator (m): base triangle of side 0.9, platform triangle of side 0.08, legs of
// two 0.4 m links.
constexpr double kBase = 0.90, kPlatform = 0.08, kLink = 0.40;
const std::array<Eigen::Vector2d, 3> kPivots = {Eigen::Vector2d(-kBase / 2, -kRoot3* kBase / 6),
                                                Eigen::Vector2d(kBase / 2, -kRoot3* kBase / 6),
                                                Eigen::Vector2d(0, kRoot3* kBase / 3)};
const std::array<Eigen::Vector2d, 3> kCorners = {
    Eigen::Vector2d(-kPlatform / 2, -kRoot3* kPlatform / 6),
    Eigen::Vector2d(kPlatform / 2, -kRoot3* kPlatform / 6),
    Eigen::Vector2d(0, kRoot3* kPlatform / 3)};

// The platform's pose: centre and angle.
struct Pose {
  Eigen::Vector2d p;
  double phi;
};

// Inv2.m's three-petal rose: r0 = 0.1 m about (0, 0.25), constant orientation.
Pose rose(double t) {
  const double r = 0.1 * std::sin(12 * kPi * t);
  return {{r * std::cos(4 * kPi * t), 0.25 + r * std::sin(4 * kPi * t)}, 0.0};
}

// Leg i's elbow B_i and the proximal link's angle in working mode +++ (B_i to the left of
// A_i -> C_i): the isosceles triangle A_i B_i C_i of sides l, l, |C_i - A_i|.
struct Leg {
  Eigen::Vector2d b, c;
  double theta;
};
Leg leg(const Pose& pose, int i) {
  const Eigen::Rotation2Dd r(pose.phi);
  const Eigen::Vector2d c = pose.p + r * kCorners[static_cast<size_t>(i)];
  const Eigen::Vector2d d = c - kPivots[static_cast<size_t>(i)];
  const double theta = std::atan2(d.y(), d.x()) + std::acos(d.norm() / (2 * kLink));
  return {
      kPivots[static_cast<size_t>(i)] + kLink * Eigen::Vector2d(std::cos(theta), std::sin(theta)),
      c, theta};
}

std::string file(const std::string& name) {
  return std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/drivers/" + name;
}

// The angle a - b reduced to (-pi, pi].
double angle_between(double a, double b) {
  return std::remainder(a - b, 2 * kPi);
}

TEST(ThreeRrr, ThePlatformFollowsTheRoseAndTheDriversAreTheInverseKinematics) {
  const Mechanism m = load_mechanism(file("three_rrr_rose.toml"));
  ASSERT_EQ(m.drivers.size(), 3u);
  const Trajectory t = sweep(m);
  ASSERT_EQ(t.samples(), 361);
  EXPECT_DOUBLE_EQ(t.time(360), 0.25);
  EXPECT_TRUE(t.events.empty());
  const Eigen::VectorXd x = *t.channel("x.P"), y = *t.channel("y.P"),
                        phi = *t.channel("angle.platform");
  // Peaks of the commanded path: |x| <= 0.1, |y| <= 0.35 m; the angle stays 0, so its error
  // is against the 1e-9 rad a turn's pi would allow.
  const double x_peak = 0.1, y_peak = 0.35, angle_peak = kPi;
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << "t = " << t.time(k);
    const Pose want = rose(t.time(k));
    EXPECT_NEAR(x(k), want.p.x(), 1e-9 * x_peak) << "t = " << t.time(k);
    EXPECT_NEAR(y(k), want.p.y(), 1e-9 * y_peak) << "t = " << t.time(k);
    EXPECT_NEAR(angle_between(phi(k), want.phi), 0.0, 1e-9 * angle_peak) << "t = " << t.time(k);
    for (int i = 0; i < 3; ++i) {
      const std::string name = "theta" + std::to_string(i + 1);
      const double got = (*t.channel("angle." + name))(k);
      EXPECT_NEAR(angle_between(got, leg(want, i).theta), 0.0, 1e-9 * kPi)
          << name << " at t = " << t.time(k);
    }
  }
}

// The turning path: P held at (0, 0.25) m, phi = t. Its direct singularity, where the direct
// Jacobian's rows [u_i^T, (C_i - P) x u_i] (u_i = C_i - B_i along each distal link) are
// dependent: the three distal lines meet in one point. det as a function of the commanded
// pose, its zero by bisection in t (the sources found 2.383692193572 s this way).
Pose turning(double t) {
  return {{0.0, 0.25}, t};
}
double direct_det(double t) {
  const Pose pose = turning(t);
  Eigen::Matrix3d a;
  for (int i = 0; i < 3; ++i) {
    const Leg l = leg(pose, i);
    const Eigen::Vector2d u = l.c - l.b, r = l.c - pose.p;
    a.row(i) << u.x(), u.y(), r.x() * u.y() - r.y() * u.x();
  }
  return a.determinant();
}

TEST(ThreeRrr, TheTurningPlatformsDirectSingularityIsLocatedNeverJumpedPast) {
  double lo = 2.3, hi = 2.5;
  ASSERT_LT(direct_det(lo) * direct_det(hi), 0.0);
  while (hi - lo > 1e-14) {
    const double mid = 0.5 * (lo + hi);
    (direct_det(mid) * direct_det(lo) > 0 ? lo : hi) = mid;
  }
  const double at = 0.5 * (lo + hi);
  ASSERT_NEAR(at, 2.383692193572, 1e-12);  // the sources' value (rrr3.py)

  const Mechanism m = load_mechanism(file("three_rrr_turning.toml"));
  const Trajectory t = sweep(m);
  ASSERT_EQ(t.samples(), 361);
  EXPECT_DOUBLE_EQ(t.time(360), 3.0);
  // One event: the crossing, located in time. The drivers' values determine the pose near a
  // direct singularity only to the square root of their error: a table offset by 1e-8 deg
  // moves the located time by 2.3e-6 s (so the pose's departure from the path grows as
  // 33 rad/s^2 (t - t*)^2 in the drivers), and the tables' own rounding, 3e-16 rad, allows
  // sqrt(3e-16 / 33) = 3e-9 s. Measured: 4.2e-9 s (a guess interpolated by the chord of the
  // step's poses instead of the cubic through their rates placed it 3.3e-8 s off).
  int crossings = 0;
  for (const Trajectory::Event& e : t.events) {
    EXPECT_EQ(e.kind, PoseStatus::singular) << e.message;
    EXPECT_NEAR(e.driver, at, 1e-8) << e.message;
    ++crossings;
  }
  EXPECT_EQ(crossings, 1);
  // Every sample is the commanded pose in working mode +++ (each elbow B_i left of A_i -> C_i),
  // or flagged: never another assembly.
  const auto col = [&](const std::string& p) {
    return static_cast<int>(std::find(t.point_names.begin(), t.point_names.end(), p) -
                            t.point_names.begin());
  };
  const Eigen::VectorXd phi = *t.channel("angle.platform");
  const double size = 0.3, turn = 3.0;  // peaks: the corners' reach, the platform's angle
  int usable = 0;
  for (int k = 0; k < t.samples(); ++k) {
    if (!has_position(t.status[static_cast<size_t>(k)])) continue;
    ++usable;
    const Pose want = turning(t.time(k));
    EXPECT_NEAR(t.x(k, col("P")), want.p.x(), 1e-9 * size) << "t = " << t.time(k);
    EXPECT_NEAR(t.y(k, col("P")), want.p.y(), 1e-9 * size) << "t = " << t.time(k);
    EXPECT_NEAR(angle_between(phi(k), want.phi), 0.0, 1e-9 * turn) << "t = " << t.time(k);
    for (int i = 0; i < 3; ++i) {
      const std::string n = std::to_string(i + 1);
      const Eigen::Vector2d a = kPivots[static_cast<size_t>(i)],
                            b(t.x(k, col("B" + n)), t.y(k, col("B" + n))),
                            c(t.x(k, col("C" + n)), t.y(k, col("C" + n)));
      const Eigen::Vector2d ac = c - a, ab = b - a;
      EXPECT_GT(ac.x() * ab.y() - ac.y() * ab.x(), 0.0) << "leg " << n << " at t = " << t.time(k);
    }
  }
  EXPECT_EQ(usable, t.samples());
}

}  // namespace
}  // namespace crosslink
