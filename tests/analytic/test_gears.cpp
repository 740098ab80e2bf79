// Gear pairs and racks (JointType::gear, rack_pinion) in the exact methods, against closed forms
// that do not use crosslink's constraint rows:
//   - an epicyclic train with its ring fixed against Willis' formula, positions to
//     accelerations, and its instantaneous centres at the pitch points;
//   - a slider-crank driving a pinion through a rack against the slider-crank's closed-form travel
//     rolled onto the pinion's pitch circle;
//   - a geared five-bar with equal gears, whose coupler point runs on its mirror line;
//   - published trains: a handout's epicyclic train and Ryan's rack and pinion against their
//     printed speeds, and Constans and Dyer's geared five-bar against an independent solution;
//   - the closed-form dyads through a rack and pinion (the pinion turned by a placed rack, the
//     rack moved by a placed pinion; both bundled racks and a rack on a turning, accelerating
//     guide) against Newton on the same file and the files' closed forms;
//   - the mesh force along the line of action: tilted from the pitch line's tangent by the
//     pressure angle, pushing the teeth apart (Newton-Euler on every link, with the mesh force at
//     the pitch point, is test_kinetostatics' ReactionsBalanceEveryLink over mechanisms/gears);
//   - wrong definitions, each located at its key.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

#include "analytic/kinematics/dyads.h"
#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/model/planar.h"
#include "analytic/physics/kinetostatics.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/sweep.h"
#include "tests/common/diagnostics.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

const double kPi = std::numbers::pi;

std::string gear_file(const std::string& name) {
  return std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/" + name;
}

int column(const std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  EXPECT_NE(it, names.end()) << name;
  return static_cast<int>(it - names.begin());
}

// The angle a - b folded into (-pi, pi].
double angle_between(double a, double b) {
  return std::remainder(a - b, 2.0 * kPi);
}

// A bundled train's sweep: each has one freedom and assembles over its driver's whole turn.
Trajectory swept(const Mechanism& m) {
  EXPECT_EQ(mobility(m).mobility, 1);
  Trajectory t = sweep(m);
  EXPECT_GT(t.samples(), 300);
  return t;
}

// z_sun 24, z_planet 12, z_ring 48, ring fixed, arm at 60 rpm (the file's description).
TEST(Gears, AnEpicyclicTrainFollowsWillisFormula) {
  const Mechanism m = load_mechanism(gear_file("planetary_fixed_ring.toml"));
  const Mobility mob = mobility(m);
  EXPECT_EQ(mob.mobility, 1);
  EXPECT_EQ(mob.half_joints, 2);  // each mesh takes one freedom
  const Trajectory t = sweep(m);
  ASSERT_GT(t.samples(), 300);
  const int arm = column(t.link_names, "arm"), sun = column(t.link_names, "sun"),
            planet = column(t.link_names, "planet");
  const double w = 2.0 * kPi;  // 60 rpm
  // Willis: (w_sun - w_arm) / (w_ring - w_arm) = -z_ring / z_sun with w_ring = 0, and
  // (w_planet - w_arm) / (w_ring - w_arm) = z_ring / z_planet (an internal mesh turns alike).
  const double sun_ratio = 1.0 + 48.0 / 24.0, planet_ratio = 1.0 - 48.0 / 12.0;
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_TRUE(usable(t.status[static_cast<size_t>(k)])) << k;
    const double arm_angle = t.angle(k, arm);
    EXPECT_NEAR(t.omega(k, arm), w, 1e-12 * w);
    EXPECT_NEAR(t.omega(k, sun), sun_ratio * w, 1e-9 * w) << k;
    EXPECT_NEAR(t.omega(k, planet), planet_ratio * w, 1e-9 * w) << k;
    EXPECT_NEAR(t.alpha(k, sun), 0.0, 1e-9 * w * w) << k;
    EXPECT_NEAR(t.alpha(k, planet), 0.0, 1e-9 * w * w) << k;
    // Drawn meshing at 0 (every pose at angle 0): the angles keep the ratios.
    EXPECT_NEAR(angle_between(t.angle(k, sun), sun_ratio * arm_angle), 0.0, 1e-9) << k;
    EXPECT_NEAR(angle_between(t.angle(k, planet), planet_ratio * arm_angle), 0.0, 1e-9) << k;
  }
}

