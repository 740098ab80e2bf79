#include "analytic/model/cam.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>

#include "analytic/model/planar.h"

namespace crosslink::cam {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kTurn = 2.0 * kPi;
// Spans that make a turn, and a program that closes, to this much [rad or the displacement's
// unit]: what a definition written in degrees to nine digits keeps.
constexpr double kClosure = 1e-9;

// A cam angle taken into [0, 2 pi).
double within_turn(double theta) {
  const double t = theta - kTurn * std::floor(theta / kTurn);
  return t >= kTurn ? 0.0 : t;
}

}  // namespace

std::string to_string(Law law) {
  switch (law) {
    case Law::dwell:
      return "dwell";
    case Law::uniform:
      return "uniform";
    case Law::simple_harmonic:
      return "simple_harmonic";
    case Law::cycloidal:
      return "cycloidal";
    case Law::polynomial_345:
      return "polynomial_345";
    case Law::polynomial_4567:
      return "polynomial_4567";
  }
  return "?";
}

Normalised normalised(Law law, double u) {
  const double u2 = u * u, u3 = u2 * u, u4 = u3 * u;
  switch (law) {
    case Law::dwell:
      return {};
    case Law::uniform:
      return {u, 1.0, 0.0, 0.0, 0.0};
    case Law::simple_harmonic: {
      const double c = std::cos(kPi * u), s = std::sin(kPi * u);
      return {(1.0 - c) / 2.0, kPi / 2.0 * s, kPi * kPi / 2.0 * c, -kPi * kPi * kPi / 2.0 * s,
              -kPi * kPi * kPi * kPi / 2.0 * c};
    }
    case Law::cycloidal: {
      const double c = std::cos(kTurn * u), s = std::sin(kTurn * u);
      return {u - s / kTurn, 1.0 - c, kTurn * s, kTurn * kTurn * c, -kTurn * kTurn * kTurn * s};
    }
    case Law::polynomial_345:
      return {10.0 * u3 - 15.0 * u4 + 6.0 * u4 * u, 30.0 * u2 - 60.0 * u3 + 30.0 * u4,
              60.0 * u - 180.0 * u2 + 120.0 * u3, 60.0 - 360.0 * u + 360.0 * u2,
              -360.0 + 720.0 * u};
    case Law::polynomial_4567:
      return {35.0 * u4 - 84.0 * u4 * u + 70.0 * u3 * u3 - 20.0 * u4 * u3,
              140.0 * u3 - 420.0 * u4 + 420.0 * u4 * u - 140.0 * u3 * u3,
              420.0 * u2 - 1680.0 * u3 + 2100.0 * u4 - 840.0 * u4 * u,
              840.0 * u - 5040.0 * u2 + 8400.0 * u3 - 4200.0 * u4,
              840.0 - 10080.0 * u + 25200.0 * u2 - 16800.0 * u3};
  }
  return {};
}

MotionProgram::MotionProgram(double start, std::vector<Segment> segments)
    : start_(start), segments_(std::move(segments)) {
  if (segments_.empty()) throw std::invalid_argument("a motion program needs a segment");
  double at = 0.0, level = start_;
  for (size_t k = 0; k < segments_.size(); ++k) {
    const Segment& g = segments_[k];
    if (!(g.span > 0.0) || !std::isfinite(g.span))
      throw std::invalid_argument(fmt::format("segment {}: its span must be positive", k + 1));
    if (!std::isfinite(g.to))
      throw std::invalid_argument(fmt::format("segment {}: its end is not a number", k + 1));
    if (g.law == Law::dwell && std::abs(g.to - level) > kClosure * std::max(1.0, std::abs(level)))
      throw std::invalid_argument(
          fmt::format("segment {}: a dwell holds the follower at {:.9g}, it cannot end at {:.9g}",
                      k + 1, level, g.to));
    begins_.push_back(at);
    at += g.span;
    level = g.to;
  }
  if (std::abs(at - kTurn) > kClosure)
    throw std::invalid_argument(
        fmt::format("the segments' spans make {:.9g} deg, not a turn (360 deg)", at * 180.0 / kPi));
  if (std::abs(level - start_) > kClosure * std::max(1.0, std::abs(start_))) {
    // Said at the last segment that moves: its `to` is where the program ends.
    size_t last = segments_.size();
    while (last > 1 && segments_[last - 1].law == Law::dwell) --last;
    throw std::invalid_argument(
        fmt::format("segment {}: the rise does not close: the program ends at {:.9g} and "
                    "starts at {:.9g}",
                    last, level, start_));
  }
}

