// IFToMM A02 reduced to one freedom: on the parallelogram branch every crank of the N four-bar
// mechanism has one angle theta, and T = (4N+1)/6 theta'^2, V = g (3N+1)/2 sin(theta) give
//   theta'' = -g 3(3N+1) / (2(4N+1)) cos(theta),
// integrated here by Bulirsch-Stoer (another method than the reference's) as an independent
// expected value for B0 = (cos theta, sin theta) at every sample.
#pragma once

#include <array>
#include <boost/numeric/odeint.hpp>
#include <cmath>

#include "analytic/trajectory.h"

namespace crosslink::test {

// The worst difference of B0 (point column `b0`) from the one-freedom equation over the samples
// of `t` (positions in m, velocities over 7 m/s, the largest speed; a sample next to the change
// point, flagged singular, has its position only); -1 if a sample has no pose.
inline double nfourbar_b0_difference(const Trajectory& t, int b0, int n) {
  const double g = 9.81, k = g * 3.0 * (3.0 * n + 1.0) / (2.0 * (4.0 * n + 1.0));
  using State = std::array<double, 2>;
  State x = {std::acos(-1.0) / 2.0, -1.0};
  double time = 0.0, worst = 0.0;
  namespace odeint = boost::numeric::odeint;
  auto pendulum = [k](const State& s, State& ds, double) { ds = {s[1], -k * std::cos(s[0])}; };
  for (int i = 0; i < t.samples(); ++i) {
    if (t.time(i) > time)
      odeint::integrate_adaptive(odeint::bulirsch_stoer<State>(1e-13, 1e-13), pendulum, x, time,
                                 t.time(i), 1e-3);
    time = t.time(i);
    const PoseStatus status = t.status[static_cast<size_t>(i)];
    if (status != PoseStatus::ok && status != PoseStatus::singular) return -1.0;
    const double dx = t.x(i, b0) - std::cos(x[0]), dy = t.y(i, b0) - std::sin(x[0]);
    worst = std::max({worst, std::abs(dx), std::abs(dy)});
    if (status == PoseStatus::singular) continue;  // next to the change point: no rates
    const double dvx = t.vx(i, b0) + std::sin(x[0]) * x[1],
                 dvy = t.vy(i, b0) - std::cos(x[0]) * x[1];
    worst = std::max({worst, std::abs(dx), std::abs(dy), std::abs(dvx) / 7.0, std::abs(dvy) / 7.0});
  }
  return worst;
}

}  // namespace crosslink::test
