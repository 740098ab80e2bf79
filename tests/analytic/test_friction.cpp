// Joint friction in the exact kinetostatics (analytic/physics/kinetostatics.h), against
// independent expected values:
//   - an independent Newton-Euler solve: every moving link's force and moment balance written
//     with the joints' reactions and the driver's effort as unknowns (no constraint Jacobian, no
//     multipliers), the friction magnitudes iterated to a fixed point; every effort, reaction and
//     friction of every sample of each bundled definition with friction agrees with the
//     sweep's to 1e-9 of its peak;
//   - Bevan's eccentric: its rod is a two-force member, so the friction-circle statics close by
//     hand; exact against that to round-off, and within the printed digit of the book's moments;
//   - samples where a friction joint's relative motion stops are flagged, never signed; friction
//     that can hold the mechanism (self-locking) is flagged; wrong friction keys are refused at
//     their key.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/model/planar.h"
#include "analytic/physics/dynamics.h"
#include "analytic/physics/kinetostatics.h"
#include "analytic/reference/sweep.h"
#include "tests/common/mechanisms.h"

namespace crosslink {
namespace {

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// The forces of one pose by Newton-Euler: per moving link, sum F = m a_c and sum M_c = I alpha,
// with unknowns per revolute joint its force (of its first link on its second), per prismatic
// joint its normal force (along the guide line's left normal) and its couple on the slider, and
// the driver's torque; joint friction is a known load at given magnitudes, which are then
// iterated: f = mu r |R| (pins), mu max(|N|, 2 |M| / b) (slides), plus the constant part. An
// external gear pair's teeth push at the pitch point (on the line of centres, r_a from the first
// gear's centre): the unknown is the tangential force F_t on the second gear, and the separating
// force |F_t| tan(phi) along the line of centres, away from the first, is iterated with the
// friction. Revolute and prismatic joints, external gear pairs and one joint_angle driver, as the
// bundled friction files use.
struct NewtonEulerForces {
  Eigen::VectorXd unknowns;
  std::vector<int> column;       // per joint: its first unknown (two; one for a gear pair)
  std::vector<double> friction;  // per joint: on its second link (moment, or force along the line)
  std::vector<Eigen::Vector2d> mesh;  // per gear pair: the force of its first gear on its second
  int iterations = 0;
};

NewtonEulerForces newton_euler(const Mechanism& m, const Eigen::VectorXd& q,
                               const Eigen::VectorXd& qdot, const Eigen::VectorXd& qddot) {
  const auto body = [&](int link) {
    return BodyMotion::of(m.moving_index(link), q, &qdot, &qddot);
  };
  const auto point_of = [&](int link, int point) {
    return body(link).position(
        m.links[static_cast<size_t>(link)].points[static_cast<size_t>(point)].local);
  };
  // The unknowns' columns: two per joint (one per gear pair), then the driver's torque.
  std::vector<int> column;
  int n = 0;
  for (const Joint& joint : m.joints) {
    column.push_back(n);
    n += joint.type == JointType::gear ? 1 : 2;
  }
  ++n;
  const int rows = 3 * m.moving_count();
  EXPECT_EQ(n, rows) << "one driver, revolute and prismatic joints and gear pairs only";
  // A gear pair's pitch point, the unit vector from its first centre to its second and the common
  // tangent, from the gears' own centres (the named centre points on each gear link).
  struct Teeth {
    Eigen::Vector2d pitch, apart, tangent;
  };
  const auto teeth = [&](const Joint& joint) {
    const Link& carrier = m.links[static_cast<size_t>(joint.carrier)];
    const auto centre = [&](int gear, int on_carrier) {
      const Link& g = m.links[static_cast<size_t>(gear)];
      const std::string& name = carrier.points[static_cast<size_t>(on_carrier)].name;
      const auto p = std::find_if(g.points.begin(), g.points.end(),
                                  [&](const Point& x) { return x.name == name; });
      return point_of(gear, static_cast<int>(p - g.points.begin()));
    };
    const Eigen::Vector2d a = centre(joint.link_a, joint.centre_a),
                          b = centre(joint.link_b, joint.centre_b);
    const Eigen::Vector2d apart = (b - a).normalized();
    return Teeth{a + joint.radius_a * apart, apart, perp(apart)};
  };
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, n);
  Eigen::VectorXd known = Eigen::VectorXd::Zero(rows);  // applied, inertia and friction
  // Adds to link's rows, in column c of `a` (or to `known` when c < 0), a force at a point and a
  // couple.
  const auto put = [&](int link, int c, const Eigen::Vector2d& at, const Eigen::Vector2d& f,
                       double couple, Eigen::VectorXd* into) {
    const int k = m.moving_index(link);
    if (k < 0) return;
    const Eigen::Vector2d arm =
        at - body(link).position(m.links[static_cast<size_t>(link)].mass.com);
    const Eigen::Vector3d w(f.x(), f.y(), cross(arm, f) + couple);
    if (into) {
      into->segment<3>(3 * k) += w;
    } else {
      a.block<3, 1>(3 * k, c) += w;
    }
  };
  std::vector<double> rate(m.joints.size()), sign(m.joints.size());
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const Joint& joint = m.joints[j];
    const int c = column[j];
    if (joint.type == JointType::gear) {
      EXPECT_GT(joint.ratio, 0.0) << "external gear pairs only";
      const Teeth g = teeth(joint);
      put(joint.link_b, c, g.pitch, g.tangent, 0.0, nullptr);
      put(joint.link_a, c, g.pitch, -g.tangent, 0.0, nullptr);
      continue;
    }
    if (joint.type == JointType::revolute) {
      const Eigen::Vector2d at = point_of(joint.link_b, joint.point_b);
      for (int axis = 0; axis < 2; ++axis) {
        const Eigen::Vector2d unit = Eigen::Vector2d::Unit(axis);
        put(joint.link_b, c + axis, at, unit, 0.0, nullptr);
        put(joint.link_a, c + axis, at, -unit, 0.0, nullptr);
      }
      rate[j] = body(joint.link_b).omega - body(joint.link_a).omega;
    } else {
      EXPECT_EQ(joint.type, JointType::prismatic);
      const BodyMotion guide = body(joint.link_a), slider = body(joint.link_b);
      const Line& line =
          m.links[static_cast<size_t>(joint.link_a)].lines[static_cast<size_t>(joint.line)];
      const Eigen::Vector2d t = guide.turn(line.direction), normal = perp(t);
      const Eigen::Vector2d at = point_of(joint.link_b, joint.point_b);
      put(joint.link_b, c, at, normal, 0.0, nullptr);
      put(joint.link_a, c, at, -normal, 0.0, nullptr);
      put(joint.link_b, c + 1, at, Eigen::Vector2d::Zero(), 1.0, nullptr);
      put(joint.link_a, c + 1, at, Eigen::Vector2d::Zero(), -1.0, nullptr);
      const Eigen::Vector2d on_guide = guide.v + guide.omega * perp(at - guide.r);
      const Eigen::Vector2d local = m.links[static_cast<size_t>(joint.link_b)]
                                        .points[static_cast<size_t>(joint.point_b)]
                                        .local;
      rate[j] = t.dot(slider.velocity(local) - on_guide);
    }
    sign[j] = rate[j] > 0.0 ? 1.0 : -1.0;
  }
  const Driver& d = m.drivers[0];
  const Joint& driven = m.joints[static_cast<size_t>(d.joint)];
  if (d.type == DriverType::slider) {  // a force along the line on the slider
    const Eigen::Vector2d t = body(driven.link_a)
                                  .turn(m.links[static_cast<size_t>(driven.link_a)]
                                            .lines[static_cast<size_t>(driven.line)]
                                            .direction);
    const Eigen::Vector2d at = point_of(driven.link_b, driven.point_b);
    put(driven.link_b, n - 1, at, t, 0.0, nullptr);
    put(driven.link_a, n - 1, at, -t, 0.0, nullptr);
  } else {
    EXPECT_EQ(d.type, DriverType::joint_angle);
    put(d.link, n - 1, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), 1.0, nullptr);
    put(driven.link_a, n - 1, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), -1.0, nullptr);
  }
  // Gravity and loads (no springs in these files), and d'Alembert's -m a_c and -I alpha.
  for (size_t l = 0; l < m.links.size(); ++l) {
    if (m.links[l].ground) continue;
    const BodyMotion b = body(static_cast<int>(l));
    const MassProperties& mp = m.links[l].mass;
    put(static_cast<int>(l), -1, b.position(mp.com), mp.mass * (m.gravity - b.acceleration(mp.com)),
        -mp.inertia * b.alpha, &known);
  }
  for (const Load& load : m.loads) {
    const Eigen::Vector2d v = load.force_at(0.0);
    if (load.kind == Load::Kind::torque)
      put(load.link, -1, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), v.x(), &known);
    else
      put(load.link, -1, body(load.link).position(load.local), v, 0.0, &known);
  }
  const Eigen::PartialPivLU<Eigen::MatrixXd> lu(a);
  NewtonEulerForces out;
  out.column = column;
  out.friction.assign(m.joints.size(), 0.0);
  out.mesh.assign(m.joints.size(), Eigen::Vector2d::Zero());
  std::vector<double> magnitude(m.joints.size(), 0.0), tangential(m.joints.size(), 0.0);
  for (out.iterations = 0; out.iterations < 2000; ++out.iterations) {
    Eigen::VectorXd b = known;
    for (size_t j = 0; j < m.joints.size(); ++j) {
      const Joint& joint = m.joints[j];
      if (joint.type != JointType::gear) continue;
      const Teeth g = teeth(joint);
      const Eigen::Vector2d separating =
          std::abs(tangential[j]) * std::tan(joint.pressure_angle) * g.apart;
      put(joint.link_b, -1, g.pitch, separating, 0.0, &b);
      put(joint.link_a, -1, g.pitch, -separating, 0.0, &b);
    }
    for (size_t j = 0; j < m.joints.size(); ++j) {
      const Joint& joint = m.joints[j];
      if (!joint.friction) continue;
      const double f = -sign[j] * magnitude[j];  // on the joint's second link
      if (joint.type == JointType::revolute) {
        put(joint.link_b, -1, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), f, &b);
        put(joint.link_a, -1, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), -f, &b);
      } else {
        const Eigen::Vector2d t = body(joint.link_a)
                                      .turn(m.links[static_cast<size_t>(joint.link_a)]
                                                .lines[static_cast<size_t>(joint.line)]
                                                .direction);
        const Eigen::Vector2d at = point_of(joint.link_b, joint.point_b);
        put(joint.link_b, -1, at, f * t, 0.0, &b);
        put(joint.link_a, -1, at, -f * t, 0.0, &b);
      }
      out.friction[j] = f;
    }
    out.unknowns = lu.solve(-b);
    double change = 0.0, largest = 0.0;
    for (size_t j = 0; j < m.joints.size(); ++j) {
      const Joint& joint = m.joints[j];
      if (!joint.friction) continue;
      const JointFriction& fr = *joint.friction;
      const double x = out.unknowns(column[j]), y = out.unknowns(column[j] + 1);
      const double next =
          joint.type == JointType::revolute
              ? fr.coefficient * fr.radius * std::hypot(x, y) + fr.constant
              : fr.coefficient * (fr.length > 0.0
                                      ? std::max(std::abs(x), 2.0 * std::abs(y) / fr.length)
                                      : std::abs(x)) +
                    fr.constant;
      change = std::max(change, std::abs(next - magnitude[j]));
      largest = std::max(largest, next);
      magnitude[j] = next;
    }
    for (size_t j = 0; j < m.joints.size(); ++j) {
      if (m.joints[j].type != JointType::gear) continue;
      const double next = out.unknowns(column[j]);
      change = std::max(change, std::abs(std::abs(next) - std::abs(tangential[j])));
      largest = std::max(largest, std::abs(next));
      tangential[j] = next;
    }
    if (change <= 1e-15 * largest) break;
  }
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const Joint& joint = m.joints[j];
    if (joint.type != JointType::gear) continue;
    const Teeth g = teeth(joint);
    out.mesh[j] = tangential[j] * g.tangent +
                  std::abs(tangential[j]) * std::tan(joint.pressure_angle) * g.apart;
  }
  return out;
}

