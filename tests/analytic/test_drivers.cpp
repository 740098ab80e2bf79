// Several drivers ([[driver]], docs/mechanism-format.md "Several drivers"), against independent
// expected values:
//   - the bundled two-crank five-bar (mechanisms/drivers/fivebar_two_cranks.toml): every point's
//     position, velocity and acceleration, each driver's value, from the intersection of the
//     circles about the two crank tips and its derivatives (the two distance equations
//     differentiated), to 1e-9 of each channel's peak;
//   - both driver torques: the power balance (sum of effort x rate = rate of change of kinetic
//     and potential energy less the load's power, from those kinematics) and an independent
//     Newton-Euler solve of the four links (12 equations: 5 pin forces and 2 torques), to 1e-9
//     of peak;
//   - the closed-form dyads (two input cranks and one RRR dyad) equal Newton there;
//   - a five-bar whose couplers stretch straight along the way: the chain stops there (never a
//     silent change of branch), located at the closed-form time, the later samples flagged;
//   - every fault of a definition with several drivers located at its key.
#include <gtest/gtest.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

#include "analytic/kinematics/dyads.h"
#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/sweep.h"
#include "tests/common/diagnostics.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}
Eigen::Vector2d perp(const Eigen::Vector2d& a) {
  return {-a.y(), a.x()};
}

// A point's motion: position, velocity, acceleration.
struct Motion {
  Eigen::Vector2d p, v, a;
};

// A crank of length l about a fixed pivot at angle theta(t) with its rates.
Motion crank_tip(const Eigen::Vector2d& pivot, double l, double th, double w, double al) {
  const Eigen::Vector2d u(std::cos(th), std::sin(th));
  return {pivot + l * u, l * w * perp(u), l * al * perp(u) - l * w * w * u};
}

// C with |C - B| = l3, |C - D| = l4, on the side where (D - B) x (C - B) > 0, and its rates from
// the two distance equations differentiated once and twice:
//   (C - B).(C' - B') = 0,  (C - D).(C' - D') = 0,
//   (C - B).(C'' - B'') + |C' - B'|^2 = 0,  (C - D).(C'' - D'') + |C' - D'|^2 = 0.
Motion circle_intersection(const Motion& b, double l3, const Motion& d, double l4) {
  const Eigen::Vector2d bd = d.p - b.p;
  const double r = bd.norm();
  const double along = (l3 * l3 - l4 * l4 + r * r) / (2.0 * r);
  const double h = std::sqrt(l3 * l3 - along * along);
  Motion c;
  c.p = b.p + along * bd / r + h * perp(bd) / r;
  Eigen::Matrix2d rows;
  rows.row(0) = (c.p - b.p).transpose();
  rows.row(1) = (c.p - d.p).transpose();
  const Eigen::PartialPivLU<Eigen::Matrix2d> lu(rows);
  c.v = lu.solve(Eigen::Vector2d((c.p - b.p).dot(b.v), (c.p - d.p).dot(d.v)));
  c.a = lu.solve(Eigen::Vector2d((c.p - b.p).dot(b.a) - (c.v - b.v).squaredNorm(),
                                 (c.p - d.p).dot(d.a) - (c.v - d.v).squaredNorm()));
  return c;
}

