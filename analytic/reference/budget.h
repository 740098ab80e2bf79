// The work a command asks of the exact solver, counted before it starts: the samples of a sweep
// and the continuation steps the solver takes to reach them. A typo such as range = [-30, 1e9]
// (degrees) is refused at once instead of running for ever. Over the limit, the error names what
// asked for the work (a key of the definition at its place, or an option), the count, the limit
// and the option that raises it. (What a definition may hold is bounded by
// analytic/model/limits.h.)
#pragma once

#include "analytic/physics/dynamics.h"
#include "analytic/reference/sweep.h"

namespace crosslink {

struct WorkLimits {
  // Samples of one sweep, and continuation steps of one sweep or solve (--max-samples).
  long max_samples = 100'000;
  // Pose solves of one exact simulation (--max-solves): SimulationOptions::max_solves.
  long max_solves = SimulationOptions::kDefaultMaxSolves;
};

// Throws, before any work, when sweep(mechanism, options) would take more samples or steps than
// `limits` allow, when options.step is not a usable step, or when the driver is at rest (speed
// 0: one pose, no sweep): a DefinitionError located at the key at fault (driver.range, the
// motion law), else std::invalid_argument naming the option (--step). A slider swept over its
// assembling range with an explicit step is measured by assembling_range() first (itself bounded).
void check_sweep_work(const Mechanism& mechanism, const SweepOptions& options,
                      const WorkLimits& limits);

// The same for solve_at(mechanism, driver_value, options): the continuation from the drawn
// position to `driver_value` (--at), which must also be finite and within the driver's limits.
void check_solve_at_work(const Mechanism& mechanism, double driver_value,
                         const SweepOptions& options, const WorkLimits& limits);

// The same for the [[reference]] rows compare solves at their `at` (solve_at), each refused at
// its place.
void check_reference_work(const Mechanism& mechanism, const WorkLimits& limits);

// The same for simulate(mechanism, options) of a dynamics case: the samples it stores (its
// duration over its interval) and their values. Over the limit, a DefinitionError located at
// [dynamics] 'duration', or, when options.duration was given by the command-line `option`
// (--duration, --at), an std::invalid_argument naming it. Its pose solves cannot be foreseen and
// are bounded by options.max_solves as it runs.
void check_simulation_work(const Mechanism& mechanism, const SimulationOptions& options,
                           std::string_view option, const WorkLimits& limits);

}  // namespace crosslink
