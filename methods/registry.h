// The registry of methods: every way crosslink solves a Mechanism, each run into the comparator's
// MethodRun (compare/method_run.h):
//   analytic  Newton-Raphson on the full constraint equations: the reference of every verdict
//             (a dynamics case: the exact forward dynamics, analytic/physics/dynamics.h; dyads and
//             ic, kinematic methods, are then not run)
//   dyads     closed-form Assur dyads solved in sequence (analytic/kinematics/dyads.h)
//   ic        instantaneous centres by Kennedy-Aronhold: velocities only (instant_centres.h)
//   then every engine of the engine table (methods/engines.h): mujoco, bullet
// A method that is not built into this binary, or cannot realise the mechanism, comes back with
// available = false and the reason; it is listed in reports and never counted as a result.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/model/trajectory.h"
#include "analytic/physics/dynamics.h"
#include "analytic/reference/sweep.h"
#include "compare/comparison.h"
#include "compare/method_run.h"
#include "compare/report.h"
#include "sim/engine.h"

namespace crosslink::methods {

using compare::MethodRun;

// "analytic", "dyads", "ic", then the engine table's, in report order.
const std::vector<std::string>& method_names();
// How method `name` is drawn in the reports: an engine's from its table row, the exact methods'
// named here; a name of neither (a file of printed values) gets a plain brown dotted line.
compare::LineStyle method_style(std::string_view name);
// Every method's, by name (compare::HtmlOptions::styles).
std::map<std::string, compare::LineStyle> method_styles();
// Whether `name` is one of method_names().
bool is_method(std::string_view name);

// The reference: the exact Newton sweep of the mechanism; for a dynamics case ([dynamics]) the
// exact simulation (analytic/physics/dynamics.h) with its energy channels, `options` unused.
MethodRun run_reference(const Mechanism& mechanism, const SweepOptions& options = {});

// A dynamics case's exact simulation as a method: with its energy channels and each sample's
// conditioning (rcond); the reference is this at the default options. A run stopped by
// options.max_solves throws a DefinitionError at the case's [dynamics] table.
MethodRun run_simulation(const Mechanism& mechanism, const SimulationOptions& options);

// Throws std::invalid_argument when `engine_settings` hold a setting the engine `name` does not
// know, or a value it cannot take (sim::Engine::check_settings), before anything runs; the
// exact methods take no settings: nothing to check.
void check_engine_settings(std::string_view name, const Mechanism& mechanism,
                           const sim::Settings& engine_settings);

// Any other method at the reference's samples. `engine_settings` are passed to the engines as
// overrides (e.g. {"dt", "1e-4"} or the test hook {"perturb_link", "coupler:1.01"}); the exact
// methods ignore them. Throws std::invalid_argument for an unknown name.
MethodRun run_method(std::string_view name, const Mechanism& mechanism, const MethodRun& reference,
                     const sim::Settings& engine_settings = {});

// The exact values a comparison judges against besides the reference's samples
// (compare::ExactValues), on `reference`, the exact sweep or simulation: the [[derived]]
// quantities located on it and each [[reference]] row solved at its driver value.
compare::ExactValues exact_values(const Mechanism& mechanism, const MethodRun& reference);

// compare::compare_methods against the exact values of `runs[0]`, the reference (a caller that
// compares many runs against one reference solves them once, exact_values, and calls
// compare::compare_methods itself).
compare::Comparison compare_runs(const Mechanism& mechanism, std::vector<MethodRun> runs,
                                 const compare::Tolerances& tolerances);

// The pose a report draws (compare::Drawing): at `at` [rad or m; several drivers: a time], by
// default the drawn start (t = 0), with its instantaneous centres where it is usable.
compare::Drawing drawing(const Mechanism& mechanism, std::optional<double> at);

}  // namespace crosslink::methods