// The five-bar as its file gives it (mm, deg), in SI: ground pivots A = (0, 0), E = (50, 0);
// cranks AB 20 and ED 15; couplers BC 50 and DC 45. The left crank at 60 rpm from 0, the right
// one from 180 deg by -180 t - 90 t^2 deg.
struct FiveBar {
  Motion a{}, e{}, b, d, c;
  double th2, w2, al2, th5, w5, al5;
  explicit FiveBar(double t) {
    a = {{0, 0}, {0, 0}, {0, 0}};
    e = {{0.05, 0}, {0, 0}, {0, 0}};
    th2 = 2 * kPi * t;
    w2 = 2 * kPi;
    al2 = 0.0;
    th5 = kPi - kPi * t - 0.5 * kPi * t * t;
    w5 = -kPi - kPi * t;
    al5 = -kPi;
    b = crank_tip(a.p, 0.02, th2, w2, al2);
    d = crank_tip(e.p, 0.015, th5, w5, al5);
    c = circle_intersection(b, 0.05, d, 0.045);
  }
  // A link's angle from two of its points (their direction in the link's frame is along x) and
  // its rates: omega = (P - Q) x (P' - Q') / |P - Q|^2, alpha likewise from the accelerations.
  static Eigen::Vector3d angle(const Motion& from, const Motion& to) {
    const Eigen::Vector2d r = to.p - from.p, v = to.v - from.v, a = to.a - from.a;
    const double omega = cross(r, v) / r.squaredNorm();
    return {std::atan2(r.y(), r.x()), omega, cross(r, a) / r.squaredNorm()};
  }
};

std::string file() {
  return std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/drivers/fivebar_two_cranks.toml";
}

// Each column of `got` against `expected` over the usable samples, to 1e-9 of the expected
// peak.
void expect_channel(const Trajectory& t, const std::string& name, const Eigen::VectorXd& expected) {
  const std::optional<Eigen::VectorXd> got = t.channel(name);
  ASSERT_TRUE(got.has_value()) << name;
  const double peak = expected.cwiseAbs().maxCoeff();
  ASSERT_GT(peak, 0.0) << name;
  for (int k = 0; k < t.samples(); ++k)
    EXPECT_NEAR((*got)(k), expected(k), 1e-9 * peak) << name << " at t = " << t.time(k);
}

TEST(FiveBarTwoCranks, EveryPointMovesAsTheCirclesAboutTheCrankTipsMeet) {
  const Mechanism m = load_mechanism(file());
  ASSERT_EQ(m.drivers.size(), 2u);
  const Trajectory t = sweep(m);
  ASSERT_EQ(t.samples(), 361);
  EXPECT_DOUBLE_EQ(t.time(360), 1.0);  // the longest cycle: one turn at 60 rpm, and 1 s
  for (int k = 0; k < t.samples(); ++k)
    ASSERT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << "t = " << t.time(k);
  const int n = t.samples();
  std::map<std::string, Eigen::VectorXd> expected;
  const auto put = [&](const std::string& name, int k, double v) {
    if (!expected.count(name)) expected[name] = Eigen::VectorXd::Zero(n);
    expected[name](k) = v;
  };
  for (int k = 0; k < n; ++k) {
    const FiveBar f(t.time(k));
    for (const auto& [p, motion] :
         {std::pair<std::string, Motion>{"B", f.b}, {"C", f.c}, {"D", f.d}}) {
      put("x." + p, k, motion.p.x());
      put("y." + p, k, motion.p.y());
      put("vx." + p, k, motion.v.x());
      put("vy." + p, k, motion.v.y());
      put("ax." + p, k, motion.a.x());
      put("ay." + p, k, motion.a.y());
    }
    const Eigen::Vector3d coupler3 = FiveBar::angle(f.b, f.c), coupler4 = FiveBar::angle(f.d, f.c);
    put("angle.coupler3", k, coupler3(0));
    put("omega.coupler3", k, coupler3(1));
    put("alpha.coupler3", k, coupler3(2));
    put("angle.coupler4", k, coupler4(0));
    put("omega.coupler4", k, coupler4(1));
    put("alpha.coupler4", k, coupler4(2));
    put("angle.left", k, f.th2);
    put("angle.right", k, f.th5);
    put("omega.crank2", k, f.w2);
    put("omega.crank5", k, f.w5);
    put("alpha.crank5", k, f.al5);
  }
  for (const auto& [name, values] : expected) expect_channel(t, name, values);
}

