// Planar parallel manipulators (issue 20, items 4 and 6): the bundled 3-RRR
// (mechanisms/drivers/three_rrr_rose.toml, three_rrr_turning.toml; dimensions from
// nopour/3RRR-mechanism, RIGID/Inv2.m), its drivers' tables from the inverse kinematics
// (scripts/reference/three_rrr.py), against independent expected values:
//   - on the rose path, the platform's pose (centre P and angle) equals the commanded path, the
//     path's own formula, to 1e-9 of peak at every sample, and each driver's value equals the
//     inverse kinematics computed here;
//   - on the turning path, the direct singularity where the three distal links' lines meet is
//     flagged, located in time, classified direct, and every sample after it is the commanded
//     pose or flagged;
//   - a five-bar's crank and coupler in line is an inverse singularity naming the crank's driver,
//     at the time the circles' intersection gives (one crank held; the bundled two-crank one).
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"

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
  // It is classified direct (the distal lines meeting leave the platform a freedom with the
  // drivers held), naming no driver: no leg is at a toggle there.
  int crossings = 0;
  for (const Trajectory::Event& e : t.events) {
    EXPECT_EQ(e.kind, PoseStatus::singular) << e.message;
    EXPECT_NEAR(e.driver, at, 1e-8) << e.message;
    EXPECT_EQ(e.singularity, ParallelSingularity::direct) << e.message;
    EXPECT_TRUE(e.chain.empty()) << e.message;
    EXPECT_NE(e.message.find("platform"), std::string::npos) << e.message;
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

// A five-bar (mechanisms/drivers/fivebar_two_cranks.toml's dimensions) with its left crank
// turning at 60 rpm and its right one held at 180 deg: C runs on the circle of 45 mm about the
// right crank's tip D = (35, 0) mm, and where the left crank A-B and its coupler B-C fall in line
// the left driver's chain is at a toggle (an inverse singularity: C at 70 mm or 30 mm from A, the
// limit of the left leg's reach) while the drivers still determine C (no direct singularity: the
// couplers are never in line, |B - D| stays within 15..55 mm, inside 5..95).
constexpr const char* kHeldFiveBar = R"toml(
name = "Five-bar, one crank held"
[units]
length = "mm"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { A = [0, 0], E = [50, 0] }
[[link]]
name = "crank2"
points = { A = [0, 0], B = [20, 0] }
pose = [0, 0, 0]
[[link]]
name = "crank5"
points = { E = [0, 0], D = [15, 0] }
pose = [50, 0, 180]
[[link]]
name = "coupler3"
points = { B = [0, 0], C = [50, 0] }
pose = [20, 0, 62.18]
[[link]]
name = "coupler4"
points = { D = [0, 0], C = [45, 0] }
pose = [35, 0, 79.33]
[[joint]]
type = "revolute"
links = ["ground", "crank2"]
point = "A"
[[joint]]
type = "revolute"
links = ["ground", "crank5"]
point = "E"
[[joint]]
type = "revolute"
links = ["crank2", "coupler3"]
point = "B"
[[joint]]
type = "revolute"
links = ["crank5", "coupler4"]
point = "D"
[[joint]]
type = "revolute"
links = ["coupler3", "coupler4"]
point = "C"
[[driver]]
name = "left"
type = "joint_angle"
joint = "A"
to = "B"
start = 0
speed = 60
speed_unit = "rpm"
[[driver]]
name = "right"
type = "joint_angle"
joint = "E"
to = "D"
start = 180
speed = 0
)toml";

// The five-bar's legs' toggle functions at crank angles (left, right) from the closed form: C the
// intersection of the circles of 50 mm about B and 45 mm about D on the drawn side (left of
// B -> D), and (B - A) x (C - B), (D - E) x (C - D), each zero where its crank and coupler are in
// line.
std::pair<double, double> leg_crosses(double left, double right) {
  const Eigen::Vector2d b = 20.0 * Eigen::Vector2d(std::cos(left), std::sin(left));
  const Eigen::Vector2d e(50.0, 0.0);
  const Eigen::Vector2d d = e + 15.0 * Eigen::Vector2d(std::cos(right), std::sin(right));
  const Eigen::Vector2d bd = d - b;
  const double l = bd.norm(), along = (50.0 * 50.0 - 45.0 * 45.0 + l * l) / (2.0 * l);
  const double h = std::sqrt(50.0 * 50.0 - along * along);
  const Eigen::Vector2d u = bd / l, side(-u.y(), u.x());
  const Eigen::Vector2d c = b + along * u + h * side;
  const auto cross = [](const Eigen::Vector2d& p, const Eigen::Vector2d& q) {
    return p.x() * q.y() - p.y() * q.x();
  };
  return {cross(b, c - b), cross(d - e, c - d)};
}
double left_leg_cross(double theta) {
  return leg_crosses(theta, kPi).first;
}