// The printed answers of a published train are within their rounding of the exact values read
// off the sweep at the reference's driver value (a grid sample).
void expect_references_within_rounding(const Mechanism& m, const Trajectory& t) {
  ASSERT_FALSE(m.references.empty());
  for (const Reference& ref : m.references) {
    int row = -1;
    for (int k = 0; k < t.samples(); ++k)
      if (std::abs(t.along(k) - ref.driver_value) < 1e-12) row = k;
    ASSERT_GE(row, 0) << ref.quantity;
    const double exact = (*t.channel(ref.quantity))(row);
    EXPECT_TRUE(ref.within_rounding(exact))
        << ref.quantity << ": printed " << ref.printed << ", exact " << exact;
  }
}

// The handout's problem (the file's citation): ring 72 fixed, sun 32, planet 20, arm at 18 rpm.
// Willis with w_ring = 0: w_sun = w_arm (1 + 72/32), w_planet = w_arm (1 - 72/20); printed
// 58.5 rpm anticlockwise and 46.8 rpm clockwise.
TEST(Gears, TheHandoutsEpicyclicTrainGivesItsPrintedSpeeds) {
  const Mechanism m = load_mechanism(gear_file("epicyclic_ring72_sun32.toml"));
  const Trajectory t = swept(m);
  const int sun = column(t.link_names, "sun"), planet = column(t.link_names, "planet");
  const double w = 18.0 * 2.0 * kPi / 60.0;
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_TRUE(usable(t.status[static_cast<size_t>(k)])) << k;
    EXPECT_NEAR(t.omega(k, sun), w * (1.0 + 72.0 / 32.0), 1e-9 * w) << k;
    EXPECT_NEAR(t.omega(k, planet), w * (1.0 - 72.0 / 20.0), 1e-9 * w) << k;
  }
  expect_references_within_rounding(m, t);
}

// Ryan's answer (the file's citation): 13 teeth at 80 rpm on a 4 mm pitch rack travel 52 mm a
// turn, 4160 mm a minute: the rack's rate is the pinion's rate times its pitch radius 13 x 4 /
// (2 pi) mm, its travel the angle turned times that radius.
void expect_ryans_travel(const Trajectory& t) {
  const int slide = column(t.slider_names, "rack_slide");
  const double radius = 13.0 * 0.004 / (2.0 * kPi), w = 80.0 * 2.0 * kPi / 60.0;
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_TRUE(usable(t.status[static_cast<size_t>(k)])) << k;
    EXPECT_NEAR(t.s(k, slide), radius * t.along(k), 1e-12) << k;
    EXPECT_NEAR(t.sdot(k, slide), radius * w, 1e-9 * radius * w) << k;  // 4160 mm a minute
    EXPECT_NEAR(t.sddot(k, slide), 0.0, 1e-9 * radius * w * w) << k;
  }
}
TEST(Gears, RyansRackTravelsFortyOneSixtyMillimetresAMinute) {
  const Mechanism m = load_mechanism(gear_file("ryan_rack_and_pinion.toml"));
  const Trajectory t = swept(m);
  expect_ryans_travel(t);
  expect_references_within_rounding(m, t);
}

// Rolling pitch circles have no relative velocity where they touch: the pitch point is the gears'
// relative instantaneous centre, and the centres give every link's velocity.
TEST(Gears, ThePitchPointsAreInstantCentres) {
  const Mechanism m = load_mechanism(gear_file("planetary_fixed_ring.toml"));
  const Trajectory t = sweep(m);
  const int row = 37;
  const InstantCentres ic = instant_centres(m, t, row);
  const double arm_angle = t.angle(row, column(t.link_names, "arm"));
  const Eigen::Vector2d along(std::cos(arm_angle), std::sin(arm_angle));
  const int sun = m.find_link("sun"), planet = m.find_link("planet"), ground = m.ground();
  // Sun-planet: 24 mm out along the arm; planet-ring: 24 + 2 x 12 = 48 mm out.
  EXPECT_LT((ic.at(sun, planet).position() - 0.024 * along).norm(), 1e-12);
  EXPECT_LT((ic.at(ground, planet).position() - 0.048 * along).norm(), 1e-12);
  const CentreVelocities v = centre_velocities(m, ic, t, row);
  ASSERT_TRUE(v.complete) << v.message;
  for (int k = 0; k < static_cast<int>(t.link_names.size()); ++k)
    EXPECT_NEAR(v.omega[static_cast<size_t>(k)], t.omega(row, k), 1e-9 * 2.0 * kPi)
        << t.link_names[static_cast<size_t>(k)];
}