// The links' centres of mass and the driver torques from the power balance and from
// Newton-Euler, with the kinematics above and the mass model as loaded.
TEST(FiveBarTwoCranks, BothTorquesBalanceThePowerAndEveryLink) {
  const Mechanism m = load_mechanism(file());
  const Trajectory t = sweep(m);
  const std::optional<Eigen::VectorXd> left = t.channel("torque.left"),
                                       right = t.channel("torque.right");
  ASSERT_TRUE(left && right);
  EXPECT_FALSE(t.channel("torque.driver").has_value());  // named per driver
  const Eigen::Vector2d g(0.0, -9.81), push(0.0, -5.0);
  const auto link = [&](const std::string& name) -> const Link& {
    return m.links[static_cast<size_t>(m.find_link(name))];
  };
  // Joint forces of each joint's first link on its second, and the two torques, per sample.
  Eigen::MatrixXd newton_euler(t.samples(), 12);
  Eigen::VectorXd power(t.samples()), expected_power(t.samples());
  for (int k = 0; k < t.samples(); ++k) {
    const FiveBar f(t.time(k));
    // Each moving link: two points (its frame's x axis along them, the first its origin), and
    // its angle's rates.
    struct Body {
      const Link* link;
      Motion origin;
      Eigen::Vector3d angle;
    };
    const Body bodies[4] = {{&link("crank2"), f.a, {f.th2, f.w2, f.al2}},
                            {&link("crank5"), f.e, {f.th5, f.w5, f.al5}},
                            {&link("coupler3"), f.b, FiveBar::angle(f.b, f.c)},
                            {&link("coupler4"), f.d, FiveBar::angle(f.d, f.c)}};
    Motion com[4];
    double kinetic_rate = 0.0, potential_rate = 0.0;
    for (int i = 0; i < 4; ++i) {
      const Body& body = bodies[i];
      const double th = body.angle(0), w = body.angle(1), al = body.angle(2);
      const Eigen::Vector2d r = Eigen::Rotation2Dd(th) * body.link->mass.com;
      com[i] = {body.origin.p + r, body.origin.v + w * perp(r),
                body.origin.a + al * perp(r) - w * w * r};
      const double mass = body.link->mass.mass, inertia = body.link->mass.inertia;
      kinetic_rate += mass * com[i].v.dot(com[i].a) + inertia * w * al;
      potential_rate -= mass * g.dot(com[i].v);
    }
    expected_power(k) = kinetic_rate + potential_rate - push.dot(f.c.v);
    power(k) = (*left)(k)*f.w2 + (*right)(k)*f.w5;

    // Newton-Euler: unknowns F_A (ground on crank2), F_E (ground on crank5), F_B (crank2 on
    // coupler3), F_D (crank5 on coupler4), F_C (coupler3 on coupler4), tau_left, tau_right.
    Eigen::Matrix<double, 12, 12> a = Eigen::Matrix<double, 12, 12>::Zero();
    Eigen::Matrix<double, 12, 1> rhs;
    // Link i's rows 3i (x), 3i + 1 (y), 3i + 2 (moment about its centre of mass).
    const auto force = [&](int i, int column, double sign, const Eigen::Vector2d& at) {
      a(3 * i, column) += sign;
      a(3 * i + 1, column + 1) += sign;
      const Eigen::Vector2d arm = at - com[i].p;
      a(3 * i + 2, column) += -sign * arm.y();
      a(3 * i + 2, column + 1) += sign * arm.x();
    };
    force(0, 0, 1, f.a.p);   // A on crank2
    force(1, 2, 1, f.e.p);   // E on crank5
    force(2, 4, 1, f.b.p);   // B on coupler3
    force(0, 4, -1, f.b.p);  // and its reaction on crank2
    force(3, 6, 1, f.d.p);   // D on coupler4
    force(1, 6, -1, f.d.p);
    force(3, 8, 1, f.c.p);  // C on coupler4
    force(2, 8, -1, f.c.p);
    a(2, 10) = 1.0;  // tau_left on crank2
    a(5, 11) = 1.0;  // tau_right on crank5
    for (int i = 0; i < 4; ++i) {
      const double mass = bodies[i].link->mass.mass, inertia = bodies[i].link->mass.inertia;
      Eigen::Vector2d sum = mass * com[i].a - mass * g;
      double moment = inertia * bodies[i].angle(2);
      if (i == 2) {  // the push at C on coupler3
        sum -= push;
        moment -= cross(f.c.p - com[i].p, push);
      }
      rhs.segment<2>(3 * i) = sum;
      rhs(3 * i + 2) = moment;
    }
    newton_euler.row(k) = Eigen::FullPivLU<Eigen::Matrix<double, 12, 12>>(a).solve(rhs).transpose();
  }
  const double power_peak = expected_power.cwiseAbs().maxCoeff();
  for (int k = 0; k < t.samples(); ++k)
    EXPECT_NEAR(power(k), expected_power(k), 1e-9 * power_peak) << "t = " << t.time(k);
  expect_channel(t, "torque.left", newton_euler.col(10));
  expect_channel(t, "torque.right", newton_euler.col(11));
  const char* joints[5] = {"A", "E", "B", "D", "C"};
  for (int j = 0; j < 5; ++j) {
    expect_channel(t, std::string("fx.") + joints[j], newton_euler.col(2 * j));
    expect_channel(t, std::string("fy.") + joints[j], newton_euler.col(2 * j + 1));
  }
}

