#include "analytic/model/constraints.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace crosslink {
namespace {

using Kind = ConstraintRows::Kind;

// The angle of a q's link k (0 for the ground, k < 0).
double angle_of(const Eigen::VectorXd& q, int k) {
  return k >= 0 ? q(3 * k + 2) : 0.0;
}

// Writes d(value)/dq of `p = w.(P_b - O_a)` (see planar.h) into row `row` of the Jacobian.
template <class Matrix>
void projection_gradient(const LinkFrames& frames, int ka, const Eigen::Vector2d& origin_a,
                         const Eigen::Vector2d& axis_a, int kb, const Eigen::Vector2d& point_b,
                         Matrix& jac, int row) {
  const BodyMotion a = frames.of(ka);
  const BodyMotion b = frames.of(kb);
  const Eigen::Vector2d w = a.turn(axis_a);
  const Eigen::Vector2d d = b.position(point_b) - a.position(origin_a);
  if (ka >= 0) {
    jac(row, 3 * ka) = -w.x();
    jac(row, 3 * ka + 1) = -w.y();
    jac(row, 3 * ka + 2) = perp(w).dot(d) - w.dot(perp(a.turn(origin_a)));
  }
  if (kb >= 0) {
    jac(row, 3 * kb) += w.x();
    jac(row, 3 * kb + 1) += w.y();
    jac(row, 3 * kb + 2) += w.dot(perp(b.turn(point_b)));
  }
}

// A pin in an arc: the length and direction of the pin P_b's offset from the arc's centre C_a
// (the direction taken along x where the pin is at the centre, so that nothing divides by zero).
struct ArcOffset {
  Eigen::Vector2d e;
  double length;
};
ArcOffset arc_offset(const BodyMotion& a, const Eigen::Vector2d& centre_a, const BodyMotion& b,
                     const Eigen::Vector2d& pin_b) {
  const Eigen::Vector2d d = b.position(pin_b) - a.position(centre_a);
  const double l = d.norm();
  return {l > 0.0 ? Eigen::Vector2d(d / l) : Eigen::Vector2d::UnitX(), l};
}

// Writes d|P_b - C_a|/dq = e . (dP_b/dq - dC_a/dq) into row `row`: the entries
// projection_gradient writes, in its order (e turns with d, not with link a).
template <class Matrix>
void arc_gradient(const LinkFrames& frames, int ka, const Eigen::Vector2d& centre_a, int kb,
                  const Eigen::Vector2d& pin_b, Matrix& jac, int row) {
  const BodyMotion a = frames.of(ka);
  const BodyMotion b = frames.of(kb);
  const Eigen::Vector2d e = arc_offset(a, centre_a, b, pin_b).e;
  if (ka >= 0) {
    jac(row, 3 * ka) = -e.x();
    jac(row, 3 * ka + 1) = -e.y();
    jac(row, 3 * ka + 2) = -e.dot(perp(a.turn(centre_a)));
  }
  if (kb >= 0) {
    jac(row, 3 * kb) += e.x();
    jac(row, 3 * kb + 1) += e.y();
    jac(row, 3 * kb + 2) += e.dot(perp(b.turn(pin_b)));
  }
}

// A pin in a spline slot: its place along the chord (x) and its height over it (y), with their
// first two time derivatives (at the frames' rates), and the curve there.
struct SlotOffset {
  Projection x, y;
  SplinePoint curve;
};
SlotOffset slot_offset(const ConstraintRows& c, const BodyMotion& a, const BodyMotion& b) {
  SlotOffset o{project(a, c.point_a, c.axis, b, c.point_b),
               project(a, c.point_a, perp(c.axis), b, c.point_b),
               {}};
  o.curve = c.slot->at(o.x.value);
  return o;
}

// A knife edge or roller's centre P_b on the pitch curve rho(psi) of cam a about C_a, at the
// polar angle psi = angle(P_b - C_a) - theta_a of the cam's frame.
double pitch_angle(const BodyMotion& a, const ArcOffset& o) {
  return std::atan2(o.e.y(), o.e.x()) - a.theta;
}

// The gradient of |d| - rho(psi) in d = P_b - C_a: with e = d / |d|, dpsi = perp(e) . dd / |d| -
// dtheta_a, so it is g = e - rho' perp(e) / |d| (the pitch curve's normal at P_b), and theta_a
// gains rho'; with rho itself there (`rho`).
struct PitchGradient {
  Eigen::Vector2d g;
  cam::Polar rho;
};
PitchGradient pitch_gradient(const ConstraintRows& c, const BodyMotion& a, const BodyMotion& b) {
  const ArcOffset o = arc_offset(a, c.point_a, b, c.point_b);
  const cam::Polar rho = c.contour->at(pitch_angle(a, o));
  return {o.e - (o.length > 0.0 ? rho.d / o.length : 0.0) * perp(o.e), rho};
}

// Writes d(|d| - rho(psi))/dq.
template <class Matrix>
void pitch_gradient(const ConstraintRows& c, const LinkFrames& frames, Matrix& jac, int row) {
  const BodyMotion a = frames.of(c.a);
  const BodyMotion b = frames.of(c.b);
  const PitchGradient p = pitch_gradient(c, a, b);
  const Eigen::Vector2d& g = p.g;
  const double slope = p.rho.d;
  if (c.a >= 0) {
    jac(row, 3 * c.a) = -g.x();
    jac(row, 3 * c.a + 1) = -g.y();
    jac(row, 3 * c.a + 2) = slope - g.dot(perp(a.turn(c.point_a)));
  }
  if (c.b >= 0) {
    jac(row, 3 * c.b) += g.x();
    jac(row, 3 * c.b + 1) += g.y();
    jac(row, 3 * c.b + 2) += g.dot(perp(b.turn(c.point_b)));
  }
}

// A flat face of follower b, through O_b with the normal n_b away from the cam, tangent to the
// profile whose support function is h(alpha), alpha the normal's angle in the cam's frame.
struct FaceContact {
  Eigen::Vector2d n, offset;  // n_b, and O_b - C_a
  double alpha;
};
FaceContact face_contact(const ConstraintRows& c, const BodyMotion& a, const BodyMotion& b) {
  return {b.turn(c.axis), b.position(c.point_b) - a.position(c.point_a),
          b.theta + c.angle - a.theta};
}

// Writes d(n . (O_b - C_a) - h(alpha))/dq, alpha = theta_b + angle - theta_a.
template <class Matrix>
void face_gradient(const ConstraintRows& c, const LinkFrames& frames, Matrix& jac, int row) {
  const BodyMotion a = frames.of(c.a);
  const BodyMotion b = frames.of(c.b);
  const FaceContact f = face_contact(c, a, b);
  const double slope = c.contour->at(f.alpha).d;
  if (c.a >= 0) {
    jac(row, 3 * c.a) = -f.n.x();
    jac(row, 3 * c.a + 1) = -f.n.y();
    jac(row, 3 * c.a + 2) = slope - f.n.dot(perp(a.turn(c.point_a)));
  }
  if (c.b >= 0) {
    jac(row, 3 * c.b) += f.n.x();
    jac(row, 3 * c.b + 1) += f.n.y();
    jac(row, 3 * c.b + 2) += perp(f.n).dot(f.offset) + f.n.dot(perp(b.turn(c.point_b))) - slope;
  }
}

// A revolute joint's two rows on link k: sign (I, perp(turn(point))), the identity's zeros
// written too (as -I writes -0), so every holder gets the same entries.
template <class Matrix>
void revolute_gradient(const LinkFrames& frames, int k, const Eigen::Vector2d& point, double sign,
                       Matrix& jac, int row) {
  const Eigen::Vector2d arm = perp(frames.of(k).turn(point));
  jac(row, 3 * k) = sign * 1.0;
  jac(row + 1, 3 * k) = sign * 0.0;
  jac(row, 3 * k + 1) = sign * 0.0;
  jac(row + 1, 3 * k + 1) = sign * 1.0;
  jac(row, 3 * k + 2) = sign > 0 ? arm.x() : -arm.x();
  jac(row + 1, 3 * k + 2) = sign > 0 ? arm.y() : -arm.y();
}

// The block's rows of dPhi/dq, entry by entry, into a dense matrix or the layout's pattern.
template <class Matrix>
void write_jacobian(const ConstraintRows& c, const LinkFrames& frames, Matrix& jac) {
  using Kind = ConstraintRows::Kind;
  const int row = c.first_row, a = c.a, b = c.b;
  switch (c.kind) {
    case Kind::revolute:
      if (a >= 0) revolute_gradient(frames, a, c.point_a, 1.0, jac, row);
      if (b >= 0) revolute_gradient(frames, b, c.point_b, -1.0, jac, row);
      return;
    case Kind::prismatic:
    case Kind::pin_in_slot:
    case Kind::slider_driver:
      projection_gradient(frames, a, c.point_a, c.axis, b, c.point_b, jac, row);
      if (c.kind == Kind::prismatic) {
        if (a >= 0) jac(row + 1, 3 * a + 2) = -1.0;
        if (b >= 0) jac(row + 1, 3 * b + 2) = 1.0;
      }
      return;
    case Kind::pin_in_arc:
      arc_gradient(frames, a, c.point_a, b, c.point_b, jac, row);
      return;
    case Kind::pin_in_spline: {  // d(y - f(x)) = the projection's on n - f'(x) u, frozen
      const SlotOffset o = slot_offset(c, frames.of(a), frames.of(b));
      projection_gradient(frames, a, c.point_a, perp(c.axis) - o.curve.dy * c.axis, b, c.point_b,
                          jac, row);
      return;
    }
    case Kind::cam_pitch:
      pitch_gradient(c, frames, jac, row);
      return;
    case Kind::cam_face:
      face_gradient(c, frames, jac, row);
      return;
    case Kind::angle_driver:
      if (b >= 0) jac(row, 3 * b + 2) += 1.0;
      if (a >= 0) jac(row, 3 * a + 2) -= 1.0;
      return;
    case Kind::gear:
      if (a >= 0) jac(row, 3 * a + 2) = 1.0;
      if (b >= 0) jac(row, 3 * b + 2) = c.ratio;
      if (c.c >= 0) jac(row, 3 * c.c + 2) = -(1.0 + c.ratio);
      return;
    case Kind::rack_pinion:
      projection_gradient(frames, a, c.point_a, c.axis, b, c.point_b, jac, row);
      if (c.c >= 0) jac(row, 3 * c.c + 2) = -c.ratio;
      if (a >= 0) jac(row, 3 * a + 2) += c.ratio;
      return;
  }
}

// The block of a driver (one row): an angle measured from link `reference` to the arm
// from -> to on `link`, or a slide joint's displacement along its line.
ConstraintRows driver_rows(const Mechanism& m, const Driver& d) {
  ConstraintRows c;
  if (d.type == DriverType::slider) {
    const Joint& j = m.joints[static_cast<size_t>(d.joint)];
    const Line& line = m.links[static_cast<size_t>(j.link_a)].lines[static_cast<size_t>(j.line)];
    c.kind = Kind::slider_driver;
    c.a = m.moving_index(j.link_a);
    c.b = m.moving_index(j.link_b);
    c.point_a = line.origin;
    c.axis = line.direction;
    c.point_b = m.links[static_cast<size_t>(j.link_b)].points[static_cast<size_t>(j.point_b)].local;
    return c;
  }
  c.kind = Kind::angle_driver;
  c.b = m.moving_index(d.link);
  c.a = m.moving_index(d.type == DriverType::joint_angle
                           ? m.joints[static_cast<size_t>(d.joint)].link_a
                           : m.ground());
  if (d.from >= 0 && d.to >= 0) {
    const Link& link = m.links[static_cast<size_t>(d.link)];
    const Eigen::Vector2d arm = link.points[static_cast<size_t>(d.to)].local -
                                link.points[static_cast<size_t>(d.from)].local;
    c.angle = std::atan2(arm.y(), arm.x());
  }
  return c;
}

ConstraintRows joint_rows(const Mechanism& m, const Joint& j) {
  ConstraintRows c;
  if (j.type == JointType::gear) {
    c.kind = Kind::gear;
    c.ratio = j.ratio;
    c.angle = j.phase;
    c.a = m.moving_index(j.link_a);
    c.b = m.moving_index(j.link_b);
    c.c = m.moving_index(j.carrier);
    return c;
  }
  if (j.type == JointType::rack_pinion) {  // the slide's travel, as a slider driver reads it
    Driver slide;
    slide.type = DriverType::slider;
    slide.joint = j.slide;
    c = driver_rows(m, slide);
    c.kind = Kind::rack_pinion;
    c.c = m.moving_index(j.link_a);
    c.ratio = j.ratio;
    c.angle = j.phase;
    return c;
  }
  c.a = m.moving_index(j.link_a);
  c.b = m.moving_index(j.link_b);
  if (j.point_b >= 0)
    c.point_b = m.links[static_cast<size_t>(j.link_b)].points[static_cast<size_t>(j.point_b)].local;
  if (j.type == JointType::cam) {
    const Link& cam = m.links[static_cast<size_t>(j.link_a)];
    const Link& follower = m.links[static_cast<size_t>(j.link_b)];
    c.point_a = cam.points[static_cast<size_t>(j.centre_a)].local;
    c.contour = j.contour;
    if (j.line < 0) {
      c.kind = Kind::cam_pitch;
      return c;
    }
    const Line& face = follower.lines[static_cast<size_t>(j.line)];
    c.kind = Kind::cam_face;
    c.point_b = face.origin;
    c.axis = perp(face.direction);
    c.angle = std::atan2(c.axis.y(), c.axis.x());
    return c;
  }
  if (j.type == JointType::pin_in_arc) {
    c.kind = Kind::pin_in_arc;
    c.point_a =
        m.links[static_cast<size_t>(j.link_a)].points[static_cast<size_t>(j.centre_a)].local;
    c.radius = j.radius_a;
    return c;
  }
  if (j.type == JointType::pin_in_spline) {
    c.kind = Kind::pin_in_spline;
    c.point_a = j.chord_start;
    c.axis = j.chord_axis;
    c.slot = j.slot;
    return c;
  }
  if (j.type == JointType::revolute) {
    c.kind = Kind::revolute;
    c.point_a = m.links[static_cast<size_t>(j.link_a)].points[static_cast<size_t>(j.point_a)].local;
    return c;
  }
  const Line& line = m.links[static_cast<size_t>(j.link_a)].lines[static_cast<size_t>(j.line)];
  c.kind = j.type == JointType::prismatic ? Kind::prismatic : Kind::pin_in_slot;
  c.point_a = line.origin;
  c.axis = perp(line.direction);
  c.angle = j.relative_angle;
  return c;
}

}  // namespace