class FrictionFiles : public ::testing::TestWithParam<std::string> {};

// Every sample's effort, reactions (a slide's with its friction force), normal forces, couples
// and friction from the sweep against the Newton-Euler fixed point at the same pose, each to
// 1e-9 of its kind's peak over the sweep (forces; torques, which include a force times the size).
TEST_P(FrictionFiles, NewtonEulerFixedPointGivesTheSweepsForces) {
  const Mechanism m = load_mechanism(GetParam());
  if (m.drivers.size() > 1)
    GTEST_SKIP() << "the Newton-Euler solve takes one driver; the two coordinates' motion is held "
                    "by TwoCoordinatesStickAndSlipApartAsEachDoesAlone";
  const Trajectory t = sweep(m);
  ASSERT_TRUE(t.has_forces);
  const NewtonSolver solver(m);
  KinematicState state(m);
  std::vector<std::pair<double, double>> forces, torques;  // (sweep, Newton-Euler)
  int checked = 0;
  for (int k = 0; k < t.samples(); ++k) {
    if (!usable(t.status[static_cast<size_t>(k)])) continue;
    state.q = coordinates_at(m, t, k);
    DriverState d = m.drivers[0].at_time(t.time(k));
    d.value = t.along(k);
    d.rate = m.drivers[0].law.speed;  // constant speed, as every bundled friction file's sweep
    state.swept() = d;
    ASSERT_EQ(solver.solve(state).status, PoseStatus::ok);
    const NewtonEulerForces ne = newton_euler(m, state.q, state.qdot, state.qddot);
    ASSERT_LT(ne.iterations, 2000) << "the fixed point did not converge at " << t.along(k);
    torques.emplace_back(t.effort(k, 0), ne.unknowns(ne.unknowns.size() - 1));
    size_t slide = 0, friction = 0;
    for (size_t j = 0; j < m.joints.size(); ++j) {
      const Joint& joint = m.joints[j];
      const auto c = static_cast<Eigen::Index>(j);
      const Eigen::Index u = ne.column[j];
      Eigen::Vector2d expected = joint.type == JointType::gear
                                     ? ne.mesh[j]
                                     : Eigen::Vector2d(ne.unknowns(u), ne.unknowns(u + 1));
      if (joint.is_slide()) {
        const BodyMotion guide =
            BodyMotion::of(m.moving_index(joint.link_a), state.q, nullptr, nullptr);
        const Eigen::Vector2d along = guide.turn(m.links[static_cast<size_t>(joint.link_a)]
                                                     .lines[static_cast<size_t>(joint.line)]
                                                     .direction);
        const auto s = static_cast<Eigen::Index>(slide++);
        forces.emplace_back(t.fn(k, s), ne.unknowns(u));
        torques.emplace_back(t.moment(k, s), ne.unknowns(u + 1));
        expected = ne.unknowns(u) * perp(along) + ne.friction[j] * along;
      }
      forces.emplace_back(t.fx(k, c), expected.x());
      forces.emplace_back(t.fy(k, c), expected.y());
      if (joint.friction) {
        const auto f = static_cast<Eigen::Index>(friction++);
        (joint.is_slide() ? forces : torques).emplace_back(t.friction(k, f), ne.friction[j]);
      }
    }
    ++checked;
  }
  ASSERT_GT(checked, t.samples() / 2) << m.file;
  for (auto* pairs : {&forces, &torques}) {
    double peak = 0.0;
    for (const auto& [a, b] : *pairs) peak = std::max(peak, std::abs(b));
    ASSERT_GT(peak, 0.0);
    for (const auto& [a, b] : *pairs) EXPECT_NEAR(a, b, 1e-9 * peak) << m.file;
  }
}

