// Forward dynamics with several free coordinates (analytic/physics/dynamics.h, one per [[driver]])
// against independent solutions:
//   - the double pendulum of MBDyn's tutorial (mechanisms/dynamics/double_pendulum_mbdyn.toml):
//     its Lagrange equations in the links' absolute angles, written out by hand for two
//     compound pendulums and integrated here by Boost.Odeint, agree with the reference's joint
//     angles and rates; the energy balance holds at every sample;
//   - the passive five-bar (mechanisms/dynamics/constans_dyer_fivebar_falling.toml): Lagrange's
//     equations in the two cranks' angles with the loop closed as a dyad (the couplers from the
//     circles' intersection, their rates and accelerations from the vector loop), no Newton and
//     no constraint Jacobian, integrated the same way;
//   - both with an effort on each coordinate (a torque table in time on each driver): the same
//     equations with the torques as generalised forces, the work they do in the energy balance,
//     and the kinetostatic efforts the reference writes (each driver's multiplier) equal to the
//     applied ones;
//   - the [dynamics] table with several drivers: each driver's keys in [dynamics.<name>], and
//     every fault located at its key.
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <Eigen/Dense>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <fstream>
#include <functional>
#include <numbers>
#include <sstream>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "tests/common/diagnostics.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

using Vector2 = Eigen::Vector2d;

std::string path_of(const std::string& name) {
  return std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/dynamics/" + name;
}

// A named point of link `link`, in its frame.
Vector2 point(const Mechanism& m, int link, const char* name) {
  const Link& l = m.links[static_cast<size_t>(link)];
  return l.points[static_cast<size_t>(l.find_point(name))].local;
}

