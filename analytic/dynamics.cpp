#include "analytic/dynamics.h"

#include <fmt/format.h>

#include <array>
#include <boost/numeric/odeint.hpp>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "analytic/kinetostatics.h"
#include "analytic/newton.h"
#include "analytic/sweep.h"

namespace crosslink {
namespace {

using State = std::array<double, 3>;  // d, ddot, w

constexpr double kFirstStep = 1e-5;  // [s]: the integrator's first trial step

// Why a run stopped: the chain could not close, or only another branch was near.
struct Stopped {
  double time;
  PoseStatus status;
  std::string message;
  bool over_budget = false;  // the run reached SimulationOptions::max_solves
};

// The minimal-coordinate equation of motion, with the pose followed by continuation.
class EquationOfMotion {
 public:
  EquationOfMotion(const Mechanism& m, long max_solves)
      : m_(m),
        max_solves_(max_solves),
        solver_(m, NewtonOptions{.tolerance = 1e-15}),
        kinetostatics_(solver_),
        state_(m),
        g0_(m.coordinate_count()),
        g1_(m.coordinate_count()),
        s_(m.coordinate_count()),
        q_last_(m.coordinate_count()),
        s_last_(m.coordinate_count()),
        guess_(m.coordinate_count()) {
    const SolveReport assembled = solver_.assemble(state_);
    if (assembled.status != PoseStatus::ok)
      throw Stopped{0.0, assembled.status,
                    "the chain does not assemble at its start: " + assembled.message};
    // Poses far less well conditioned than the drawn one are next to a singular position (a
    // long chain's Jacobian is ill-conditioned everywhere: A02's rcond is 4e-2 upright at
    // N = 2 and 2e-4 at N = 40).
    if (const std::string why = singular_start(m, assembled.rcond); !why.empty())
      throw Stopped{0.0, PoseStatus::singular, why};
    near_singular_rcond_ = std::min(1e-4, 1e-2 * assembled.rcond);
    d_last_ = state_.driver.value;
    q_last_ = state_.q;
    unit_rate();
    s_last_ = s_;
  }

  const NewtonSolver& solver() const { return solver_; }
  const Kinetostatics& kinetostatics() const { return kinetostatics_; }
  KinematicState& state() { return state_; }
  long evaluations() const { return evaluations_; }
  // The reciprocal condition of the pose at the coordinate of the last acceleration().
  double rcond() const { return rcond_; }
  long solves() const { return solves_; }

  // dd/dt, dddot/dt and dw/dt at (t, x).
  void operator()(const State& x, State& dxdt, double t) {
    ++evaluations_;
    const double effort = m_.dynamics->effort_at(t);
    double power = 0.0;
    const double dddot = acceleration(t, x[0], x[1], effort, &power);
    dxdt = {x[1], dddot, effort * x[1] + power};
  }

  // The coordinate's acceleration at (d, ddot) under `effort`, and the power of the loads and
  // dampers. Next to a singular position (a change point, where J loses rank but the motion
  // goes on smoothly) the pose is resolved only to Newton's tolerance over the condition, and s
  // and qddot0 to round-off over it, so there both come from six regular evaluations around it
  // (d + k delta, k = +-1, +-2, +-3, Lagrange weights at 0): the error is ~delta^6 times the
  // sixth derivative, delta = 0.01 rad (or 0.01 of the size).
  double acceleration(double t, double d, double ddot, double effort, double* power = nullptr) {
    rcond_ = move_to(t, d);
    if (rcond_ >= near_singular_rcond_) return regular(t, d, ddot, effort, power);
    // Nodes 0.005 rad (or of the size) apart, spread twice as far while one of them is itself
    // next to the singular position: the longer the chain, the wider that zone (A02: 0.002 rad
    // at N = 2, 0.03 at N = 10).
    const double offsets[6] = {-3.0, -2.0, -1.0, 1.0, 2.0, 3.0};
    const double weights[6] = {1.0 / 20, -3.0 / 10, 3.0 / 4, 3.0 / 4, -3.0 / 10, 1.0 / 20};
    double dddot = 0.0, p = 0.0;
    for (double delta = 5e-3 * (m_.driver().angular() ? 1.0 : m_.size());; delta *= 2.0) {
      if (delta > kWidestSpread * (m_.driver().angular() ? 1.0 : m_.size()))
        throw Stopped{t, PoseStatus::singular,
                      fmt::format("singular on both sides of coordinate {:.12g}", d)};
      bool regular_nodes = true;
      dddot = p = 0.0;
      for (int i = 0; i < 6 && regular_nodes; ++i) {
        regular_nodes = move_to(t, d + offsets[i] * delta) >= near_singular_rcond_;
        double pi = 0.0;
        if (regular_nodes)
          dddot += weights[i] * regular(t, d + offsets[i] * delta, ddot, effort, &pi);
        p += weights[i] * pi;
      }
      if (!regular_nodes) continue;
      break;
    }
    // The state at d itself: its pose, with the rates of the smooth branch where it can.
    move_to(t, d);
    state_.qdot = s_ * ddot;
    state_.driver = {t, d, ddot, dddot};
    solver_.solve_acceleration(state_);
    if (power) *power = p;
    near_singular_ = true;
    return dddot;
  }