INSTANTIATE_TEST_SUITE_P(Bundled, FrictionFiles, ::testing::ValuesIn(test::friction_files()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return std::filesystem::path(info.param).stem().string();
                         });

// Bevan's eccentric by hand. Its links are massless and its rod carries nothing between its
// pins, so the rod's force on the crosshead is F_P = (L, N) (the guide is frictionless and takes
// only a normal force), |R| = |F_P| at every pin, and the rod's moment balance about C,
// dx N - dy L = -(m_C + m_P) with the pins' friction moments on the rod, fixes N; the crank's
// balance about O then gives the driver's torque. Iterated on |R| to a fixed point.
TEST(Friction, BevansEccentricByTheFrictionCircles) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/friction/bevan_eccentric_friction.toml");
  const double inch = 0.0254, mu = 0.05, load = 6 * 2240 * 4.4482216152605;  // N
  const double r = 8 * inch, l = 80 * inch, rho_o = mu * 7 * inch, rho_c = mu * 15 * inch,
               rho_p = mu * 4.4 * inch;
  const double theta = std::numbers::pi / 3, crank_rate = -2 * std::numbers::pi;  // -60 rpm
  const Eigen::Vector2d c(r * std::cos(theta), r * std::sin(theta));
  const double phi = std::asin(c.y() / l);
  const Eigen::Vector2d p(c.x() + l * std::cos(phi), 0.0);
  // The rod's angle is -phi with sin(-phi) = -r sin(theta) / l: its rate.
  const double rod_rate = -r * std::cos(theta) * crank_rate / (l * std::cos(phi));
  const auto sign = [](double x) { return x > 0.0 ? 1.0 : -1.0; };
  double normal = 0.0, pull = load;
  for (int it = 0; it < 200; ++it) {
    pull = std::hypot(load, normal);
    const double on_rod_c = -sign(rod_rate - crank_rate) * rho_c * pull;  // C: crank on rod
    const double on_rod_p = sign(0.0 - rod_rate) * rho_p * pull;          // P: rod is its first
    normal = ((p.y() - c.y()) * load - on_rod_c - on_rod_p) / (p.x() - c.x());
  }
  pull = std::hypot(load, normal);
  const double on_crank_c = sign(rod_rate - crank_rate) * rho_c * pull;
  const double on_crank_o = -sign(crank_rate) * rho_o * pull;
  const double torque = -cross(c, Eigen::Vector2d(load, normal)) - on_crank_o - on_crank_c;

  const Trajectory exact = solve_at(m, theta);
  ASSERT_EQ(exact.status[0], PoseStatus::ok);
  EXPECT_NEAR(exact.effort(0, 0), torque, 1e-12 * torque);
  const Eigen::Index first = 0;
  EXPECT_NEAR(exact.friction(0, first), -sign(crank_rate) * rho_o * pull, 1e-12 * torque);
  // Bevan prints 3.06 ton ft with friction, 3.64 without (Ex. 7, p. 198): to its last digit.
  const double ton_ft = 2240 * 4.4482216152605 * 0.3048;
  EXPECT_NEAR(exact.effort(0, 0) / ton_ft, 3.06, 0.005);
  Mechanism frictionless = m;
  for (Joint& j : frictionless.joints) j.friction.reset();
  const Trajectory without = solve_at(frictionless, theta);
  EXPECT_NEAR(without.effort(0, 0),
              -cross(c, Eigen::Vector2d(load, (p.y() - c.y()) * load / (p.x() - c.x()))),
              1e-12 * torque);
  EXPECT_NEAR(without.effort(0, 0) / ton_ft, 3.64, 0.005);
}