// s(theta) = r cos theta + sqrt(l^2 - r^2 sin^2 theta), r = 40 mm, l = 120 mm; the pinion turns
// by (s - 160 mm) / 30 mm, its centre on the rack line's left.
void expect_pinion_turned_by_travel(const Trajectory& t) {
  const int pinion = column(t.link_names, "pinion");
  const double r = 0.040, l = 0.120, radius = 0.030, w = 4.0 * kPi;  // 120 rpm
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_TRUE(usable(t.status[static_cast<size_t>(k)])) << k;
    const double th = t.along(k), s = std::sin(th), c = std::cos(th);
    const double g = std::sqrt(l * l - r * r * s * s);
    const double g1 = -r * r * s * c / g;                          // dg/dtheta
    const double g2 = -r * r * (c * c - s * s) / g - g1 * g1 / g;  // d2g/dtheta2
    const double travel = r * c + g, rate = (-r * s + g1) * w, accel = (-r * c + g2) * w * w;
    EXPECT_NEAR(angle_between(t.angle(k, pinion), (travel - 0.160) / radius), 0.0, 1e-9) << k;
    EXPECT_NEAR(t.omega(k, pinion), rate / radius, 1e-9 * (r * w / radius)) << k;
    EXPECT_NEAR(t.alpha(k, pinion), accel / radius, 1e-9 * (r * w * w / radius)) << k;
  }
}
TEST(Gears, ARackTurnsItsPinionByTheTravelOverThePitchRadius) {
  expect_pinion_turned_by_travel(swept(load_mechanism(gear_file("rack_pinion_slider_crank.toml"))));
}

// The closed-form dyads through a rack and pinion (a pinion turned by a placed rack's travel, a
// rack moved along its guide by a placed pinion) against Newton on the same file: every
// position, velocity and acceleration channel of every link, point and slide to 1e-9 of the
// largest peak of its kind over the sweep (angles to 1e-9 rad), at every sample, and against the
// file's closed form above. Returns the largest relative difference.
double expect_dyads_agree_with_newton(const Mechanism& m, const std::string& name) {
  const Decomposition d = decompose(m);
  EXPECT_TRUE(d.complete) << name << ": " << d.reason;
  if (!d.complete) return 1.0;
  const Trajectory newton = swept(m);
  const Trajectory dyads = dyad_sweep(m, newton);
  EXPECT_EQ(dyads.method, "dyads");
  EXPECT_EQ(dyads.samples(), newton.samples());
  const auto kind = [](const std::string& channel) {
    const bool angular = channel.rfind("omega.", 0) == 0 || channel.rfind("alpha.", 0) == 0;
    return std::string(to_string(Trajectory::quantity_of(channel))) + (angular ? "/angular" : "");
  };
  std::map<std::string, double> peak;
  for (const std::string& channel : newton.channel_names())
    peak[kind(channel)] =
        std::max(peak[kind(channel)], newton.channel(channel)->cwiseAbs().maxCoeff());
  double omega = 0.0;  // the driver's largest rate [rad/s]
  for (int k = 0; k < newton.samples(); ++k)
    omega = std::max(omega, std::abs(m.drivers[0].at_time(newton.time(k)).rate));
  double worst = 0.0;
  std::string worst_channel;
  for (int k = 0; k < newton.samples(); ++k) {
    EXPECT_TRUE(usable(newton.status[static_cast<size_t>(k)])) << name << " " << k;
    EXPECT_EQ(dyads.status[static_cast<size_t>(k)], PoseStatus::ok) << name << " " << k;
  }
  for (const std::string& channel : newton.channel_names()) {
    const Quantity q = Trajectory::quantity_of(channel);
    if (q == Quantity::force || q == Quantity::torque) continue;
    // A kind that is zero by design (Ryan's angular accelerations, at a constant speed) is
    // measured against the chain's own rate of it: the driver's rate omega and the size L give
    // omega, omega^2, omega L, omega^2 L.
    const double rate = q == Quantity::velocity ? omega : omega * omega;
    const double own = kind(channel).ends_with("/angular") ? rate : rate * m.size();
    const double scale = q == Quantity::angle      ? 1.0  // rad
                         : q == Quantity::position ? peak[kind(channel)]
                                                   : std::max(peak[kind(channel)], own);
    const Eigen::VectorXd a = *newton.channel(channel), b = *dyads.channel(channel);
    for (int k = 0; k < newton.samples(); ++k) {
      const double error = std::abs(a(k) - b(k)) / scale;
      if (error > worst) worst = error, worst_channel = channel;
      EXPECT_LE(error, 1e-9) << name << " " << channel << " at driver " << newton.along(k)
                             << ": newton " << a(k) << ", dyads " << b(k);
    }
  }
  std::printf("[ dyads - newton ] %s: %d samples, largest difference %.2e of its peak (%s)\n",
              name.c_str(), newton.samples(), worst, worst_channel.c_str());
  return worst;
}