CamContact cam_contact(const Mechanism& m, const Joint& j, const BodyMotion& a,
                       const BodyMotion& b) {
  return cam_contact(joint_rows(m, j), a, b);
}

namespace {
// The contact, and the profile's function where the follower touches it: the pitch curve's
// rho(psi) at the knife edge or roller's centre, or the support function h(alpha) at the face's
// normal (one evaluation of the contour for both).
struct ContactOnProfile {
  CamContact contact;
  cam::Polar profile;
};
ContactOnProfile contact_on_profile(const ConstraintRows& c, const BodyMotion& a,
                                    const BodyMotion& b) {
  ContactOnProfile out;
  if (c.kind == Kind::cam_face) {  // the support function's point: h n + h' perp(n) from C
    const FaceContact f = face_contact(c, a, b);
    out.profile = c.contour->at(f.alpha);
    out.contact.normal = f.n;
    out.contact.point = a.position(c.point_a) + out.profile.value * f.n + out.profile.d * perp(f.n);
    return out;
  }
  // The pitch curve's normal at the knife edge or roller's centre: the row's gradient there.
  const PitchGradient p = pitch_gradient(c, a, b);
  out.profile = p.rho;
  out.contact.normal = p.g.normalized();
  out.contact.point =
      b.position(c.point_b) - c.contour->follower().roller_radius * out.contact.normal;
  return out;
}
}  // namespace

