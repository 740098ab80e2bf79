#include "sim/sampling.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <time.h>

namespace crosslink::sim {

std::string start_mismatch(const Mechanism& m, const Eigen::VectorXd& read,
                           const Eigen::VectorXd& q_start) {
  const double mismatch = (read - q_start).cwiseAbs().maxCoeff();
  if (mismatch < 1e-9 * std::max(m.size(), 1.0)) return "";
  return fmt::format("scene does not reproduce the assembled configuration (off by {:.3e})",
                     mismatch);
}

double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

void check_steps(double steps, double dt, long max_steps) {
  if (steps <= static_cast<double>(max_steps)) return;  // NaN (no dt) is refused too
  // Whole steps while they read as a count; beyond 1e15 (dt = 1e-300 takes 1e300) in 3 digits.
  const std::string count =
      steps < 1e15 ? fmt::format("{:.0f}", steps) : fmt::format("{:.3g}", steps);
  throw std::runtime_error(
      fmt::format("dt = {:g} s takes {} steps over the run: the limit is {} steps (raise it with "
                  "--max-steps N, or the setting max_steps)",
                  dt, count, max_steps));
}

Span usable_span(const Trajectory& reference) {
  Span span;
  for (int i = 0; i < reference.samples(); ++i)
    if (usable(reference.status[static_cast<size_t>(i)])) {
      if (span.first < 0) span.first = i;
      span.last = i;
    }
  if (span.first < 0) throw std::runtime_error("the reference has no usable sample to start from");
  if (span.last == span.first)
    throw std::runtime_error("the reference has a single usable sample: nothing to run over");
  return span;
}

Eigen::VectorXd reference_coordinates(const Mechanism& m, const Trajectory& reference, int row) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(m.coordinate_count());
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const double theta = reference.angle(row, k);
    Eigen::Vector2d origin = Eigen::Vector2d::Zero();
    for (const Point& p : m.links[l].points)
      for (size_t c = 0; c < reference.point_names.size(); ++c)
        if (reference.point_names[c] == p.name) {
          const Eigen::Vector2d at(reference.x(row, static_cast<Eigen::Index>(c)),
                                   reference.y(row, static_cast<Eigen::Index>(c)));
          origin = at - Eigen::Rotation2Dd(theta).toRotationMatrix() * p.local;
        }
    q.segment<3>(3 * k) << origin, theta;
  }
  return q;
}

ReferenceState reference_state(const Mechanism& m, const Trajectory& reference, int row) {
  ReferenceState out;
  const Eigen::Index n = m.coordinate_count();
  out.q = Eigen::VectorXd::Zero(n);
  out.qdot = Eigen::VectorXd::Zero(n);
  out.qddot = Eigen::VectorXd::Zero(n);
  auto perp = [](const Eigen::Vector2d& v) { return Eigen::Vector2d(-v.y(), v.x()); };
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const double theta = reference.angle(row, k), omega = reference.omega(row, k),
                 alpha = reference.alpha(row, k);
    out.q(3 * k + 2) = theta;
    out.qdot(3 * k + 2) = omega;
    out.qddot(3 * k + 2) = alpha;
    for (const Point& p : m.links[l].points)
      for (size_t c = 0; c < reference.point_names.size(); ++c) {
        if (reference.point_names[c] != p.name) continue;
        const auto i = static_cast<Eigen::Index>(c);
        // From the point P to the frame origin O: r = O - P = -R p_local.
        const Eigen::Vector2d r = -(Eigen::Rotation2Dd(theta).toRotationMatrix() * p.local);
        out.q.segment<2>(3 * k) = Eigen::Vector2d(reference.x(row, i), reference.y(row, i)) + r;
        out.qdot.segment<2>(3 * k) =
            Eigen::Vector2d(reference.vx(row, i), reference.vy(row, i)) + omega * perp(r);
        out.qddot.segment<2>(3 * k) = Eigen::Vector2d(reference.ax(row, i), reference.ay(row, i)) +
                                      alpha * perp(r) - omega * omega * r;
      }
  }
  return out;
}

double configuration_distance(const Eigen::VectorXd& a, const Eigen::VectorXd& b, double size) {
  double off = 0.0;
  for (Eigen::Index k = 0; k + 2 < a.size(); k += 3) {
    off = std::max({off, std::abs(a(k) - b(k)) / size, std::abs(a(k + 1) - b(k + 1)) / size,
                    std::abs(std::remainder(a(k + 2) - b(k + 2), 2.0 * std::numbers::pi))});
  }
  return off;
}