TEST(Gears, TheDyadsTurnThePinionByTheRacksTravel) {
  const Mechanism m = load_mechanism(gear_file("rack_pinion_slider_crank.toml"));
  EXPECT_LE(expect_dyads_agree_with_newton(m, "rack_pinion_slider_crank"), 1e-9);
  expect_pinion_turned_by_travel(dyad_sweep(m));
}

TEST(Gears, TheDyadsMoveRyansRackByThePinionsTurn) {
  const Mechanism m = load_mechanism(gear_file("ryan_rack_and_pinion.toml"));
  EXPECT_LE(expect_dyads_agree_with_newton(m, "ryan_rack_and_pinion"), 1e-9);
  const Trajectory t = dyad_sweep(m);
  expect_ryans_travel(t);
  expect_references_within_rounding(m, t);
}

// A rack's guide that turns: an arm driven about O from 60 rpm, accelerating at 20 rad/s^2,
// carries the rack's line and the pinion's centre D, 15 mm off the line (pitch radius 15 mm), so
// the travel's rates have the guide's turning terms. `holder` is what else holds the chain (a rod
// and its joints), `poses` the pinion's and the rack's drawn poses. Newton solves the same file.
Mechanism rack_on_a_turning_arm(const std::string& poses, const std::string& holder) {
  return parse_mechanism(R"(name = "rack on a turning arm"
[units]
length = "mm"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { O = [0, 0], F = [30, 0], G = [10, 0] }
[[link]]
name = "arm"
points = { O = [0, 0], D = [40, 15], P = [100, 0] }
lines = { guide = { through = "O", angle = 0 } }
[[joint]]
type = "revolute"
links = ["ground", "arm"]
point = "O"
[[joint]]
type = "revolute"
links = ["arm", "pinion"]
point = "D"
[[joint]]
type = "prismatic"
name = "rack_slide"
guide = "arm"
line = "guide"
slider = "rack"
point = "C"
[[joint]]
type = "rack_pinion"
name = "mesh"
pinion = "pinion"
rack = "rack_slide"
radius = 15
[driver]
type = "joint_angle"
joint = "O"
to = "P"
start = 0
speed = 60
speed_unit = "rpm"
acceleration = 20
)" + poses + holder,
                         "turning_arm.toml");
}

TEST(Gears, TheDyadsFollowARackOnATurningGuide) {
  // A rod from F to the rack (60 mm; F inside its circle, so the arm turns fully): the RRP
  // dyad places the rod and the rack, whose travel turns the pinion.
  const Mechanism by_rack = rack_on_a_turning_arm(R"(
[[link]]
name = "pinion"
points = { D = [0, 0], E = [15, 0] }
pose = [40, 15, 0]
[[link]]
name = "rack"
points = { C = [0, 0], R = [-40, 0] }
pose = [90, 0, 0]
[[link]]
name = "rod"
points = { C = [0, 0], F = [-60, 0] }
pose = [90, 0, 0]
)",
                                                  R"(
[[joint]]
type = "revolute"
links = ["rack", "rod"]
point = "C"
[[joint]]
type = "revolute"
links = ["rod", "ground"]
point = "F"
)");
  const Decomposition placed_by_rack = decompose(by_rack);
  ASSERT_TRUE(placed_by_rack.complete) << placed_by_rack.reason;
  EXPECT_EQ(placed_by_rack.groups.back().link[0], by_rack.find_link("pinion"));
  EXPECT_LE(expect_dyads_agree_with_newton(by_rack, "pinion turned by the rack"), 1e-9);

  // A rod from G to the pinion's point E (45 mm): the RRR dyad places the rod and the pinion,
  // whose turn moves the rack along the turning arm.
  const Mechanism by_pinion = rack_on_a_turning_arm(R"(
[[link]]
name = "pinion"
points = { D = [0, 0], E = [15, 0] }
pose = [40, 15, -21.3]
[[link]]
name = "rack"
points = { C = [0, 0], R = [-40, 0] }
pose = [70, 0, 0]
[[link]]
name = "rod"
points = { G = [0, 0], E = [45, 0] }
pose = [10, 0, 12.25]
)",
                                                    R"(