// A spur gear pair whose bearings have friction circles (mechanisms/friction/
// gear_pair_bearing_friction.toml), by hand: each bearing carries only the tooth force, whose
// tangential part F_t turns the gear and whose separating part F_t tan(phi) the pressure angle
// adds, so |R| = F_t / cos(phi) at both; the wheel's balance against the load T_L and its
// bearing's friction gives F_t, the pinion's the driver's torque.
TEST(Friction, AGearPairsBearingsByTheFrictionCircles) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/friction/gear_pair_bearing_friction.toml");
  const double r1 = 0.05, r2 = 0.1, rho1 = 0.1 * 0.015, rho2 = 0.1 * 0.02, load = 50.0;
  const double c = std::cos(20.0 * std::numbers::pi / 180.0);
  const double tangential = load / (r2 - rho2 / c);
  const double torque = tangential * (r1 + rho1 / c);
  const Trajectory t = sweep(m);
  ASSERT_TRUE(t.has_forces);
  const Eigen::Index mesh = 2;  // the third joint
  int checked = 0;
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << k;
    EXPECT_NEAR(t.effort(k, 0), torque, 1e-12 * torque) << k;
    // On each gear against its turn: the pinion turns counter-clockwise, the wheel clockwise.
    EXPECT_NEAR(t.friction(k, 0), -rho1 * tangential / c, 1e-12 * torque) << k;
    EXPECT_NEAR(t.friction(k, 1), rho2 * tangential / c, 1e-12 * torque) << k;
    EXPECT_NEAR(std::hypot(t.fx(k, mesh), t.fy(k, mesh)), tangential / c, 1e-12 * tangential);
    ++checked;
  }
  EXPECT_EQ(checked, t.samples());
  // The file's description: 26.359 N m against the frictionless r_1 / r_2 T_L = 25 N m, an
  // efficiency of 94.84 %.
  EXPECT_NEAR(torque, 26.359, 5e-4);
  EXPECT_NEAR(load * r1 / r2 / torque, 0.9484, 5e-5);
}

// Ryan's rack and pinion (mechanisms/gears/ryan_rack_and_pinion.toml) made massless, with a 100 N
// load against the rack's motion, friction at the rack's slide (mu 0.15, a point contact) and at
// the pinion's bearing (mu 0.1 on a 3 mm journal), by hand: the teeth push the rack along its
// line with F_t and away from the pinion with F_t tan(phi), which the guide's normal force N
// balances, so F_t - mu N - F_L = 0 gives F_t = F_L / (1 - mu tan(phi)); the pinion's bearing
// carries |R| = F_t / cos(phi), and T = F_t (r + mu_p r_p / cos(phi)).
TEST(Friction, ARackAndPinionsSlideAndBearingByHand) {
  std::string text = test::source_text("mechanisms/gears/ryan_rack_and_pinion.toml");
  const auto after = [&](const std::string& line, const std::string& added) {
    const size_t at = text.find(line);
    ASSERT_NE(at, std::string::npos) << line;
    text.insert(at + line.size(), added);
  };
  after("angle = \"deg\"\n", "mass = \"kg\"\nforce = \"N\"\n");
  after("pose = [0, \"13 * 4 / (2 * pi)\", 0]\n", "mass = 0\ncom = [0, 0]\ninertia = 0\n");
  after("pose = [0, 0, 0]\n", "mass = 0\ncom = [0, 0]\ninertia = 0\n");
  after("point = \"X\"\n", "friction = { coefficient = 0.1, radius = 3 }\n");
  after("point = \"A\"\n", "friction = { coefficient = 0.15 }\n");
  text +=
      "\n[[load]]\nname = \"resistance\"\nlink = \"rack\"\npoint = \"A\"\n"
      "force = [-100, 0]\n";
  const Mechanism m = parse_mechanism(text, "rough_rack.toml");
  const double r = 0.052 / (2 * std::numbers::pi), tan_phi = std::tan(20 * std::numbers::pi / 180);
  const double cos_phi = std::cos(20 * std::numbers::pi / 180);
  const double tangential = 100.0 / (1.0 - 0.15 * tan_phi);
  const double torque = tangential * (r + 0.1 * 0.003 / cos_phi);
  const Trajectory t = sweep(m);
  ASSERT_TRUE(t.has_forces);
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << k;
    EXPECT_NEAR(t.effort(k, 0), torque, 1e-12 * torque) << k;
    EXPECT_NEAR(std::abs(t.fn(k, 0)), tangential * tan_phi, 1e-12 * tangential) << k;
    // Against the pinion's anticlockwise turn and the rack's motion to the right.
    EXPECT_NEAR(t.friction(k, 0), -0.1 * 0.003 * tangential / cos_phi, 1e-12 * torque) << k;
    EXPECT_NEAR(t.friction(k, 1), -0.15 * tangential * tan_phi, 1e-12 * tangential) << k;
  }
}