std::array<std::vector<double>, 3> stencil_weights(double x0, const std::vector<double>& x) {
  const size_t n = x.size();
  std::array<std::vector<double>, 3> c;
  for (auto& row : c) row.assign(n, 0.0);
  c[0][0] = 1.0;
  double c1 = 1.0, c4 = x[0] - x0;
  for (size_t i = 1; i < n; ++i) {
    const size_t mn = std::min<size_t>(i, 2);
    double c2 = 1.0;
    const double c5 = c4;
    c4 = x[i] - x0;
    for (size_t j = 0; j < i; ++j) {
      const double c3 = x[i] - x[j];
      c2 *= c3;
      if (j == i - 1) {
        for (size_t k = mn; k >= 1; --k)
          c[k][i] = c1 * (static_cast<double>(k) * c[k - 1][i - 1] - c5 * c[k][i - 1]) / c2;
        c[0][i] = -c1 * c5 * c[0][i - 1] / c2;
      }
      for (size_t k = mn; k >= 1; --k)
        c[k][j] = (c4 * c[k][j] - static_cast<double>(k) * c[k - 1][j]) / c3;
      c[0][j] = c4 * c[0][j] / c3;
    }
    c1 = c2;
  }
  return c;
}

std::vector<long> difference_stencil(long at, long last_step) {
  if (at - 1 >= 1 && at + 1 <= last_step) return {at - 1, at, at + 1};
  std::vector<long> steps;
  const long count = std::min(4L, last_step);
  const long from = std::clamp(at - count / 2, 1L, last_step - count + 1);
  for (long k = from; k < from + count; ++k) steps.push_back(k);
  return steps;
}

SamplePlan plan_samples(const Trajectory& reference, Span span,
                        const std::vector<double>& step_time, const std::vector<long>& sample_step,
                        bool with_forces) {
  const auto samples = static_cast<size_t>(reference.samples());
  const long last_step = static_cast<long>(step_time.size()) - 1;
  SamplePlan plan;
  plan.stencil.resize(samples);
  plan.forces.resize(samples);
  plan.read_forces.assign(static_cast<size_t>(last_step + 1), false);
  for (int i = span.first; i <= span.last; ++i) {
    const auto row = static_cast<size_t>(i);
    plan.stencil[row] = difference_stencil(sample_step[row], last_step);
    if (!with_forces) continue;
    plan.forces[row] = force_stencil(reference.time(i), last_step, step_time);
    for (long k : plan.forces[row].steps) plan.read_forces[static_cast<size_t>(k)] = true;
  }
  return plan;
}

long SamplePlan::complete_at(int i) const {
  long at = stencil[static_cast<size_t>(i)].back();
  for (long k : forces[static_cast<size_t>(i)].steps) at = std::max(at, k + 1);
  return at;
}

void difference_state(double t, const std::vector<long>& steps,
                      const std::vector<double>& step_time, const PoseAt& pose, Eigen::VectorXd& q,
                      Eigen::VectorXd& qdot, Eigen::VectorXd& qddot) {
  std::vector<double> times;
  for (long k : steps) times.push_back(step_time[static_cast<size_t>(k)]);
  const auto w = stencil_weights(t, times);
  q.setZero();
  qdot.setZero();
  qddot.setZero();
  for (size_t n = 0; n < steps.size(); ++n) {
    const Eigen::Ref<const Eigen::VectorXd> at = pose(steps[n]);
    q += w[0][n] * at;
    qdot += w[1][n] * at;
    qddot += w[2][n] * at;
  }
}

void recent_velocity(long k, const std::vector<double>& step_time, const PoseAt& pose,
                     Eigen::VectorXd& velocity) {
  std::vector<double> times;
  for (long n = std::max(0L, k - 2); n <= k; ++n)
    times.push_back(step_time[static_cast<size_t>(n)]);
  const auto w = stencil_weights(step_time[static_cast<size_t>(k)], times);
  velocity.setZero();
  for (size_t n = 0; n < times.size(); ++n)
    velocity += w[1][n] * pose(k - static_cast<long>(times.size()) + 1 + static_cast<long>(n));
}

}  // namespace crosslink::sim
