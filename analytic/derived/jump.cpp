#include "analytic/derived/jump.h"

#include <fmt/format.h>

#include <array>
#include <cmath>
#include <limits>

#include "analytic/derived/golden.h"
#include "analytic/kinematics/instant_centres.h"
#include "analytic/kinematics/newton.h"
#include "analytic/physics/kinetostatics.h"
#include "analytic/reference/sweep.h"

namespace crosslink {
namespace {

constexpr double kNone = std::numeric_limits<double>::infinity();

// The least lambda > 0 with a + b lambda + c lambda^2 = 0 (infinity: none), for a > 0.
double least_root(double a, double b, double c) {
  if (c == 0.0) return b < 0.0 ? -a / b : kNone;
  const double d = b * b - 4.0 * a * c;
  if (d < 0.0) return kNone;
  // The two roots without cancellation: q = -(b + sign(b) sqrt(d)) / 2, roots q / c and a / q.
  const double q = -0.5 * (b + std::copysign(std::sqrt(d), b));
  double best = kNone;
  for (const double r : {q / c, q != 0.0 ? a / q : kNone})
    if (r > 0.0 && r < best) best = r;
  return best;
}

}  // namespace

JumpSpeed jump_speed(const Mechanism& m, int joint) {
  JumpSpeed out;
  const Joint& j = m.joints[static_cast<size_t>(joint)];
  if (j.type != JointType::cam) {
    out.reason = fmt::format("joint '{}' is not a cam", j.name);
    return out;
  }
  if (j.form_closed) {
    out.reason = "a groove holds the follower both ways (form closure): it cannot jump";
    return out;
  }
  const Driver& driver = m.drivers[0];
  if (m.drivers.size() != 1 || driver.law.kind != MotionLaw::Kind::constant_speed ||
      driver.law.speed == 0.0) {
    out.reason = "the jump speed is that of one driver at a constant speed";
    return out;
  }
  if (!m.friction_joints().empty()) {
    out.reason = "with joint friction the contact force is not a quadratic in the speed";
    return out;
  }
  // The poses the cam imposes over the cycle, every follower held on (none flagged as leaving).
  Mechanism held = m;
  for (Joint& cam : held.joints) cam.form_closed = true;
  const Trajectory t = sweep(held);
  const NewtonSolver solver(m);
  const Kinetostatics kinetostatics(solver);
  ForceSample forces = kinetostatics.make_sample();
  KinematicState state(m);
  const double w0 = driver.law.speed;
  // At driver value x, from the pose `guess`: the least lambda > 0 at which the contact force at
  // speed lambda w0 is zero; NaN where the pose does not solve, -1 where the follower is not held
  // on even at rest.
  const auto root_at = [&](double x, const Eigen::VectorXd& guess) {
    state.q = guess;
    DriverState d = driver.at_time(0.0);
    d.value = x;
    d.rate = w0;
    d.accel = 0.0;
    state.swept() = d;
    if (solver.solve(state).status != PoseStatus::ok) return std::nan("");
    const Eigen::VectorXd rates = state.qdot, accelerations = state.qddot;
    const auto push = [&](double scale) {
      state.qdot = scale * rates;
      state.qddot = scale * scale * accelerations;
      kinetostatics.solve(state, forces);  // contact_lost or not: the forces that hold it on
      const BodyMotion a = BodyMotion::of(m.moving_index(j.link_a), state.q, nullptr, nullptr);
      const BodyMotion b = BodyMotion::of(m.moving_index(j.link_b), state.q, nullptr, nullptr);
      return forces.joint_force[static_cast<size_t>(joint)].dot(
          cam_contact(solver.layout().joint(joint), a, b).normal);
    };
    const double rest = push(0.0), ahead = push(1.0), back = push(-1.0);
    if (!(rest > 0.0)) return -1.0;
    return least_root(rest, 0.5 * (ahead - back), 0.5 * (ahead + back) - rest);
  };
  double best = kNone;
  int at = -1;
  for (int k = 0; k < t.samples(); ++k) {
    if (!has_position(t.status[static_cast<size_t>(k)])) continue;
    const double lambda = root_at(t.swept(k), coordinates_at(m, t, k).head(m.coordinate_count()));
    if (lambda == -1.0) {
      out.reason = fmt::format(
          "the loads do not hold the follower on at rest at driver value {:.6g}: the contact "
          "would pull there at any speed",
          t.swept(k));
      return out;
    }
    if (lambda < best) {
      best = lambda;
      at = k;
    }
  }
  if (at < 0) {
    out.reason = "the contact force reaches zero at no speed over the sweep";
    return out;
  }
  // Golden-section search between the neighbouring samples, from the best sample's pose.
  const Eigen::VectorXd guess = coordinates_at(m, t, at).head(m.coordinate_count());
  const auto lowered = [&](double x) -> std::optional<double> {
    const double r = root_at(x, guess);
    if (std::isnan(r) || r < 0.0) return std::nullopt;
    return -r;
  };
  const double x = golden_section_max(lowered, t.swept(std::max(at - 1, 0)),
                                      t.swept(std::min(at + 1, t.samples() - 1)));
  const std::optional<double> refined = lowered(x);
  const bool better = refined && -*refined < best;
  const double lambda = better ? -*refined : best;
  out.speed = lambda * std::abs(w0);
  out.at = better ? x : t.swept(at);
  return out;
}

}  // namespace crosslink