// The same pair coasting from 300 rpm with no load and a constant 0.5 N m more at the wheel's
// bearing. With the gears' centres of mass on their axes and no gravity, the tooth force F_y
// (on the wheel, along the common tangent) and the pinion's acceleration follow from
//   I_1 alpha_1 = -r_1 F_y - rho_1 |F_y| / cos(phi)             (the pinion turns ccw)
//   I_2 alpha_2 = -r_2 F_y + rho_2 |F_y| / cos(phi) + T_c,  alpha_2 = -(r_1 / r_2) alpha_1,
// linear once F_y's sign is chosen (the one that agrees): a constant deceleration, so the pinion
// stops at t* = omega_0 / |alpha_1| and friction holds it there.
TEST(FrictionDynamics, AGearPairCoastsToRestAsTheClosedFormSays) {
  std::string text = test::source_text("mechanisms/friction/gear_pair_bearing_friction.toml");
  text = text.substr(0, text.find("[driver]")) +
         "[driver]\ntype = \"joint_angle\"\njoint = \"A\"\nto = \"B\"\nstart = 0\n\n"
         "[dynamics]\nduration = 2\ninterval = 0.01\nrate = 300\nrate_unit = \"rpm\"\n";
  const std::string wheel = "friction = { coefficient = 0.1, radius = 20 }";
  text.replace(text.find(wheel), wheel.size(),
               "friction = { coefficient = 0.1, radius = 20, torque = 500 }");  // N mm
  const Mechanism m = parse_mechanism(text, "coasting_gears.toml");
  const double r1 = 0.05, r2 = 0.1, rho1 = 0.1 * 0.015, rho2 = 0.1 * 0.02, held = 0.5;
  const double i1 = 0.0015, i2 = 0.024, c = std::cos(20.0 * std::numbers::pi / 180.0);
  const double omega0 = 300 * 2 * std::numbers::pi / 60;
  double alpha = 0.0, tooth = 0.0;
  int agreeing = 0;
  for (const double sign : {1.0, -1.0}) {
    Eigen::Matrix2d a;
    a << i1, r1 + sign * rho1 / c, -i2 * r1 / r2, r2 - sign * rho2 / c;
    const Eigen::Vector2d x = a.partialPivLu().solve(Eigen::Vector2d(0.0, held));
    if (sign * x(1) < 0.0) continue;
    alpha = x(0);
    tooth = x(1);
    ++agreeing;
  }
  ASSERT_EQ(agreeing, 1);
  ASSERT_LT(alpha, 0.0);
  const double stop = -omega0 / alpha;
  ASSERT_LT(stop, 2.0);

  const Simulation run = simulate(m);
  ASSERT_TRUE(run.ok) << run.message;
  ASSERT_EQ(run.stops.size(), 1u);
  EXPECT_TRUE(run.held);
  EXPECT_NEAR(run.stops[0].first, stop, 1e-9 * stop);
  const double rest = omega0 * stop + 0.5 * alpha * stop * stop;
  EXPECT_NEAR(run.stops[0].second, rest, 1e-9 * rest);
  const Trajectory& t = run.trajectory;
  for (int k = 0; k < t.samples(); ++k) {
    const double time = t.time(k);
    const double angle = time < stop ? omega0 * time + 0.5 * alpha * time * time : rest;
    EXPECT_NEAR(t.angle(k, 0), angle, 1e-9 * rest) << time;
    EXPECT_LT(run.energy_error(k), 1e-9) << time;
    if (time >= stop) continue;  // held by two bearings: how they share it is not determined
    EXPECT_NEAR(t.fy(k, 2), tooth, 1e-9 * std::abs(tooth)) << time;
    EXPECT_NEAR(t.friction(k, 1), rho2 * std::abs(tooth) / c + held, 1e-9 * held) << time;
  }
}

// Where the rod stops turning (the crank at 90 and 270 deg), the crosshead pin's friction has no
// sign: those samples are flagged with an event naming the joint, their forces are not given,
// and their poses are.
TEST(Friction, ARelativeRestIsFlaggedNeverSigned) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/friction/bevan_eccentric_friction.toml");
  const Trajectory t = sweep(m);
  std::vector<double> flagged;
  for (int k = 0; k < t.samples(); ++k)
    if (t.status[static_cast<size_t>(k)] == PoseStatus::friction_indeterminate) {
      flagged.push_back(t.along(k) * 180.0 / std::numbers::pi);
      EXPECT_FALSE(t.has_value(k, Quantity::torque));
      EXPECT_TRUE(t.has_value(k, Quantity::position));
    }
  // The crank turns clockwise from 60 deg: through -90 and -270 deg.
  ASSERT_EQ(flagged.size(), 2u);
  EXPECT_NEAR(flagged[0], -90.0, 1e-9);
  EXPECT_NEAR(flagged[1], -270.0, 1e-9);
  int events = 0;
  for (const Trajectory::Event& e : t.events)
    if (e.kind == PoseStatus::friction_indeterminate) {
      ++events;
      EXPECT_NE(e.message.find("joint 'P'"), std::string::npos) << e.message;
    }
  EXPECT_EQ(events, 2);
  // One sample beside it, the friction has its sign: the driver's torque jumps across the stop
  // (the pin's friction changes side) but each side is determined.
  EXPECT_EQ(solve_at(m, -89.9 * std::numbers::pi / 180).status[0], PoseStatus::ok);
}

// A piston on slide bars as rough as mu = 5 locks where the rod's obliquity phi has mu tan(phi)
// >= 1 (the friction angle and the obliquity make 90 deg): the driver's push along the rod only
// presses the piston harder on its bars. There the friction gain reaches 1 and the samples are
// flagged self_locking; near the dead centres (small phi) the forces stand. (The pins' friction
// and the rod's inertia move the border a little from mu tan(phi) = 1: 5 %.)
TEST(Friction, FrictionThatCanLockTheMechanismIsFlagged) {
  Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                               "/mechanisms/friction/slider_crank_friction.toml");
  for (Joint& j : m.joints)
    if (j.is_slide()) j.friction->coefficient = 5.0;
  const Trajectory t = sweep(m);
  int locked = 0, ok = 0;
  for (int k = 0; k < t.samples(); ++k) {
    const PoseStatus s = t.status[static_cast<size_t>(k)];
    // The obliquity at this crank angle: sin(phi) = r sin(theta) / l.
    const double tan_phi = std::tan(std::asin(0.3 * std::sin(t.along(k)) / 1.2));
    if (s == PoseStatus::self_locking) {
      ++locked;
      EXPECT_GT(5.0 * std::abs(tan_phi), 0.95) << t.along(k);
    }
    if (s == PoseStatus::ok) {
      ++ok;
      EXPECT_LT(5.0 * std::abs(tan_phi), 1.05) << t.along(k);
    }
  }
  EXPECT_GT(locked, 0);
  EXPECT_GT(ok, 0);
}

// The friction keys' errors, each at its key (file:line:column), with what to write.
std::string with_friction(const std::string& joint_line, const std::string& friction) {
  std::string text = test::source_text("mechanisms/friction/slider_crank_friction.toml");
  const size_t at = text.find(joint_line);
  EXPECT_NE(at, std::string::npos) << joint_line;
  const size_t end = text.find('\n', at);
  return text.replace(at, end - at, friction);
}

void expect_refused(const std::string& text, const std::string& key_text,
                    const std::string& message) {
  const size_t at = text.find(key_text);
  ASSERT_NE(at, std::string::npos) << key_text;
  const int line =
      1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
  try {
    (void)parse_definition(text, "friction.toml");
    ADD_FAILURE() << "accepted: " << key_text;
  } catch (const DefinitionError& e) {
    bool found = false;
    for (const Diagnostic& d : e.diagnostics())
      if (d.message.find(message) != std::string::npos) {
        found = true;
        EXPECT_EQ(d.where.line, line) << d.message;
      }
    EXPECT_TRUE(found) << e.what();
  }
}