// The five-bar with both cranks driven is one RRR dyad once the cranks are placed by their
// drivers (two input links): the closed form over Newton's samples equals Newton to 1e-9 of
// each channel's peak, forces included.
TEST(FiveBarTwoCranks, TheDyadsPlaceItAsOneRrrDyadAndAgreeWithNewton) {
  const Mechanism m = load_mechanism(file());
  const Decomposition groups = decompose(m);
  ASSERT_TRUE(groups.complete) << groups.reason;
  ASSERT_EQ(groups.groups.size(), 3u);
  EXPECT_EQ(groups.groups[0].kind, AssurGroup::Kind::input);
  EXPECT_EQ(groups.groups[1].kind, AssurGroup::Kind::input);
  EXPECT_EQ(groups.groups[2].kind, AssurGroup::Kind::dyad);
  EXPECT_NE(groups.groups[2].name.find("RRR dyad"), std::string::npos) << groups.groups[2].name;
  const Trajectory newton = sweep(m);
  const Trajectory closed = dyad_sweep(m, newton, true);
  ASSERT_EQ(closed.samples(), newton.samples());
  for (int k = 0; k < closed.samples(); ++k)
    ASSERT_EQ(closed.status[static_cast<size_t>(k)], PoseStatus::ok) << "t = " << closed.time(k);
  for (const std::string& name : newton.channel_names()) {
    const Eigen::VectorXd expected = *newton.channel(name);
    const double peak = expected.cwiseAbs().maxCoeff();
    if (peak == 0.0) continue;
    const Eigen::VectorXd got = *closed.channel(name);
    for (int k = 0; k < closed.samples(); ++k)
      EXPECT_NEAR(got(k), expected(k), 1e-9 * peak) << name << " at t = " << closed.time(k);
  }
}

// The five-bar's links with couplers of 30 and 20 mm, the right crank at rest (D at (35, 0)
// mm): |BD|^2 = 1625 - 1400 cos(theta) mm^2 reaches (30 + 20)^2 at cos(theta) = -0.625, where the
// couplers lie straight; beyond, the chain does not close.
std::string stretching_fivebar(const std::string& drivers) {
  return R"(name = "five-bar stretched straight"
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
points = { B = [0, 0], C = [30, 0] }
pose = [20, 0, 36.34]
[[link]]
name = "coupler4"
points = { D = [0, 0], C = [20, 0] }
pose = [35, 0, 62.72]
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
)" + drivers;
}

const std::string kTwoCranks = R"([[driver]]
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
)";