[[joint]]
type = "revolute"
links = ["pinion", "rod"]
point = "E"
[[joint]]
type = "revolute"
links = ["rod", "ground"]
point = "G"
)");
  const Decomposition placed_by_pinion = decompose(by_pinion);
  ASSERT_TRUE(placed_by_pinion.complete) << placed_by_pinion.reason;
  EXPECT_EQ(placed_by_pinion.groups.back().link[0], by_pinion.find_link("rack"));
  EXPECT_LE(expect_dyads_agree_with_newton(by_pinion, "rack moved by the pinion"), 1e-9);
}

// Equal external gears turn the cranks mirror-wise (theta_5 = 180 deg - theta_2), so the chain is
// symmetric about x = 25 mm and C, where the couplers meet, runs on that line:
// C_y = 20 sin t + sqrt(60^2 - (25 - 20 cos t)^2) mm.
TEST(Gears, AGearedFiveBarWithEqualGearsMovesCOnItsMirrorLine) {
  const Mechanism m = load_mechanism(gear_file("geared_fivebar.toml"));
  const Trajectory t = swept(m);
  const int c = column(t.point_names, "C"), crank5 = column(t.link_names, "crank5");
  const double w = 2.0 * kPi;  // 60 rpm
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_TRUE(usable(t.status[static_cast<size_t>(k)])) << k;
    const double th = t.along(k), s = std::sin(th), co = std::cos(th);
    const double gap = 0.025 - 0.020 * co, root = std::sqrt(0.060 * 0.060 - gap * gap);
    const double y = 0.020 * s + root;
    const double dy = 0.020 * co - gap * 0.020 * s / root;  // dC_y / d theta
    EXPECT_NEAR(angle_between(t.angle(k, crank5), kPi - th), 0.0, 1e-9) << k;
    EXPECT_NEAR(t.x(k, c), 0.025, 1e-12) << k;
    EXPECT_NEAR(t.y(k, c), y, 1e-12) << k;
    EXPECT_NEAR(t.vx(k, c), 0.0, 1e-9 * 0.080 * w) << k;
    EXPECT_NEAR(t.vy(k, c), dy * w, 1e-9 * 0.080 * w) << k;
  }
}

