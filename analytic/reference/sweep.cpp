#include "analytic/reference/sweep.h"

#include "analytic/reference/sweep_samples.h"
#include "analytic/reference/tracer.h"

#include "analytic/kinematics/driver_chains.h"
#include "analytic/model/planar.h"
#include "analytic/model/units_text.h"
#include "analytic/physics/kinetostatics.h"

#include <fmt/format.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace crosslink {
using sweeping::drop_rates;
using sweeping::drop_rates_beside_singular;
using sweeping::Leg;
using sweeping::LegLimits;
using sweeping::locate;
using sweeping::Recorder;
using sweeping::sign_of;
using sweeping::SingularBand;
using sweeping::timed_sweep;
using sweeping::trace_leg;
using sweeping::Tracer;
using sweeping::without_pose;

namespace {

constexpr double kPi = std::numbers::pi;

}  // namespace

namespace {

double default_step(const Mechanism& m, const SweepOptions& o) {
  if (o.step > 0.0) return o.step;
  return m.swept().angular() ? kPi / 180.0 : 0.0;  // sliders: set from the range
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
        predicted_(state.q.size()) {}

  // The state must be solved (J factorised) at its driver value, with `last` its report.
  void start(const SolveReport& last) { last_ = last; }

  // Moves the solved state to driver value `target`. On failure the state is left solved at
  // the last value reached and the report says why.
  SolveReport advance_to(double target, double max_step, double min_step) {
    double h = std::copysign(max_step, target - state_.swept().value);
    while (state_.swept().value != target) {
      const double d0 = state_.swept().value;
      if (std::abs(target - d0) <= std::abs(h)) h = target - d0;
      const bool tangent_ok = take_tangent();
      q0_ = state_.q;
      predicted_ = q0_ + h * tangent_ + (0.5 * h * h) * curvature_;
      state_.q = predicted_;
      state_.swept().value = d0 + h;
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
      state_.swept().value = d0;
      last_ = solver_.solve_position(state_);
      h *= 0.5;
      if (std::abs(h) < min_step) {
        // Newton may still converge on the near side of a fold, so a refused step at a limit
        // looks like a jump: a limit has no solution at all a little beyond it.
        const bool closes_beyond = converged && solvable_at(d0 + std::copysign(1e6 * min_step, h));
        report.status = closes_beyond ? PoseStatus::branch_jump : PoseStatus::cannot_assemble;
        report.message =
            closes_beyond
                ? fmt::format("at driver = {} the only nearby solution is on another branch",
                              driver_unit_of(solver_.mechanism()).text(d0, 12))
                : fmt::format("the chain does not close beyond driver = {}",
                              driver_unit_of(solver_.mechanism()).text(d0, 12));
        return report;
      }
    }
    return last_;
  }

  const SolveReport& last() const { return last_; }

 private:
  // Whether Newton from the current pose closes the chain at `driver`; the state is restored.
  bool solvable_at(double driver) {
    q0_ = state_.q;
    const double d0 = state_.swept().value;
    state_.swept().value = driver;
    const PoseStatus s = solver_.solve_position(state_).status;
    state_.q = q0_;
    state_.swept().value = d0;
    last_ = solver_.solve_position(state_);
    return s == PoseStatus::ok || s == PoseStatus::singular;
  }

  double size_free_norm(const Eigen::VectorXd& v) const { return solver_.size_free_norm(v); }

  // Newton may only polish the prediction. Without a tangent (at a singular position) the
  // motion is bounded instead by the square-root growth of a fold.
  bool acceptable(bool tangent_ok, double h) const {
    if (!tangent_ok) return size_free_norm(state_.q - q0_) <= 4.0 * std::sqrt(std::abs(h));
    const double predicted_move = size_free_norm(predicted_ - q0_);
    return size_free_norm(state_.q - predicted_) <= 0.1 * predicted_move + 1e-10;
  }

  // q' and q'' with respect to the driver, from the factorisation at the current pose.
  bool take_tangent() {
    const DriverState real = state_.swept();
    state_.swept().rate = 1.0;
    state_.swept().accel = 0.0;
    solver_.solve_velocity(state_);
    solver_.solve_acceleration(state_);
    state_.swept() = real;
    tangent_ = state_.qdot;
    curvature_ = state_.qddot;
    const bool ok =
        last_.status == PoseStatus::ok && tangent_.allFinite() && curvature_.allFinite();
    if (!ok) {
      tangent_.setZero();
      curvature_.setZero();
    }
    return ok;
  }

  const NewtonSolver& solver_;
  KinematicState& state_;
  Eigen::VectorXd q0_, tangent_, curvature_, predicted_;
  SolveReport last_;
};

// The driver's rate and acceleration at a driver value for a constant-speed law. At rest (speed
// 0) the pose is the same at every time: t = 0.
DriverState constant_speed_state(const Driver& d, double value) {
  DriverState s;
  s.value = value;
  s.rate = d.law.speed;
  s.time = d.at_rest() ? 0.0 : (value - d.start) / d.law.speed;
  return s;
}

double min_step(const NewtonSolver& solver, double tolerance) {
  // Driver values closer than this are not told apart (angles in rad, slider in m).
  const Mechanism& m = solver.mechanism();
  return m.swept().angular() ? tolerance : tolerance * m.size();
}

// The largest rcond over the traced legs' nodes (the curve, whatever the output grid).
double best_rcond(const NewtonSolver& solver, const std::vector<Leg>& legs) {
  KinematicState state(solver.mechanism());
  double best = 0.0;
  for (const Leg& leg : legs)
    for (const Tracer::Node& n : leg.nodes) {
      state.q = n.q;
      state.swept().value = n.driver;
      state.factorized = false;
      const SolveReport r = solver.solve_position(state);
      if (r.status == PoseStatus::ok || r.status == PoseStatus::singular)
        best = std::max(best, r.rcond);
    }
  return best;
}

// One sample to write: where it lies on a leg and the driver state it is taken at.
struct PlannedSample {
  double key;  // position along the sweep's path
  Tracer::Node node;
  double value;
  bool toggle = false;  // the sample is a located toggle
};

// Samples of a leg at the grid values start + k*step (and at its toggles), each located on the
// curve by regula falsi on the driver, so it lies on the traced branch whatever the Jacobian.
// With `values` (ascending), those driver values instead of the grid, and only the toggles
// inside the window.
void plan_leg(const NewtonSolver& solver, const Leg& leg, double grid_start, double step,
              double key_sign, double lo_window, double hi_window, std::vector<PlannedSample>& out,
              const std::vector<double>* values = nullptr) {
  Tracer tracer(solver);
  const double unit = solver.mechanism().swept().angular() ? 1.0 : solver.length_scale();
  // The values (grid or given) on a segment [dmin, dmax], and within `slack` beyond it.
  const auto segment_values = [&](double dmin, double dmax, double slack, std::vector<double>& on) {
    on.clear();
    if (values) {
      const auto first = std::lower_bound(values->begin(), values->end(), dmin - slack);
      for (auto v = first; v != values->end() && *v <= dmax + slack; ++v) on.push_back(*v);
      return;
    }
    const long k0 = static_cast<long>(std::ceil((dmin - grid_start) / step - slack / step));
    const long k1 = static_cast<long>(std::floor((dmax - grid_start) / step + slack / step));
    for (long k = k0; k <= k1; ++k) on.push_back(grid_start + k * step);
  };
  std::vector<double> on;
  for (size_t j = 0; j + 1 < leg.nodes.size(); ++j) {
    const Tracer::Node& a = leg.nodes[j];
    const Tracer::Node& b = leg.nodes[j + 1];
    const int base_index = leg.base[j + 1];
    const Tracer::Node& base = leg.nodes[static_cast<size_t>(base_index)];
    Tracer::Node lo = a;
    lo.s = static_cast<int>(j) == base_index ? 0.0 : a.s;
    const double dmin = std::min(a.driver, b.driver), dmax = std::max(a.driver, b.driver);
    // Grid values on the segment, and within 1e-12 of the driver's unit beyond it (the accuracy
    // of a located toggle): never a value beyond a limit, where the chain does not close.
    segment_values(dmin, dmax, 1e-12 * unit, on);
    for (const double g : on) {
      if (g < lo_window - 1e-12 * unit || g > hi_window + 1e-12 * unit) continue;
      Tracer::Node at;
      if (std::abs(a.driver - g) <= 1e-15 * unit) {
        at = lo;
      } else if (std::abs(b.driver - g) <= 1e-15 * unit) {
        at = b;
      } else {
        // Away from toggles straight at the driver value from the nearer end; it must land
        // inside the segment. Else (near a toggle) by regula falsi in s.
        const Tracer::Node& near = std::abs(g - a.driver) < std::abs(g - b.driver) ? lo : b;
        const bool direct = tracer.correct_driver(base, g, at, near) &&
                            at.s >= std::min(lo.s, b.s) - 1e-12 &&
                            at.s <= std::max(lo.s, b.s) + 1e-12;
        if (!direct)
          at = locate(
              tracer, base, lo, b, [&](const Tracer::Node& n) { return n.driver - g; },
              1e-15 * unit);
      }
      const double key = leg.key[j] + (at.s - lo.s);
      if (key > leg.end_key + 1e-12) continue;
      out.push_back({key_sign * key, at, g, false});
    }
  }
  for (size_t i = 0; i < leg.singular.size(); ++i) {
    if (leg.singular[i].kind != SingularKind::toggle) continue;  // toggles are extra samples
    const auto index = static_cast<size_t>(leg.singular_node[i]);
    if (leg.key[index] > leg.end_key + 1e-12) continue;
    const double at = leg.nodes[index].driver;
    if (values && (at < lo_window - 1e-12 * unit || at > hi_window + 1e-12 * unit)) continue;
    out.push_back({key_sign * leg.key[index], leg.nodes[index], leg.nodes[index].driver, true});
  }
}

// A moving driver's start, assembled, is taken to round-off (Tracer::settle); then, drawn at a
// change point to working precision, it is bad input: two branches cross there, so the drawing
// cannot say which one the chain follows, and no sweep from it is the chain's. Along the other
// branch the residual grows as the square of the distance, so round-off tells the branches apart
// only where C's singular values are in a ratio above sqrt(eps): a kite drawn folded 1e-6 deg
// before its change point (ratio 2.1e-9) settles on the held-driver branch, and 1e-4 deg before
// (1.8e-7) on its own (tests/analytic/test_edges.cpp).
const double kCrossingZone = std::sqrt(std::numeric_limits<double>::epsilon());

void settle_start(const NewtonSolver& solver, KinematicState& state) {
  const Mechanism& m = solver.mechanism();
  if (m.swept().at_rest()) return;
  Tracer tracer(solver);
  const std::string start = driver_unit_of(m).text(m.swept().start, 12);
  std::string why;
  if (const double over = tracer.settle(state.q); over > 1.0) {
    why = fmt::format(
        "the chain closes at the driver's start, {}, only to the solver's tolerance (its residual "
        "stays {:.0f} times round-off): the start lies just beyond a limit of the assembling "
        "range (a toggle), by less than the tolerance, where no pose closes exactly; draw it "
        "inside the range",
        start, over);
  } else if (const double ratio = tracer.crossing_ratio(state.q); ratio < kCrossingZone) {
    why = fmt::format(
        "the drawn position, driver = {}, is a change point to working precision (the "
        "constraint Jacobian's singular values in a ratio of {:.1e}, below sqrt(eps) = {:.1e}): "
        "two branches cross there, so the drawing does not say which one the chain follows; draw "
        "it at another driver value",
        start, ratio, kCrossingZone);
  }
  if (!why.empty()) throw DefinitionError({Diagnostic{m.swept().where, why}});
}

}  // namespace