MotionProgram MotionProgram::table(const std::vector<std::pair<double, double>>& points) {
  const int n = static_cast<int>(points.size());
  if (n < 3) throw std::invalid_argument("a periodic spline needs at least three points");
  MotionProgram p;
  for (int i = 0; i < n; ++i) {
    const auto& [theta, s] = points[static_cast<size_t>(i)];
    if (!std::isfinite(theta) || !std::isfinite(s))
      throw std::invalid_argument(fmt::format("point {}: not a number", i + 1));
    if (i > 0 && !(theta > p.knot_theta_.back()))
      throw std::invalid_argument(
          fmt::format("point {}: its angle must exceed the one before", i + 1));
    p.knot_theta_.push_back(theta);
    p.knot_s_.push_back(s);
  }
  if (!(p.knot_theta_.back() < p.knot_theta_.front() + kTurn))
    throw std::invalid_argument("the points' angles must lie within one turn");
  // The periodic spline's second derivatives M: for each knot i, with h the interval lengths
  // (the last wrapping to the first knot a turn on),
  // h[i-1] M[i-1] + 2 (h[i-1] + h[i]) M[i] + h[i] M[i+1] = 6 (slope[i] - slope[i-1]).
  const auto h = [&](int i) {
    const int j = (i + n) % n;
    return j + 1 < n
               ? p.knot_theta_[static_cast<size_t>(j + 1)] - p.knot_theta_[static_cast<size_t>(j)]
               : p.knot_theta_.front() + kTurn - p.knot_theta_.back();
  };
  const auto value = [&](int i) { return p.knot_s_[static_cast<size_t>((i + n) % n)]; };
  const auto slope = [&](int i) { return (value(i + 1) - value(i)) / h(i); };
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    a(i, (i + n - 1) % n) += h(i - 1);
    a(i, i) += 2.0 * (h(i - 1) + h(i));
    a(i, (i + 1) % n) += h(i);
    b(i) = 6.0 * (slope(i) - slope(i - 1));
  }
  const Eigen::VectorXd m = a.partialPivLu().solve(b);
  p.knot_m_.assign(m.data(), m.data() + n);
  return p;
}

Motion MotionProgram::at(double theta) const {
  if (!knot_theta_.empty()) {
    const int n = static_cast<int>(knot_theta_.size());
    // The interval [t0, t0 + h) holding theta, a whole number of turns moved.
    const double first = knot_theta_.front();
    const double x = first + within_turn(theta - first);
    const int i = static_cast<int>(std::upper_bound(knot_theta_.begin(), knot_theta_.end(), x) -
                                   knot_theta_.begin()) -
                  1;
    const int j = (i + 1) % n;
    const double t0 = knot_theta_[static_cast<size_t>(i)];
    const double h = (i + 1 < n ? knot_theta_[static_cast<size_t>(i + 1)] : first + kTurn) - t0;
    const double mi = knot_m_[static_cast<size_t>(i)], mj = knot_m_[static_cast<size_t>(j)];
    const double si = knot_s_[static_cast<size_t>(i)], sj = knot_s_[static_cast<size_t>(j)];
    const double t = x - t0, r = h - t;  // from the interval's start and to its end
    const double ci = si / h - mi * h / 6.0, cj = sj / h - mj * h / 6.0;
    return {mi * r * r * r / (6.0 * h) + mj * t * t * t / (6.0 * h) + ci * r + cj * t,
            -mi * r * r / (2.0 * h) + mj * t * t / (2.0 * h) - ci + cj, (mi * r + mj * t) / h,
            (mj - mi) / h, 0.0};
  }
  const double x = within_turn(theta);
  size_t k =
      static_cast<size_t>(std::upper_bound(begins_.begin(), begins_.end(), x) - begins_.begin()) -
      1;
  const Segment& g = segments_[k];
  const double from = k == 0 ? start_ : segments_[k - 1].to;
  const double rise = g.to - from, b = g.span;
  const Normalised y = normalised(g.law, std::clamp((x - begins_[k]) / b, 0.0, 1.0));
  return {from + rise * y.y, rise * y.dy / b, rise * y.ddy / (b * b), rise * y.dddy / (b * b * b),
          rise * y.ddddy / (b * b * b * b)};
}

