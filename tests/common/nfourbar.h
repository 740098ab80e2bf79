// IFToMM A02 reduced to one freedom: on the parallelogram branch every crank of the N four-bar
// mechanism has one angle theta, and T = (4N+1)/6 theta'^2, V = g (3N+1)/2 sin(theta) give
//   theta'' = -g 3(3N+1) / (2(4N+1)) cos(theta),
// integrated here by Bulirsch-Stoer (another method than the reference's) as an independent
// expected value for B0 = (cos theta, sin theta) at every sample.
#pragma once

#include <fmt/format.h>
#include <array>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <string>

#include "analytic/model/trajectory.h"

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

// IFToMM A02 with N four-bars as a definition (scripts/generate_a02.py's model), simulated for
// `duration` s, written in `length` units ("m" or "mm"): the same linkage whatever the unit.
inline std::string nfourbar_definition(int n, double duration, const std::string& length = "m") {
  const double u = length == "mm" ? 1000.0 : 1.0;  // file units per metre
  std::string t = fmt::format(
      "name = \"A02, N = {}\"\ngravity = [0, {}]\n[units]\nlength = \"{}\"\nangle = \"deg\"\n", n,
      -9.81 * u, length);
  const std::string bar =
      fmt::format("mass = 1\ncom = [{}, 0]\ninertia = {:.17g}\n", 0.5 * u, u * u / 12.0);
  t += "[[link]]\nname = \"ground\"\nground = true\npoints = { ";
  for (int i = 0; i <= n; ++i) t += fmt::format("{}A{} = [{}, 0]", i ? ", " : "", i, i * u);
  t += " }\n";
  for (int i = 0; i <= n; ++i)
    t += fmt::format(
        "[[link]]\nname = \"crank{}\"\npoints = {{ A{} = [0, 0], B{} = [{}, 0] }}\npose = [{}, 0, "
        "90]\n{}",
        i, i, i, u, i * u, bar);
  for (int i = 1; i <= n; ++i)
    t += fmt::format(
        "[[link]]\nname = \"coupler{}\"\npoints = {{ B{} = [0, 0], B{} = [{}, 0] }}\npose = [{}, "
        "{}, 0]\n{}",
        i, i - 1, i, u, (i - 1) * u, u, bar);
  for (int i = 0; i <= n; ++i)
    t += fmt::format(
        "[[joint]]\ntype = \"revolute\"\nlinks = [\"ground\", \"crank{}\"]\npoint = \"A{}\"\n", i,
        i);
  for (int i = 1; i <= n; ++i)
    t += fmt::format(
        "[[joint]]\ntype = \"revolute\"\nname = \"B{}c{}\"\nlinks = [\"crank{}\", "
        "\"coupler{}\"]\npoint = \"B{}\"\n[[joint]]\ntype = \"revolute\"\nname = "
        "\"B{}c{}\"\nlinks = [\"coupler{}\", \"crank{}\"]\npoint = \"B{}\"\n",
        i - 1, i, i - 1, i, i - 1, i, i, i, i, i);
  t += fmt::format(
      "[driver]\ntype = \"joint_angle\"\njoint = \"A0\"\nto = \"B0\"\nstart = 90\n[dynamics]\n"
      "duration = {}\ninterval = 0.025\nrate = -1\n",
      duration);
  return t;
}

}  // namespace crosslink::test