std::string text_of(const std::string& name) {
  std::ifstream in(path_of(name));
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

using State = std::array<double, 4>;  // two coordinates, their rates
// The generalised accelerations of two coordinates at (t, q, qdot).
using Accelerations = std::function<Vector2(double, const Vector2&, const Vector2&)>;

// Integrates q'' = f(t, q, q') from (q0, q0') with Runge-Kutta-Fehlberg 7(8) at 1e-13, as the
// reference's own rkf78 but on other equations, and returns (q, q') at `times`.
std::vector<State> integrated(const Accelerations& f, const State& start,
                              const std::vector<double>& times) {
  namespace odeint = boost::numeric::odeint;
  std::vector<State> out;
  State x = start;
  auto rhs = [&](const State& y, State& dydt, double t) {
    const Vector2 a = f(t, {y[0], y[1]}, {y[2], y[3]});
    dydt = {y[2], y[3], a(0), a(1)};
  };
  odeint::integrate_times(
      odeint::make_controlled(1e-13, 1e-13, odeint::runge_kutta_fehlberg78<State>()), rhs, x,
      times.begin(), times.end(), 1e-5, [&](const State& y, double) { out.push_back(y); });
  return out;
}

std::vector<double> sample_times(const Simulation& sim) {
  const Trajectory& t = sim.trajectory;
  return std::vector<double>(t.time.data(), t.time.data() + t.samples());
}

// The torques applied in the effort tests: each coordinate's, linear in time between rows.
void drive_with_efforts(Mechanism& m, double scale) {
  m.dynamics->effort = {{0.0, 0.5 * scale}, {0.4, -0.3 * scale}, {1.0, 0.2 * scale}};
  m.dynamics->others.at(0).effort = {{0.0, -0.2 * scale}, {0.7, 0.4 * scale}};
}

// The double pendulum in the links' absolute angles phi1, phi2 (from +x), with the torques of
// its two drivers (the shoulder's on link 1 from the ground, the elbow's on link 2 from link 1).
struct DoublePendulum {
  double m1, m2, c1, c2, l1, i1, i2, g;
  FreeCoordinate shoulder, elbow;

  explicit DoublePendulum(const Mechanism& m)
      : m1(m.links[1].mass.mass),
        m2(m.links[2].mass.mass),
        c1(m.links[1].mass.com.x()),
        c2(m.links[2].mass.com.x()),
        l1(point(m, 1, "B").x()),
        i1(m.links[1].mass.inertia),
        i2(m.links[2].mass.inertia),
        g(-m.gravity.y()),
        shoulder(m.dynamics->coordinate(0)),
        elbow(m.dynamics->coordinate(1)) {}

  // T = 1/2 (a11 phi1'^2 + a22 phi2'^2 + 2 b cos(phi1 - phi2) phi1' phi2'),
  // V = g ((m1 c1 + m2 l1) sin phi1 + m2 c2 sin phi2); the elbow's torque does work on
  // phi2 - phi1.
  Vector2 operator()(double t, const Vector2& phi, const Vector2& rate) const {
    const double a11 = m1 * c1 * c1 + i1 + m2 * l1 * l1, a22 = m2 * c2 * c2 + i2, b = m2 * l1 * c2;
    const double c = std::cos(phi(0) - phi(1)), s = std::sin(phi(0) - phi(1));
    Eigen::Matrix2d mass;
    mass << a11, b * c, b * c, a22;
    const double ts = shoulder.effort_at(t), te = elbow.effort_at(t);
    const Vector2 force(
        -b * s * rate(1) * rate(1) - g * (m1 * c1 + m2 * l1) * std::cos(phi(0)) + ts - te,
        b * s * rate(0) * rate(0) - g * m2 * c2 * std::cos(phi(1)) + te);
    return mass.fullPivLu().solve(force);
  }
};

// The five-bar A-B-E-C-D in its cranks' angles: the couplers B-E and C-E closed as a dyad.
struct FiveBar {
  struct Body {
    double mass, inertia;
    Vector2 com;  // in the link's frame: origin at its first point, x along the bar
  };
  Vector2 a, d;           // the ground pivots
  double r1, r2, l3, l4;  // the cranks, the couplers
  std::array<Body, 4> bodies;
  Vector2 g;
  FreeCoordinate left, right;

  explicit FiveBar(const Mechanism& m)
      : a(point(m, 0, "A")),
        d(point(m, 0, "D")),
        r1(point(m, 1, "B").x()),
        r2(point(m, 2, "C").x()),
        l3(point(m, 3, "E").x()),
        l4(point(m, 4, "E").x()),
        g(m.gravity),
        left(m.dynamics->coordinate(0)),
        right(m.dynamics->coordinate(1)) {
    for (size_t k = 0; k < 4; ++k)
      bodies[k] = {m.links[k + 1].mass.mass, m.links[k + 1].mass.inertia, m.links[k + 1].mass.com};
  }

  static Vector2 unit(double angle) { return {std::cos(angle), std::sin(angle)}; }
  static Vector2 perp(const Vector2& v) { return {-v.y(), v.x()}; }

  // Each link's frame: origin, angle, and their first and second time derivatives.
  struct Motion {
    std::array<Vector2, 4> r, v, acc;
    std::array<double, 4> angle, omega, alpha;
  };

  // The links' motion at crank angles q, rates qd, accelerations qdd: E below the line B-C
  // (the hanging assembly), the couplers' rates and accelerations from the vector loop
  // B + l3 e3 = C + l4 e4 differentiated once and twice.
  Motion motion(const Vector2& q, const Vector2& qd, const Vector2& qdd) const {
    Motion o;
    const Vector2 e1 = unit(q(0)), e2 = unit(q(1));
    const Vector2 b = a + r1 * e1, c = d + r2 * e2;
    const Vector2 bc = c - b;
    const double dist = bc.norm(), along = (dist * dist + l3 * l3 - l4 * l4) / (2.0 * dist);
    const Vector2 u = bc / dist, down(u.y(), -u.x());
    const Vector2 e = b + along * u + std::sqrt(l3 * l3 - along * along) * down;
    const double phi3 = std::atan2(e.y() - b.y(), e.x() - b.x()),
                 phi4 = std::atan2(e.y() - c.y(), e.x() - c.x());
    const Vector2 e3 = unit(phi3), e4 = unit(phi4);
    const Vector2 vb = r1 * qd(0) * perp(e1), vc = r2 * qd(1) * perp(e2);
    // l3 w3 perp(e3) - l4 w4 perp(e4) = vc - vb
    Eigen::Matrix2d loop;
    loop.col(0) = l3 * perp(e3);
    loop.col(1) = -l4 * perp(e4);
    const Vector2 w = loop.fullPivLu().solve(vc - vb);
    const Vector2 ab = r1 * qdd(0) * perp(e1) - r1 * qd(0) * qd(0) * e1,
                  ac = r2 * qdd(1) * perp(e2) - r2 * qd(1) * qd(1) * e2;
    // l3 a3 perp(e3) - l3 w3^2 e3 - l4 a4 perp(e4) + l4 w4^2 e4 = ac - ab
    const Vector2 al =
        loop.fullPivLu().solve(ac - ab + l3 * w(0) * w(0) * e3 - l4 * w(1) * w(1) * e4);
    o.r = {a, d, b, c};
    o.v = {Vector2::Zero(), Vector2::Zero(), vb, vc};
    o.acc = {Vector2::Zero(), Vector2::Zero(), ab, ac};
    o.angle = {q(0), q(1), phi3, phi4};
    o.omega = {qd(0), qd(1), w(0), w(1)};
    o.alpha = {qdd(0), qdd(1), al(0), al(1)};
    return o;
  }

  // A body's centre of mass: velocity and acceleration.
  std::pair<Vector2, Vector2> centre(const Motion& o, size_t k) const {
    const Eigen::Rotation2Dd turn(o.angle[k]);
    const Vector2 arm = turn * bodies[k].com;
    return {o.v[k] + o.omega[k] * perp(arm),
            o.acc[k] + o.alpha[k] * perp(arm) - o.omega[k] * o.omega[k] * arm};
  }

  // Lagrange's equations M(q) q'' = Q - b(q, q'): M and Q from the motion at unit rates, b from
  // the motion at q'' = 0.
  Vector2 operator()(double t, const Vector2& q, const Vector2& qd) const {
    Eigen::Matrix2d mass = Eigen::Matrix2d::Zero();
    Vector2 force(left.effort_at(t), right.effort_at(t));
    const Motion bias = motion(q, qd, Vector2::Zero());
    std::array<Motion, 2> unit_rate = {motion(q, {1.0, 0.0}, Vector2::Zero()),
                                       motion(q, {0.0, 1.0}, Vector2::Zero())};
    for (size_t k = 0; k < 4; ++k) {
      const Body& body = bodies[k];
      const Vector2 a0 = centre(bias, k).second;
      for (int i = 0; i < 2; ++i) {
        const Vector2 vi = centre(unit_rate[static_cast<size_t>(i)], k).first;
        const double wi = unit_rate[static_cast<size_t>(i)].omega[k];
        force(i) +=
            body.mass * vi.dot(g) - body.mass * vi.dot(a0) - body.inertia * wi * bias.alpha[k];
        for (int j = 0; j < 2; ++j) {
          const Vector2 vj = centre(unit_rate[static_cast<size_t>(j)], k).first;
          mass(i, j) += body.mass * vi.dot(vj) +
                        body.inertia * wi * unit_rate[static_cast<size_t>(j)].omega[k];
        }
      }
    }
    return mass.fullPivLu().solve(force);
  }
};

// The largest of |a - b| over the samples, and the peak of |b|, for column pairs.
struct Agreement {
  double worst = 0.0, peak = 0.0;
  void add(double value, double expected) {
    worst = std::max(worst, std::abs(value - expected));
    peak = std::max(peak, std::abs(expected));
  }
};

// The reference's run against the double pendulum's equations over the first `span` seconds:
// the joint angles (the drivers' values) and the links' absolute rates.
void expect_double_pendulum(const Mechanism& m, double span, double within) {
  const Simulation sim = simulate(m);
  ASSERT_TRUE(sim.ok) << sim.message;
  const Trajectory& t = sim.trajectory;
  const std::vector<State> expected = integrated(
      DoublePendulum(m),
      {m.drivers[0].start, m.drivers[0].start + m.drivers[1].start, m.dynamics->coordinate(0).rate,
       m.dynamics->coordinate(0).rate + m.dynamics->coordinate(1).rate},
      sample_times(sim));
  ASSERT_EQ(static_cast<int>(expected.size()), t.samples());
  Agreement angle, rate;
  for (int k = 0; k < t.samples() && t.time(k) <= span; ++k) {
    const State& x = expected[static_cast<size_t>(k)];
    angle.add(t.driver_values(k, 0), x[0]);
    angle.add(t.driver_values(k, 1), x[1] - x[0]);
    rate.add(t.omega(k, 0), x[2]);
    rate.add(t.omega(k, 1), x[3]);
  }
  EXPECT_LT(angle.worst, within * angle.peak) << "angles";
  EXPECT_LT(rate.worst, within * rate.peak) << "rates";
  double balance = 0.0;
  for (int k = 0; k < t.samples(); ++k) balance = std::max(balance, sim.energy_error(k));
  EXPECT_LT(balance, 1e-11) << "of the largest energy, " << sim.energy_scale << " J";
}

void expect_five_bar(const Mechanism& m, double within) {
  const Simulation sim = simulate(m);
  ASSERT_TRUE(sim.ok) << sim.message;
  const Trajectory& t = sim.trajectory;
  const std::vector<State> expected =
      integrated(FiveBar(m),
                 {m.drivers[0].start, m.drivers[1].start, m.dynamics->coordinate(0).rate,
                  m.dynamics->coordinate(1).rate},
                 sample_times(sim));
  ASSERT_EQ(static_cast<int>(expected.size()), t.samples());
  Agreement angle, rate;
  for (int k = 0; k < t.samples(); ++k) {
    const State& x = expected[static_cast<size_t>(k)];
    for (int i = 0; i < 2; ++i) {
      angle.add(t.driver_values(k, i), x[static_cast<size_t>(i)]);
      rate.add(t.omega(k, i), x[static_cast<size_t>(2 + i)]);
    }
  }
  EXPECT_LT(angle.worst, within * angle.peak) << "angles";
  EXPECT_LT(rate.worst, within * rate.peak) << "rates";
  double balance = 0.0;
  for (int k = 0; k < t.samples(); ++k) balance = std::max(balance, sim.energy_error(k));
  EXPECT_LT(balance, 1e-11) << "of the largest energy, " << sim.energy_scale << " J";
}

TEST(DoublePendulum, FollowsItsLagrangeEquations) {
  expect_double_pendulum(load_mechanism(path_of("double_pendulum_mbdyn.toml")), 5.0, 1e-9);
}

TEST(DoublePendulum, WithAnEffortOnEachCoordinate) {
  Mechanism m = load_mechanism(path_of("double_pendulum_mbdyn.toml"));
  drive_with_efforts(m, 10.0);
  expect_double_pendulum(m, 5.0, 1e-9);
}

TEST(PassiveFiveBar, FollowsLagrangesEquationsWithTheLoopClosedAsADyad) {
  expect_five_bar(load_mechanism(path_of("constans_dyer_fivebar_falling.toml")), 1e-9);
}

TEST(PassiveFiveBar, WithAnEffortOnEachCoordinate) {
  Mechanism m = load_mechanism(path_of("constans_dyer_fivebar_falling.toml"));
  drive_with_efforts(m, 1.0);
  expect_five_bar(m, 1e-9);
}

// Each driver's effort as the reference writes it (minus its row's multiplier, from the
// kinetostatics at each sample) is the effort applied along its coordinate.
TEST(PassiveFiveBar, EachDriversEffortIsTheAppliedOne) {
  Mechanism m = load_mechanism(path_of("constans_dyer_fivebar_falling.toml"));
  drive_with_efforts(m, 1.0);
  const Simulation sim = simulate(m);
  ASSERT_TRUE(sim.ok) << sim.message;
  const Trajectory& t = sim.trajectory;
  double worst = 0.0;
  for (int k = 0; k < t.samples(); ++k)
    for (int i = 0; i < 2; ++i)
      worst = std::max(worst,
                       std::abs(t.effort(k, i) - m.dynamics->coordinate(i).effort_at(t.time(k))));
  EXPECT_LT(worst, 1e-9 * 0.4);
}

// The five-bar drawn with its cranks' tips 2e-4 mm apart (the cranks at acos(90/120) from each
// pivot, the right one 1e-4 deg off): there the couplers all but turn about the tips together
// without moving a crank, so the drivers' rates do not determine the chain's and no initial
// velocity is consistent; refused at [dynamics] (at the tips' meeting itself the chain's
// Jacobian is singular and it does not assemble).
TEST(PassiveFiveBar, AStartAtASingularPositionIsRefusedAtItsDynamicsTable) {
  std::string text = text_of("constans_dyer_fivebar_falling.toml");
  const double at = std::acos(90.0 / 120.0) * 180.0 / std::numbers::pi;
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"pose = [0, 0, -60]", fmt::format("pose = [0, 0, {:.12g}]", at)},
           {"pose = [180, 0, -90]", fmt::format("pose = [180, 0, {:.12g}]", 180.0 - at + 1e-4)},
           {"pose = [60, -103.92, -83.62]", "pose = [90, 79.37253933, -70]"},
           {"pose = [180, -120, -111.64]", "pose = [90, 79.37253933, -70]"},
           {"start = -60", fmt::format("start = {:.12g}", at)},
           {"start = -90", fmt::format("start = {:.12g}", 180.0 - at + 1e-4)}})
    text.replace(text.find(from), from.size(), to);
  const std::vector<Diagnostic> found = [&] {
    try {
      (void)simulate(parse_mechanism(text, "bad.toml"));
    } catch (const DefinitionError& e) {
      return e.diagnostics();
    }
    return std::vector<Diagnostic>{};
  }();
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].where.line, test::line_of(text, "[dynamics]")) << found[0].str();
  EXPECT_NE(found[0].message.find("is a singular position of the coordinates"), std::string::npos)
      << found[0].str();
  EXPECT_NE(found[0].message.find("left = 41.4096221 deg, right = 138.590478 deg"),
            std::string::npos)
      << found[0].str();
}