// Minitaur's leg (mechanisms/drivers/minitaur_leg.toml: l1 = 0.1, l2 = 0.2 m from the robot's
// controller library). At t = 0 the toe is at the library's closed-form extension below the hip,
// FKext(m) = sqrt(l2^2 - (l1 sin m)^2) - l1 cos m with m = 60 deg (half the upper links' angle).
// Along the motion (q1 = 150 deg + 3 t, q2 = 30 deg - t) the toe's position, velocity and
// acceleration, and with massless links the motors' torques under the 50 N ground reaction
// (tau = -J^T F), from an independent solution: the circle intersection and its derivatives,
// checked against central differences and the library's FKext and its derivative to 1e-16
// (scripts/reference/minitaur_leg.py, law B), each to 1e-9 of its class's peak.
TEST(MinitaurLeg, TheToeAndTheMotorTorquesAreTheClosedForms) {
  Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/drivers/minitaur_leg.toml");
  for (Link& l : m.links) l.mass = MassProperties{0.0, Eigen::Vector2d::Zero(), 0.0, false};
  const Trajectory t = sweep(m);
  ASSERT_EQ(t.samples(), 361);
  const auto col = [](const std::vector<std::string>& names, const std::string& name) {
    return static_cast<int>(std::find(names.begin(), names.end(), name) - names.begin());
  };
  const int toe = col(t.point_names, "T");
  ASSERT_LT(toe, static_cast<int>(t.point_names.size()));
  const double extension =
      std::sqrt(0.04 - std::pow(0.1 * std::sin(kPi / 3.0), 2)) - 0.1 * std::cos(kPi / 3.0);
  EXPECT_NEAR(t.x(0, toe), 0.0, 1e-15);
  EXPECT_NEAR(t.y(0, toe), -extension, 1e-15);
  const Eigen::VectorXd tau1 = *t.channel("torque.motor1"), tau2 = *t.channel("torque.motor2");
  const auto peak = [](const Eigen::VectorXd& v) { return v.cwiseAbs().maxCoeff(); };
  const double length = 0.3, speed = peak(t.vx.col(toe)) + peak(t.vy.col(toe)),
               accel = peak(t.ax.col(toe)) + peak(t.ay.col(toe)), torque = peak(tau1) + peak(tau2);
  struct Expected {
    int sample;  // t = sample x 0.4 / 360 s
    double x, y, vx, vy, ax, ay, tau1, tau2;
  };
  for (const Expected& e :
       {Expected{90, 0.014406129217, -0.143580767426, 0.159092898729, -0.140197767729,
                 0.324925923416, -0.125632745354, 1.572395481392, -2.292701942264},
        Expected{225, 0.042271810317, -0.165549824781, 0.214342988202, -0.148817702865,
                 0.399298351537, 0.030541616397, 1.331823656840, -3.445414172713},
        Expected{360, 0.078908322576, -0.186635733685, 0.273224663817, -0.125893756300,
                 0.361800886132, 0.286243230055, 0.587317921551, -4.532734050360}}) {
    const int k = e.sample;
    ASSERT_NEAR(t.time(k), k * 0.4 / 360.0, 1e-15);
    EXPECT_NEAR(t.x(k, toe), e.x, 1e-9 * length) << k;
    EXPECT_NEAR(t.y(k, toe), e.y, 1e-9 * length) << k;
    EXPECT_NEAR(t.vx(k, toe), e.vx, 1e-9 * speed) << k;
    EXPECT_NEAR(t.vy(k, toe), e.vy, 1e-9 * speed) << k;
    EXPECT_NEAR(t.ax(k, toe), e.ax, 1e-9 * accel) << k;
    EXPECT_NEAR(t.ay(k, toe), e.ay, 1e-9 * accel) << k;
    EXPECT_NEAR(tau1(k), e.tau1, 1e-9 * torque) << k;
    EXPECT_NEAR(tau2(k), e.tau2, 1e-9 * torque) << k;
  }
}

