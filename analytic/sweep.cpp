#include "analytic/sweep.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;

double default_step(const Mechanism& m, const SweepOptions& o) {
  if (o.step > 0.0) return o.step;
  return m.driver.angular() ? kPi / 180.0 : 0.0;  // sliders: set from the range
}

// Follows one assembly branch as the driver moves, by predictor-corrector continuation.
//
// Predictor: the second-order Taylor step q + q' h + q'' h^2 / 2, where q' = dq/dd and
// q'' = d2q/dd2 come from the velocity and acceleration solves at unit driver rate. Corrector:
// Newton. A step is accepted only when Newton's correction is small against the predicted
// motion; otherwise it is halved. So a jump to another assembly mode is refused rather than
// taken, and a step that cannot be taken however small locates a limit (or a singular position)
// to within the minimum step.
class Follower {
 public:
  Follower(const NewtonSolver& solver, KinematicState& state)
      : solver_(solver),
        state_(state),
        q0_(state.q.size()),
        tangent_(state.q.size()),
        curvature_(state.q.size()),
        predicted_(state.q.size()),
        inverse_scale_(state.q.size()) {
    // Distances in units of the mechanism's size: lengths / size, angles as they are.
    inverse_scale_.setConstant(1.0 / solver.length_scale());
    for (Eigen::Index k = 2; k < inverse_scale_.size(); k += 3) inverse_scale_(k) = 1.0;
  }

  // The state must be solved (J factorised) at its driver value, with `last` its report.
  void start(const SolveReport& last) { last_ = last; }

  // Moves the solved state to driver value `target`. On failure the state is left solved at
  // the last value reached and the report says why.
  SolveReport advance_to(double target, double max_step, double min_step) {
    double h = std::copysign(max_step, target - state_.driver.value);
    while (state_.driver.value != target) {
      const double d0 = state_.driver.value;
      if (std::abs(target - d0) <= std::abs(h)) h = target - d0;
      const bool tangent_ok = take_tangent();
      q0_ = state_.q;
      predicted_ = q0_ + h * tangent_ + (0.5 * h * h) * curvature_;
      state_.q = predicted_;
      state_.driver.value = d0 + h;
      SolveReport report = solver_.solve_position(state_);
      const bool converged =
          report.status == PoseStatus::ok || report.status == PoseStatus::singular;
      if (converged && acceptable(tangent_ok, h)) {
        last_ = report;
        if (std::abs(h) < max_step) h = std::copysign(std::min(2.0 * std::abs(h), max_step), h);
        continue;
      }
      // Refused: back to the last accepted pose (refactorising J there), and a shorter step.
      state_.q = q0_;
      state_.driver.value = d0;
      last_ = solver_.solve_position(state_);
      h *= 0.5;
      if (std::abs(h) < min_step) {
        report.status = converged ? PoseStatus::branch_jump : PoseStatus::cannot_assemble;
        report.message =
            converged
                ? fmt::format("at driver = {:.12g} the only nearby solution is on another branch",
                              d0)
                : fmt::format("the chain does not close beyond driver = {:.12g}", d0);
        return report;
      }
    }
    return last_;
  }

  const SolveReport& last() const { return last_; }

 private:
  double size_free_norm(const Eigen::VectorXd& v) const {
    return v.cwiseProduct(inverse_scale_).lpNorm<Eigen::Infinity>();
  }

  // Newton may only polish the prediction. Without a tangent (at a singular position) the
  // motion is bounded instead by the square-root growth of a fold.
  bool acceptable(bool tangent_ok, double h) const {
    if (!tangent_ok) return size_free_norm(state_.q - q0_) <= 4.0 * std::sqrt(std::abs(h));
    const double predicted_move = size_free_norm(predicted_ - q0_);
    return size_free_norm(state_.q - predicted_) <= 0.1 * predicted_move + 1e-10;
  }

  // q' and q'' with respect to the driver, from the factorisation at the current pose.
  bool take_tangent() {
    const DriverState real = state_.driver;
    state_.driver.rate = 1.0;
    state_.driver.accel = 0.0;
    solver_.solve_velocity(state_);
    solver_.solve_acceleration(state_);
    state_.driver = real;
    tangent_ = state_.qdot;
    curvature_ = state_.qddot;
    const bool ok = last_.status == PoseStatus::ok && tangent_.allFinite() &&
                    curvature_.allFinite();
    if (!ok) {
      tangent_.setZero();
      curvature_.setZero();
    }
    return ok;
  }