CamContact cam_contact(const ConstraintRows& c, const BodyMotion& a, const BodyMotion& b) {
  return contact_on_profile(c, a, b).contact;
}

CamReading::Pose CamReading::at(const BodyMotion& cam, const BodyMotion& follower) const {
  Pose p;
  p.centre = cam.position(rows.point_a);
  p.cam_angle = cam.theta;
  const auto [contact, profile] = contact_on_profile(rows, cam, follower);
  p.contact = contact;
  const Eigen::Vector2d& n = p.contact.normal;
  p.at = rows.kind == Kind::cam_face ? p.contact.point : follower.position(rows.point_b);
  p.motion = (pivoted ? perp(p.at - guide) : guide).normalized();
  if (p.motion.dot(n) < 0.0) p.motion = -p.motion;
  p.pressure_angle = std::atan2(cross(p.motion, n), p.motion.dot(n));
  if (rows.kind == Kind::cam_face) {  // the support function's h + h'' is the radius
    p.curvature = 1.0 / (profile.value + profile.dd);
    return p;
  }
  // The pitch curve's curvature from its polar form, and the profile's, a roller's radius in.
  const cam::Polar& rho = profile;
  const double pitch = (rho.value * rho.value + 2.0 * rho.d * rho.d - rho.value * rho.dd) /
                       std::pow(rho.value * rho.value + rho.d * rho.d, 1.5);
  p.curvature = pitch / (1.0 - rows.contour->follower().roller_radius * pitch);
  return p;
}