std::string AssemblingRange::explain(const Mechanism& m) const {
  if (!unknown.empty()) return "unknown: " + unknown;
  if (full_cycle) return m.swept().angular() ? "full rotation (360 degrees)" : "unbounded";
  const DriverUnit u = driver_unit_of(m);
  return fmt::format("{:.6f} to {:.6f} {}", lower / u.scale, upper / u.scale, u.name);
}

AssemblingRange assembling_range(const Mechanism& mechanism, const SweepOptions& options,
                                 double /*tolerance: toggles are located to ~1e-12*/) {
  AssemblingRange range;
  // A range of one driver's value: with several the chain moves in time (the timed sweep).
  if (mechanism.axis().timed()) {
    range.unknown =
        fmt::format("the assembling range is one driver's; with {} drivers the sweep runs in time",
                    mechanism.drivers.size());
    return range;
  }
  const NewtonSolver solver(mechanism, options.newton);
  KinematicState state(mechanism);
  const SolveReport assembled = solver.assemble(state);
  if (assembled.status != PoseStatus::ok && assembled.status != PoseStatus::singular)
    return range;  // lower = upper = 0: nothing assembles; the caller reports `assembled`
  settle_start(solver, state);
  const bool angular = mechanism.swept().angular();
  const LegLimits limits{true, angular ? 4.0 * kPi : 100.0 * mechanism.size(), angular,
                         options.tracer_steps};
  Tracer tracer(solver);
  auto search = [&](double direction, Leg& leg) {
    Tracer::Node start;
    if (!tracer.start(state.q, direction, start)) return false;
    leg = trace_leg(solver, start, limits);
    return true;
  };
  Leg up, down;
  const std::string no_start = "the configuration curve has no direction at the drawn position";
  if (!search(+1.0, up)) {
    range.unknown = no_start;
    return range;
  }
  if (up.full_cycle) {
    range.full_cycle = true;
    range.lower = state.swept().value;
    range.upper = state.swept().value + 2.0 * kPi;
    return range;
  }
  if (!search(-1.0, down)) {
    range.unknown = no_start;
    return range;
  }
  for (const Leg* leg : {&up, &down})
    if (leg->failed) range.unknown = leg->singular.back().message;
  const auto free = [](const Leg& leg) { return !leg.failed && leg.singular.empty(); };
  range.full_cycle = free(up) && free(down) && !angular;
  range.lower = down.nodes.back().driver;
  range.upper = up.nodes.back().driver;
  return range;
}