// Where f changes sign over [0, 1] (scanned in 1e-4, each bracket bisected to 1e-15).
template <class F>
std::vector<double> sign_changes(const F& f) {
  std::vector<double> out;
  const int scan = 10000;
  for (int k = 0; k < scan; ++k) {
    double lo = static_cast<double>(k) / scan, hi = static_cast<double>(k + 1) / scan;
    if (f(lo) * f(hi) > 0) continue;
    while (hi - lo > 1e-15) {
      const double mid = 0.5 * (lo + hi);
      (f(mid) * f(lo) > 0 ? lo : hi) = mid;
    }
    out.push_back(0.5 * (lo + hi));
  }
  return out;
}

TEST(FiveBar, ACranksChainInLineIsAnInverseSingularityNamingItsDriver) {
  // The toggles over one turn of the left crank (t = theta / 2 pi at 60 rpm), by bisection on
  // the closed form: at theta = acos(4100 / 4900) (A, B, C stretched in line, 33.2 deg) and at
  // -acos(-100 / 2100) + 2 pi (folded, 267.3 deg); the other two roots of the in-line
  // conditions lie on the other assembly.
  const std::vector<double> want =
      sign_changes([](double t) { return left_leg_cross(2 * kPi * t); });
  ASSERT_EQ(want.size(), 2u);
  EXPECT_NEAR(want[0] * 2 * kPi, std::acos(4100.0 / 4900.0), 1e-12);
  EXPECT_NEAR(want[1] * 2 * kPi, 2 * kPi - std::acos(-100.0 / 2100.0), 1e-12);

  const Mechanism m = parse_mechanism(kHeldFiveBar, "held_fivebar.toml");
  const Trajectory t = sweep(m);
  ASSERT_EQ(t.samples(), 361);
  std::vector<double> got;
  for (const Trajectory::Event& e : t.events) {
    EXPECT_EQ(e.singularity, ParallelSingularity::inverse) << e.message;
    EXPECT_EQ(e.chain, "left") << e.message;
    EXPECT_NE(e.message.find("crank2, coupler3"), std::string::npos) << e.message;
    got.push_back(e.driver);
  }
  ASSERT_EQ(got.size(), want.size());
  // Located as the direct singularity is: to the bisection's 1e-13 s on a smooth determinant.
  for (size_t i = 0; i < want.size(); ++i) EXPECT_NEAR(got[i], want[i], 1e-9) << i;
  // J stays regular through an inverse singularity: every sample keeps its rates.
  for (const PoseStatus s : t.status) EXPECT_EQ(s, PoseStatus::ok);
}

// The bundled two-crank five-bar (mechanisms/drivers/fivebar_two_cranks.toml: left crank at
// 60 rpm, right at 180 - 180 t - 90 t^2 deg) passes three toggles of its legs over its 1 s
// cycle, by the closed form: the left chain's at 0.1225 and 0.6315 s, the right's at 0.3174 s.
// Each is an inverse singularity naming its driver, at the closed form's time.
TEST(FiveBar, TheBundledTwoCrankFiveBarsLegsPassThreeToggles) {
  const auto angles = [](double t) {
    return std::pair<double, double>(2 * kPi * t, (180.0 - 180.0 * t - 90.0 * t * t) * kPi / 180);
  };
  const std::vector<double> left = sign_changes([&](double t) {
    const auto [a, b] = angles(t);
    return leg_crosses(a, b).first;
  });
  const std::vector<double> right = sign_changes([&](double t) {
    const auto [a, b] = angles(t);
    return leg_crosses(a, b).second;
  });
  ASSERT_EQ(left.size(), 2u);
  ASSERT_EQ(right.size(), 1u);
  const std::vector<std::pair<double, std::string>> want = {
      {left[0], "left"}, {right[0], "right"}, {left[1], "left"}};
  ASSERT_TRUE(left[0] < right[0] && right[0] < left[1]);

  const Trajectory t = sweep(load_mechanism(file("fivebar_two_cranks.toml")));
  std::vector<std::pair<double, std::string>> got;
  for (const Trajectory::Event& e : t.events) {
    EXPECT_EQ(e.singularity, ParallelSingularity::inverse) << e.message;
    got.emplace_back(e.driver, e.chain);
  }
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_NEAR(got[i].first, want[i].first, 1e-9) << i;
    EXPECT_EQ(got[i].second, want[i].second) << i;
  }
}

}  // namespace
}  // namespace crosslink