FollowerPath follower_path(const MotionProgram& motion, const Follower& f, double theta) {
  if (!(f.base_radius > 0.0))
    throw std::invalid_argument("the base circle's radius must be positive");
  if (f.kind == FollowerKind::roller && !(f.roller_radius > 0.0))
    throw std::invalid_argument("the roller's radius must be positive");
  if (f.kind == FollowerKind::flat_faced && f.oscillating)
    throw std::invalid_argument("an oscillating flat-faced follower is not supported yet");
  const Motion m = motion.at(theta);
  FollowerPath p;
  if (f.kind == FollowerKind::flat_faced) {  // the face y = base + s, its point on the axis
    p.F = {f.offset, f.base_radius + m.s};
    p.dF = {0.0, m.ds};
    p.ddF = {0.0, m.dds};
    p.dddF = {0.0, m.ddds};
    p.along = {0.0, 1.0};
    return p;
  }
  const double prime = f.base_radius + (f.kind == FollowerKind::roller ? f.roller_radius : 0.0);
  if (!f.oscillating) {
    if (!(std::abs(f.offset) < prime))
      throw std::invalid_argument(
          "the follower's offset must be less than the prime circle's radius");
    p.F = {f.offset, std::sqrt(prime * prime - f.offset * f.offset) + m.s};
    p.dF = {0.0, m.ds};
    p.ddF = {0.0, m.dds};
    p.dddF = {0.0, m.ddds};
    p.along = {0.0, 1.0};
    return p;
  }
  if (!(f.arm > 0.0)) throw std::invalid_argument("the follower's arm must be positive");
  // The arm's lowest angle puts F on the prime circle, on the side where a larger angle lifts
  // it: |pivot + arm u(gamma)| = prime, d|F|/dgamma > 0.
  const double d = f.pivot.norm();
  const double c = (prime * prime - d * d - f.arm * f.arm) / (2.0 * f.arm * d);
  if (!(d > 0.0) || !(std::abs(c) <= 1.0))
    throw std::invalid_argument("the follower's arm cannot reach the prime circle from its pivot");
  p.arm_angle = std::atan2(f.pivot.y(), f.pivot.x()) - std::acos(c) + m.s;
  const Eigen::Vector2d u(std::cos(p.arm_angle), std::sin(p.arm_angle));
  p.F = f.pivot + f.arm * u;
  p.along = perp(u);
  p.dF = f.arm * m.ds * p.along;
  p.ddF = f.arm * (m.dds * p.along - m.ds * m.ds * u);
  p.dddF = f.arm * ((m.ddds - m.ds * m.ds * m.ds) * p.along - 3.0 * m.ds * m.dds * u);
  return p;
}