// [dynamics] with several drivers: the one-driver keys go in each driver's own table.
std::string pendulum_with(const std::string& dynamics) {
  const std::string text = text_of("double_pendulum_mbdyn.toml");
  return text.substr(0, text.find("[dynamics]")) + dynamics;
}

TEST(SeveralFreeCoordinates, EachDriversRateAndEffortAreItsOwn) {
  const Mechanism m = parse_mechanism(
      pendulum_with("[dynamics]\nduration = 1\ninterval = 0.1\n[dynamics.elbow]\nrate = 2\n"
                    "effort_table = [[0, 1], [1, 3]]\n"),
      "good.toml");
  ASSERT_TRUE(m.dynamics.has_value());
  EXPECT_EQ(m.dynamics->coordinate_count(), 2);
  EXPECT_EQ(m.dynamics->coordinate(0).rate, 0.0);  // no table of its own: at rest, free
  EXPECT_TRUE(m.dynamics->coordinate(0).effort.empty());
  EXPECT_DOUBLE_EQ(m.dynamics->coordinate(1).rate, 2.0);
  EXPECT_DOUBLE_EQ(m.dynamics->coordinate(1).effort_at(0.5), 2.0);
}

struct Fault {
  std::string dynamics, marker, phrase;
};

TEST(SeveralFreeCoordinates, FaultsAreLocatedAtTheirKeys) {
  const std::vector<Fault> faults = {
      {"[dynamics]\nduration = 1\ninterval = 0.1\nrate = 2\n", "rate = 2",
       "[dynamics] 'rate' belongs to one driver: with 2 drivers give each driver's rate and "
       "effort in its own table [dynamics.<name>] ([dynamics.shoulder])"},
      {"[dynamics]\nduration = 1\ninterval = 0.1\neffort = 2\n", "effort = 2",
       "[dynamics] 'effort' belongs to one driver"},
      {"[dynamics]\nduration = 1\ninterval = 0.1\n[dynamics.knee]\nrate = 2\n", "knee",
       "unknown key 'knee' in [dynamics]: it takes 'duration', 'interval' and one table per "
       "driver, [dynamics.<name>] (drivers: shoulder, elbow)"},
      {"[dynamics]\nduration = 1\ninterval = 0.1\n[dynamics.elbow]\nspeed = 2\n", "speed",
       "unknown key 'speed' in [dynamics.elbow] (valid keys: rate, rate_unit, effort, "
       "effort_table)"},
      {"[dynamics]\nduration = 1\ninterval = 0.1\n[dynamics.elbow]\neffort = 1\n"
       "effort_table = [[0, 1], [1, 2]]\n",
       "effort_table", "[dynamics.elbow] takes 'effort' (constant) or 'effort_table'"},
      {"[dynamics]\nduration = 1\ninterval = 0.1\n[dynamics.elbow]\neffort_table = [[1, 1], "
       "[0, 2]]\n",
       "[0, 2]", "[dynamics.elbow] 'effort_table' times must increase strictly"},
      {"[dynamics]\nduration = 1\ninterval = 0.1\n[dynamics.shoulder]\nrate = \"x\"\n", "\"x\"",
       "'rate' in [dynamics.shoulder]"},
      {"[dynamics]\nduration = 1\ninterval = 0.1\nelbow = 3\n", "elbow = 3",
       "'elbow' must be a table"},
  };
  for (const Fault& f : faults) {
    const std::string text = pendulum_with(f.dynamics);
    const std::vector<Diagnostic> found = test::diagnostics_of(text);
    ASSERT_EQ(found.size(), 1u) << test::error_of(text);
    EXPECT_NE(found[0].message.find(f.phrase), std::string::npos) << found[0].str();
    EXPECT_EQ(found[0].where.line, test::line_of(text, f.marker)) << found[0].str();
  }
}

}  // namespace
}  // namespace crosslink