TEST(SeveralDrivers, TheSweepStopsWhereTheCouplersLieStraightNeverOnAnotherBranch) {
  const Mechanism m = parse_mechanism(stretching_fivebar(kTwoCranks), "stretched.toml");
  const Trajectory t = sweep(m);
  const double at = std::acos(-0.625) / (2 * kPi);  // [s] at 60 rpm
  ASSERT_EQ(t.samples(), 361);
  int usable_samples = 0;
  for (int k = 0; k < t.samples(); ++k) {
    const bool before = t.time(k) < at;
    if (before) {
      EXPECT_TRUE(has_position(t.status[static_cast<size_t>(k)])) << t.time(k);
      ++usable_samples;
    } else {
      EXPECT_FALSE(has_position(t.status[static_cast<size_t>(k)])) << t.time(k);
    }
  }
  EXPECT_EQ(usable_samples, static_cast<int>(std::floor(at * 360)) + 1);
  // The stop, located in time (the follower's steps shrink to 1e-12 of the time there), and
  // said: the chain does not close beyond it.
  bool located = false;
  for (const Trajectory::Event& e : t.events) {
    EXPECT_NE(e.kind, PoseStatus::branch_jump) << e.message;
    if (e.kind == PoseStatus::cannot_assemble) {
      EXPECT_NEAR(e.driver, at, 1e-9) << e.message;
      EXPECT_NE(e.message.find("the chain does not close beyond t = "), std::string::npos);
      located = true;
    }
  }
  EXPECT_TRUE(located);
}

// A definition's fault: its message and where (line and column) it is reported.
void expect_fault(const std::string& text, const std::string& message, int line, int column = 0) {
  bool found = false;
  std::string all;
  for (const Diagnostic& d : test::diagnostics_of(text, "faulty.toml")) {
    all += d.str() + "\n";
    found = found || (d.message.find(message) != std::string::npos && d.where.line == line &&
                      (column == 0 || d.where.column == column));
  }
  EXPECT_TRUE(found) << "expected at line " << line << ": " << message << "\ngot:\n" << all;
}

using test::line_of;

const std::string kThird = R"([[driver]]
name = "third"
type = "joint_angle"
joint = "B"
to = "C"
start = 36
speed = 1
)";

TEST(SeveralDriversFaults, OneDriverTooManyIsReportedAtIt) {
  const std::string text = stretching_fivebar(kTwoCranks + kThird);
  expect_fault(text, "mobility 2 with 3 drivers", line_of(text, "[[driver]]", 3));
  expect_fault(text, "this driver is one too many", line_of(text, "[[driver]]", 3));
}

TEST(SeveralDriversFaults, AFreedomLeftUndrivenIsReportedAtTheFirstDriver) {
  // Without the joint at C the couplers hang free: mobility 4 with 2 drivers.
  std::string text = stretching_fivebar(kTwoCranks);
  const size_t c =
      text.find("[[joint]]\ntype = \"revolute\"\nlinks = [\"coupler3\", \"coupler4\"]");
  ASSERT_NE(c, std::string::npos);
  text.erase(c, text.find("point = \"C\"\n", c) + 12 - c);
  const size_t point = text.find("points = { D = [0, 0], C = [20, 0] }");
  ASSERT_NE(point, std::string::npos);
  text.replace(point, 36, "points = { D = [0, 0], F = [20, 0] }");
  expect_fault(text, "mobility 4 with 2 drivers", line_of(text, "[[driver]]", 1));
  expect_fault(text, "2 freedoms left undriven", line_of(text, "[[driver]]", 1));
}

TEST(SeveralDriversFaults, TwoDriversOnOneJoint) {
  std::string drivers = kTwoCranks;
  drivers.replace(drivers.find("joint = \"E\""), 11, "joint = \"A\"");
  const std::string text = stretching_fivebar(drivers);
  expect_fault(text, "drivers 'left' and 'right' both drive the angle of link 'crank2'",
               line_of(text, "joint = \"A\"", 2), 9);
}

TEST(SeveralDriversFaults, DuplicateNames) {
  std::string drivers = kTwoCranks;
  drivers.replace(drivers.find("name = \"right\""), 14, "name = \"left\"");
  const std::string text = stretching_fivebar(drivers);
  expect_fault(text, "duplicate driver name 'left'", line_of(text, "name = \"left\"", 2), 8);
}