ProfilePoint profile_at(const MotionProgram& motion, const Follower& f, double theta) {
  const FollowerPath path = follower_path(motion, f, theta);
  ProfilePoint p;
  p.follower = path.F;
  p.arm_angle = path.arm_angle;
  const Eigen::Rotation2Dd to_cam(-theta);
  if (f.kind == FollowerKind::flat_faced) {
    // The face touches the cam where the profile's normal is +y: at x = ds from the cam's
    // centre (the support function's derivative), whatever the axis's offset.
    const Motion m = motion.at(theta);
    const double h = f.base_radius + m.s;
    p.contact = p.pitch = to_cam * Eigen::Vector2d(m.ds, h);
    p.normal = to_cam * Eigen::Vector2d(0.0, 1.0);
    p.pressure_angle = 0.0;
    p.radius_of_curvature = p.pitch_radius_of_curvature = h + m.dds;
    return p;
  }
  const double r = f.kind == FollowerKind::roller ? f.roller_radius : 0.0;
  const Eigen::Vector2d &F = path.F, &dF = path.dF, &ddF = path.ddF;
  // In the cam frame P = R(-theta) F, and d/dtheta R(-theta) v = -R(-theta) perp(v).
  p.pitch = to_cam * F;
  const Eigen::Vector2d dP = to_cam * (dF - perp(F));
  const Eigen::Vector2d ddP = to_cam * (ddF - 2.0 * perp(dF) - F);
  // The pitch curve runs clockwise as the cam turns, so its outward normal is its tangent
  // turned by +90 degrees, and a convex arc has cross(dP, ddP) < 0.
  p.normal = perp(dP.normalized());
  p.pitch_radius_of_curvature = -std::pow(dP.norm(), 3) / cross(dP, ddP);
  p.contact = p.pitch - r * p.normal;
  p.radius_of_curvature = p.pitch_radius_of_curvature - r;
  const Eigen::Vector2d n = to_cam.inverse() * p.normal;  // the common normal, fixed frame
  p.pressure_angle = std::atan2(cross(path.along, n), path.along.dot(n));
  return p;
}

namespace {
constexpr int kSamples = 3600;  // a turn's samples for the profile's checks: every 0.1 degree
constexpr double kDegree = kPi / 180.0;
}  // namespace

Contour::Contour(MotionProgram motion, Follower follower)
    : motion_(std::move(motion)), follower_(follower) {
  const bool flat = flat_faced();
  largest_pressure_ = 0.0;
  least_radius_ = std::numeric_limits<double>::infinity();
  psi_.reserve(kSamples + 1);
  for (int k = 0; k <= kSamples; ++k) {
    const double theta = kTurn * k / kSamples;
    const ProfilePoint p = profile_at(*motion_, follower_, theta);
    largest_pressure_ = std::max(largest_pressure_, std::abs(p.pressure_angle));
    if (flat) {
      if (!(p.radius_of_curvature > 0.0))
        throw std::invalid_argument(fmt::format(
            "the flat face's profile has a cusp at cam angle {:.1f} deg (its radius of curvature "
            "base + s + s'' is {:.4g}): a larger base circle or a gentler law cuts it",
            theta / kDegree, p.radius_of_curvature));
      least_radius_ = std::min(least_radius_, p.radius_of_curvature);
      continue;
    }
    if (p.pitch_radius_of_curvature > 0.0) {
      if (follower_.kind == FollowerKind::roller &&
          !(p.pitch_radius_of_curvature > follower_.roller_radius))
        throw std::invalid_argument(fmt::format(
            "the profile undercuts at cam angle {:.1f} deg: the pitch curve's radius of "
            "curvature there ({:.4g}) is less than the roller's ({:.4g})",
            theta / kDegree, p.pitch_radius_of_curvature, follower_.roller_radius));
      least_radius_ = std::min(least_radius_, p.radius_of_curvature);
    }
    // A ray from the centre crosses the pitch curve once while its polar angle keeps falling.
    const FollowerPath f = follower_path(*motion_, follower_, theta);
    if (!(cross(f.F, f.dF) < f.F.squaredNorm()))
      throw std::invalid_argument(fmt::format(
          "the pitch curve is not star-shaped about the cam's centre at cam angle {:.1f} deg: "
          "the follower's path turns about the centre faster than the cam",
          theta / kDegree));
    const double angle = std::atan2(f.F.y(), f.F.x()) - theta;
    psi_.push_back(k == 0 ? angle : psi_.back() + std::remainder(angle - psi_.back(), kTurn));
  }
}