namespace {

// Fills one sample per driver state, in order, by continuation from the assembled state: first
// to the first sample, then from each sample to the next. Where the branch cannot be followed
// (the chain does not close, or only another branch is near), the sample carries that status
// and zeros, and so does every later one beyond that point the same way; a later sample back on
// the near side is followed from there (a range that starts outside the assembling range).
void sweep_values(const NewtonSolver& solver, KinematicState& state, const SolveReport& assembled,
                  const std::vector<DriverState>& drivers, double max_step, double small,
                  Trajectory& out) {
  Follower follower(solver, state);
  Recorder record(solver);
  follower.start(assembled);
  SolveReport failure = assembled;
  bool lost = assembled.status != PoseStatus::ok && assembled.status != PoseStatus::singular;
  // Where the branch stopped, and the way it was going (0: it has not).
  double stopped_at = 0.0, stopped_way = 0.0;
  for (size_t i = 0; i < drivers.size(); ++i) {
    const int row = static_cast<int>(i);
    const double target = drivers[i].value;
    if (!lost && (target - stopped_at) * stopped_way <= 0.0) {
      const double from = state.swept().value;
      const SolveReport r = solver.polish(state, follower.advance_to(target, max_step, small));
      if (r.status == PoseStatus::ok || r.status == PoseStatus::singular) {
        if (r.status == PoseStatus::singular) out.events.push_back({target, r.status, r.message});
        state.swept() = drivers[i];
        record(state, r, out, row);
        continue;
      }
      failure = r;
      out.events.push_back({state.swept().value, r.status, r.message});
      stopped_at = state.swept().value;
      stopped_way = target > from ? 1.0 : -1.0;
    }
    // The flagged sample from a copy: the state stays where the branch stopped.
    KinematicState flagged = without_pose(state);
    flagged.swept() = drivers[i];
    solver.write_sample(flagged, failure, out, row);
  }
}

}  // namespace