  // Whether the last acceleration() was taken next to a singular position.
  bool near_singular() const { return near_singular_; }

 private:
  // The widest spacing of the interpolation's nodes [rad, or of the size]: 0.16, so the nodes
  // span +-0.48 and the interpolation's error, ~(spacing)^6 times the sixth derivative, is still
  // small against the motion's scale.
  static constexpr double kWidestSpread = 0.16;

  double regular(double t, double d, double ddot, double effort, double* power) {
    near_singular_ = false;
    state_.qdot = s_ * ddot;
    state_.driver = {t, d, ddot, 0.0};
    solver_.solve_acceleration(state_);
    kinetostatics_.generalised_forces(state_, g0_);
    state_.qddot += s_;
    kinetostatics_.generalised_forces(state_, g1_);
    state_.qddot -= s_;
    const double mass = s_.dot(g0_ - g1_);  // s^T M s
    if (!(mass > 0.0))
      throw Stopped{t, PoseStatus::singular,
                    fmt::format("the generalised mass is {:g} at coordinate {:.12g}", mass, d)};
    const double dddot = (effort + s_.dot(g0_)) / mass;
    state_.qddot += s_ * dddot;
    state_.driver.accel = dddot;
    if (power) *power = kinetostatics_.load_power(state_);
    return dddot;
  }

  // Solves the pose at d from the last regular one, in continuation steps; s_ = dq/dd there.
  // Returns the pose's reciprocal condition; a pose next to a singular one is not taken as the
  // start of the next continuation (its s is not reliable) and its correction is not checked
  // (Newton resolves it only to ~sqrt(tolerance) there).
  double move_to(double t, double d) {
    const double from = d_last_, span = d - from;
    const double wanted = std::max(1.0, std::ceil(std::abs(span) / continuation_step(m_)));
    // Counted before they are taken: one evaluation may ask for billions (a coordinate thrown
    // across 1e9 rad by an effort of 1e12 in a nanosecond).
    if (!(solves_ + wanted <= static_cast<double>(max_solves_)))
      throw Stopped{t, PoseStatus::not_reached,
                    fmt::format("the run has taken {} pose solves and its next evaluation asks "
                                "for {:.0f} more (coordinate {:.6g} to {:.6g}): the limit is {} "
                                "(raise it with --max-solves N)",
                                solves_, wanted, from, d, max_solves_),
                    true};
    const int steps = static_cast<int>(wanted);
    solves_ += steps;
    double rcond = 1.0;
    for (int i = 1; i <= steps; ++i) {
      const double target = i == steps ? d : from + span * i / steps, h = target - d_last_;
      guess_ = q_last_ + h * s_last_;
      state_.q = guess_;
      state_.driver = {t, target, 1.0, 0.0};
      const SolveReport r = solver_.solve_position(state_);
      if (r.status != PoseStatus::ok && r.status != PoseStatus::singular)
        throw Stopped{t, r.status, fmt::format("at coordinate {:.12g}: {}", target, r.message)};
      rcond = r.rcond;
      if (rcond < near_singular_rcond_) {
        // Stepped over: the next pose is predicted from the last regular one, across.
        if (i < steps) continue;
        unit_rate();
        return rcond;
      }
      // Newton may only polish the predicted pose: a large correction is another branch.
      const double predicted = (h * s_last_).lpNorm<Eigen::Infinity>();
      if ((state_.q - guess_).lpNorm<Eigen::Infinity>() > 0.1 * predicted + 1e-9 * m_.size())
        throw Stopped{
            t, PoseStatus::branch_jump,
            fmt::format("the only pose near coordinate {:.12g} is on another branch", target)};
      unit_rate();
      d_last_ = target;
      q_last_ = state_.q;
      s_last_ = s_;
    }
    return rcond;
  }

  void unit_rate() {
    state_.driver.rate = 1.0;
    solver_.solve_velocity(state_);
    s_ = state_.qdot;
  }