double Contour::cam_angle(double angle) const {
  if (!motion_)
    throw std::logic_error("a profile given by its shape: its contact follows the guide, no law");
  if (flat_faced()) return kPi / 2.0 - angle;  // the face's normal +y turned by -theta
  // The turn's sample whose polar angle lies just above `angle` (taken into (psi_0 - 2 pi,
  // psi_0]), then Newton on angle(F(theta)) - theta = angle.
  const double x = angle + kTurn * std::floor((psi_.front() - angle) / kTurn);
  const auto below = std::upper_bound(psi_.begin(), psi_.end(), x, std::greater<double>());
  const size_t i = below == psi_.begin()
                       ? 0  // x rounded above psi_0
                       : std::min(static_cast<size_t>(below - psi_.begin()) - 1, psi_.size() - 2);
  const double step = kTurn / kSamples;
  double theta = step * (static_cast<double>(i) + (psi_[i] - x) / (psi_[i] - psi_[i + 1]));
  for (int iteration = 0; iteration < 30; ++iteration) {
    const FollowerPath f = follower_path(*motion_, follower_, theta);
    const double slope = cross(f.F, f.dF) / f.F.squaredNorm() - 1.0;
    const double delta = std::remainder(std::atan2(f.F.y(), f.F.x()) - theta - x, kTurn) / slope;
    theta -= delta;
    if (std::abs(delta) <= 1e-15) break;
  }
  return theta;
}

double TangentCam::ascent() const {
  return std::acos((base_radius - nose_radius) / distance);
}

TangentCam TangentCam::from_lift(double base_radius, double lift, double ascent, double nose_radius,
                                 double nose_angle) {
  if (!(base_radius > 0.0))
    throw std::invalid_argument("base_radius: the base circle's radius must be positive");
  if (!(lift > 0.0)) throw std::invalid_argument("lift: the lift must be positive");
  TangentCam cam;
  cam.base_radius = base_radius;
  cam.nose_angle = nose_angle;
  if (std::isnan(nose_radius)) {
    // Rb - Rn = (Rb + lift - Rn) cos(alpha), solved for Rn.
    const double c = std::cos(ascent);
    if (!(ascent > 0.0 && ascent < kPi / 2.0))
      throw std::invalid_argument("ascent: the angle of ascent must lie between 0 and 90 deg");
    nose_radius = (base_radius - (base_radius + lift) * c) / (1.0 - c);
    if (!(nose_radius > 0.0))
      throw std::invalid_argument(fmt::format(
          "ascent: a lift of {:.6g} over {:.6g} deg leaves no nose (its radius {:.6g}): the "
          "angle of ascent must exceed {:.6g} deg",
          lift, ascent / kDegree, nose_radius,
          std::acos(base_radius / (base_radius + lift)) / kDegree));
  } else if (!(nose_radius > 0.0 && nose_radius < base_radius)) {
    throw std::invalid_argument(
        "nose_radius: the nose's radius must be positive and less than the base circle's");
  }
  cam.nose_radius = nose_radius;
  cam.distance = base_radius + lift - nose_radius;
  return cam;
}

Contour::Contour(TangentCam shape, Follower follower) : Contour(follower) {
  tangent_ = shape;
  if (follower_.kind == FollowerKind::flat_faced)
    throw std::invalid_argument(
        "a flat face on a tangent cam would leave the base circle for the nose at once, its "
        "velocity not continuous: a tangent cam takes a knife edge or a roller");
  // The flanks have no curvature, the base circle more radius than the nose.
  least_radius_ = shape.nose_radius;
}

Contour::Contour(Follower follower) : follower_(follower) {
  if (follower_.kind == FollowerKind::roller && !(follower_.roller_radius > 0.0))
    throw std::invalid_argument("the roller's radius must be positive");
  largest_pressure_ = std::numeric_limits<double>::quiet_NaN();  // the follower's guide's
}

Contour::Contour(EccentricCam shape, Follower follower) : Contour(follower) {
  eccentric_ = shape;
  if (!(shape.eccentricity >= 0.0))
    throw std::invalid_argument("eccentricity: the eccentricity must not be negative");
  if (!(shape.radius > shape.eccentricity))
    throw std::invalid_argument(
        fmt::format("radius: the disc's radius {:.6g} must exceed its eccentricity {:.6g}, so "
                    "that it holds the cam's centre",
                    shape.radius, shape.eccentricity));
  least_radius_ = shape.radius;
}