// Constans and Dyer's geared five-bar (the file's citation) against an independent solution:
// scripts/reference/geared_fivebar_constans_dyer.py (the circle intersection of B's and C's
// circles, 2 x 2 solves for the rates and accelerations, checked there against central
// differences and against the book's reader's code's angles to 9e-16 rad). Each value to 1e-9 of
// its class's peak over the turn. With the links massless and 100 N downwards at P, the driver
// torque and the tangential mesh force (gear 1 on gear 2, along +y at the pitch point (120, 0)
// mm) by virtual work, as printed by the script.
TEST(Gears, ConstansAndDyersGearedFiveBarMatchesTheIndependentSolution) {
  Mechanism m = load_mechanism(gear_file("constans_dyer_geared_fivebar.toml"));
  m.gravity = Eigen::Vector2d::Zero();
  for (Link& l : m.links) l.mass = MassProperties{0.0, Eigen::Vector2d::Zero(), 0.0, false};
  const int coupler1 = m.find_link("coupler1");
  Load load;
  load.name = "at_P";
  load.link = coupler1;
  load.point = "P";
  for (const Point& p : m.links[static_cast<size_t>(coupler1)].points)
    if (p.name == "P") load.local = p.local;
  load.rows = {Eigen::Vector3d(0.0, 0.0, -100.0)};
  m.loads.push_back(load);
  const Trajectory t = sweep(m);
  ASSERT_EQ(t.samples(), 361);
  struct Expected {
    double degrees, ex, ey, px, py, w3, w4, a3, a4, vx, vy, ax, ay;
  };
  const Expected rows[] = {{0, 0.210000000000, 0.233238075794, 0.123840172607, 0.199963129287,
                            -20.000000000000, -20.000000000000, -77.174363314129, 77.174363314129,
                            3.999262585745, 1.123196547860, 1.895958146251, -80.281614590859},
                           {60, 0.306546317660, 0.062511537397, 0.256673061068, 0.140250820891,
                            -1.927928591288, -5.764379101020, 252.531050299355, 85.680054137171,
                            -0.969193133402, 0.220828382431, -15.904906331084, 39.138722819897},
                           {210, 0.090857906322, 0.096717515474, -0.000376105439, 0.111108242327,
                            5.879744665460, -8.756962994373, 120.984012232783, 13.649935938409,
                            -0.406072775038, -0.430400898723, -13.888819346787, 12.612073588321}};
  const int e = column(t.point_names, "E"), p = column(t.point_names, "P");
  const int c1 = column(t.link_names, "coupler1"), c2 = column(t.link_names, "coupler2");
  const auto peak = [](const Eigen::VectorXd& v) { return v.cwiseAbs().maxCoeff(); };
  const double length = 0.370, rate = peak(t.omega.col(c1)) + peak(t.omega.col(c2)),
               accel = peak(t.alpha.col(c1)) + peak(t.alpha.col(c2)),
               speed = peak(t.vx.col(p)) + peak(t.vy.col(p)),
               acceleration = peak(t.ax.col(p)) + peak(t.ay.col(p));
  for (const Expected& r : rows) {
    const int k = static_cast<int>(r.degrees);  // the 1 degree grid
    ASSERT_NEAR(t.along(k), r.degrees * kPi / 180.0, 1e-12);
    EXPECT_NEAR(t.x(k, e), r.ex, 1e-9 * length) << r.degrees;
    EXPECT_NEAR(t.y(k, e), r.ey, 1e-9 * length) << r.degrees;
    EXPECT_NEAR(t.x(k, p), r.px, 1e-9 * length) << r.degrees;
    EXPECT_NEAR(t.y(k, p), r.py, 1e-9 * length) << r.degrees;
    EXPECT_NEAR(t.omega(k, c1), r.w3, 1e-9 * rate) << r.degrees;
    EXPECT_NEAR(t.omega(k, c2), r.w4, 1e-9 * rate) << r.degrees;
    EXPECT_NEAR(t.alpha(k, c1), r.a3, 1e-9 * accel) << r.degrees;
    EXPECT_NEAR(t.alpha(k, c2), r.a4, 1e-9 * accel) << r.degrees;
    EXPECT_NEAR(t.vx(k, p), r.vx, 1e-9 * speed) << r.degrees;
    EXPECT_NEAR(t.vy(k, p), r.vy, 1e-9 * speed) << r.degrees;
    EXPECT_NEAR(t.ax(k, p), r.ax, 1e-9 * acceleration) << r.degrees;
    EXPECT_NEAR(t.ay(k, p), r.ay, 1e-9 * acceleration) << r.degrees;
  }
  // Massless: torque.driver [N m] and the mesh force's y component [N] (its x component is the
  // teeth's separating force, |f_t| tan 20 deg).
  const Eigen::VectorXd torque = *t.channel("torque.driver"), fx = *t.channel("fx.mesh"),
                        fy = *t.channel("fy.mesh");
  const double torque_peak = peak(torque), force_peak = peak(fy);
  for (const auto& [degrees, tau, tangential] :
       std::vector<std::tuple<int, double, double>>{{0, 11.231965478603, -4.266858452204},
                                                    {30, -12.317451441113, -140.285602740999},
                                                    {300, 16.708841175486, 178.480686258099}}) {
    EXPECT_NEAR(torque(degrees), tau, 1e-9 * torque_peak) << degrees;
    EXPECT_NEAR(fy(degrees), tangential, 1e-9 * force_peak) << degrees;
    EXPECT_NEAR(std::abs(fx(degrees)), std::abs(tangential) * std::tan(20.0 * kPi / 180.0),
                1e-9 * force_peak)
        << degrees;
  }
}

