// The comparison study as one call: every method asked for against the exact reference, each at
// its settings (or at the cheapest ones meeting an accuracy), the verdicts, and each failing
// engine rerun at half its time step. `crosslink compare` parses its options into a
// CompareOptions and prints what run_compare returns; any other front end calls the same
// function and gets the same Comparison (docs/compare.md; the command's JSON is compare::to_json
// of it).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/reference/budget.h"
#include "analytic/reference/sweep.h"
#include "compare/comparison.h"
#include "methods/settings_sweep.h"
#include "sim/settings.h"

namespace crosslink::methods {

struct CompareOptions {
  // The methods, each one of method_names(), in the order given; the reference ("analytic")
  // runs whether named or not.
  std::vector<std::string> methods = method_names();
  // "CLASS=PERCENT" or "METHOD:CLASS=PERCENT" over default_tolerances(); a later one wins.
  std::vector<std::string> tolerances;
  // "KEY=VALUE" for every engine that runs, "ENGINE:KEY=VALUE" for one (engine_settings()).
  std::vector<std::string> settings;
  // Each engine at its cheapest settings meeting this % of peak on every class (searched coarse
  // to fine, cheapest_setting()); it is also every class's tolerance, under `tolerances`.
  std::optional<double> accuracy_pct;
  double step = 0.0;         // the reference sweep's step [rad or m]; 0: the default
  std::optional<double> at;  // the pose a report draws [rad or m; with several drivers: s]
  WorkLimits limits;
  long max_steps = sim::kDefaultMaxSteps;  // of one engine run, under the engines' max_steps
  int jobs = 1;                            // threads the runs share (methods/jobs.h)
  // An accuracy search's progress, and what it chose for each engine, in the engines' order.
  Progress progress;
  std::function<void(const Selection&)> chose;
};

// The settings of `engine` among `all` KEY=VALUE and ENGINE:KEY=VALUE texts, in order, behind
// max_steps = `max_steps` (a later max_steps wins). Throws std::invalid_argument for a text
// without '='.
sim::Settings engine_settings(std::string_view engine, const std::vector<std::string>& all,
                              long max_steps = sim::kDefaultMaxSteps);

// Throws std::invalid_argument, before anything runs, for a setting text an engine would refuse:
// a bare KEY=VALUE goes to every engine of `runs`, ENGINE:KEY=VALUE to that engine whether it runs
// or not (an MJCF export builds MuJoCo's scene without running it), and the prefix must name an
// engine.
void check_setting_texts(const Mechanism& mechanism, const std::vector<std::string>& texts,
                         const std::vector<std::string>& runs);

// Throws std::invalid_argument naming `option` when an engine's explicit time step `dt` would take
// more than `max_steps` steps over `span` seconds, before the engine runs.
void check_time_step(double span, double dt, long max_steps, std::string_view option);

// Everything the study refuses before any work, as std::invalid_argument (a DefinitionError for
// work the definition itself asks for): an unknown method, tolerance or setting (an ENGINE:
// prefix must name an engine; each engine checks what it would be given), a step on a dynamics
// case, and work beyond `limits`: the sweep or simulation, the [[reference]] rows, the pose at
// `at`. An engine's explicit time step is checked against its run's span in run_compare, once
// the reference has run.
void check_compare(const Mechanism& mechanism, const CompareOptions& options);

// The study: check_compare, the reference (a dynamics case: its exact simulation), every other
// method at once (options.jobs), compare::compare_methods, then the step probes. The result
// points to `mechanism`, which must outlive it.
compare::Comparison run_compare(const Mechanism& mechanism, const CompareOptions& options);

}  // namespace crosslink::methods
