// The registry of methods: every way crosslink solves a Mechanism, each run into the comparator's
// MethodRun (compare/method_run.h):
//   analytic  Newton-Raphson on the full constraint equations: the reference of every verdict
//             (a dynamics case: the exact forward dynamics, analytic/dynamics.h; dyads and ic,
//             kinematic methods, are then not run)
//   dyads     closed-form Assur dyads solved in sequence (analytic/dyads.h)
//   ic        instantaneous centres by Kennedy-Aronhold: velocities only (instant_centres.h)
//   then every engine of the engine table (methods/engines.h): mujoco, bullet
// A method that is not built into this binary, or cannot realise the mechanism, comes back with
// available = false and the reason; it is listed in reports and never counted as a result.
#pragma once

#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/dynamics.h"
#include "analytic/sweep.h"
#include "analytic/trajectory.h"
#include "compare/method_run.h"
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
// exact simulation (analytic/dynamics.h) with its energy channels, `options` unused.
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

}  // namespace crosslink::methods