namespace {
// A point X(phi) = r(phi) u(phi) of a surface given in polar form, and its first four
// derivatives in phi (u' = perp(u), perp(u)' = -u).
struct Curve {
  Eigen::Vector2d X, dX, ddX, dddX, ddddX;
};
Curve surface_point(const MotionProgram& radius, double phi) {
  const Motion m = radius.at(phi);
  const Eigen::Vector2d u(std::cos(phi), std::sin(phi)), v = perp(u);
  return {m.s * u, m.ds * u + m.s * v, (m.dds - m.s) * u + 2.0 * m.ds * v,
          (m.ddds - 3.0 * m.ds) * u + (3.0 * m.dds - m.s) * v,
          (m.dddds - 6.0 * m.dds + m.s) * u + 4.0 * (m.ddds - m.ds) * v};
}
// The curve moved by r along its outward normal n = -perp(X') / |X'| (the surface runs
// counterclockwise), with its first three derivatives: a roller's centre on the surface.
struct Path {
  Eigen::Vector2d P, dP, ddP, dddP;
};
Path moved_out(const Curve& c, double r) {
  const double s = c.dX.norm(), ds = c.dX.dot(c.ddX) / s;
  const double dds = (c.ddX.squaredNorm() + c.dX.dot(c.dddX) - ds * ds) / s;
  const Eigen::Vector2d n = -perp(c.dX) / s;
  const Eigen::Vector2d dn = -perp(c.ddX) / s + perp(c.dX) * ds / (s * s);
  const Eigen::Vector2d ddn = -perp(c.dddX) / s + 2.0 * perp(c.ddX) * ds / (s * s) +
                              perp(c.dX) * (dds / (s * s) - 2.0 * ds * ds / (s * s * s));
  // The third by differentiating n s = -perp(X') and s^2 = X' . X' three times.
  const double ddds = (3.0 * c.ddX.dot(c.dddX) + c.dX.dot(c.ddddX) - 3.0 * ds * dds) / s;
  const Eigen::Vector2d dddn = (-perp(c.ddddX) - 3.0 * ddn * ds - 3.0 * dn * dds - n * ddds) / s;
  return {c.X + r * n, c.dX + r * dn, c.ddX + r * ddn, c.dddX + r * dddn};
}
// A path F(t) in polar form: rho = |F| against psi = angle(F) - spin t, by the chain rule
// through t (spin 1: a follower's path seen from the turning cam; 0: a curve of the cam).
Polar polar_of(const Eigen::Vector2d& F, const Eigen::Vector2d& dF, const Eigen::Vector2d& ddF,
               const Eigen::Vector2d& dddF, double spin) {
  const double r = F.norm(), r2 = F.squaredNorm();
  const double dr = F.dot(dF) / r;
  const double ddr = (dF.squaredNorm() + F.dot(ddF) - dr * dr) / r;
  const double turn = cross(F, dF);
  const double dpsi = turn / r2 - spin;
  const double ddpsi = cross(F, ddF) / r2 - 2.0 * turn * F.dot(dF) / (r2 * r2);
  // The third derivatives of r (r^2 = F . F) and of the polar angle (its rate times r^2 is
  // cross(F, F')), each differentiated once more.
  const double dddr = (3.0 * dF.dot(ddF) + F.dot(dddF) - 3.0 * dr * ddr) / r;
  const double dr2 = 2.0 * F.dot(dF), ddr2 = 2.0 * (dF.squaredNorm() + F.dot(ddF));
  const double dddpsi =
      (cross(dF, ddF) + cross(F, dddF) - 2.0 * ddpsi * dr2 - (dpsi + spin) * ddr2) / r2;
  const double p3 = dpsi * dpsi * dpsi;
  return {r, dr / dpsi, (ddr * dpsi - dr * ddpsi) / p3,
          ((dddr * dpsi - dr * dddpsi) * dpsi - 3.0 * ddpsi * (ddr * dpsi - dr * ddpsi)) /
              (p3 * dpsi * dpsi)};
}
}  // namespace