// The teeth push along the line of action: the mesh force makes the pressure angle with the
// pitch line (a rack's line, the gears' common tangent), and its normal part pushes the teeth
// apart (the rack away from the pinion's centre; each gear away from the other).
TEST(Gears, TheMeshForceActsAlongTheLineOfAction) {
  for (const char* name : {"rack_pinion_slider_crank.toml", "planetary_fixed_ring.toml"}) {
    Mechanism m = load_mechanism(gear_file(name));
    m.gravity = Eigen::Vector2d(0.0, -9.81);
    const NewtonSolver solver(m);
    const Kinetostatics kinetostatics(solver);
    ForceSample forces = kinetostatics.make_sample();
    const Trajectory t = sweep(m);
    KinematicState state(m);
    int checked = 0;
    for (int k = 0; k < t.samples(); k += 7) {
      state.q = coordinates_at(m, t, k);
      state.swept() = m.drivers[0].at_time(t.time(k));
      ASSERT_EQ(solver.solve(state).status, PoseStatus::ok);
      kinetostatics.solve(state, forces);
      for (size_t ji = 0; ji < m.joints.size(); ++ji) {
        const Joint& j = m.joints[ji];
        if (!j.is_gearing()) continue;
        const Eigen::Vector2d f = forces.joint_force[ji];  // of the first gear on the second
        const BodyMotion carrier =
            BodyMotion::of(m.moving_index(j.carrier), state.q, nullptr, nullptr);
        const Eigen::Vector2d pitch = carrier.position(pitch_point(m, j));
        const Eigen::Vector2d centre =
            carrier.position(m.links[j.carrier].points[static_cast<size_t>(j.centre_a)].local);
        // Along the first gear's radius through the pitch point, and across it.
        const Eigen::Vector2d radial = (pitch - centre).normalized();
        const double across = f.dot(perp(radial)), out = f.dot(radial);
        if (std::abs(across) < 1e-6 * f.norm() + 1e-12) continue;
        EXPECT_NEAR(std::abs(out), std::abs(across) * std::tan(20.0 * kPi / 180.0), 1e-9 * f.norm())
            << name << " " << j.name;
        // The second gear (or the rack) is pushed away from the first's centre, except where
        // the first is the ring of an internal pair, which pushes its pinion inward.
        const bool first_is_ring =
            j.ratio < 0.0 && j.type == JointType::gear && j.radius_a > j.radius_b;
        EXPECT_GT(first_is_ring ? -out : out, 0.0) << name << " " << j.name;
        ++checked;
      }
    }
    EXPECT_GT(checked, 20) << name;
  }
}

// Each fault of a gear pair or rack is reported at its key.
std::string error_of(const std::string& text) {
  return test::error_of(text, "gear.toml");
}

// Two gears on ground pivots 50 mm apart (pitch radii 20 and 30 mm), the first driven; `gear`
// is the gear pair's table.
std::string two_gears(const std::string& gear) {
  return R"(name = "two gears"
[units]
length = "mm"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { A = [0, 0], B = [50, 0] }
lines = { l = { through = "A", angle = 0 } }
[[link]]
name = "g1"
points = { A = [0, 0], P = [20, 0] }
[[link]]
name = "g2"
points = { B = [0, 0], Q = [30, 0] }
pose = [50, 0, 0]
[[joint]]
type = "revolute"
links = ["ground", "g1"]
point = "A"
[[joint]]
type = "revolute"
links = ["ground", "g2"]
point = "B"
)" + gear +
         R"(
[driver]
type = "joint_angle"
joint = "A"
to = "P"
start = 0
speed = 1
)";
}

using test::line_of;

TEST(Gears, TwoGearsOnTheGroundTurnInverselyAsTheirRadii) {
  const Mechanism m = parse_mechanism(
      two_gears("[[joint]]\ntype = \"gear\"\ngears = [\"g1\", \"g2\"]\nteeth = [20, 30]\n"),
      "gear.toml");
  EXPECT_EQ(mobility(m).mobility, 1);
  const Joint& mesh = m.joints.back();
  EXPECT_EQ(mesh.name, "g1/g2");
  EXPECT_DOUBLE_EQ(mesh.radius_a, 0.020);
  EXPECT_DOUBLE_EQ(mesh.radius_b, 0.030);
  const Trajectory t = sweep(m);
  for (int k = 0; k < t.samples(); ++k) EXPECT_NEAR(t.omega(k, 1), -20.0 / 30.0, 1e-12) << k;
}