namespace {
// The contacts round a cam's profile in its cam link's frame, the centre at `centre`: the cam's
// frame unturned, and the follower placed where the row holds it at each of `count` angles, its
// pitch point at rho(psi) or its face at h(alpha).
std::vector<CamContact> profile_contacts(const ConstraintRows& rows, int count,
                                         const Eigen::Vector2d& centre) {
  BodyMotion cam;
  cam.r = centre - rows.point_a;
  std::vector<CamContact> contacts;
  for (int k = 0; k < count; ++k) {
    const double angle = 2.0 * std::numbers::pi * k / count;
    const Eigen::Vector2d u(std::cos(angle), std::sin(angle));
    BodyMotion follower;
    if (rows.kind == Kind::cam_face) {
      follower.theta = angle - rows.angle;
      follower.rotation = Eigen::Rotation2Dd(follower.theta).toRotationMatrix();
      follower.r = rows.contour->at(angle).value * u - follower.turn(rows.point_b);
    } else {
      follower.r = rows.contour->at(angle).value * u - rows.point_b;
    }
    follower.r += centre;
    contacts.push_back(cam_contact(rows, cam, follower));
  }
  return contacts;
}
}  // namespace

std::vector<Eigen::Vector2d> CamReading::outline(int count) const {
  std::vector<Eigen::Vector2d> points;
  for (const CamContact& c : profile_contacts(rows, count, Eigen::Vector2d::Zero()))
    points.push_back(c.point);
  return points;
}

std::vector<CamContact> cam_profile(const Mechanism& m, const Joint& cam, int count) {
  const ConstraintRows rows = joint_rows(m, cam);
  return profile_contacts(rows, count, rows.point_a);
}

std::vector<CamReading> cam_readings(const Mechanism& m) {
  std::vector<CamReading> readings;
  const int g = m.ground();
  for (const Joint& cam : m.joints) {
    if (cam.type != JointType::cam) continue;
    int guides = 0;
    CamReading r{cam.name, joint_rows(m, cam)};
    for (const Joint& j : m.joints) {
      const bool joins =
          (j.link_a == g && j.link_b == cam.link_b) || (j.link_b == g && j.link_a == cam.link_b);
      if (!joins) continue;
      if (j.type == JointType::revolute) {
        ++guides;
        r.pivoted = true;
        const int p = j.link_a == g ? j.point_a : j.point_b;
        r.guide = m.links[static_cast<size_t>(g)].points[static_cast<size_t>(p)].local;
      } else if (j.type == JointType::prismatic && j.link_a == g) {
        ++guides;
        r.guide = m.links[static_cast<size_t>(g)].lines[static_cast<size_t>(j.line)].direction;
      } else {
        guides += 2;  // a guide this reading does not take: no pressure angle
      }
    }
    if (guides == 1) readings.push_back(std::move(r));
  }
  return readings;
}