  const NewtonSolver& solver_;
  KinematicState& state_;
  Eigen::VectorXd q0_, tangent_, curvature_, predicted_, inverse_scale_;
  SolveReport last_;
};

// The driver's rate and acceleration at a driver value for a constant-speed law.
DriverState constant_speed_state(const Driver& d, double value) {
  DriverState s;
  s.value = value;
  s.rate = d.law.speed;
  s.time = (value - d.start) / d.law.speed;
  return s;
}

// Solves velocity and acceleration for the real driver state and writes one sample.
void record(const NewtonSolver& solver, KinematicState& state, const SolveReport& report,
            const DriverState& driver, Trajectory& out, int row) {
  state.driver = driver;
  if (report.status == PoseStatus::ok) {
    solver.solve_velocity(state);
    solver.solve_acceleration(state);
  } else {
    state.qdot.setZero();
    state.qddot.setZero();
  }
  solver.write_sample(state, report, out, row);
}

double min_step(const NewtonSolver& solver, double tolerance) {
  // Driver values closer than this are not told apart (angles in rad, slider in m).
  const Mechanism& m = solver.mechanism();
  return m.driver.angular() ? tolerance : tolerance * m.size();
}

}  // namespace

std::string AssemblingRange::explain(const Mechanism& m) const {
  if (full_cycle) return m.driver.angular() ? "full rotation (360 degrees)" : "unbounded";
  const double unit = m.driver.angular() ? m.units.angle : m.units.length;
  const std::string& name = m.driver.angular() ? m.units.angle_name : m.units.length_name;
  return fmt::format("{:.6f} to {:.6f} {}", lower / unit, upper / unit, name);
}

AssemblingRange assembling_range(const Mechanism& mechanism, const SweepOptions& options,
                                 double tolerance) {
  const NewtonSolver solver(mechanism, options.newton);
  KinematicState state(mechanism);
  const SolveReport assembled = solver.assemble(state);
  AssemblingRange range;
  if (assembled.status != PoseStatus::ok && assembled.status != PoseStatus::singular)
    return range;  // lower = upper = 0: nothing assembles; the caller reports `assembled`
  const double start = state.driver.value;
  const double step = mechanism.driver.angular() ? default_step(mechanism, options)
                                                 : mechanism.size() / 50.0;
  // Angles: search one turn each way. Sliders: up to 100 mechanism sizes each way.
  const double reach = mechanism.driver.angular() ? 2.0 * kPi : 100.0 * mechanism.size();
  const double small = min_step(solver, tolerance);
  const Eigen::VectorXd q_start = state.q;

  auto search = [&](double direction) {
    state.q = q_start;
    state.driver.value = start;
    Follower follower(solver, state);
    follower.start(solver.solve_position(state));
    const SolveReport r = follower.advance_to(start + direction * reach, step, small);
    return std::make_pair(r.status == PoseStatus::ok || r.status == PoseStatus::singular,
                          state.driver.value);
  };
  const auto [forward_free, upper] = search(+1.0);
  if (forward_free && mechanism.driver.angular()) {
    range.full_cycle = true;
    range.lower = start;
    range.upper = start + 2.0 * kPi;
    return range;
  }
  const auto [backward_free, lower] = search(-1.0);
  range.full_cycle = forward_free && backward_free;
  range.lower = lower;
  range.upper = upper;
  return range;
}

namespace {

// Fills one sample per driver state, in order, by continuation from the assembled state: first
// to the first sample, then from each sample to the next. Once the branch is lost (the chain
// cannot close, or only another branch is near), later samples carry that status and zeros.
void sweep_values(const NewtonSolver& solver, KinematicState& state, const SolveReport& assembled,
                  const std::vector<DriverState>& drivers, double max_step, double small,
                  Trajectory& out) {
  Follower follower(solver, state);
  follower.start(assembled);
  SolveReport failure = assembled;
  bool lost = assembled.status != PoseStatus::ok && assembled.status != PoseStatus::singular;
  for (size_t i = 0; i < drivers.size(); ++i) {
    const int row = static_cast<int>(i);
    if (!lost) {
      const SolveReport r = follower.advance_to(drivers[i].value, max_step, small);
      if (r.status == PoseStatus::ok || r.status == PoseStatus::singular) {
        if (r.status == PoseStatus::singular)
          out.events.push_back({drivers[i].value, r.status, r.message});
        record(solver, state, r, drivers[i], out, row);
        continue;
      }
      lost = true;
      failure = r;
      out.events.push_back({state.driver.value, r.status, r.message});
    }
    state.q.setZero();
    state.qdot.setZero();
    state.qddot.setZero();
    state.driver = drivers[i];
    solver.write_sample(state, failure, out, row);
  }
}

}  // namespace