Contour Contour::from_points(MotionProgram surface, Follower follower) {
  Contour c(follower);
  c.surface_ = std::move(surface);
  c.least_radius_ = std::numeric_limits<double>::infinity();
  const bool flat = c.flat_faced();
  const double r = follower.kind == FollowerKind::roller ? follower.roller_radius : 0.0;
  for (int k = 0; k <= kSamples; ++k) {
    const double phi = kTurn * k / kSamples;
    const Curve s = surface_point(*c.surface_, phi);
    const double bend = cross(s.dX, s.ddX);  // |X'|^3 times the curvature
    const double radius = std::pow(s.dX.norm(), 3) / bend;
    if (!(s.X.dot(Eigen::Vector2d(std::cos(phi), std::sin(phi))) > 0.0))
      throw std::invalid_argument(
          fmt::format("points: the profile's radius is not positive at {:.1f} deg", phi / kDegree));
    if (flat && !(bend > 0.0))
      throw std::invalid_argument(fmt::format(
          "points: the profile is concave at {:.1f} deg: a flat face bridges a concave stretch, "
          "so it needs a convex profile",
          phi / kDegree));
    if (bend < 0.0 && !(-radius > r))
      throw std::invalid_argument(fmt::format(
          "points: the profile's concave stretch at {:.1f} deg (radius of curvature {:.4g}) is "
          "tighter than the {}",
          phi / kDegree, -radius, r > 0.0 ? "roller" : "knife edge can follow"));
    if (bend > 0.0) c.least_radius_ = std::min(c.least_radius_, radius);
    // The angle the row reads: the face's normal's, or the pitch point's polar angle.
    double angle = std::atan2(s.dX.y(), s.dX.x()) - kPi / 2.0;
    if (!flat) {
      const Path p = moved_out(s, r);
      if (!(cross(p.P, p.dP) > 0.0))
        throw std::invalid_argument(fmt::format(
            "points: the roller's path is not star-shaped about the cam's centre at {:.1f} deg",
            phi / kDegree));
      angle = std::atan2(p.P.y(), p.P.x());
    }
    c.psi_.push_back(k == 0 ? angle : c.psi_.back() + std::remainder(angle - c.psi_.back(), kTurn));
  }
  return c;
}

double Contour::surface_angle(double angle) const {
  const double x =
      angle + kTurn * std::floor((psi_.back() - angle) / kTurn);  // in (psi_n - 2 pi, psi_n]
  const auto above = std::upper_bound(psi_.begin(), psi_.end(), x);
  const size_t i = above == psi_.begin()
                       ? 0
                       : std::min(static_cast<size_t>(above - psi_.begin()) - 1, psi_.size() - 2);
  const double step = kTurn / kSamples;
  double phi = step * (static_cast<double>(i) + (x - psi_[i]) / (psi_[i + 1] - psi_[i]));
  const double r = follower_.kind == FollowerKind::roller ? follower_.roller_radius : 0.0;
  for (int iteration = 0; iteration < 30; ++iteration) {
    const Curve s = surface_point(*surface_, phi);
    double value = 0.0, slope = 0.0;
    if (flat_faced()) {
      value = std::atan2(s.dX.y(), s.dX.x()) - kPi / 2.0;
      slope = cross(s.dX, s.ddX) / s.dX.squaredNorm();
    } else {
      const Path p = moved_out(s, r);
      value = std::atan2(p.P.y(), p.P.x());
      slope = cross(p.P, p.dP) / p.P.squaredNorm();
    }
    const double delta = std::remainder(value - x, kTurn) / slope;
    phi -= delta;
    if (std::abs(delta) <= 1e-15) break;
  }
  return phi;
}