double CamReading::follower_jerk(const Eigen::VectorXd& qdddot) const {
  const int k = rows.b;
  if (k < 0) return 0.0;
  return pivoted ? qdddot(3 * k + 2) : guide.dot(qdddot.segment<2>(3 * k));
}

double ConstraintRows::value(const LinkFrames& frames) const {
  const Eigen::VectorXd& q = frames.q;
  switch (kind) {
    case Kind::angle_driver:
      return angle_of(q, b) + angle - angle_of(q, a);  // linear in q
    case Kind::gear:
      return angle_of(q, a) - angle_of(q, c) + ratio * (angle_of(q, b) - angle_of(q, c)) - angle;
    case Kind::rack_pinion:
      return project(frames.of(a), point_a, axis, frames.of(b), point_b).value -
             ratio * (angle_of(q, c) - angle_of(q, a)) - angle;
    case Kind::pin_in_arc:
      return arc_offset(frames.of(a), point_a, frames.of(b), point_b).length - radius;
    case Kind::pin_in_spline: {
      const SlotOffset o = slot_offset(*this, frames.of(a), frames.of(b));
      return o.y.value - o.curve.y;
    }
    case Kind::cam_pitch: {
      const BodyMotion ma = frames.of(a);
      const ArcOffset o = arc_offset(ma, point_a, frames.of(b), point_b);
      return o.length - contour->at(pitch_angle(ma, o)).value;
    }
    case Kind::cam_face: {
      const FaceContact f = face_contact(*this, frames.of(a), frames.of(b));
      return f.n.dot(f.offset) - contour->at(f.alpha).value;
    }
    default:
      return project(frames.of(a), point_a, axis, frames.of(b), point_b).value;
  }
}

void ConstraintRows::position(const LinkFrames& frames, Eigen::VectorXd& phi) const {
  switch (kind) {
    case Kind::revolute: {
      const BodyMotion ma = frames.of(a), mb = frames.of(b);
      phi.segment<2>(first_row) = ma.position(point_a) - mb.position(point_b);
      return;
    }
    case Kind::prismatic: {
      const BodyMotion ma = frames.of(a), mb = frames.of(b);
      phi(first_row) = project(ma, point_a, axis, mb, point_b).value;
      phi(first_row + 1) = mb.theta - ma.theta - angle;
      return;
    }
    case Kind::pin_in_slot:
    case Kind::pin_in_arc:
    case Kind::pin_in_spline:
    case Kind::cam_pitch:
    case Kind::cam_face:
    case Kind::angle_driver:
    case Kind::slider_driver:
    case Kind::gear:
    case Kind::rack_pinion:
      phi(first_row) = value(frames);
      return;
  }
}

void ConstraintRows::velocity_squared(const LinkFrames& frames, const Eigen::VectorXd& qdot,
                                      Eigen::VectorXd& out) const {
  switch (kind) {
    case Kind::revolute: {
      const BodyMotion ma = frames.of(a, &qdot), mb = frames.of(b, &qdot);
      out.segment<2>(first_row) = ma.acceleration(point_a) - mb.acceleration(point_b);
      return;
    }
    case Kind::prismatic:
    case Kind::pin_in_slot:
    case Kind::slider_driver:
    case Kind::rack_pinion:  // its angle term is linear in q
      out(first_row) =
          project(frames.of(a, &qdot), point_a, axis, frames.of(b, &qdot), point_b).accel;
      if (kind == Kind::prismatic) out(first_row + 1) = 0.0;  // an angle is linear in q
      return;
    case Kind::pin_in_arc: {
      // d2|d|/dt2 = e . d'' + (|d'|^2 - (e . d')^2) / |d|, d'' with qddot = 0.
      const BodyMotion ma = frames.of(a, &qdot), mb = frames.of(b, &qdot);
      const ArcOffset o = arc_offset(ma, point_a, mb, point_b);
      const Eigen::Vector2d rate = mb.velocity(point_b) - ma.velocity(point_a);
      const double along = o.e.dot(rate);
      out(first_row) = o.e.dot(mb.acceleration(point_b) - ma.acceleration(point_a)) +
                       (o.length > 0.0 ? (rate.squaredNorm() - along * along) / o.length : 0.0);
      return;
    }
    case Kind::pin_in_spline: {  // y'' - f'' x'^2 - f' x'', with qddot = 0
      const SlotOffset o = slot_offset(*this, frames.of(a, &qdot), frames.of(b, &qdot));
      out(first_row) = o.y.accel - o.curve.ddy * o.x.rate * o.x.rate - o.curve.dy * o.x.accel;
      return;
    }
    case Kind::cam_pitch: {
      // |d|'' as pin_in_arc's, less rho'' psi'^2 + rho' psi'', where psi' = d x d' / |d|^2 -
      // omega_a and psi'' = d x d'' / |d|^2 - 2 (d x d')(d . d') / |d|^4 (alpha_a = 0).
      const BodyMotion ma = frames.of(a, &qdot), mb = frames.of(b, &qdot);
      const ArcOffset o = arc_offset(ma, point_a, mb, point_b);
      const Eigen::Vector2d d = o.length * o.e;
      const Eigen::Vector2d rate = mb.velocity(point_b) - ma.velocity(point_a);
      const Eigen::Vector2d accel = mb.acceleration(point_b) - ma.acceleration(point_a);
      const double along = o.e.dot(rate), d2 = o.length * o.length;
      const cam::Polar rho = contour->at(pitch_angle(ma, o));
      const double psi_rate = d2 > 0.0 ? cross(d, rate) / d2 - ma.omega : 0.0;
      const double psi_accel =
          d2 > 0.0 ? cross(d, accel) / d2 - 2.0 * cross(d, rate) * d.dot(rate) / (d2 * d2) : 0.0;
      out(first_row) = o.e.dot(accel) +
                       (o.length > 0.0 ? (rate.squaredNorm() - along * along) / o.length : 0.0) -
                       rho.dd * psi_rate * psi_rate - rho.d * psi_accel;
      return;
    }
    case Kind::cam_face: {
      // (n . D)'' = n'' . D + 2 n' . D' + n . D'' with n' = omega_b perp(n), n'' = -omega_b^2 n;
      // h(alpha)'' = h'' (omega_b - omega_a)^2.
      const BodyMotion ma = frames.of(a, &qdot), mb = frames.of(b, &qdot);
      const FaceContact f = face_contact(*this, ma, mb);
      const Eigen::Vector2d rate = mb.velocity(point_b) - ma.velocity(point_a);
      const Eigen::Vector2d accel = mb.acceleration(point_b) - ma.acceleration(point_a);
      const double turn = mb.omega - ma.omega;
      out(first_row) = -mb.omega * mb.omega * f.n.dot(f.offset) +
                       2.0 * mb.omega * perp(f.n).dot(rate) + f.n.dot(accel) -
                       contour->at(f.alpha).dd * turn * turn;
      return;
    }
    case Kind::angle_driver:
    case Kind::gear:
      out(first_row) = 0.0;
      return;
  }
}