Trajectory sweep(const Mechanism& mechanism, const SweepOptions& options) {
  const Driver& d = mechanism.driver;
  const NewtonSolver solver(mechanism, options.newton);
  KinematicState state(mechanism);
  const SolveReport assembled = solver.assemble(state);
  const double small = min_step(solver, 1e-10);

  std::vector<DriverState> drivers;
  double max_step = default_step(mechanism, options);
  std::string note;
  if (d.law.kind != MotionLaw::Kind::constant_speed) {
    // Equal time steps over the law's duration.
    const int n = static_cast<int>(std::lround(2.0 * kPi / (kPi / 180.0)));
    for (int k = 0; k <= n; ++k) drivers.push_back(d.at_time(d.law.duration * k / n));
    if (max_step == 0.0) max_step = mechanism.size() / 50.0;
  } else {
    std::optional<std::pair<double, double>> interval = options.range ? options.range : d.range;
    bool full = false;
    if (!interval && assembled.status != PoseStatus::cannot_assemble) {
      const AssemblingRange range = assembling_range(mechanism, options);
      full = range.full_cycle && d.angular();
      if (!full) interval = std::make_pair(range.lower, range.upper);
    }
    if (!d.angular() && max_step == 0.0 && interval)
      max_step = (interval->second - interval->first) / 360.0;
    const double direction = d.law.speed > 0 ? 1.0 : -1.0;
    if (full || !interval) {
      const int n = static_cast<int>(std::lround(2.0 * kPi / max_step));
      for (int k = 0; k <= n; ++k)
        drivers.push_back(constant_speed_state(d, d.start + direction * k * max_step));
    } else {
      // The grid start + k*step inside the interval, in the driver's direction of motion.
      const auto [lo, hi] = *interval;
      const long k_lo = static_cast<long>(std::ceil((lo - d.start) / max_step - 1e-9));
      const long k_hi = static_cast<long>(std::floor((hi - d.start) / max_step + 1e-9));
      for (long k = k_lo; k <= k_hi; ++k)
        drivers.push_back(constant_speed_state(d, d.start + k * max_step));
      if (direction < 0) std::reverse(drivers.begin(), drivers.end());
    }
  }

  Trajectory out;
  out.method = "newton";
  out.resize(mechanism, static_cast<int>(drivers.size()));
  if (assembled.status == PoseStatus::cannot_assemble ||
      assembled.status == PoseStatus::no_convergence)
    out.events.push_back({d.start, assembled.status, assembled.message});
  sweep_values(solver, state, assembled, drivers, max_step, small, out);
  std::stable_sort(out.events.begin(), out.events.end(),
                   [](const auto& a, const auto& b) { return a.driver < b.driver; });
  return out;
}

Trajectory solve_at(const Mechanism& mechanism, double driver_value,
                    const SweepOptions& options) {
  const Driver& d = mechanism.driver;
  const NewtonSolver solver(mechanism, options.newton);
  KinematicState state(mechanism);
  const SolveReport assembled = solver.assemble(state);
  DriverState target = constant_speed_state(d, driver_value);
  if (d.law.kind != MotionLaw::Kind::constant_speed) {
    // The first time in the law's cycle at which it passes the value (bisection on a bracket).
    const int n = 3600;
    target = d.at_time(0.0);
    for (int k = 0; k < n; ++k) {
      double t0 = d.law.duration * k / n, t1 = d.law.duration * (k + 1) / n;
      double v0 = d.at_time(t0).value - driver_value, v1 = d.at_time(t1).value - driver_value;
      if (v0 == 0.0 || v0 * v1 < 0.0) {
        for (int i = 0; i < 100 && v0 != 0.0; ++i) {
          const double tm = 0.5 * (t0 + t1), vm = d.at_time(tm).value - driver_value;
          if ((vm < 0) == (v0 < 0)) {
            t0 = tm;
            v0 = vm;
          } else {
            t1 = tm;
          }
        }
        target = d.at_time(t0);
        target.value = driver_value;
        break;
      }
    }
  }
  double max_step = default_step(mechanism, options);
  if (max_step == 0.0) max_step = mechanism.size() / 50.0;
  Trajectory out;
  out.method = "newton";
  out.resize(mechanism, 1);
  sweep_values(solver, state, assembled, {target}, max_step, min_step(solver, 1e-10), out);
  return out;
}

}  // namespace crosslink
