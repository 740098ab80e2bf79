// Exact forward dynamics (analytic/dynamics.h) against independent expected values:
//   - IFToMM A02 with N = 2: on the parallelogram branch every crank has one angle theta, and
//     T = (4N+1)/6 theta'^2, V = g (3N+1)/2 sin(theta) give theta'' = -g 3(3N+1)/(2(4N+1)) cos
//     theta; that one-line equation, integrated here by a different method, is the reference for
//     B0 at every sample. B0 at 10 s is also compared, for the record, with the value EXUDYN's
//     documentation prints for its finest step (generalised-alpha, h = 1.25e-4 s).
//   - the energy balance at every sample, and a second integration (rkf78 against dopri5).
#include <gtest/gtest.h>

#include <array>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <string>

#include "analytic/dynamics.h"
#include "analytic/loader.h"

namespace crosslink {
namespace {

Mechanism bundled(const std::string& name) {
  return load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + name);
}

int column(const std::vector<std::string>& names, const std::string& name) {
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  return -1;
}

TEST(DoubleFourBar, B0FollowsTheOneFreedomPendulumEquation) {
  const Mechanism m = bundled("iftomm_a02_double_fourbar.toml");
  const Simulation sim = simulate(m);
  ASSERT_TRUE(sim.ok) << sim.message;
  const Trajectory& t = sim.trajectory;
  const int b0 = column(t.point_names, "B0");
  ASSERT_GE(b0, 0);

  // theta'' = -k cos theta, N = 2, from theta = 90 deg at -1 rad/s (Bulirsch-Stoer).
  const double N = 2.0, g = 9.81, k = g * 3.0 * (3.0 * N + 1.0) / (2.0 * (4.0 * N + 1.0));
  using State = std::array<double, 2>;
  State x = {std::acos(-1.0) / 2.0, -1.0};
  double time = 0.0;
  namespace odeint = boost::numeric::odeint;
  auto pendulum = [k](const State& s, State& ds, double) { ds = {s[1], -k * std::cos(s[0])}; };
  double worst = 0.0;
  for (int i = 0; i < t.samples(); ++i) {
    if (t.time(i) > time)
      odeint::integrate_adaptive(odeint::bulirsch_stoer<State>(1e-13, 1e-13), pendulum, x, time,
                                 t.time(i), 1e-3);
    time = t.time(i);
    ASSERT_EQ(t.status[static_cast<size_t>(i)], PoseStatus::ok) << "at t = " << time;
    const double dx = t.x(i, b0) - std::cos(x[0]), dy = t.y(i, b0) - std::sin(x[0]);
    const double dvx = t.vx(i, b0) + std::sin(x[0]) * x[1],
                 dvy = t.vy(i, b0) - std::cos(x[0]) * x[1];
    worst = std::max({worst, std::abs(dx), std::abs(dy), std::abs(dvx) / 7.0, std::abs(dvy) / 7.0});
  }
  std::printf(
      "[ A02 N=2 ] B0 at 10 s: (%.11f, %.11f); worst difference from the pendulum "
      "equation %.2e (positions m, velocities / 7 m/s)\n",
      t.x(t.samples() - 1, b0), t.y(t.samples() - 1, b0), worst);
  EXPECT_LT(worst, 1e-8);
  // EXUDYN (IFToMM A02 example, N = 2, h = 1.25e-4 s): B0 = (0.3284573768, 0.9445187937) at 10 s,
  // second order in h towards the exact value: within its own step error, not to our digits.
  EXPECT_NEAR(t.x(t.samples() - 1, b0), 0.3284573768, 2e-6);
  EXPECT_NEAR(t.y(t.samples() - 1, b0), 0.9445187937, 2e-6);
}

TEST(DoubleFourBar, EnergyIsConservedAndTwoIntegratorsAgree) {
  const Mechanism m = bundled("iftomm_a02_double_fourbar.toml");
  const Simulation a = simulate(m);
  SimulationOptions other;
  other.integrator = "rkf78";
  const Simulation b = simulate(m, other);
  ASSERT_TRUE(a.ok && b.ok) << a.message << b.message;
  ASSERT_EQ(a.trajectory.samples(), b.trajectory.samples());
  // The reference (dopri5) and the check (rkf78): energy balance at every usable sample, in J
  // and relative to the energies; and the two integrations' link angles.
  double drift = 0.0, joules = 0.0, check_drift = 0.0, apart = 0.0;
  for (int k = 0; k < a.trajectory.samples(); ++k) {
    if (!usable(a.trajectory.status[static_cast<size_t>(k)]) ||
        !usable(b.trajectory.status[static_cast<size_t>(k)]))
      continue;
    drift = std::max(drift, a.energy_error(k));
    joules =
        std::max(joules, std::abs(a.kinetic(k) + a.potential(k) - a.initial_energy - a.work(k)));
    check_drift = std::max(check_drift, b.energy_error(k));
    for (Eigen::Index c = 0; c < a.trajectory.angle.cols(); ++c)
      apart = std::max(apart, std::abs(a.trajectory.angle(k, c) - b.trajectory.angle(k, c)));
  }
  std::printf(
      "[ A02 N=2 ] energy balance: dopri5 %.2e (%.2e J), rkf78 %.2e; dopri5 vs rkf78 "
      "angles %.2e rad; evaluations %ld and %ld\n",
      drift, joules, check_drift, apart, a.evaluations, b.evaluations);
  EXPECT_LT(drift, 1e-10);
  EXPECT_LT(joules, 1e-9);  // the bound for A02 over 10 s
  EXPECT_LT(check_drift, 1e-9);
  EXPECT_LT(apart, 1e-8);
}

}  // namespace
}  // namespace crosslink