namespace {
// A vector fixed in a link, or a point of it, and its first three time derivatives with
// q''' = 0: w''' = -3 omega alpha w - omega^3 perp(w) (the link's own jerk and the origin's are
// q''', the unknowns).
struct Jet {
  Eigen::Vector2d d0, d1, d2, d3;
  Jet operator-(const Jet& o) const { return {d0 - o.d0, d1 - o.d1, d2 - o.d2, d3 - o.d3}; }
};
Jet vector_jet(const BodyMotion& m, const Eigen::Vector2d& local) {
  const Eigen::Vector2d w = m.turn(local);
  return {w, m.omega * perp(w), m.alpha * perp(w) - m.omega * m.omega * w,
          -3.0 * m.omega * m.alpha * w - m.omega * m.omega * m.omega * perp(w)};
}
Jet point_jet(const BodyMotion& m, const Eigen::Vector2d& local) {
  Jet j = vector_jet(m, local);
  j.d0 += m.r;
  j.d1 += m.v;
  j.d2 += m.a;
  return j;
}
// (u . v)''' by Leibniz.
double dot_jerk(const Jet& u, const Jet& v) {
  return u.d3.dot(v.d0) + 3.0 * u.d2.dot(v.d1) + 3.0 * u.d1.dot(v.d2) + u.d0.dot(v.d3);
}
// |d| and the polar angle of d, each with its first three derivatives: from |d|^2 = d . d and
// angle' |d|^2 = cross(d, d'), differentiated.
struct PolarJet {
  double r, r1, r2, r3, a1, a2, a3;
};
PolarJet polar_jet(const Jet& d) {
  PolarJet p{};
  const double h = d.d0.squaredNorm(), h1 = 2.0 * d.d0.dot(d.d1),
               h2 = 2.0 * (d.d1.squaredNorm() + d.d0.dot(d.d2));
  p.r = std::sqrt(h);
  if (!(p.r > 0.0)) return p;  // the pin on the centre: no direction (as arc_offset's)
  p.r1 = d.d0.dot(d.d1) / p.r;
  p.r2 = (d.d1.squaredNorm() + d.d0.dot(d.d2) - p.r1 * p.r1) / p.r;
  p.r3 = (3.0 * d.d1.dot(d.d2) + d.d0.dot(d.d3) - 3.0 * p.r1 * p.r2) / p.r;
  p.a1 = cross(d.d0, d.d1) / h;
  p.a2 = (cross(d.d0, d.d2) - p.a1 * h1) / h;
  p.a3 = (cross(d.d1, d.d2) + cross(d.d0, d.d3) - 2.0 * p.a2 * h1 - p.a1 * h2) / h;
  return p;
}
// f(x(t))''' with x''' = 0: f''' x'^3 + 3 f'' x' x''.
double composed_jerk(const cam::Polar& f, double x1, double x2) {
  return f.ddd * x1 * x1 * x1 + 3.0 * f.dd * x1 * x2;
}
}  // namespace

