// Every joint type and driver of the constraint layout (analytic/model/constraints.h) through every
// level of its definition, each against a check that does not use it (as Pinocchio runs every
// joint through every algorithm in one test):
//   position      each row is the geometry it stands for, computed here with Eigen's rotations
//                 (the points' gap, the pin's distance off its line, the relative angle, the
//                 driver's angle or displacement), zero where the joint is closed by construction;
//   angle rows    the rows flagged as angles do not change when every length is in mm, the others
//                 grow 1000 times;
//   Jacobian      central differences of the position rows, coordinate by coordinate;
//   velocity      J qdot against the time derivative of the rows along an exact trajectory;
//   acceleration  the velocity-squared terms against the time derivative of the velocity
//                 constraint J(q(t)) qdot(t) along it, less J qddot; the right-hand sides
//                 assembled from the drivers' states.
// The trajectory is a quadratic in time, q(t) = q0 + v t + a t^2 / 2, so qdot and qddot are exact.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <memory>
#include <numbers>
#include <set>

#include "analytic/model/cam.h"
#include "analytic/model/constraints.h"

namespace crosslink {
namespace {

using Kind = ConstraintRows::Kind;

Point point(const char* name, double x, double y) {
  return {name, Eigen::Vector2d(x, y), {}};
}

// Ground G and three moving links A, B, C with every joint type, the ground on either side of a
// slide: revolute G-A, revolute A-B, prismatic A-C (A the guide), pin-in-slot G-B (G the slot),
// prismatic G-C, a gear pair A-C about B, A as a pinion on the rack C of G-C, C's pin S in an
// arc of A about its point O, B's point E a roller on a cam A about O, and C's face a flat-faced
// follower on a cam B about its point B, and C's point S in a spline slot of A through its
// points Q1 ... Q4. Not a mechanism of mobility one: the layout does not
// need a square system. The driver is of `type`; `scale` multiplies every length (1000: the
// same mechanism in mm).
Mechanism every_kind(DriverType type, double scale = 1.0) {
  Mechanism m;
  const double s = scale;
  Link ground{"G", true, {point("O", 0, 0), point("P", 0.3 * s, -0.1 * s)}, {}, {}, {}, {}, {}};
  ground.lines.push_back(
      {"slot", Eigen::Vector2d(0.1 * s, 0.2 * s), Eigen::Vector2d(0.6, 0.8), {}});
  ground.lines.push_back({"rail",
                          Eigen::Vector2d(-0.2 * s, 0.05 * s),
                          Eigen::Vector2d(std::cos(2.0), std::sin(2.0)),
                          {}});
  Link a{"A",
         false,
         {point("O", 0.05 * s, -0.02 * s), point("B", 0.7 * s, 0.1 * s),
          point("Q1", -0.1 * s, -0.3 * s), point("Q2", 0.1 * s, -0.2 * s),
          point("Q3", 0.3 * s, -0.32 * s), point("Q4", 0.6 * s, -0.25 * s)},
         {},
         {},
         {},
         {},
         {}};
  a.lines.push_back({"guide",
                     Eigen::Vector2d(0.2 * s, -0.1 * s),
                     Eigen::Vector2d(std::cos(-0.4), std::sin(-0.4)),
                     {}});
  Link b{"B", false, {point("B", -0.1 * s, 0.03 * s), point("E", 0.4 * s, 0.25 * s)}, {}, {}, {},
         {},  {}};
  Link c{"C", false, {point("S", 0.02 * s, 0.09 * s)}, {}, {}, {}, {}, {}};
  c.lines.push_back({"face",
                     Eigen::Vector2d(-0.03 * s, 0.04 * s),
                     Eigen::Vector2d(std::cos(0.3), std::sin(0.3)),
                     {}});
  m.links = {ground, a, b, c};
  auto joint = [](const char* name, JointType t, int la, int lb, int pa, int pb, int line,
                  double angle) {
    Joint j;
    j.name = name;
    j.type = t;
    j.link_a = la;
    j.link_b = lb;
    j.point_a = pa;
    j.point_b = pb;
    j.line = line;
    j.relative_angle = angle;
    return j;
  };
  m.joints = {joint("GA", JointType::revolute, 0, 1, 0, 0, -1, 0.0),
              joint("AB", JointType::revolute, 1, 2, 1, 0, -1, 0.0),
              joint("AC", JointType::prismatic, 1, 3, -1, 0, 0, 0.35),
              joint("GB", JointType::pin_in_slot, 0, 2, -1, 1, 0, 0.0),
              joint("GC", JointType::prismatic, 0, 3, -1, 0, 1, -1.1)};
  // A gear pair A-C about the moving carrier B, and a rack and pinion: A rolling on the rack C of
  // slide GC (guide G).
  Joint gear = joint("ACg", JointType::gear, 1, 3, -1, -1, -1, 0.0);
  gear.carrier = 2;
  gear.ratio = -1.7;
  gear.phase = 0.3;
  Joint rack = joint("GCr", JointType::rack_pinion, 1, 3, -1, -1, -1, 0.0);
  rack.carrier = 0;
  rack.slide = 4;
  rack.ratio = 0.23 * s;
  rack.phase = -0.05 * s;
  Joint arc = joint("ACa", JointType::pin_in_arc, 1, 3, -1, 0, -1, 0.0);
  arc.centre_a = 0;
  arc.radius_a = 0.21 * s;
  m.joints.push_back(gear);
  m.joints.push_back(rack);
  m.joints.push_back(arc);
  // Cams cut for a cycloidal rise and return: an offset roller and a flat face.
  const cam::MotionProgram rise(0.0, {{cam::Law::cycloidal, std::numbers::pi, 0.05 * s},
                                      {cam::Law::cycloidal, std::numbers::pi, 0.0}});
  cam::Follower roller{cam::FollowerKind::roller, false, 0.1 * s, 0.02 * s, 0.01 * s, {}, 0.0};
  cam::Follower face{cam::FollowerKind::flat_faced, false, 0.15 * s, 0.0, 0.0, {}, 0.0};
  Joint pitch = joint("ABc", JointType::cam, 1, 2, -1, 1, -1, 0.0);
  pitch.centre_a = 0;
  pitch.contour = std::make_shared<const cam::Contour>(rise, roller);
  Joint flat = joint("BCc", JointType::cam, 2, 3, -1, -1, 0, 0.0);
  flat.centre_a = 0;
  flat.contour = std::make_shared<const cam::Contour>(rise, face);
  m.joints.push_back(pitch);
  m.joints.push_back(flat);
  // The spline over its chord Q1-Q4: each point's place along it and height to its left.
  Joint spline = joint("ACs", JointType::pin_in_spline, 1, 3, -1, 0, -1, 0.0);
  spline.through = {2, 3, 4, 5};
  const Eigen::Vector2d q1 = a.points[2].local, chord = (a.points[5].local - q1).normalized();
  std::vector<double> along, height;
  for (int p : spline.through) {
    const Eigen::Vector2d d = a.points[static_cast<size_t>(p)].local - q1;
    along.push_back(chord.dot(d));
    height.push_back(chord.x() * d.y() - chord.y() * d.x());
  }
  spline.chord_start = q1;
  spline.chord_axis = chord;
  spline.slot = std::make_shared<const NaturalSpline>(along, height);
  m.joints.push_back(spline);
  Driver d;
  d.type = type;
  switch (type) {
    case DriverType::joint_angle:  // the arm B -> E of B, measured in A's frame at joint AB
      d.joint = 1;
      d.link = 2;
      d.from = 0;
      d.to = 1;
      break;
    case DriverType::slider:  // C along A's guide
      d.joint = 2;
      break;
    case DriverType::link_angle:  // A's arm O -> B from the ground
      d.link = 1;
      d.from = 0;
      d.to = 1;
      break;
  }
  m.drivers[0] = d;
  return m;
}

// A generic pose, rate and acceleration (nothing closed, no angle a multiple of 90 degrees).
Eigen::VectorXd pose(double scale = 1.0) {
  Eigen::VectorXd q(9);
  q << 0.11 * scale, -0.07 * scale, 0.6, 0.5 * scale, 0.2 * scale, -0.9, 0.3 * scale, -0.25 * scale,
      1.7;
  return q;
}
Eigen::VectorXd rate() {
  Eigen::VectorXd v(9);
  v << 0.3, -0.8, 1.9, -0.4, 0.7, -2.3, 1.1, 0.2, 0.8;
  return v;
}
Eigen::VectorXd accel() {
  Eigen::VectorXd a(9);
  a << -1.2, 0.5, 3.1, 0.9, -0.3, 1.4, -2.2, 0.6, -1.7;
  return a;
}

// A point of moving link k (-1: the ground) in world coordinates, by Eigen's rotation.
Eigen::Vector2d world(const Eigen::VectorXd& q, int k, const Eigen::Vector2d& local) {
  if (k < 0) return local;
  return q.segment<2>(3 * k) + Eigen::Rotation2Dd(q(3 * k + 2)) * local;
}
Eigen::Vector2d world_direction(const Eigen::VectorXd& q, int k, const Eigen::Vector2d& local) {
  return k < 0 ? local : Eigen::Vector2d(Eigen::Rotation2Dd(q(3 * k + 2)) * local);
}
double angle_of(const Eigen::VectorXd& q, int k) {
  return k < 0 ? 0.0 : q(3 * k + 2);
}
double cross(const Eigen::Vector2d& u, const Eigen::Vector2d& w) {
  return u.x() * w.y() - u.y() * w.x();
}

Eigen::VectorXd position(const ConstraintLayout& layout, const Eigen::VectorXd& q) {
  Eigen::VectorXd phi(layout.rows());
  layout.position(LinkFrames{q}, phi);
  return phi;
}
Eigen::MatrixXd jacobian(const ConstraintLayout& layout, const Eigen::VectorXd& q) {
  Eigen::MatrixXd jac(layout.rows(), q.size());
  layout.jacobian(LinkFrames{q}, jac);
  return jac;
}

class EveryKind : public testing::TestWithParam<DriverType> {};

// Each joint type and driver appears in the layout, in joint order, then the driver.
TEST_P(EveryKind, LayoutHasEveryKindInOrder) {
  const Mechanism m = every_kind(GetParam());
  const ConstraintLayout layout(m);
  std::set<Kind> kinds;
  int row = 0;
  for (const ConstraintRows& c : layout.blocks()) {
    EXPECT_EQ(c.first_row, row);
    row += c.rows();
    kinds.insert(c.kind);
  }
  EXPECT_EQ(row, layout.rows());
  EXPECT_EQ(layout.rows(), 2 + 2 + 2 + 1 + 2 + 1 + 1 + 1 + 1 + 1 + 1 + 1);
  EXPECT_EQ(layout.joint_row_count(), layout.rows() - 1);
  EXPECT_EQ(layout.driver_count(), 1);
  EXPECT_EQ(layout.driver_row(0), layout.rows() - 1);
  EXPECT_TRUE(kinds.count(Kind::revolute) && kinds.count(Kind::prismatic) &&
              kinds.count(Kind::pin_in_slot) && kinds.count(Kind::gear) &&
              kinds.count(Kind::rack_pinion) && kinds.count(Kind::pin_in_arc) &&
              kinds.count(Kind::cam_pitch) && kinds.count(Kind::cam_face) &&
              kinds.count(Kind::pin_in_spline));
  EXPECT_TRUE(
      kinds.count(GetParam() == DriverType::slider ? Kind::slider_driver : Kind::angle_driver));
}

// Each row is the geometry it stands for, computed here without the layout.
TEST_P(EveryKind, PositionRowsAreTheirGeometry) {
  const Mechanism m = every_kind(GetParam());
  const ConstraintLayout layout(m);
  const Eigen::VectorXd q = pose();
  const Eigen::VectorXd phi = position(layout, q);
  Eigen::VectorXd expected(layout.rows());
  int row = 0;
  auto slide_offset = [&](const Joint& j, bool along) {
    const int ka = m.moving_index(j.link_a), kb = m.moving_index(j.link_b);
    const Line& line = m.links[j.link_a].lines[j.line];
    const Eigen::Vector2d pin = world(q, kb, m.links[j.link_b].points[j.point_b].local);
    const Eigen::Vector2d d = pin - world(q, ka, line.origin);
    const Eigen::Vector2d u = world_direction(q, ka, line.direction);
    return along ? u.dot(d) : cross(u, d);  // along the line, or its left normal
  };
  for (const Joint& j : m.joints) {
    const int ka = m.moving_index(j.link_a), kb = m.moving_index(j.link_b);
    const double turned_a = angle_of(q, ka) - angle_of(q, m.moving_index(j.carrier));
    if (j.type == JointType::gear) {  // the turns relative to the carrier, in the ratio
      expected(row++) =
          turned_a + j.ratio * (angle_of(q, kb) - angle_of(q, m.moving_index(j.carrier))) - j.phase;
      continue;
    }
    if (j.type == JointType::rack_pinion) {  // the rack's travel, the pinion's turn times r
      expected(row++) = slide_offset(m.joints[j.slide], true) - j.ratio * turned_a - j.phase;
      continue;
    }
    if (j.type == JointType::revolute) {
      expected.segment<2>(row) = world(q, ka, m.links[j.link_a].points[j.point_a].local) -
                                 world(q, kb, m.links[j.link_b].points[j.point_b].local);
      row += 2;
      continue;
    }
    if (j.type == JointType::pin_in_arc) {  // the pin's distance from the centre, less the radius
      expected(row++) = (world(q, kb, m.links[j.link_b].points[j.point_b].local) -
                         world(q, ka, m.links[j.link_a].points[j.centre_a].local))
                            .norm() -
                        j.radius_a;
      continue;
    }
    if (j.type == JointType::pin_in_spline) {  // the pin's height over the chord, less the curve's
      const Eigen::Vector2d q1 = world(q, ka, m.links[j.link_a].points[j.through.front()].local);
      const Eigen::Vector2d chord =
          (world(q, ka, m.links[j.link_a].points[j.through.back()].local) - q1).normalized();
      const Eigen::Vector2d d = world(q, kb, m.links[j.link_b].points[j.point_b].local) - q1;
      expected(row++) = cross(chord, d) - j.slot->at(chord.dot(d)).y;
      continue;
    }
    if (j.type == JointType::cam) {  // the follower's distance from the centre, less the profile's
      const Eigen::Vector2d centre = world(q, ka, m.links[j.link_a].points[j.centre_a].local);
      if (j.contour->flat_faced()) {  // along the face's normal, at the normal's angle
        const Line& face = m.links[j.link_b].lines[j.line];
        const Eigen::Vector2d u = world_direction(q, kb, face.direction);
        const Eigen::Vector2d n(-u.y(), u.x());
        expected(row++) = n.dot(world(q, kb, face.origin) - centre) -
                          j.contour->at(std::atan2(n.y(), n.x()) - angle_of(q, ka)).value;
      } else {  // along the ray to the roller's centre, at the ray's angle
        const Eigen::Vector2d d = world(q, kb, m.links[j.link_b].points[j.point_b].local) - centre;
        expected(row++) =
            d.norm() - j.contour->at(std::atan2(d.y(), d.x()) - angle_of(q, ka)).value;
      }
      continue;
    }
    expected(row++) = slide_offset(j, false);
    if (j.type == JointType::prismatic)
      expected(row++) = angle_of(q, kb) - angle_of(q, ka) - j.relative_angle;
  }
  const Driver& d = m.drivers[0];
  if (d.type == DriverType::slider) {
    expected(row) = slide_offset(m.joints[d.joint], true);
  } else {
    const Link& link = m.links[d.link];
    const int k = m.moving_index(d.link);
    const Eigen::Vector2d arm =
        world(q, k, link.points[d.to].local) - world(q, k, link.points[d.from].local);
    const int reference =
        d.type == DriverType::joint_angle ? m.moving_index(m.joints[d.joint].link_a) : -1;
    // The arm's world angle from the reference link's: equal modulo a turn.
    const double measured = std::atan2(arm.y(), arm.x()) - angle_of(q, reference);
    expected(row) = phi(row) + std::remainder(measured - phi(row), 2.0 * std::numbers::pi);
  }
  EXPECT_LT((phi - expected).lpNorm<Eigen::Infinity>(), 1e-14) << phi.transpose() << "\n"
                                                               << expected.transpose();
}

// Where each joint is closed by construction, its rows are zero: B's point on A's, C on A's guide
// at A's angle plus the held angle, and so on.
TEST_P(EveryKind, ClosedJointsHaveZeroRows) {
  const Mechanism m = every_kind(GetParam());
  const ConstraintLayout layout(m);
  for (const Joint& j : m.joints) {
    // Link b placed so that this joint closes, from a generic pose.
    Eigen::VectorXd q = pose();
    const int ka = m.moving_index(j.link_a), kb = m.moving_index(j.link_b);
    if (j.is_gearing()) {  // turn the first link until the pitch circles mesh
      const double carrier = angle_of(q, m.moving_index(j.carrier));
      if (j.type == JointType::gear) {
        q(3 * ka + 2) = carrier + j.phase - j.ratio * (angle_of(q, kb) - carrier);
      } else {  // the guide is the ground: the pinion turns by (travel - phase) / r
        const Joint& slide = m.joints[j.slide];
        const Line& rail = m.links[slide.link_a].lines[slide.line];
        const double travel =
            (world(q, kb, m.links[j.link_b].points[slide.point_b].local) - rail.origin)
                .dot(rail.direction);
        q(3 * ka + 2) = (travel - j.phase) / j.ratio;
      }
      const Eigen::VectorXd phi = position(layout, q);
      EXPECT_NEAR(phi(layout.joint(m.find_joint(j.name)).first_row), 0.0, 1e-15) << j.name;
      continue;
    }
    const bool face = j.type == JointType::cam && j.contour->flat_faced();
    const Eigen::Vector2d pb =
        face ? m.links[j.link_b].lines[j.line].origin : m.links[j.link_b].points[j.point_b].local;
    Eigen::Vector2d target;
    if (j.type == JointType::cam) {  // the profile at the angle 0.8 of the cam's frame
      const double psi = 0.8, turned = angle_of(q, ka) + psi;
      const Eigen::Vector2d ray(std::cos(turned), std::sin(turned));
      const Eigen::Vector2d centre = world(q, ka, m.links[j.link_a].points[j.centre_a].local);
      target = centre + j.contour->at(psi).value * ray;
      if (face) {  // the face square to the ray, its origin 0.37 along it
        const Line& line = m.links[j.link_b].lines[j.line];
        q(3 * kb + 2) = turned - std::atan2(line.direction.x(), -line.direction.y());
        target += 0.37 * world_direction(q, kb, line.direction);
      }
    } else if (j.type == JointType::revolute) {
      target = world(q, ka, m.links[j.link_a].points[j.point_a].local);
    } else if (j.type == JointType::pin_in_arc) {
      target = world(q, ka, m.links[j.link_a].points[j.centre_a].local) +
               j.radius_a * Eigen::Vector2d(std::cos(0.8), std::sin(0.8));
    } else if (j.type == JointType::pin_in_spline) {  // on the curve 0.37 along its chord
      const Eigen::Vector2d q1 = world(q, ka, m.links[j.link_a].points[j.through.front()].local);
      const Eigen::Vector2d chord =
          (world(q, ka, m.links[j.link_a].points[j.through.back()].local) - q1).normalized();
      target = q1 + 0.37 * chord + j.slot->at(0.37).y * Eigen::Vector2d(-chord.y(), chord.x());
    } else {
      const Line& line = m.links[j.link_a].lines[j.line];
      if (j.type == JointType::prismatic) q(3 * kb + 2) = angle_of(q, ka) + j.relative_angle;
      target = world(q, ka, line.origin) + 0.37 * world_direction(q, ka, line.direction);
    }
    q.segment<2>(3 * kb) = target - Eigen::Rotation2Dd(q(3 * kb + 2)) * pb;
    const Eigen::VectorXd phi = position(layout, q);
    const ConstraintRows& c = layout.joint(m.find_joint(j.name));
    for (int r = 0; r < c.rows(); ++r)
      EXPECT_NEAR(phi(c.first_row + r), 0.0, 1e-15) << j.name << " row " << r;
  }
}

// The angle rows keep their value when every length is in mm; the other rows scale with them.
TEST_P(EveryKind, AngleRowsAreTheOnesThatDoNotScale) {
  const ConstraintLayout metres(every_kind(GetParam())), millimetres(every_kind(GetParam(), 1e3));
  const Eigen::VectorXd phi = position(metres, pose()), phi_mm = position(millimetres, pose(1e3));
  int angles = 0;
  for (int r = 0; r < metres.rows(); ++r) {
    ASSERT_GT(std::abs(phi(r)), 1e-3) << "row " << r << " must be away from zero to tell";
    const double ratio = phi_mm(r) / phi(r);
    EXPECT_NEAR(ratio, metres.angle_row(r) ? 1.0 : 1e3, 1e-9 * ratio) << "row " << r;
    EXPECT_EQ(metres.angle_row(r), millimetres.angle_row(r));
    angles += metres.angle_row(r);
  }
  // The prismatics' angles and the gear pair's.
  EXPECT_EQ(angles, 3 + (GetParam() == DriverType::slider ? 0 : 1));
}

// The Jacobian against central differences of the position rows (step 1e-6: truncation ~1e-12,
// round-off ~1e-10).
TEST_P(EveryKind, JacobianIsDerivativeOfPosition) {
  const ConstraintLayout layout(every_kind(GetParam()));
  const Eigen::VectorXd q = pose();
  const Eigen::MatrixXd analytic = jacobian(layout, q);
  const double h = 1e-6;
  for (int i = 0; i < q.size(); ++i) {
    Eigen::VectorXd plus = q, minus = q;
    plus(i) += h;
    minus(i) -= h;
    const Eigen::VectorXd numeric = (position(layout, plus) - position(layout, minus)) / (2 * h);
    EXPECT_LT((analytic.col(i) - numeric).lpNorm<Eigen::Infinity>(), 1e-8) << "column " << i;
  }
}

// Along the exact trajectory q(t): J qdot is the rows' time derivative, and the velocity-squared
// terms are d/dt (J(q) qdot) - J qddot.
TEST_P(EveryKind, VelocityAndAccelerationAlongATrajectory) {
  const ConstraintLayout layout(every_kind(GetParam()));
  const Eigen::VectorXd q0 = pose(), v = rate(), a = accel();
  auto q_at = [&](double t) { return Eigen::VectorXd(q0 + v * t + 0.5 * a * t * t); };
  auto qdot_at = [&](double t) { return Eigen::VectorXd(v + a * t); };
  auto velocity_constraint = [&](double t) {
    return Eigen::VectorXd(jacobian(layout, q_at(t)) * qdot_at(t));
  };
  const double h = 1e-5;
  const Eigen::VectorXd phi_dot =
      (position(layout, q_at(h)) - position(layout, q_at(-h))) / (2 * h);
  EXPECT_LT((velocity_constraint(0.0) - phi_dot).lpNorm<Eigen::Infinity>(), 1e-8);

  const Eigen::VectorXd numeric =
      (velocity_constraint(h) - velocity_constraint(-h)) / (2 * h) - jacobian(layout, q0) * a;
  Eigen::VectorXd squared(layout.rows());
  for (const ConstraintRows& c : layout.blocks()) c.velocity_squared(LinkFrames{q0}, v, squared);
  EXPECT_LT((squared - numeric).lpNorm<Eigen::Infinity>(), 1e-7) << squared.transpose() << "\n"
                                                                 << numeric.transpose();

  // The right-hand sides: the driver's rate and acceleration in its row, the rest from the terms.
  const DriverState driver{0.0, 0.0, 2.5, -4.0};
  Eigen::VectorXd nu(layout.rows()), gamma(layout.rows());
  layout.velocity_rhs({&driver, 1}, nu);
  layout.acceleration_rhs(LinkFrames{q0}, v, {&driver, 1}, gamma);
  for (int r = 0; r < layout.rows(); ++r) {
    const bool driver_row = r == layout.driver_row(0);
    EXPECT_EQ(nu(r), driver_row ? driver.rate : 0.0);
    EXPECT_NEAR(gamma(r), -numeric(r) + (driver_row ? driver.accel : 0.0), 1e-7);
  }
}

// Along the same trajectory (q''' = 0) the jerk terms are d/dt of the second derivative
// J(q) qddot + (velocity-squared terms at q, qdot); the right-hand side adds the driver's jerk.
TEST_P(EveryKind, JerkTermsAreTheSecondDerivativesRate) {
  const ConstraintLayout layout(every_kind(GetParam()));
  const Eigen::VectorXd q0 = pose(), v = rate(), a = accel();
  auto second = [&](double t) {
    const Eigen::VectorXd q = q0 + v * t + 0.5 * a * t * t, qdot = v + a * t;
    Eigen::VectorXd squared(layout.rows());
    for (const ConstraintRows& c : layout.blocks())
      c.velocity_squared(LinkFrames{q}, qdot, squared);
    return Eigen::VectorXd(jacobian(layout, q) * a + squared);
  };
  const double h = 1e-5;
  const Eigen::VectorXd numeric = (second(h) - second(-h)) / (2 * h);
  Eigen::VectorXd terms(layout.rows());
  for (const ConstraintRows& c : layout.blocks()) c.jerk_terms(LinkFrames{q0}, v, a, terms);
  EXPECT_LT((terms - numeric).lpNorm<Eigen::Infinity>(), 1e-6) << terms.transpose() << "\n"
                                                               << numeric.transpose();
  EXPECT_GT(numeric.lpNorm<Eigen::Infinity>(), 1e-3);  // terms to check
  const DriverState driver{0.0, 0.0, 2.5, -4.0, 7.0};
  Eigen::VectorXd eta(layout.rows());
  layout.jerk_rhs(LinkFrames{q0}, v, a, {&driver, 1}, eta);
  for (int r = 0; r < layout.rows(); ++r)
    EXPECT_NEAR(eta(r), -terms(r) + (r == layout.driver_row(0) ? driver.jerk : 0.0), 1e-15);
}

INSTANTIATE_TEST_SUITE_P(Drivers, EveryKind,
                         testing::Values(DriverType::joint_angle, DriverType::slider,
                                         DriverType::link_angle),
                         [](const testing::TestParamInfo<DriverType>& info) {
                           return std::string(to_string(info.param));
                         });

}  // namespace
}  // namespace crosslink