TEST(SeveralDriversFaults, ANameIsNeededAmongSeveral) {
  std::string drivers = kTwoCranks;
  drivers.erase(drivers.find("name = \"right\"\n"), 15);
  const std::string text = stretching_fivebar(drivers);
  expect_fault(text, "[[driver]] needs a 'name' when there are several drivers (2 here)",
               line_of(text, "[[driver]]", 2));
}

TEST(SeveralDriversFaults, ANameThatIsAPointsWouldMakeChannelsAmbiguous) {
  std::string drivers = kTwoCranks;
  drivers.replace(drivers.find("name = \"right\""), 14, "name = \"C\"");
  const std::string text = stretching_fivebar(drivers);
  expect_fault(text, "[[driver]] name 'C' is already a link's, joint's or point's name",
               line_of(text, "name = \"C\""), 8);
}

TEST(SeveralDriversFaults, ADriversFaultNamesIt) {
  std::string drivers = kTwoCranks;
  drivers.replace(drivers.find("speed = 0"), 9, "speed = 0\nspeeed = 1");
  const std::string text = stretching_fivebar(drivers);
  expect_fault(text, "unknown key 'speeed' in [[driver]] 'right'", line_of(text, "speeed"), 1);
}

TEST(SeveralDriversFaults, ARangeAmongSeveral) {
  std::string drivers = kTwoCranks;
  drivers += "range = [170, 190]\n";
  const std::string text = stretching_fivebar(drivers);
  expect_fault(text, "[[driver]] 'right': 'range' sweeps one driver's values",
               line_of(text, "range"), 9);
}

TEST(SeveralDriversFaults, WhatReadsOneDriversSweep) {
  const std::string base = stretching_fivebar(kTwoCranks);
  {
    const std::string text = base + "[[reference]]\nquantity = \"x.C\"\nat = 10\nvalue = 1\n";
    expect_fault(text, "[[reference]] 'at' is a driver value; this definition has 2 drivers",
                 line_of(text, "[[reference]]"));
  }
  {
    const std::string text = base +
                             "[[derived]]\nname = \"Q\"\nquantity = \"extremes\"\n"
                             "channel = \"x.C\"\n";
    expect_fault(text, "[[derived]] quantities are read over one driver's sweep",
                 line_of(text, "[[derived]]"));
  }
  {
    const std::string text = base +
                             "[[load]]\nlink = \"coupler3\"\npoint = \"C\"\n"
                             "force_table = [[0, 1, 0], [360, 1, 0]]\n";
    expect_fault(text, "a load's table is over the driver's value; with 2 drivers",
                 line_of(text, "[[load]]"));
  }
  {
    const std::string text = base + "[expect]\ntoggles = []\n";
    expect_fault(text, "[expect] gives one driver's values; this definition has 2 drivers",
                 line_of(text, "[expect]"));
  }
}

// Two independent bodies: a crank on the ground and a block on a ground line (mobility 2).
const std::string kCrankAndBlock = R"(name = "crank and block"
[units]
length = "mm"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { A = [0, 0], O = [0, 50] }
lines = { rail = { through = "O", angle = 0 } }
[[link]]
name = "crank"
points = { A = [0, 0], B = [20, 0] }
pose = [0, 0, 0]
[[link]]
name = "block"
points = { P = [0, 0] }
pose = [0, 50, 0]
[[joint]]
type = "revolute"
links = ["ground", "crank"]
point = "A"
[[joint]]
type = "prismatic"
name = "slide"
guide = "ground"
line = "rail"
slider = "block"
point = "P"
[[driver]]
name = "turn"
type = "joint_angle"
joint = "A"
to = "B"
start = 0
speed = 60
speed_unit = "rpm"
[[driver]]
name = "push"
type = "slider"
joint = "slide"
start = 0
speed = 10
)";