TEST(Friction, WrongFrictionIsRefusedAtItsKey) {
  const std::string main_bearing = "friction = { coefficient = 0.02, radius = 0.12 }";
  for (const auto& [written, key, message] :
       std::vector<std::tuple<std::string, std::string, std::string>>{
           {"friction = { coefficient = -0.1, radius = 0.12 }", "friction",
            "must be zero or positive"},
           {"friction = { coefficient = 0.1 }", "friction", "needs 'radius'"},
           {"friction = { coefficient = 0.1, radius = 0 }", "friction",
            "'radius' in the friction of"},
           {"friction = { coefficient = 0.1, length = 0.2 }", "friction", "unknown key 'length'"},
           {"friction = { radius = 0.1 }", "friction", "without 'coefficient'"},
           {"friction = 0.1", "friction", "must be a table"},
           {"friction = { coefficient = 11, radius = 0.1 }", "friction", "too large"},
           {"friction = { coefficient = 0.1, radius = 5 }", "friction",
            "larger than the mechanism"},
           {"friction = { torque = -3 }", "friction", "must be zero or positive"},
       }) {
    SCOPED_TRACE(written);
    expect_refused(with_friction(main_bearing, written), written, message);
  }
  // Two journals on the crank crossing: 0.25 m and 0.12 m radius, 0.3 m apart.
  const std::string crossing = with_friction("friction = { coefficient = 0.02, radius = 0.09 }",
                                             "friction = { coefficient = 0.02, radius = 0.25 }");
  expect_refused(crossing, "radius = 0.25", "cross on link 'crank'");
  // Friction where crosslink has none: a pin in a slot, a gear pair's teeth.
  std::string slot = test::source_text("mechanisms/quick_return.toml");
  const std::string prismatic =
      "type = \"prismatic\"        # s = distance of B from C along the slot";
  const size_t pin = slot.find(prismatic);
  ASSERT_NE(pin, std::string::npos);
  slot.replace(pin, prismatic.size(), "type = \"pin_in_slot\"\nfriction = { coefficient = 0.1 }");
  expect_refused(slot, "friction = { coefficient = 0.1 }",
                 "friction on a pin in a slot is not modelled");
  std::string gears = test::source_text("mechanisms/gears/planetary_fixed_ring.toml");
  const size_t gear = gears.find("type = \"gear\"");
  ASSERT_NE(gear, std::string::npos);
  gears.insert(gears.find('\n', gear) + 1, "friction = { coefficient = 0.1 }\n");
  expect_refused(gears, "friction = { coefficient = 0.1 }", "its teeth have no friction");
  expect_refused(with_friction("friction = { coefficient = 0.02, radius = 0.12 }",
                               "friction = { coefficient = 0.1, static_coefficient = 0.05, "
                               "radius = 0.12 }"),
                 "static_coefficient = 0.05", "must be at least 'coefficient'");
}

// Forward dynamics with friction against closed forms. A block launched down a slope decelerates
// at g (mu cos(alpha) - sin(alpha)), stops at t = v0 / a after v0^2 / (2 a), and stays (the
// static coefficient holds it); the energy balance, with the friction's work, holds throughout.
TEST(FrictionDynamics, ABlockSlidesToRestAndSticksAsTheClosedFormSays) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/friction/block_sliding_to_rest.toml");
  const Simulation run = simulate(m);
  ASSERT_TRUE(run.ok) << run.message;
  const double g = 9.81, alpha = std::numbers::pi / 6, v0 = 3.0;
  const double a = g * (0.8 * std::cos(alpha) - std::sin(alpha));
  ASSERT_EQ(run.stops.size(), 1u);
  EXPECT_TRUE(run.held);
  EXPECT_NEAR(run.stops[0].first, v0 / a, 1e-9 * v0 / a);
  EXPECT_NEAR(run.stops[0].second, v0 * v0 / (2 * a), 1e-9 * v0 * v0 / (2 * a));
  const Trajectory& t = run.trajectory;
  for (int k = 0; k < t.samples(); ++k) {
    const double time = t.time(k);
    const double s = time < v0 / a ? v0 * time - 0.5 * a * time * time : v0 * v0 / (2 * a);
    EXPECT_NEAR(t.s(k, 0), s, 1e-9) << time;
    EXPECT_LT(run.energy_error(k), 1e-11) << time;
    EXPECT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << time;
    if (time < v0 / a)  // sliding: the friction force mu N up the slope (-s), N = m g cos(alpha)
      EXPECT_NEAR(t.friction(k, 0), -0.8 * 2 * g * std::cos(alpha), 1e-9);
    else  // held: what balances gravity along the slope, inside the static cone
      EXPECT_NEAR(t.friction(k, 0), -2 * g * std::sin(alpha), 1e-9);
    EXPECT_NEAR(t.fn(k, 0), 2 * g * std::cos(alpha), 1e-9) << time;
  }
}

