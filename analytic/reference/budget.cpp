#include "analytic/reference/budget.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "analytic/model/limits.h"
#include "analytic/model/units_text.h"

namespace crosslink {
namespace {

constexpr double kDegree = std::numbers::pi / 180.0;

// How many times the driver's motion the gears can turn a link (or move a rack): the product
// over the meshes of each one's ratio or its inverse, whichever is above 1 (a rack's, of its
// pitch radius against the size, per radian). The continuation's corrector follows a link only
// while it turns about as far a step as the driver does, so a step is halved until it does: a
// gear of 1e6 teeth against 1 made one pose 1e6 times the steps counted here (75 s, uncounted).
double gear_speed_up(const Mechanism& m) {
  double speed_up = 1.0;
  for (const Joint& j : m.joints) {
    const double r = std::abs(j.ratio);
    if (!j.is_gearing() || !(r > 0.0)) continue;
    const double relative = j.type == JointType::gear ? r : r / m.size();
    speed_up = std::min(speed_up * std::max(relative, 1.0 / relative), 1e30);
  }
  return speed_up;
}

// The longest step the solver's continuation takes between two solves: the grid step, and at
// most 1 degree of an angular driver or the arc the mechanism's size sweeps in 1 degree, over
// the gears' speed-up.
double continuation_bound(const Mechanism& m, double step) {
  const double largest = (m.swept().angular() ? kDegree : m.size() * kDegree) / gear_speed_up(m);
  return step > 0.0 ? std::min(step, largest) : largest;
}

// What asked for the work: a key of the definition at its place, or an option (line 0).
struct Cause {
  std::string what;
  SourceLocation where;
};

[[noreturn]] void refuse(const Mechanism& m, const Cause& cause, const std::string& message) {
  if (cause.where.line > 0) throw DefinitionError({{cause.where, cause.what + " " + message}});
  throw std::invalid_argument(fmt::format("{}: {} {}", m.file, cause.what, message));
}

void check_count(const Mechanism& m, const Cause& cause, double count, std::string_view of_what,
                 const WorkLimits& limits) {
  if (count <= static_cast<double>(limits.max_samples)) return;
  refuse(m, cause,
         fmt::format("asks for {:.0f} {}: the limit is {} (raise it with --max-samples N)", count,
                     of_what, limits.max_samples));
}

// The memory of the samples: each holds a value of every channel (Trajectory::resize, with
// forces), 8 bytes each, in the solver's trajectory, again in each engine's for compare, and in
// an output's copy. The limit, kValuesPerSample for each sample --max-samples allows (160 MB at
// the default), lets a sewing machine (about 130 values) have every sample it may and bounds the
// long chains': A02 at N = 40 holds about 1,000 values a sample, and 97,298 samples of it (0.0037
// degrees, within --max-samples) took 26 GB as a JSON document.
constexpr double kValuesPerSample = 200.0;

void check_values(const Mechanism& m, const Cause& cause, double samples,
                  const WorkLimits& limits) {
  Trajectory one;
  one.resize(m, 1, true);
  const double each = static_cast<double>(one.channel_names().size()) + 4.0;  // + time, driver,
                                                                              // rcond, gap
  const double limit = kValuesPerSample * static_cast<double>(limits.max_samples);
  if (samples * each <= limit) return;
  refuse(m, cause,
         fmt::format("asks for {:.0f} samples of {:.0f} values each ({:.2g} GB): the limit is "
                     "{:.3g} values, {:.0f} for each of --max-samples (raise it with "
                     "--max-samples N)",
                     samples, each, samples * each * 8e-9, limit, kValuesPerSample));
}

// A step lost in the round-off of the driver's values would be accepted without moving the
// driver, for ever: steps must stay far above it (1e-12 of the largest value, 4500 ulps).
void check_resolution(const Mechanism& m, const Cause& cause, double step, double magnitude) {
  if (step >= 1e-12 * magnitude) return;
  const DriverUnit u = driver_unit_of(m);
  refuse(m, cause,
         fmt::format("takes steps of {:g} {} among driver values up to {:g} {}: a step must be "
                     "at least {:g} {} there, or it is lost in round-off",
                     step / u.scale, u.name, magnitude / u.scale, u.name,
                     1e-12 * magnitude / u.scale, u.name));
}

std::string steps_of(const Mechanism& m, double step) {
  const DriverUnit u = driver_unit_of(m);
  const double speed_up = gear_speed_up(m);
  return fmt::format("continuation steps of at most {:g} {}{}", step / u.scale, u.name,
                     speed_up > 1.0 ? fmt::format(" (its gears turn a link up to {:g} times as "
                                                  "far as the driver)",
                                                  speed_up)
                                    : "");
}

void check_step(const Mechanism& m, const SweepOptions& options) {
  if (options.step == 0.0 || (options.step > 0.0 && std::isfinite(options.step))) return;
  throw std::invalid_argument(fmt::format("{}: --step must be a positive number", m.file));
}

// Several drivers: the follower in time keeps every driver within its continuation step (1
// degree, or the size's arc over 1 degree) between solves, from 0 to `until` [s] over
// `intervals` equal intervals; the steps are at most the sum of the drivers' travels so counted.
double timed_steps(const Mechanism& m, double until, int intervals) {
  double steps = static_cast<double>(intervals);
  for (const Driver& d : m.drivers) {
    const double limit = (d.angular() ? 1.0 : m.size()) * kDegree / gear_speed_up(m);
    double previous = d.start;
    for (int k = 1; k <= intervals; ++k) {
      const double value = d.at_time(until * k / intervals).value;
      steps += std::abs(value - previous) / limit;
      previous = value;
    }
  }
  return steps;
}

}  // namespace

void check_sweep_work(const Mechanism& m, const SweepOptions& options, const WorkLimits& limits) {
  check_step(m, options);
  if (m.axis().timed()) {  // 361 samples in time over the longest cycle
    const auto longest =
        std::ranges::max_element(m.drivers, {}, [](const Driver& d) { return d.cycle(); });
    const Cause cause{"the drivers' laws over their longest cycle", longest->where};
    check_count(m, cause, timed_steps(m, m.cycle_period(), 360), "continuation steps", limits);
    check_values(m, cause, 361.0, limits);
    return;
  }
  const Driver& d = m.swept();
  if (d.at_rest())
    throw DefinitionError(
        {{d.law.where,
          "[driver] 'speed' = 0 states one pose at rest: solve it with `crosslink solve FILE "
          "--at VALUE`; a sweep needs a speed (any: the positions do not depend on it)"}});
  const DriverUnit u = driver_unit_of(m);
  const bool step_given = options.step > 0.0;
  const Cause step_option{fmt::format("--step {:g} {}", options.step / u.scale, u.name), {}};
  const double continuation = continuation_bound(m, options.step);

  if (d.law.kind != MotionLaw::Kind::constant_speed) {
    // 361 samples at equal times over the duration; the solver continues from each to the next.
    double travel = 0.0, previous = d.start, magnitude = std::abs(d.start);
    for (int k = 0; k <= 360; ++k) {
      const double value = d.at_time(d.law.duration * k / 360).value;
      travel += std::abs(value - previous);
      magnitude = std::max(magnitude, std::abs(value));
      previous = value;
    }
    Cause law{"driver." + std::string(to_string(d.law.kind)), d.law.where};
    if (step_given) law.what += " at " + step_option.what;
    check_count(m, law, travel / continuation, steps_of(m, continuation), limits);
    check_resolution(m, step_given ? step_option : law, continuation, magnitude);
    return;
  }

  if (const auto range = options.range ? options.range : d.range) {
    const auto [lo, hi] = *range;
    const double step = step_given ? options.step : d.angular() ? kDegree : (hi - lo) / 360.0;
    Cause cause{"the sweep's range", {}};
    if (!options.range)
      cause = {fmt::format("driver.range = [{:g}, {:g}] {}", lo / u.scale, hi / u.scale, u.name),
               d.range_where};
    cause.what += step_given ? " at " + step_option.what
                             : fmt::format(" at a step of {:g} {}", step / u.scale, u.name);
    const double samples = static_cast<double>(range_grid(d.start, step, lo, hi).size());
    check_count(m, cause, samples, "samples", limits);
    check_values(m, cause, samples, limits);
    // From the drawn position to the first sample, then across the range.
    const double first = d.law.speed > 0.0 ? lo : hi;
    check_count(m, cause, (std::abs(d.start - first) + (hi - lo)) / continuation,
                steps_of(m, continuation), limits);
    check_resolution(m, cause, std::min(step, continuation),
                     std::max({std::abs(lo), std::abs(hi), std::abs(d.start)}));
    return;
  }

  // Over the cycle or the assembling range, both found by continuation: an angular driver
  // covers at most a turn, a slider 360 default steps of its range (or its assembling range at
  // an explicit step); following the loop back (at_limit = reverse) covers it twice.
  const double passes = options.at_limit == SweepOptions::AtLimit::reverse ? 2.0 : 1.0;
  double span = 2.0 * std::numbers::pi, step = step_given ? options.step : kDegree;
  if (!d.angular()) {
    span = 360.0;
    step = 1.0;
    if (step_given) {
      const AssemblingRange range = assembling_range(m, options);
      span = range.upper - range.lower;
      step = options.step;
    }
  }
  const Cause cause = step_given
                          ? step_option
                          : Cause{fmt::format("the default step of {}",
                                              d.angular() ? "1 degree" : "1/360 of the range"),
                                  {}};
  const double samples = passes * (std::floor(span / step + 1e-9) + 1.0);
  check_count(m, cause, samples, "samples", limits);
  check_values(m, cause, samples, limits);
  // Gears that turn a link faster than the driver take continuation steps of their own.
  // (A slider's cycle here is its assembling range, unknown before it is found: over a range
  // it is counted above.)
  if (d.angular() && gear_speed_up(m) > 1.0)
    check_count(m, cause, passes * span / continuation, steps_of(m, continuation), limits);
}

namespace {

// The continuation solve_at takes from the drawn position to `driver_value`.
void check_continuation(const Mechanism& m, double driver_value, const SweepOptions& options,
                        const WorkLimits& limits, const Cause& cause) {
  const DriverUnit u = driver_unit_of(m);
  const double largest = m.swept().angular() ? limits::kDriverValue : limits::kLength;
  if (!(std::abs(driver_value) <= largest))
    refuse(m, cause,
           fmt::format("is not a driver value: the limit is {:g} {}", largest / u.scale, u.name));
  const double continuation = continuation_bound(m, options.step);
  // The solver continues from the drawn position to the value, less the whole turns it skips
  // (solve_at), plus the turn that shows it may.
  double travel = std::abs(driver_value - m.swept().start);
  // (The skip is found by continuing a turn: not when the turn alone is over the limit.)
  if (travel / continuation > static_cast<double>(limits.max_samples) &&
      2.0 * std::numbers::pi / continuation <= static_cast<double>(limits.max_samples))
    if (const SkippedTurns skip = skipped_turns(m, driver_value, options); skip.turns != 0)
      travel =
          std::abs(driver_value - skip.driver_shift() - m.swept().start) + 2.0 * std::numbers::pi;
  check_count(m, cause, travel / continuation, steps_of(m, continuation), limits);
  check_resolution(m, cause, continuation,
                   std::max(std::abs(driver_value), std::abs(m.swept().start)));
}

}  // namespace

void check_solve_at_work(const Mechanism& m, double driver_value, const SweepOptions& options,
                         const WorkLimits& limits) {
  check_step(m, options);
  if (m.axis().timed()) {  // the value is a time, reached from 0 by the follower in time
    const Cause cause{fmt::format("--at {:g} s", driver_value), {}};
    if (!(driver_value >= 0.0 && driver_value <= limits::kDuration))
      refuse(
          m, cause,
          fmt::format("is not a time of the drivers' laws: from 0 to {:g} s", limits::kDuration));
    check_count(m, cause, timed_steps(m, driver_value, 3600), "continuation steps", limits);
    return;
  }
  const DriverUnit u = driver_unit_of(m);
  check_continuation(m, driver_value, options, limits,
                     {fmt::format("--at {:g} {}", driver_value / u.scale, u.name), {}});
}

void check_reference_work(const Mechanism& m, const WorkLimits& limits) {
  if (m.references.empty()) return;  // (none in a sweep in time: the loader refuses them)
  const DriverUnit u = driver_unit_of(m);
  for (const Reference& r : m.references)
    check_continuation(
        m, r.driver_value, {}, limits,
        {fmt::format("[[reference]] at = {:g} {}", r.driver_value / u.scale, u.name), r.where});
}

void check_simulation_work(const Mechanism& m, const SimulationOptions& options,
                           std::string_view option, const WorkLimits& limits) {
  const DynamicsCase& c = *m.dynamics;
  const double duration = options.duration > 0.0 ? options.duration : c.duration;
  const double interval = options.interval > 0.0 ? options.interval : c.interval;
  Cause cause =
      options.duration > 0.0
          ? Cause{fmt::format("{} {:g} s", option, duration), {}}
          : Cause{fmt::format("[dynamics] 'duration' = {:g} s", duration), c.duration_where};
  cause.what += fmt::format(" at {} interval of {:g} s",
                            options.interval > 0.0 ? "an" : "the case's", interval);
  const double samples = std::floor(duration / interval + 1e-9) + 1.0;
  check_count(m, cause, samples, "samples", limits);
  check_values(m, cause, samples, limits);
}

}  // namespace crosslink