TEST(SeveralDriversFaults, ASliderAtConstantSpeedNeedsADuration) {
  expect_fault(kCrankAndBlock, "[[driver]] 'push': a slider at constant speed has no turn",
               line_of(kCrankAndBlock, "speed = 10"), 9);
  // With one, both run over the longest cycle: the crank's turn (1 s) against the block's 2 s.
  const Mechanism m = parse_mechanism(kCrankAndBlock + "duration = 2\n", "crank_and_block.toml");
  const Trajectory t = sweep(m);
  ASSERT_EQ(t.samples(), 361);
  EXPECT_DOUBLE_EQ(t.time(360), 2.0);
  // The block's travel is its driver's value, 10 mm/s from 0; the crank's angle 360 deg/s.
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok);
    EXPECT_NEAR(t.channel("s.push").value()(k), 0.01 * t.time(k), 1e-12);
    EXPECT_NEAR(t.channel("s.slide").value()(k), 0.01 * t.time(k), 1e-12);
    EXPECT_NEAR(t.channel("angle.crank").value()(k), 2 * kPi * t.time(k), 1e-12);
  }
  // Each effort by its kind: a torque and a force.
  EXPECT_TRUE(t.channel("torque.turn").has_value());
  EXPECT_TRUE(t.channel("force.push").has_value());
}

// Issue 36 item 1: the sweep's axis is chosen once. One driver: its value, and the swept driver is
// that one; several: time, and no code path may take one of them for the sweep's driver.
TEST(SweepAxis, OneDriverIsItsValueSeveralAreTime) {
  const Mechanism one = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  EXPECT_FALSE(one.axis().timed());
  EXPECT_EQ(&one.swept(), &one.drivers.front());
  const Mechanism two = load_mechanism("mechanisms/drivers/fivebar_two_cranks.toml");
  EXPECT_TRUE(two.axis().timed());
  EXPECT_THROW((void)two.swept(), std::logic_error);
}

// Every driver's value is filled, whatever the axis: the one driver's is its swept value (each
// sample's `along`), and each of several drivers' is its own law's at the sample's time; so are
// the dyads' and every engine's, which take them from the reference.
TEST(SweepAxis, EveryDriversValueIsFilledOnEitherAxis) {
  for (const char* file :
       {"mechanisms/fourbar_crank_rocker.toml", "mechanisms/drivers/fivebar_two_cranks.toml"}) {
    const Mechanism m = load_mechanism(file);
    const Trajectory t = sweep(m, SweepOptions{});
    ASSERT_GT(t.samples(), 10) << file;
    ASSERT_EQ(t.driver_values.cols(), static_cast<Eigen::Index>(m.drivers.size())) << file;
    ASSERT_EQ(t.driver_names.size(), m.drivers.size()) << file;
    for (int row = 0; row < t.samples(); ++row) {
      for (size_t d = 0; d < m.drivers.size(); ++d)
        EXPECT_NEAR(t.driver_values(row, static_cast<Eigen::Index>(d)),
                    m.drivers[d].at_time(t.time(row)).value, 1e-9)
            << file << " " << m.drivers[d].name << " #" << row;
      if (m.axis().timed()) {
        EXPECT_EQ(t.along(row), t.time(row)) << file << " #" << row;
        EXPECT_THROW((void)t.swept(row), std::logic_error);
      } else {
        EXPECT_EQ(t.along(row), t.driver_values(row, m.axis().driver)) << file << " #" << row;
      }
    }
  }
}

// Every driver seeds the instantaneous centres (it was the first only): each driven crank's
// angular velocity from the centres is its own law's rate, whatever the other driver does.
TEST(SweepAxis, EveryDriverSeedsTheCentres) {
  const Mechanism m = load_mechanism("mechanisms/drivers/fivebar_two_cranks.toml");
  const Trajectory t = sweep(m, SweepOptions{});
  ASSERT_GT(t.samples(), 10);
  for (const int row : {0, t.samples() / 3}) {
    const CentreVelocities v = centre_velocities(m, instant_centres(m, t, row), t, row);
    ASSERT_TRUE(v.complete) << v.message;
    for (const Driver& d : m.drivers) {
      const int k = m.moving_index(d.link);
      EXPECT_EQ(v.omega[static_cast<size_t>(k)], d.at_time(t.time(row)).rate) << d.name;
    }
  }
}
}  // namespace
}  // namespace crosslink