void ConstraintRows::jerk_terms(const LinkFrames& frames, const Eigen::VectorXd& qdot,
                                const Eigen::VectorXd& qddot, Eigen::VectorXd& out) const {
  const BodyMotion ma = frames.of(a, &qdot, &qddot), mb = frames.of(b, &qdot, &qddot);
  switch (kind) {
    case Kind::revolute:
      out.segment<2>(first_row) = point_jet(ma, point_a).d3 - point_jet(mb, point_b).d3;
      return;
    case Kind::prismatic:
    case Kind::pin_in_slot:
    case Kind::slider_driver:
    case Kind::rack_pinion:  // its angle term is linear in q
      out(first_row) =
          dot_jerk(vector_jet(ma, axis), point_jet(mb, point_b) - point_jet(ma, point_a));
      if (kind == Kind::prismatic) out(first_row + 1) = 0.0;  // an angle is linear in q
      return;
    case Kind::pin_in_arc:
      out(first_row) = polar_jet(point_jet(mb, point_b) - point_jet(ma, point_a)).r3;
      return;
    case Kind::pin_in_spline: {  // y''' - f''' x'^3 - 3 f'' x' x'' - f' x''', with q''' = 0
      const SlotOffset o = slot_offset(*this, ma, mb);
      const Jet d = point_jet(mb, point_b) - point_jet(ma, point_a);
      const double x3 = dot_jerk(vector_jet(ma, axis), d);
      const double y3 = dot_jerk(vector_jet(ma, perp(axis)), d);
      out(first_row) = y3 - o.curve.dddy * o.x.rate * o.x.rate * o.x.rate -
                       3.0 * o.curve.ddy * o.x.rate * o.x.accel - o.curve.dy * x3;
      return;
    }
    case Kind::cam_pitch: {
      // |d| - rho(psi), psi = angle(d) - theta_a: psi' = angle' - omega_a, psi'' = angle'' -
      // alpha_a, psi''' = angle'''.
      const PolarJet p = polar_jet(point_jet(mb, point_b) - point_jet(ma, point_a));
      const cam::Polar rho = contour->at(pitch_angle(ma, arc_offset(ma, point_a, mb, point_b)));
      out(first_row) = p.r3 - composed_jerk(rho, p.a1 - ma.omega, p.a2 - ma.alpha) - rho.d * p.a3;
      return;
    }
    case Kind::cam_face: {
      // n . D - h(alpha), alpha = theta_b + angle - theta_a linear in q.
      const FaceContact f = face_contact(*this, ma, mb);
      out(first_row) =
          dot_jerk(vector_jet(mb, axis), point_jet(mb, point_b) - point_jet(ma, point_a)) -
          composed_jerk(contour->at(f.alpha), mb.omega - ma.omega, mb.alpha - ma.alpha);
      return;
    }
    case Kind::angle_driver:
    case Kind::gear:
      out(first_row) = 0.0;
      return;
  }
}

void ConstraintRows::jacobian(const LinkFrames& frames, Eigen::MatrixXd& jac) const {
  write_jacobian(*this, frames, jac);
}

void ConstraintRows::jacobian(const LinkFrames& frames, SparseJacobian& jac) const {
  write_jacobian(*this, frames, jac);
}

ConstraintLayout::ConstraintLayout(const Mechanism& m) {
  auto add = [&](ConstraintRows c) {
    c.first_row = rows_;
    for (int r = 0; r < c.rows(); ++r) angle_rows_.push_back(c.angle_row(r) ? 1 : 0);
    rows_ += c.rows();
    blocks_.push_back(c);
  };
  for (const Joint& j : m.joints) add(joint_rows(m, j));
  joint_count_ = blocks_.size();
  joints_ = rows_;
  for (const Driver& d : m.drivers) add(driver_rows(m, d));
}

void ConstraintLayout::position(const LinkFrames& frames, Eigen::VectorXd& phi) const {
  for (const ConstraintRows& c : blocks_) c.position(frames, phi);
}

void ConstraintLayout::residual(const LinkFrames& frames, std::span<const DriverState> drivers,
                                Eigen::VectorXd& phi) const {
  position(frames, phi);
  for (int d = 0; d < driver_count(); ++d) phi(driver_row(d)) -= drivers[d].value;
}

void ConstraintLayout::jacobian(const LinkFrames& frames, Eigen::MatrixXd& jac) const {
  jac.setZero();
  for (const ConstraintRows& c : blocks_) c.jacobian(frames, jac);
}

void ConstraintLayout::jacobian(const LinkFrames& frames, SparseJacobian& jac) const {
  jac.setZero();
  for (const ConstraintRows& c : blocks_) c.jacobian(frames, jac);
}

namespace {
// Records the entries a block writes, whatever their values.
struct PatternRecorder {
  std::vector<std::pair<int, int>> entries;  // (column, row)
  double scratch = 0.0;
  double& operator()(int row, int column) {
    entries.emplace_back(column, row);
    return scratch;
  }
};
}  // namespace

SparseJacobian::SparseJacobian(const ConstraintLayout& layout, int columns) {
  // Where each block writes does not depend on q: record it at q = 0.
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(columns);
  PatternRecorder recorder;
  for (const ConstraintRows& c : layout.blocks()) write_jacobian(c, LinkFrames{q}, recorder);
  std::sort(recorder.entries.begin(), recorder.entries.end());
  recorder.entries.erase(std::unique(recorder.entries.begin(), recorder.entries.end()),
                         recorder.entries.end());
  set_pattern(layout.rows(), columns, recorder.entries);
}