namespace {

// A constant-speed sweep along the traced configuration curve (see Tracer): the cycle, the
// assembling range (at_limit = stop), or the whole loop through its toggles (reverse). Returns
// false when the tracer cannot start (the caller falls back to the Follower).
// With `range` (an explicit range [lower, upper] of a chain that does not turn fully), the
// range's grid and its own ends (range_grid()) on the legs traced from the start to each limit:
// a range's end at a limit (to 1e-9 of the driver's unit) is the toggle there, and a value
// beyond a limit is a sample without a pose (cannot_assemble, or the lost leg's status), so the
// curve is always reached from the drawing, never by Newton started on a fold. Returns false
// for a chain that turns fully (the Follower covers a range of several turns).
bool traced_sweep(const Mechanism& mechanism, const SweepOptions& options,
                  const NewtonSolver& solver, KinematicState& state, Trajectory& out,
                  std::vector<SingularPosition>& singular,
                  const std::optional<std::pair<double, double>>& range = std::nullopt) {
  const Driver& d = mechanism.swept();
  const bool angular = d.angular();
  const bool stop = range || options.at_limit == SweepOptions::AtLimit::stop;
  const double sigma = d.law.speed > 0 ? 1.0 : -1.0;
  const double start_value = state.swept().value;
  const double size = mechanism.size();
  double reach = angular ? (stop ? 4.0 : 40.0) * kPi : (stop ? 100 : 400) * size;
  if (range)  // the legs reach past both ends of the range
    reach = std::max(reach, 1.01 * std::max(std::abs(range->first - start_value),
                                            std::abs(range->second - start_value)));
  const LegLimits limits{stop, reach, angular, options.tracer_steps};
  Tracer tracer(solver);
  Tracer::Node first;
  if (!tracer.start(state.q, sigma, first)) return false;
  std::vector<Leg> legs;
  legs.push_back(trace_leg(solver, first, limits));
  if (range && legs[0].full_cycle) return false;
  if (stop && !legs[0].full_cycle) {
    Tracer::Node back;
    if (!tracer.start(state.q, -sigma, back)) return false;
    legs.push_back(trace_leg(solver, back, limits));
  }

  // The grid: start + k*step; a slider's step is 1/360 of the range it covers.
  double step = default_step(mechanism, options);
  double lo = start_value, hi = start_value;
  for (const Leg& leg : legs)
    for (const Tracer::Node& n : leg.nodes) {
      lo = std::min(lo, n.driver);
      hi = std::max(hi, n.driver);
    }
  if (step == 0.0 && range) step = (range->second - range->first) / 360.0;
  if (step == 0.0) step = hi > lo ? (hi - lo) / 360.0 : size / 50.0;
  double window_lo = -std::numeric_limits<double>::infinity(), window_hi = -window_lo;
  if (legs[0].full_cycle) {
    window_lo = std::min(start_value, start_value + sigma * 2.0 * kPi);
    window_hi = std::max(start_value, start_value + sigma * 2.0 * kPi);
  }
  const double unit = angular ? 1.0 : size;
  std::vector<double> wanted;  // a range's values, ascending
  if (range) {
    window_lo = range->first;
    window_hi = range->second;
    wanted = range_grid(d.start, step, range->first, range->second).values();
    // An end of the range at a limit, to 1e-9 of the unit (its value in the file to a few
    // ulps, the located toggle to ~1e-12), is the toggle: taken at the toggle's value, where
    // the pose is exact, not at a value a round-off beyond it, where the chain does not close.
    for (const Leg& leg : legs)
      for (size_t i = 0; i < leg.singular.size(); ++i) {
        if (leg.singular[i].kind != SingularKind::toggle) continue;
        const double at = leg.singular[i].driver;
        for (double* end : {&window_lo, &window_hi})
          if (std::abs(*end - at) < 1e-9 * unit) *end = at;
        for (double& v : wanted)
          if (std::abs(v - at) < 1e-9 * unit) v = at;
      }
  }
  std::vector<PlannedSample> plan;
  for (size_t l = 0; l < legs.size(); ++l)
    plan_leg(solver, legs[l], start_value, step, l == 0 ? 1.0 : -1.0, window_lo, window_hi, plan,
             range ? &wanted : nullptr);
  std::stable_sort(plan.begin(), plan.end(),
                   [](const auto& a, const auto& b) { return a.key < b.key; });
  // The start is on both legs and a toggle may fall on the grid: keep one of each.
  std::vector<PlannedSample> samples;
  for (const PlannedSample& p : plan) {
    // A grid value within round-off of a toggle is the toggle (along the curve the two are up
    // to sqrt(1e-12) apart, as the driver folds there): one sample, on the grid, flagged.
    // The start planned twice along the curve (drawn beside a change point, where the located
    // nodes around it pass its value again, the poses only determined to ~sqrt(tolerance) there)
    // is the same pose at the same value, as the loop's closure takes it: one sample, or the
    // times repeat.
    const bool toggle = !samples.empty() && (p.toggle || samples.back().toggle);
    const bool same_pose =
        !samples.empty() && tracer.distance(p.node.q, samples.back().node.q, false) < 1e-6;
    if (!samples.empty() && (std::abs(p.key - samples.back().key) < 1e-9 || toggle || same_pose) &&
        std::abs(p.value - samples.back().value) < 1e-12 * unit) {
      if (p.toggle && !samples.back().toggle) {
        samples.back().node = p.node;  // the located fold's pose, at the grid's value
        samples.back().toggle = true;
      } else if (!p.toggle && samples.back().toggle) {
        samples.back().value = p.value;
      }
      continue;
    }
    samples.push_back(p);
  }
  // A range's values beyond the traced curve: before its first sample (behind the start) and
  // after its last, each flagged with why the leg ended there.
  struct Beyond {
    double value;
    const Leg* leg;
  };
  std::vector<Beyond> behind, ahead;
  if (range) {
    const double first_value = samples.empty() ? start_value : samples.front().value;
    const double last_value = samples.empty() ? start_value : samples.back().value;
    for (const double v : wanted) {
      if (sigma * (v - first_value) < -1e-12 * unit) behind.push_back({v, &legs.back()});
      if (sigma * (v - last_value) > 1e-12 * unit) ahead.push_back({v, &legs.front()});
    }
    if (sigma < 0) {  // in the sweep's order
      std::reverse(behind.begin(), behind.end());
      std::reverse(ahead.begin(), ahead.end());
    }
  }
  const int written = static_cast<int>(behind.size() + samples.size() + ahead.size());
  out.resize(mechanism, written, true);
  Recorder record(solver);
  const SingularBand band(best_rcond(solver, legs));
  // A sample on a located toggle or change point is that event, not another one.
  const auto located_at = [&](double value) {
    for (const Leg& leg : legs)
      for (const SingularPosition& p : leg.singular)
        if (p.kind != SingularKind::branch_jump && std::abs(p.driver - value) < 1e-9 * unit)
          return true;
    return false;
  };
  double travel = 0.0;
  for (size_t i = 0; i < samples.size(); ++i) {
    const PlannedSample& p = samples[i];
    if (i > 0) travel += std::abs(p.value - samples[i - 1].value);
    // Direction of the driver at the sample: toward the next sample (at the end, from the last).
    double direction = sigma;
    if (i + 1 < samples.size() && samples[i + 1].value != p.value)
      direction = sign_of(samples[i + 1].value - p.value);
    else if (i > 0)
      direction = sign_of(p.value - samples[i - 1].value);
    DriverState driver;
    driver.value = p.value;
    if (stop) {
      driver.rate = d.law.speed;
      driver.time = (p.value - d.start) / d.law.speed;
    } else {
      driver.rate = direction * std::abs(d.law.speed);
      driver.time = travel / std::abs(d.law.speed);
    }
    // Polish at the exact driver value: Newton starts on the traced branch, so it stays there.
    state.q = p.node.q;
    state.swept() = driver;
    SolveReport report = solver.polish(state, solver.solve_position(state));
    // At a change point the position is only determined to ~sqrt(tolerance) (the residual is
    // quadratic along the branches there): that is a singular sample, not a jump.
    const double moved = tracer.distance(state.q, p.node.q, false);
    if ((report.status == PoseStatus::ok || report.status == PoseStatus::singular) &&
        moved > 1e-6) {
      const bool at_crossing = report.rcond < 1e-6;
      report.status = at_crossing ? PoseStatus::singular : PoseStatus::branch_jump;
      report.message =
          at_crossing ? "at a change point: Jacobian singular" : "Newton left the traced branch";
    }
    if (p.toggle && report.status == PoseStatus::ok) {
      report.status = PoseStatus::singular;
      report.message = "toggle (dead point): Jacobian singular";
    } else if (const std::string why = band.why(report.rcond);
               !why.empty() && report.status == PoseStatus::ok) {
      report.status = PoseStatus::singular;
      report.message = why;
    } else if (!p.toggle && report.status == PoseStatus::singular && moved <= 1e-6 &&
               !located_at(p.value)) {
      // Singular with no sign change along the curve around it (the tracer saw no toggle or
      // change point): the Jacobian touches rank loss there, as A02's chain with every bar on
      // one line. The sample is flagged by the solver; the event says where.
      out.events.push_back({p.value, PoseStatus::singular, report.message});
    }
    const int row = static_cast<int>(behind.size() + i);
    record(state, report, out, row);
  }
  // The range's values beyond a limit: no pose, the status of the leg's end.
  const auto write_beyond = [&](const std::vector<Beyond>& values, int first_row) {
    for (size_t i = 0; i < values.size(); ++i) {
      const Leg& leg = *values[i].leg;
      SolveReport report;
      report.status = leg.failed ? PoseStatus::branch_jump : PoseStatus::cannot_assemble;
      const double end = leg.nodes.back().driver;
      report.message = leg.failed ? leg.singular.back().message
                                  : fmt::format(
                                        "the chain does not close beyond driver = {:.12g} "
                                        "(limit of the assembling range)",
                                        end);
      if (i == 0) out.events.push_back({end, report.status, report.message});
      KinematicState none = without_pose(state);
      none.swept() = constant_speed_state(d, values[i].value);
      solver.write_sample(none, report, out, first_row + static_cast<int>(i));
    }
  };
  write_beyond(behind, 0);
  write_beyond(ahead, static_cast<int>(behind.size() + samples.size()));

  // Singular positions in the sweep's order.
  std::vector<std::pair<double, SingularPosition>> found;
  for (size_t l = 0; l < legs.size(); ++l)
    for (size_t k = 0; k < legs[l].singular.size(); ++k) {
      const double key = legs[l].singular_key[k];
      if (key > legs[l].end_key + 1e-12) continue;
      // A full cycle's leg may trace a little past the cycle's last sample: not the sweep's.
      const double at = legs[l].singular[k].driver;
      if (at < window_lo - 1e-12 * unit || at > window_hi + 1e-12 * unit) continue;
      found.push_back({(l == 0 ? 1.0 : -1.0) * key, legs[l].singular[k]});
    }
  std::stable_sort(found.begin(), found.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  for (const auto& [key, position] : found) {
    singular.push_back(position);
    out.events.push_back({position.driver,
                          position.kind == SingularKind::branch_jump ? PoseStatus::branch_jump
                                                                     : PoseStatus::singular,
                          position.message});
  }
  if (!stop && !legs[0].closed && !legs[0].full_cycle && !legs[0].failed)
    out.events.push_back({samples.empty() ? start_value : samples.back().value, PoseStatus::ok,
                          "the loop did not close within the sweep's reach; the sweep ends here"});
  return true;
}

// The sweep by driver-parametrised continuation (the Follower), over the driver values of a
// polynomial or table law, or of an explicit range.
Trajectory follower_sweep(const Mechanism& mechanism, const SweepOptions& options,
                          const NewtonSolver& solver, KinematicState& state,
                          const SolveReport& assembled) {
  const Driver& d = mechanism.swept();
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
    } else if (options.range || d.range) {
      // The range's grid and its own ends, in the driver's direction of motion.
      for (const double value :
           range_grid(d.start, max_step, interval->first, interval->second).values())
        drivers.push_back(constant_speed_state(d, value));
      if (direction < 0) std::reverse(drivers.begin(), drivers.end());
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
  out.resize(mechanism, static_cast<int>(drivers.size()), true);
  if (assembled.status == PoseStatus::cannot_assemble ||
      assembled.status == PoseStatus::no_convergence)
    out.events.push_back({d.start, assembled.status, assembled.message});
  sweep_values(solver, state, assembled, drivers, std::min(max_step, continuation_step(mechanism)),
               small, out);
  // Without a traced curve, the best condition along the sweep is its samples'.
  drop_rates_beside_singular(out);
  std::stable_sort(out.events.begin(), out.events.end(),
                   [](const auto& a, const auto& b) { return a.driver < b.driver; });
  return out;
}

}  // namespace

RangeGrid range_grid(double start, double step, double lower, double upper) {
  RangeGrid g{start, step, lower, upper};
  g.first = std::ceil((lower - start) / step - 1e-9);
  g.last = std::floor((upper - start) / step + 1e-9);
  // A grid value at an end, to 1e-9 of a step or the values' round-off, is that end (compared
  // as values: an index near 1e9 has no room for 1e-9 of it).
  const double near =
      1e-9 * step + 8.0 * std::numeric_limits<double>::epsilon() *
                        std::max({std::abs(start), std::abs(lower), std::abs(upper)});
  if (start + g.first * step - lower < near) ++g.first;
  if (upper - (start + g.last * step) < near) --g.last;
  return g;
}

std::vector<double> RangeGrid::values() const {
  std::vector<double> out = {lower};
  for (double k = first; k <= last; ++k) out.push_back(start + k * step);
  out.push_back(upper);
  return out;
}

std::string_view to_string(SingularKind kind) {
  switch (kind) {
    case SingularKind::toggle:
      return "toggle";
    case SingularKind::change_point:
      return "change_point";
    case SingularKind::branch_jump:
      return "branch_jump";
  }
  return "?";
}

namespace {
// Where a pin leaves its spline slot (NewtonSolver::write_sample's event, at the first sample
// past the end) and where it comes back (an event of its own, at the first sample that holds it
// again): bisection on exact solves between the sample past the end and its neighbour holding the
// pin, to the driver's round-off; the event is placed at the value past the end.
void locate_slot_ends(const Mechanism& mechanism, const SweepOptions& options, Trajectory& out) {
  if (mechanism.axis().timed()) return;
  const DriverUnit unit = driver_unit_of(mechanism);
  const auto reached = [&](double held, double past) {
    const double resolution =
        8.0 * std::numeric_limits<double>::epsilon() * std::max(std::abs(held), std::abs(past));
    while (std::abs(past - held) > resolution) {
      const double mid = 0.5 * (held + past);
      (usable(solve_at(mechanism, mid, options).status[0]) ? held : past) = mid;
    }
    return past;
  };
  for (Trajectory::Event& e : out.events) {
    if (e.kind != PoseStatus::cannot_assemble || e.message.find("spline slot") == std::string::npos)
      continue;
    int k = 0;
    while (k < out.samples() && out.along(k) != e.driver) ++k;
    if (k == 0 || k == out.samples() || !usable(out.status[static_cast<size_t>(k - 1)])) continue;
    e.driver = reached(out.along(k - 1), out.along(k));
    e.message += fmt::format(
        " (at the first sample past it, {}; the pin reaches the end at driver = {}, where this "
        "event is placed)",
        unit.text(out.along(k), 6), unit.text(e.driver, 9));
  }
  // Each run of samples past an end that the sweep leaves again: where the pin is back.
  std::vector<Trajectory::Event> back;
  for (int k = 1; k < out.samples(); ++k) {
    if (out.status[static_cast<size_t>(k - 1)] != PoseStatus::cannot_assemble ||
        !usable(out.status[static_cast<size_t>(k)]))
      continue;
    const Trajectory before = solve_at(mechanism, out.along(k - 1), options);
    const auto slot = std::find_if(before.events.begin(), before.events.end(), [](const auto& e) {
      return e.kind == PoseStatus::cannot_assemble &&
             e.message.find("spline slot") != std::string::npos;
    });
    if (slot == before.events.end()) continue;  // not a slot's end that flagged it
    // "the pin B is past the end S1 of spline slot 'slot', by ...": the pin and the end.
    std::string pin = slot->message.substr(0, slot->message.find(", by "));
    pin.replace(pin.find(" is past "), 9, " comes back from past ");
    const double at = reached(out.along(k), out.along(k - 1));
    back.emplace_back(at, PoseStatus::cannot_assemble,
                      fmt::format("{}: the samples since it left have no pose (at the first "
                                  "sample that holds it, {}; the pin reaches the end at driver = "
                                  "{}, where this event is placed)",
                                  pin, unit.text(out.along(k), 6), unit.text(at, 9)));
  }
  if (back.empty()) return;
  // In the sweep's order, which runs either way.
  const double ahead = out.along(out.samples() - 1) < out.along(0) ? -1.0 : 1.0;
  out.events.insert(out.events.end(), back.begin(), back.end());
  std::stable_sort(out.events.begin(), out.events.end(), [ahead](const auto& a, const auto& b) {
    return ahead * a.driver < ahead * b.driver;
  });
}

// The sweep, the pins' leaving their spline slots placed on the samples past the ends.
Trajectory sweep_once(const Mechanism& mechanism, const SweepOptions& options,
                      std::vector<SingularPosition>& singular) {
  const NewtonSolver solver(mechanism, options.newton);
  KinematicState state(mechanism);
  const SolveReport assembled = solver.assemble(state);
  if (mechanism.axis().timed()) {
    // 360 equal intervals of the longest cycle (one sample when every driver is at rest).
    const double period = mechanism.cycle_period();
    const int intervals = period > 0.0 ? 360 : 0;
    std::vector<double> times;
    for (int k = 0; k <= intervals; ++k) times.push_back(period * k / intervals);
    return timed_sweep(solver, state, assembled, times);
  }
  const Driver& d = mechanism.swept();
  const bool assembles =
      assembled.status == PoseStatus::ok || assembled.status == PoseStatus::singular;
  if (assembles) settle_start(solver, state);
  if (assembles && d.law.kind == MotionLaw::Kind::constant_speed) {
    Trajectory out;
    out.method = "newton";
    const Eigen::VectorXd q_start = state.q;
    if (traced_sweep(mechanism, options, solver, state, out, singular,
                     options.range ? options.range : d.range))
      return out;
    state.q = q_start;
    state.swept() = d.at_time(0.0);
    solver.solve_position(state);
  }
  return follower_sweep(mechanism, options, solver, state, assembled);
}

}  // namespace

Trajectory sweep(const Mechanism& mechanism, const SweepOptions& options,
                 std::vector<SingularPosition>& singular) {
  Trajectory out = sweep_once(mechanism, options, singular);
  locate_slot_ends(mechanism, options, out);
  return out;
}

Trajectory sweep(const Mechanism& mechanism, const SweepOptions& options) {
  std::vector<SingularPosition> singular;
  return sweep(mechanism, options, singular);
}

void SkippedTurns::move_on(const Mechanism& mechanism, double driver_value,
                           Trajectory& pose) const {
  if (turns == 0) return;
  pose.angle.row(0) += static_cast<double>(std::abs(turns)) * link_turn.transpose();
  const auto swept = static_cast<Eigen::Index>(pose.axis.driver);
  for (Trajectory::Event& e : pose.events) e.driver += driver_value - pose.driver_values(0, swept);
  pose.driver_values(0, swept) = driver_value;
  pose.time(0) = constant_speed_state(mechanism.swept(), driver_value).time;
}

SkippedTurns skipped_turns(const Mechanism& mechanism, double driver_value,
                           const SweepOptions& options) {
  if (mechanism.axis().timed()) return {};  // in time: no driver's turns to skip
  const Driver& d = mechanism.swept();
  if (!d.angular() || d.law.kind != MotionLaw::Kind::constant_speed) return {};
  const double turns = std::trunc((driver_value - d.start) / (2.0 * kPi));
  if (std::abs(turns) < 2.0) return {};  // within two turns: nothing to gain
  const Trajectory a = solve_at(mechanism, d.start, options);
  const Trajectory b = solve_at(mechanism, d.start + std::copysign(2.0 * kPi, turns), options);
  if (!usable(a.status[0]) || !usable(b.status[0])) return {};
  // The same pose one turn on: every point and slider where it was, every link turned by whole
  // turns.
  const auto apart = [](const Eigen::MatrixXd& u, const Eigen::MatrixXd& v) {
    return u.size() == 0 ? 0.0 : (u - v).cwiseAbs().maxCoeff();
  };
  const double near = 1e-9 * mechanism.size();
  if (!(apart(a.x, b.x) <= near && apart(a.y, b.y) <= near && apart(a.s, b.s) <= near)) return {};
  SkippedTurns out{static_cast<long>(turns), Eigen::VectorXd(a.angle.cols())};
  for (Eigen::Index l = 0; l < a.angle.cols(); ++l) {
    const double whole = (b.angle(0, l) - a.angle(0, l)) / (2.0 * kPi);
    if (!(std::abs(whole - std::round(whole)) <= 1e-9)) return {};
    out.link_turn(l) = std::round(whole) * 2.0 * kPi;  // over one turn the way it goes
  }
  return out;
}

Trajectory solve_at(const Mechanism& mechanism, double driver_value, const SweepOptions& options) {
  if (mechanism.axis().timed()) {  // the value is a time: the drivers followed up to it
    if (!(driver_value >= 0.0))
      throw std::invalid_argument(fmt::format(
          "with several drivers the value is a time, from 0 s (here {:g} s)", driver_value));
    const NewtonSolver solver(mechanism, options.newton);
    KinematicState state(mechanism);
    const SolveReport assembled = solver.assemble(state);
    return timed_sweep(solver, state, assembled, {driver_value});
  }
  // A driver that turns fully is at the same pose a whole number of turns nearer its start:
  // solved there, its links' angles moved on by their turns (a reference at 5e9 degrees took
  // 1.5 h of continuation).
  if (const SkippedTurns skip = skipped_turns(mechanism, driver_value, options); skip.turns != 0) {
    Trajectory out = solve_at(mechanism, driver_value - skip.driver_shift(), options);
    skip.move_on(mechanism, driver_value, out);
    return out;
  }
  const Driver& d = mechanism.swept();
  const NewtonSolver solver(mechanism, options.newton);
  KinematicState state(mechanism);
  const SolveReport assembled = solver.assemble(state);
  if (assembled.status == PoseStatus::ok || assembled.status == PoseStatus::singular)
    settle_start(solver, state);
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
  out.resize(mechanism, 1, true);
  sweep_values(solver, state, assembled, {target}, std::min(max_step, continuation_step(mechanism)),
               min_step(solver, 1e-10), out);
  return out;
}

}  // namespace crosslink