namespace {
// A circle of radius r about the point at distance c in the direction 0, in polar form about
// the origin: rho(t) = c cos t + sqrt(r^2 - c^2 sin^2 t), with its derivatives in t.
Polar circle_polar(double c, double r, double t) {
  const double a = c * std::cos(t), b = c * std::sin(t), w = std::sqrt(r * r - b * b);
  const double w3 = w * w * w;
  return {a + w, -b - a * b / w, -a + (b * b - a * a) / w - a * a * b * b / w3,
          b + 4.0 * a * b / w + 3.0 * a * b * (b * b - a * a) / w3 -
              3.0 * a * a * a * b * b * b / (w3 * w * w)};
}
// The line n . x = p, n at the angle 0, in polar form: rho(t) = p / cos t.
Polar line_polar(double p, double t) {
  const double c = std::cos(t), s = std::sin(t);
  return {p / c, p * s / (c * c), p * (1.0 + s * s) / (c * c * c),
          p * s * (5.0 + s * s) / (c * c * c * c)};
}
}  // namespace

Polar Contour::at(double angle) const {
  if (tangent_) {  // the pitch curve: each piece moved out by the roller's radius
    const TangentCam& cam = *tangent_;
    const double r = follower_.kind == FollowerKind::roller ? follower_.roller_radius : 0.0;
    const double t = std::remainder(angle - cam.nose_angle, kTurn), alpha = cam.ascent();
    const double nose = cam.nose_radius + r;
    // The flank leaves the nose where the nose's normal is at alpha: seen from the centre at
    // delta.
    const double delta = std::atan2(nose * std::sin(alpha), cam.distance + nose * std::cos(alpha));
    if (std::abs(t) <= delta) return circle_polar(cam.distance, nose, t);
    if (std::abs(t) < alpha) {
      const double side = t > 0.0 ? 1.0 : -1.0;  // the flank whose normal is at +-alpha
      return line_polar(cam.base_radius + r, t - side * alpha);
    }
    return {cam.base_radius + r, 0.0, 0.0, 0.0};
  }
  if (eccentric_) {  // the disc (moved out by the roller's radius), or its support function
    const EccentricCam& cam = *eccentric_;
    const double t = angle - cam.angle, e = cam.eccentricity;
    if (flat_faced())
      return {cam.radius + e * std::cos(t), -e * std::sin(t), -e * std::cos(t), e * std::sin(t)};
    const double r = follower_.kind == FollowerKind::roller ? follower_.roller_radius : 0.0;
    return circle_polar(e, cam.radius + r, t);
  }
  if (surface_) {
    if (flat_faced()) {  // h = X . n, h' = X . perp(n), h + h'' the radius of curvature
      const Curve s = surface_point(*surface_, surface_angle(angle));
      const Eigen::Vector2d n(std::cos(angle), std::sin(angle));
      const double h = s.X.dot(n), h1 = s.X.dot(perp(n));
      // The radius of curvature |X'|^3 / k, k = cross(X', X''), turned from phi to the normal's
      // angle, which turns k / |X'|^2 per unit of phi.
      const double speed = s.dX.norm(), k = cross(s.dX, s.ddX);
      const double radius = speed * speed * speed / k;
      const double radius_per_phi =
          3.0 * speed * s.dX.dot(s.ddX) / k - radius * cross(s.dX, s.dddX) / k;
      return {h, h1, radius - h, radius_per_phi * speed * speed / k - h1};
    }
    if (follower_.kind == FollowerKind::knife_edge) {  // the pitch curve is the surface
      const Motion m = surface_->at(angle);
      return {m.s, m.ds, m.dds, m.ddds};
    }
    const Path p =
        moved_out(surface_point(*surface_, surface_angle(angle)), follower_.roller_radius);
    return polar_of(p.P, p.dP, p.ddP, p.dddP, 0.0);
  }
  const double theta = cam_angle(angle);
  if (flat_faced()) {  // h(alpha) = base + s(pi/2 - alpha)
    const Motion m = motion_->at(theta);
    return {follower_.base_radius + m.s, -m.ds, m.dds, -m.ddds};
  }
  // rho = |F(theta)| against psi = angle(F) - theta.
  const FollowerPath f = follower_path(*motion_, follower_, theta);
  return polar_of(f.F, f.dF, f.ddF, f.dddF, 1.0);
}

}  // namespace crosslink::cam