SparseJacobian::SparseJacobian(const Eigen::MatrixXd& dense) {
  std::vector<std::pair<int, int>> entries;
  for (int c = 0; c < dense.cols(); ++c)
    for (int r = 0; r < dense.rows(); ++r)
      if (dense(r, c) != 0.0) entries.emplace_back(c, r);
  set_pattern(static_cast<int>(dense.rows()), static_cast<int>(dense.cols()), entries);
  for (const auto& [c, r] : entries) (*this)(r, c) = dense(r, c);
}

void SparseJacobian::set_pattern(int rows, int columns,
                                 const std::vector<std::pair<int, int>>& entries) {
  rows_ = rows;
  column_start_.assign(static_cast<size_t>(columns) + 1, 0);
  row_index_.clear();
  for (const auto& [column, row] : entries) {
    ++column_start_[static_cast<size_t>(column) + 1];
    row_index_.push_back(row);
  }
  for (int c = 0; c < columns; ++c)
    column_start_[static_cast<size_t>(c) + 1] += column_start_[static_cast<size_t>(c)];
  values_.assign(row_index_.size(), 0.0);
  // By row: each entry's column and place, for writing by (row, column).
  row_start_.assign(static_cast<size_t>(rows_) + 1, 0);
  for (int r : row_index_) ++row_start_[static_cast<size_t>(r) + 1];
  for (int r = 0; r < rows_; ++r)
    row_start_[static_cast<size_t>(r) + 1] += row_start_[static_cast<size_t>(r)];
  row_entries_.resize(row_index_.size());
  std::vector<int> next(row_start_.begin(), row_start_.end() - 1);
  for (int c = 0; c < columns; ++c)
    for (int e = column_start(c); e < column_start(c + 1); ++e)
      row_entries_[static_cast<size_t>(next[static_cast<size_t>(row_index(e))]++)] = {c, e};
}

int SparseJacobian::slot(int row, int column) const {
  for (int i = row_start_[static_cast<size_t>(row)]; i < row_start_[static_cast<size_t>(row) + 1];
       ++i)
    if (row_entries_[static_cast<size_t>(i)].first == column)
      return row_entries_[static_cast<size_t>(i)].second;
  return -1;
}

double SparseJacobian::coeff(int row, int column) const {
  const int e = slot(row, column);
  return e < 0 ? 0.0 : values_[static_cast<size_t>(e)];
}

SparseJacobian SparseJacobian::with_full_row(int row) const {
  std::vector<std::pair<int, int>> entries;
  for (int c = 0; c < cols(); ++c) {
    for (int e = column_start(c); e < column_start(c + 1); ++e)
      if (row_index(e) != row) entries.emplace_back(c, row_index(e));
    entries.emplace_back(c, row);
  }
  std::sort(entries.begin(), entries.end());
  SparseJacobian out;
  out.set_pattern(rows_, cols(), entries);
  return out;
}

double SparseJacobian::row_norm(int row) const {
  double sum = 0.0;
  for (int i = row_start_[static_cast<size_t>(row)]; i < row_start_[static_cast<size_t>(row) + 1];
       ++i) {
    const double v = values_[static_cast<size_t>(row_entries_[static_cast<size_t>(i)].second)];
    sum += v * v;
  }
  return std::sqrt(sum);
}

Eigen::MatrixXd SparseJacobian::dense() const {
  Eigen::MatrixXd out = Eigen::MatrixXd::Zero(rows_, cols());
  for (int c = 0; c < cols(); ++c)
    for (int e = column_start(c); e < column_start(c + 1); ++e) out(row_index(e), c) = value(e);
  return out;
}

void ConstraintLayout::velocity_rhs(std::span<const DriverState> drivers,
                                    Eigen::VectorXd& nu) const {
  // Only the drivers' rows depend on time: -dPhi/dt is their rate.
  nu.setZero();
  for (int d = 0; d < driver_count(); ++d) nu(driver_row(d)) = drivers[d].rate;
}

void ConstraintLayout::acceleration_rhs(const LinkFrames& frames, const Eigen::VectorXd& qdot,
                                        std::span<const DriverState> drivers,
                                        Eigen::VectorXd& gamma) const {
  for (const ConstraintRows& c : blocks_) c.velocity_squared(frames, qdot, gamma);
  gamma = -gamma;
  for (int d = 0; d < driver_count(); ++d) gamma(driver_row(d)) += drivers[d].accel;
}

void ConstraintLayout::jerk_rhs(const LinkFrames& frames, const Eigen::VectorXd& qdot,
                                const Eigen::VectorXd& qddot, std::span<const DriverState> drivers,
                                Eigen::VectorXd& eta) const {
  eta.resize(rows_);
  for (const ConstraintRows& c : blocks_) c.jerk_terms(frames, qdot, qddot, eta);
  eta = -eta;
  for (int d = 0; d < driver_count(); ++d) eta(driver_row(d)) += drivers[d].jerk;
}

}  // namespace crosslink