// A block held at rest on the slope by static friction, pushed down it by an effort that rises
// 20 N a second to 20 N at 1 s, then held (effort_table): it breaks away when m g sin(alpha) +
// F(t) reaches mu_s N, at t* = (mu_s N - m g sin(alpha)) / 20, and then slides with
// a = ((mu_s - mu_k) N + 20 u) / m, u = t - t*: v = ((mu_s - mu_k) N u + 10 u^2) / m,
// s = ((mu_s - mu_k) N u^2 / 2 + 10 u^3 / 3) / m, and from 1 s on at the constant acceleration
// it has reached.
// Until t* its friction is what holds it, m g sin(alpha) + F(t) up the slope; the energy balance
// holds throughout, and the breakaway is an event and a stop (beside_stop).
TEST(FrictionDynamics, AHeldBlockBreaksAwayWhenARisingEffortOvercomesItsStaticFriction) {
  std::string text = test::source_text("mechanisms/friction/block_sliding_to_rest.toml");
  const std::string launched = "rate = 3";
  const size_t at = text.find(launched);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, launched.size(), "rate = 0\neffort_table = [[0, 0], [1, 20]]");
  const Mechanism m = parse_mechanism(text, "held_block.toml");
  const Simulation run = simulate(m);
  ASSERT_TRUE(run.ok) << run.message;
  const double mass = 2.0, g = 9.81, alpha = std::numbers::pi / 6;
  const double normal = mass * g * std::cos(alpha), along = mass * g * std::sin(alpha);
  const double breakaway = (0.9 * normal - along) / 20.0;
  const Trajectory& t = run.trajectory;
  ASSERT_EQ(t.held.size(), 1u);
  EXPECT_EQ(t.held[0].first, 0.0);
  EXPECT_NEAR(t.held[0].second, breakaway, 1e-12);
  EXPECT_FALSE(run.held);
  ASSERT_EQ(t.stops.size(), 2u);  // the start at rest and the breakaway
  EXPECT_NEAR(t.stops[1], breakaway, 1e-12);
  EXPECT_TRUE(std::ranges::any_of(t.events, [&](const Trajectory::Event& e) {
    return std::abs(e.driver - breakaway) < 1e-12 && e.message.find("breaks away") == 0;
  }));
  const double jump = (0.9 - 0.8) * normal;  // the friction's drop at the breakaway [N]
  const auto ramp = [&](double u, double& s, double& v) {
    s = (jump * u * u / 2 + 10.0 * u * u * u / 3) / mass;
    v = (jump * u + 10.0 * u * u) / mass;
  };
  int sliding = 0;
  for (int k = 0; k < t.samples(); ++k) {
    const double time = t.time(k), u = std::max(0.0, time - breakaway);
    const double u1 = 1.0 - breakaway, late = std::max(0.0, u - u1);
    double s = 0.0, v = 0.0;
    ramp(std::min(u, u1), s, v);
    const double a1 = (jump + 20.0 * u1) / mass;
    s += v * late + a1 * late * late / 2;
    v += a1 * late;
    EXPECT_NEAR(t.s(k, 0), s, 1e-9) << time;
    EXPECT_NEAR(t.sdot(k, 0), v, 1e-9) << time;
    EXPECT_LT(run.energy_error(k), 1e-11) << time;
    if (t.beside_stop(k)) continue;
    EXPECT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << time;
    if (time < breakaway) {  // held: what balances gravity and the effort along the slope
      EXPECT_NEAR(t.friction(k, 0), -(along + 20.0 * time), 1e-9) << time;
    } else {
      EXPECT_NEAR(t.friction(k, 0), -0.8 * normal, 1e-9) << time;
      ++sliding;
    }
  }
  EXPECT_GT(sliding, 100);
}

// A pendulum with a constant friction torque T at its pivot, released at rest: between two
// successive extremes phi_n, phi_n+1 (from the downward vertical, on opposite sides) the energy
// balance m g l (cos phi_n+1 - cos phi_n) = T (|phi_n| + |phi_n+1|) is exact; it is held at the
// first extreme where m g l |sin phi| <= T, and at none before.
TEST(FrictionDynamics, APendulumsSwingsDecayAsTheEnergyBalanceSays) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/friction/pendulum_pin_friction.toml");
  const Simulation run = simulate(m);
  ASSERT_TRUE(run.ok) << run.message;
  const double mgl = 1.0 * 9.81 * 0.5, torque = 0.2;
  ASSERT_GE(run.stops.size(), 10u);
  EXPECT_TRUE(run.held);
  const auto phi = [](double angle) { return angle + std::numbers::pi / 2; };
  for (size_t i = 0; i + 1 < run.stops.size(); ++i) {
    const double a = phi(run.stops[i].second), b = phi(run.stops[i + 1].second);
    EXPECT_LT(a * b, 0.0) << "extremes on opposite sides";
    EXPECT_NEAR(mgl * (std::cos(b) - std::cos(a)), torque * (std::abs(a) + std::abs(b)),
                1e-10 * mgl)
        << "half swing " << i;
    EXPECT_GT(mgl * std::abs(std::sin(a)), torque) << "it would have been held at " << a;
  }
  EXPECT_LE(mgl * std::abs(std::sin(phi(run.stops.back().second))), torque);
  for (int k = 0; k < run.trajectory.samples(); ++k) EXPECT_LT(run.energy_error(k), 1e-11);
  // Released at rest, it breaks away downwards (its angle falling): the first sample's friction
  // is the whole torque against that, though its rate is zero there.
  EXPECT_EQ(run.trajectory.status[0], PoseStatus::ok);
  EXPECT_DOUBLE_EQ(run.trajectory.friction(0, 0), torque);
  // The second integrator (Dormand-Prince, which carries its last derivative from step to
  // step) finds the same stops.
  SimulationOptions dopri5;
  dopri5.integrator = "dopri5";
  dopri5.tolerance = 1e-12;
  const Simulation other = simulate(m, dopri5);
  ASSERT_EQ(other.stops.size(), run.stops.size());
  for (size_t i = 0; i < run.stops.size(); ++i) {
    EXPECT_NEAR(other.stops[i].first, run.stops[i].first, 1e-8);
    EXPECT_NEAR(other.stops[i].second, run.stops[i].second, 1e-8);
  }
}

// A friction joint's relative acceleration (what a held joint's phase keeps at zero) is the time
// derivative of its relative rate: against central differences along the quick-return's exact
// motion at constant crank speed, on its slot (a slide on a turning guide) and on its ram's.
TEST(Friction, RelativeAccelerationIsTheRelativeRatesDerivative) {
  std::string text = test::source_text("mechanisms/quick_return.toml");
  for (const std::string point :
       {"slider = \"block\"\npoint = \"B\"\n", "slider = \"ram\"\npoint = \"E\"\n"}) {
    const size_t at = text.find(point);
    ASSERT_NE(at, std::string::npos);
    text.insert(at + point.size(), "friction = { coefficient = 0.1 }\n");
  }
  const Mechanism m = parse_mechanism(text, "rough_quick_return.toml");
  const NewtonSolver solver(m);
  const Kinetostatics forces(solver);
  const double speed = m.drivers[0].law.speed, h = 1e-5 / std::abs(speed);
  KinematicState state(m);
  ASSERT_EQ(solver.assemble(state).status, PoseStatus::ok);
  const auto at_time = [&](double t, double theta) {
    DriverState d = m.drivers[0].at_time(t);
    d.value = theta + speed * t;
    d.rate = speed;
    d.accel = 0.0;
    state.swept() = d;
    EXPECT_EQ(solver.solve(state).status, PoseStatus::ok);
  };
  int checked = 0;
  for (double theta = 0.1; theta < 6.2; theta += 0.7) {
    for (int f = 0; f < 2; ++f) {
      at_time(h, theta);
      const double ahead = forces.relative_rate(state, f);
      at_time(-h, theta);
      const double behind = forces.relative_rate(state, f);
      at_time(0.0, theta);
      const double exact = forces.relative_acceleration(state, f);
      const double scale = std::abs(speed) * std::abs(speed) * m.size();
      EXPECT_NEAR((ahead - behind) / (2 * h), exact, 1e-8 * scale) << theta << " joint " << f;
      ++checked;
    }
  }
  EXPECT_GT(checked, 10);
}

