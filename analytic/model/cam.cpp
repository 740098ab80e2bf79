#include "analytic/model/cam.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
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
      return {u, 1.0, 0.0, 0.0};
    case Law::simple_harmonic: {
      const double c = std::cos(kPi * u), s = std::sin(kPi * u);
      return {(1.0 - c) / 2.0, kPi / 2.0 * s, kPi * kPi / 2.0 * c, -kPi * kPi * kPi / 2.0 * s};
    }
    case Law::cycloidal: {
      const double c = std::cos(kTurn * u), s = std::sin(kTurn * u);
      return {u - s / kTurn, 1.0 - c, kTurn * s, kTurn * kTurn * c};
    }
    case Law::polynomial_345:
      return {10.0 * u3 - 15.0 * u4 + 6.0 * u4 * u, 30.0 * u2 - 60.0 * u3 + 30.0 * u4,
              60.0 * u - 180.0 * u2 + 120.0 * u3, 60.0 - 360.0 * u + 360.0 * u2};
    case Law::polynomial_4567:
      return {35.0 * u4 - 84.0 * u4 * u + 70.0 * u3 * u3 - 20.0 * u4 * u3,
              140.0 * u3 - 420.0 * u4 + 420.0 * u4 * u - 140.0 * u3 * u3,
              420.0 * u2 - 1680.0 * u3 + 2100.0 * u4 - 840.0 * u4 * u,
              840.0 * u - 5040.0 * u2 + 8400.0 * u3 - 4200.0 * u4};
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
  if (std::abs(level - start_) > kClosure * std::max(1.0, std::abs(start_)))
    throw std::invalid_argument(
        fmt::format("the rise does not close: the last segment ends at {:.9g}, the program "
                    "starts at {:.9g}",
                    level, start_));
}

MotionProgram MotionProgram::table(const std::vector<std::pair<double, double>>& points) {
  const int n = static_cast<int>(points.size());
  if (n < 3) throw std::invalid_argument("a table needs at least three points");
  MotionProgram p;
  for (int i = 0; i < n; ++i) {
    const auto& [theta, s] = points[static_cast<size_t>(i)];
    if (!std::isfinite(theta) || !std::isfinite(s))
      throw std::invalid_argument(fmt::format("table point {}: not a number", i + 1));
    if (i > 0 && !(theta > p.knot_theta_.back()))
      throw std::invalid_argument(
          fmt::format("table point {}: its cam angle must exceed the one before", i + 1));
    p.knot_theta_.push_back(theta);
    p.knot_s_.push_back(s);
  }
  if (!(p.knot_theta_.back() < p.knot_theta_.front() + kTurn))
    throw std::invalid_argument("the table's cam angles must lie within one turn");
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
            (mj - mi) / h};
  }
  const double x = within_turn(theta);
  size_t k =
      static_cast<size_t>(std::upper_bound(begins_.begin(), begins_.end(), x) - begins_.begin()) -
      1;
  const Segment& g = segments_[k];
  const double from = k == 0 ? start_ : segments_[k - 1].to;
  const double rise = g.to - from, b = g.span;
  const Normalised y = normalised(g.law, std::clamp((x - begins_[k]) / b, 0.0, 1.0));
  return {from + rise * y.y, rise * y.dy / b, rise * y.ddy / (b * b), rise * y.dddy / (b * b * b)};
}

ProfilePoint profile_at(const MotionProgram& motion, const Follower& f, double theta) {
  if (!(f.base_radius > 0.0))
    throw std::invalid_argument("the base circle's radius must be positive");
  if (f.kind == FollowerKind::roller && !(f.roller_radius > 0.0))
    throw std::invalid_argument("the roller's radius must be positive");
  const Motion m = motion.at(theta);
  ProfilePoint p;

  if (f.kind == FollowerKind::flat_faced) {
    if (f.oscillating)
      throw std::invalid_argument("an oscillating flat-faced follower is not supported yet");
    // The face y = base + s touches the cam where the profile's normal is +y: at x = ds from
    // the cam's centre (the support function's derivative), whatever the axis's offset.
    const double h = f.base_radius + m.s;
    p.follower = {f.offset, h};
    const Eigen::Rotation2Dd to_cam(-theta);
    p.contact = p.pitch = to_cam * Eigen::Vector2d(m.ds, h);
    p.normal = to_cam * Eigen::Vector2d(0.0, 1.0);
    p.pressure_angle = 0.0;
    p.radius_of_curvature = p.pitch_radius_of_curvature = h + m.dds;
    return p;
  }

  // The roller's centre (or the knife's edge) F in the fixed frame, its derivatives in theta,
  // and the direction it moves in.
  const double r = f.kind == FollowerKind::roller ? f.roller_radius : 0.0;
  const double prime = f.base_radius + r;
  Eigen::Vector2d F, dF, ddF, along;
  if (!f.oscillating) {
    if (!(std::abs(f.offset) < prime))
      throw std::invalid_argument(
          "the follower's offset must be less than the prime circle's radius");
    F = {f.offset, std::sqrt(prime * prime - f.offset * f.offset) + m.s};
    dF = {0.0, m.ds};
    ddF = {0.0, m.dds};
    along = {0.0, 1.0};
  } else {
    if (!(f.arm > 0.0)) throw std::invalid_argument("the follower's arm must be positive");
    // The arm's lowest angle puts F on the prime circle, on the side where a larger angle lifts
    // it: |pivot + arm u(gamma)| = prime, d|F|/dgamma > 0.
    const double d = f.pivot.norm();
    const double c = (prime * prime - d * d - f.arm * f.arm) / (2.0 * f.arm * d);
    if (!(d > 0.0) || !(std::abs(c) <= 1.0))
      throw std::invalid_argument(
          "the follower's arm cannot reach the prime circle from its pivot");
    const double gamma = std::atan2(f.pivot.y(), f.pivot.x()) - std::acos(c) + m.s;
    const Eigen::Vector2d u(std::cos(gamma), std::sin(gamma));
    F = f.pivot + f.arm * u;
    along = perp(u);
    dF = f.arm * m.ds * along;
    ddF = f.arm * (m.dds * along - m.ds * m.ds * u);
    p.arm_angle = gamma;
  }
  p.follower = F;
  // In the cam frame P = R(-theta) F, and d/dtheta R(-theta) v = -R(-theta) perp(v).
  const Eigen::Rotation2Dd to_cam(-theta);
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
  p.pressure_angle = std::atan2(cross(along, n), along.dot(n));
  return p;
}

}  // namespace crosslink::cam