  const Mechanism& m_;
  const long max_solves_;
  long solves_ = 0;
  NewtonSolver solver_;
  Kinetostatics kinetostatics_;
  KinematicState state_;
  Eigen::VectorXd g0_, g1_, s_, q_last_, s_last_, guess_;
  double d_last_ = 0.0, rcond_ = 1.0;
  long evaluations_ = 0;
  bool near_singular_ = false;
  // Poses closer to a singular one than this (reciprocal condition of J; Newton resolves them
  // to its tolerance over it) are interpolated.
  double near_singular_rcond_ = 1e-4;
};

}  // namespace

double Simulation::energy_error(int k) const {
  return std::abs(energy_balance(k)) / std::max(energy_scale, 1e-300);
}

std::string singular_start(const Mechanism& m, double rcond) {
  if (rcond >= kSingularStartRcond) return "";
  const bool angular = m.driver().angular();
  return fmt::format(
      "the start, driver = {:.9g} {}, is a singular position of the coordinate (rcond {:.1e}): "
      "there the other coordinates' rates are not determined by its rate, so no initial "
      "velocity is consistent with it; start the [driver] away from it",
      m.driver().start / (angular ? m.units.angle : m.units.length),
      angular ? m.units.angle_name : m.units.length_name, rcond);
}

Simulation simulate(const Mechanism& mechanism, const SimulationOptions& options) {
  if (!mechanism.dynamics)
    throw std::invalid_argument(mechanism.file + ": not a dynamics case (no [dynamics] table)");
  const DynamicsCase& c = *mechanism.dynamics;
  const double duration = options.duration > 0.0 ? options.duration : c.duration;
  const double interval = options.interval > 0.0 ? options.interval : c.interval;
  // Samples are stored: a duration far beyond its interval is refused, not attempted.
  constexpr double kMostSamples = 1e6;
  if (!(duration / interval < kMostSamples))
    throw std::invalid_argument(fmt::format(
        "{}: [dynamics] duration / interval = {:g} samples, more than {:g}: lengthen 'interval'",
        mechanism.file, duration / interval, kMostSamples));
  const int n = static_cast<int>(std::floor(duration / interval + 1e-9)) + 1;
  std::vector<double> times(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) times[static_cast<size_t>(k)] = k * interval;

  Simulation out;
  Trajectory& t = out.trajectory;
  t.method = "exact dynamics (" + options.integrator + ")";
  t.resize(mechanism, n, true);
  for (int k = 0; k < n; ++k) t.time(k) = times[static_cast<size_t>(k)];
  out.kinetic.setZero(n);
  out.potential.setZero(n);
  out.work.setZero(n);

  int written = 0;
  std::optional<EquationOfMotion> started;
  try {
    EquationOfMotion& eom = started.emplace(mechanism, options.max_solves);
    const Kinetostatics& kinetostatics = eom.kinetostatics();
    ForceSample forces = kinetostatics.make_sample();
    State x = {mechanism.driver().start, c.rate, 0.0};
    auto observe = [&](const State& y, double time) {
      const int k = written;  // counted once whole: a stop inside leaves it not_reached
      const double effort = c.effort_at(time);
      eom.acceleration(time, y[0], y[1], effort);
      KinematicState& s = eom.state();
      SolveReport report;
      report.rcond = eom.rcond();  // the trust rules' conditioning (analytic/trust.h)
      if (eom.near_singular()) {
        // Its coordinate's motion is exact, the rest of its pose only to round-off.
        report.status = PoseStatus::singular;
        report.message = "next to a singular position";
      }
      eom.solver().write_sample(s, report, t, k);
      if (!eom.near_singular()) {
        kinetostatics.solve(s, forces);
        kinetostatics.write_sample(forces, t, k);
      }
      out.kinetic(k) = kinetostatics.kinetic_energy(s);
      out.potential(k) = kinetostatics.potential_energy(s);
      out.work(k) = y[2];
      out.energy_scale = std::max({out.energy_scale, std::abs(out.kinetic(k)),
                                   std::abs(out.potential(k)), std::abs(out.work(k))});
      if (k == 0) out.initial_energy = out.kinetic(0) + out.potential(0);
      ++written;
    };
    namespace odeint = boost::numeric::odeint;
    const double tol = options.tolerance;
    // Every trial step evaluates poses along it: the first is small (the controller grows it by
    // up to 5 times a step) and none is longer than an interval, so no trial reaches far past
    // the motion (a first trial of 10 s put A02's crank 986 rad away).
    const double first = std::min(interval, kFirstStep);
    if (options.integrator == "dopri5") {
      odeint::integrate_times(
          odeint::make_dense_output(tol, tol, odeint::runge_kutta_dopri5<State>()), std::ref(eom),
          x, times.begin(), times.end(), first, observe);
    } else if (options.integrator == "rkf78") {
      odeint::integrate_times(
          odeint::make_controlled(tol, tol, odeint::runge_kutta_fehlberg78<State>()), std::ref(eom),
          x, times.begin(), times.end(), first, observe);
    } else {
      throw std::invalid_argument("unknown integrator '" + options.integrator +
                                  "' (valid: dopri5, rkf78)");
    }
  } catch (const Stopped& stop) {
    // No state at all: the case cannot start, bad input at its [dynamics] table, not a result.
    if (written == 0) throw DefinitionError({Diagnostic{mechanism.dynamics->where, stop.message}});
    out.ok = false;
    out.over_budget = stop.over_budget;
    out.message = fmt::format("stopped at t = {:.9g} s: {}", stop.time, stop.message);
    t.events.push_back({stop.time, stop.status, out.message});
    for (int k = written; k < n; ++k) t.status[static_cast<size_t>(k)] = PoseStatus::not_reached;
  }
  if (started) {
    out.evaluations = started->evaluations();
    out.solves = started->solves();
  }
  return out;
}

}  // namespace crosslink
