#include "sim/sampling.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include <time.h>

namespace crosslink::sim {

double thread_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

long parse_max_steps(const std::string& text) {
  size_t used = 0;
  long value = 0;
  try {
    value = std::stol(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || value < 1)
    throw std::invalid_argument(
        fmt::format("setting max_steps: a positive whole number, got '{}'", text));
  return value;
}

void check_steps(double steps, double dt, long max_steps) {
  if (steps <= static_cast<double>(max_steps)) return;  // NaN (no dt) is refused too
  throw std::runtime_error(fmt::format(
      "dt = {:g} s takes {:.0f} steps over the run: the limit is {} steps (raise it with "
      "--max-steps N, or the setting max_steps)",
      dt, steps, max_steps));
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

}  // namespace crosslink::sim