// Two free coordinates whose friction sticks and slips apart (mechanisms/friction/
// block_and_pendulum_two_coordinates.toml): nothing couples the block and the pendulum, so the
// block follows its closed form (as ABlockSlidesToRestAndSticksAsTheClosedFormSays) and the
// pendulum its run as the one coordinate of pendulum_pin_friction.toml (held to the energy
// relation between its extremes by APendulumsSwingsDecayAsTheEnergyBalanceSays): every sample,
// every friction, and every phase change at the instant each alone gives.
TEST(FrictionDynamics, TwoCoordinatesStickAndSlipApartAsEachDoesAlone) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                     "/mechanisms/friction/block_and_pendulum_two_coordinates.toml");
  const Mechanism alone = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                         "/mechanisms/friction/pendulum_pin_friction.toml");
  const Simulation run = simulate(m), pendulum = simulate(alone);
  ASSERT_TRUE(run.ok) << run.message;
  ASSERT_TRUE(pendulum.ok) << pendulum.message;
  const double g = 9.81, alpha = std::numbers::pi / 6, v0 = 3.0;
  const double a = g * (0.8 * std::cos(alpha) - std::sin(alpha)), stop = v0 / a;
  const Trajectory& t = run.trajectory;
  const Trajectory& p = pendulum.trajectory;
  ASSERT_EQ(t.samples(), p.samples());
  const Eigen::Index arm = 1;  // the moving links: block, arm
  for (int k = 0; k < t.samples(); ++k) {
    const double time = t.time(k);
    ASSERT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << time;
    const double s = time < stop ? v0 * time - 0.5 * a * time * time : v0 * v0 / (2 * a);
    EXPECT_NEAR(t.s(k, 0), s, 1e-9) << time;
    EXPECT_NEAR(t.friction(k, 0),
                time < stop ? -0.8 * 2 * g * std::cos(alpha) : -2 * g * std::sin(alpha), 1e-9)
        << time;
    EXPECT_NEAR(t.angle(k, arm), p.angle(k, 0), 1e-9) << time;
    EXPECT_NEAR(t.friction(k, 1), p.friction(k, 0), 1e-9) << time;
    EXPECT_LT(run.energy_error(k), 1e-11) << time;
  }
  // The phase changes: the block's stop and each of the pendulum's, and no other.
  std::vector<double> expected = {stop};
  for (const double at : p.stops) expected.push_back(at);
  std::sort(expected.begin(), expected.end());
  expected.erase(std::unique(expected.begin(), expected.end()), expected.end());
  ASSERT_EQ(t.stops.size(), expected.size());
  std::vector<double> found = t.stops;
  std::sort(found.begin(), found.end());
  for (size_t i = 0; i < found.size(); ++i) EXPECT_NEAR(found[i], expected[i], 1e-9) << i;
  // At rest as a whole only once the pendulum is held too (the block held before): the span an
  // engine's creep is measured over.
  EXPECT_TRUE(run.held);
  ASSERT_EQ(t.held.size(), 1u);
  ASSERT_EQ(p.held.size(), 1u);
  EXPECT_NEAR(t.held[0].first, p.held[0].first, 1e-9);
  EXPECT_EQ(t.held[0].second, t.time(t.samples() - 1));
}

// Coupled coordinates: the MBDyn double pendulum (mechanisms/dynamics/double_pendulum_mbdyn.toml)
// with friction circles at both pins and a constant 2 N m more at the elbow, whose phases
// change while the other coordinate moves on. Every sample keeps the friction law of its phase
// (sliding: mu r |R| + c against the joint's rate, |R| the sample's own reaction; held: the
// joint's relative rate zero and its friction inside the static limit), the energy balance with
// the friction's work closes, and the second integrator finds the same phase changes and motion.
TEST(FrictionDynamics, ARoughDoublePendulumKeepsEachPhasesLawAndAgreesWithASecondIntegrator) {
  std::string text = test::source_text("mechanisms/dynamics/double_pendulum_mbdyn.toml");
  for (const auto& [pin, friction] :
       {std::pair<std::string, std::string>{"point = \"O\"\n",
                                            "friction = { coefficient = 0.2, radius = 0.02 }\n"},
        {"point = \"B\"\n", "friction = { coefficient = 0.2, radius = 0.02, torque = 2 }\n"}}) {
    const size_t at = text.find(pin);
    ASSERT_NE(at, std::string::npos);
    text.insert(at + pin.size(), friction);
  }
  const Mechanism m = parse_mechanism(text, "rough_double_pendulum.toml");
  const Simulation run = simulate(m);
  ASSERT_TRUE(run.ok) << run.message;
  const Trajectory& t = run.trajectory;
  ASSERT_GE(t.stops.size(), 3u) << "phases that change while the other coordinate moves";
  const double constant[2] = {0.0, 2.0};
  int held = 0;
  for (int k = 0; k < t.samples(); ++k) {
    ASSERT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << t.time(k);
    EXPECT_LT(run.energy_error(k), 1e-10) << t.time(k);
    for (Eigen::Index f = 0; f < 2; ++f) {
      const double load = 0.2 * 0.02 * std::hypot(t.fx(k, f), t.fy(k, f)) + constant[f];
      const double rate = f == 0 ? t.omega(k, 0) : t.omega(k, 1) - t.omega(k, 0);
      if (std::abs(rate) > 1e-9) {
        EXPECT_NEAR(t.friction(k, f), rate > 0.0 ? -load : load, 1e-9 * load) << t.time(k);
      } else {
        EXPECT_LE(std::abs(t.friction(k, f)), load * (1 + 1e-12)) << t.time(k);
        if (k > 0) ++held;
      }
    }
  }
  EXPECT_GT(held, 20) << "the elbow held while the shoulder swings";
  SimulationOptions dopri5;
  dopri5.integrator = "dopri5";
  dopri5.tolerance = 1e-12;
  const Simulation other = simulate(m, dopri5);
  ASSERT_TRUE(other.ok) << other.message;
  ASSERT_EQ(other.trajectory.stops.size(), t.stops.size());
  for (size_t i = 0; i < t.stops.size(); ++i)
    EXPECT_NEAR(other.trajectory.stops[i], t.stops[i], 1e-7) << i;
  for (int k = 0; k < t.samples(); ++k)
    for (Eigen::Index l = 0; l < 2; ++l)
      EXPECT_NEAR(other.trajectory.angle(k, l), t.angle(k, l), 1e-7) << t.time(k);
}

}  // namespace
}  // namespace crosslink