TEST(Gears, EachFaultIsLocatedAtItsKey) {
  struct Case {
    std::string table, key, says;
  };
  const std::vector<Case> cases = {
      {"[[joint]]\ntype = \"gear\"\ngears = [\"g1\", \"g3\"]\nteeth = [20, 30]\n", "\"g3\"",
       "unknown link 'g3'"},
      {"[[joint]]\ntype = \"gear\"\ngears = [\"g1\", \"g2\"]\nteeth = [20, 30]\nradii = [20, "
       "30]\n",
       "teeth", "exactly one of 'teeth'"},
      {"[[joint]]\ntype = \"gear\"\ngears = [\"g1\", \"g2\"]\nradii = [20, 25]\n", "radii",
       "are 50 mm apart"},
      {"[[joint]]\ntype = \"gear\"\ngears = [\"g1\", \"g2\"]\nteeth = [20, 30.5]\n", "teeth",
       "two whole numbers"},
      {"[[joint]]\ntype = \"gear\"\ngears = [\"g1\", \"g2\"]\ncarrier = \"g1\"\nteeth = [20, "
       "30]\n",
       "gears =", "three different links"},
      {"[[joint]]\ntype = \"gear\"\ngears = [\"g1\", \"g2\"]\nteeth = [20, 30]\nmesh = "
       "\"sideways\"\n",
       "mesh", "\"external\" or \"internal\""},
      {"[[joint]]\ntype = \"gear\"\ngears = [\"g1\", \"g2\"]\nteeth = [20, 30]\nratio = 2\n",
       "ratio", "unknown key 'ratio'"},
      {"[[joint]]\ntype = \"rack_pinion\"\npinion = \"g1\"\nrack = \"B\"\nradius = 20\n",
       "rack =", "'B' is not prismatic"},
      // No mesh: two free gears, one driver.
      {"", "[driver]", "mobility 2 with 1 driver"},
  };
  for (const Case& c : cases) {
    const std::string text = two_gears(c.table);
    const std::string error = error_of(text);
    EXPECT_NE(error.find(c.says), std::string::npos) << error;
    const std::string where = "gear.toml:" + std::to_string(line_of(text, c.key)) + ":";
    EXPECT_EQ(error.rfind(where, 0), 0u) << where << " in " << error;
  }
}

// A rack whose prismatic is refused (its line misnamed) is said once, at the prismatic: the
// rack and pinion is not read on (it read the guide's line -1, found by fuzzing:
// tests/fuzz/regressions/ryan_rack_slide_line_unknown.toml).
TEST(Gears, ARackOnARefusedSlideIsNotReadOn) {
  std::string text = test::source_text("mechanisms/gears/ryan_rack_and_pinion.toml");
  const size_t at = text.find("lines = { guide");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 15, "lines = { gUide");
  const std::vector<Diagnostic> found = test::diagnostics_of(text, "gear.toml");
  ASSERT_EQ(found.size(), 1u) << error_of(text);
  EXPECT_NE(found[0].message.find("line 'guide' is not on link 'ground' (its lines: gUide)"),
            std::string::npos)
      << found[0].str();
  EXPECT_EQ(found[0].where.line, line_of(text, "line = \"guide\""));
}

// Issue 35, item 8: a planetary train whose sun mesh is moved onto the ground meshes the planet
// with two fixed gears (24 teeth outside it, the 48-tooth ring round it) that ask opposite turns
// of it for one turn of the arm: the arm, the driven link, cannot move (the sun, on its bearing
// and in no mesh, turns freely). Grübler–Kutzbach counts 3 x 3 - 2 x 3 - 2 = 1 all the same, and
// `check` said ok while `solve` wrote 6,283 samples all at t = 0. Refused at the driver.
TEST(Gears, APlanetaryTrainLockedByItsMeshesIsRefusedAtTheDriver) {
  const std::string base = test::source_text("mechanisms/gears/planetary_fixed_ring.toml");
  ASSERT_NO_THROW(parse_mechanism(base, "planetary.toml"));  // the train as bundled moves
  const std::string locked =
      test::replaced(base, "gears = [\"sun\", \"planet\"]", "gears = [\"ground\", \"planet\"]");
  const std::vector<Diagnostic> d = test::diagnostics_of(locked, "locked.toml");
  ASSERT_EQ(d.size(), 1u);
  EXPECT_EQ(d[0].where.line, test::line_of(locked, "[driver]"));
  EXPECT_EQ(d[0].where.column, 1);
  EXPECT_NE(d[0].message.find("the chain is locked"), std::string::npos) << d[0].str();
  EXPECT_NE(d[0].message.find("counts a mobility of 1"), std::string::npos) << d[0].str();
  // Driving the sun instead, the chain moves: the sun is free, the arm and planet held.
  const std::string sun = test::replaced(locked, "joint = \"arm_bearing\"\nto = \"P\"",
                                         "joint = \"sun_bearing\"\nto = \"S\"");
  EXPECT_NO_THROW(parse_mechanism(sun, "sun.toml"));
}

}  // namespace
}  // namespace crosslink
