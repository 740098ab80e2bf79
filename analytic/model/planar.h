// Planar rigid-body kinematics shared by the solvers: a link's motion and the motion of points
// and directions fixed in it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace crosslink {

// The vector turned by +90 degrees: perp(v) = R(90) v. d/dtheta (R(theta) v) = perp(R(theta) v).
inline Eigen::Vector2d perp(const Eigen::Vector2d& v) {
  return {-v.y(), v.x()};
}

// The z component of a x b: a's turn towards b, scaled by both lengths.
inline double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Motion of a link frame: origin position, velocity, acceleration [m, m/s, m/s^2], angle,
// angular velocity, angular acceleration [rad, rad/s, rad/s^2]. Ground is all zeros.
struct BodyMotion {
  Eigen::Vector2d r = Eigen::Vector2d::Zero();
  Eigen::Vector2d v = Eigen::Vector2d::Zero();
  Eigen::Vector2d a = Eigen::Vector2d::Zero();
  double theta = 0.0, omega = 0.0, alpha = 0.0;
  Eigen::Matrix2d rotation = Eigen::Matrix2d::Identity();

  // Link k's motion from coordinate vectors laid out as (x, y, theta) per moving link; k < 0 is
  // the ground. Any of the derivative vectors may be null (taken as zero).
  static BodyMotion of(int k, const Eigen::VectorXd& q, const Eigen::VectorXd* qdot,
                       const Eigen::VectorXd* qddot) {
    if (k < 0) return {};
    const double theta = q(3 * k + 2);
    return of(k, q, qdot, qddot, std::cos(theta), std::sin(theta));
  }
  // The same with cos and sin of the link's angle already at hand (as Rotation2D builds them).
  static BodyMotion of(int k, const Eigen::VectorXd& q, const Eigen::VectorXd* qdot,
                       const Eigen::VectorXd* qddot, double cos_theta, double sin_theta) {
    BodyMotion m;
    m.r = q.segment<2>(3 * k);
    m.theta = q(3 * k + 2);
    m.rotation << cos_theta, -sin_theta, sin_theta, cos_theta;
    if (qdot) {
      m.v = qdot->segment<2>(3 * k);
      m.omega = (*qdot)(3 * k + 2);
    }
    if (qddot) {
      m.a = qddot->segment<2>(3 * k);
      m.alpha = (*qddot)(3 * k + 2);
    }
    return m;
  }

  // A vector fixed in the link (a point's offset, a line's direction), in world axes, and its
  // first and second time derivatives.
  Eigen::Vector2d turn(const Eigen::Vector2d& local) const { return rotation * local; }
  Eigen::Vector2d turn_rate(const Eigen::Vector2d& local) const {
    return omega * perp(rotation * local);
  }
  Eigen::Vector2d turn_accel(const Eigen::Vector2d& local) const {
    const Eigen::Vector2d w = rotation * local;
    return alpha * perp(w) - omega * omega * w;
  }
  // A point fixed in the link.
  Eigen::Vector2d position(const Eigen::Vector2d& local) const { return r + turn(local); }
  Eigen::Vector2d velocity(const Eigen::Vector2d& local) const { return v + turn_rate(local); }
  Eigen::Vector2d acceleration(const Eigen::Vector2d& local) const { return a + turn_accel(local); }
};

// The projection  p = w . (P - O)  of a point P of link b on a direction w through a point O,
// both fixed in link a, with its first and second time derivatives: the slider displacement
// (w = the line's direction) or the distance off a slot line (w = the line's normal).
struct Projection {
  double value = 0.0, rate = 0.0, accel = 0.0;
};
inline Projection project(const BodyMotion& a, const Eigen::Vector2d& origin_a,
                          const Eigen::Vector2d& axis_a, const BodyMotion& b,
                          const Eigen::Vector2d& point_b) {
  const Eigen::Vector2d w = a.turn(axis_a), wd = a.turn_rate(axis_a), wdd = a.turn_accel(axis_a);
  const Eigen::Vector2d d = b.position(point_b) - a.position(origin_a);
  const Eigen::Vector2d dd = b.velocity(point_b) - a.velocity(origin_a);
  const Eigen::Vector2d ddd = b.acceleration(point_b) - a.acceleration(origin_a);
  return {w.dot(d), wd.dot(d) + w.dot(dd), wdd.dot(d) + 2.0 * wd.dot(dd) + w.dot(ddd)};
}

}  // namespace crosslink
