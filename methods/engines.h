// The engine table: every physics engine crosslink runs, one row each (docs/design.md, "Adding an
// engine"). The registry (methods/registry.h), the settings sweep's variants
// (methods/settings_sweep.h), the default tolerances (compare::Tolerances) and the command line
// read it; nothing else names an engine. An engine is its folder (sim/<engine>) plus one row.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/model/mechanism.h"
#include "compare/method_run.h"
#include "compare/tolerance.h"
#include "sim/engine.h"

namespace crosslink::methods {

// One variant a settings sweep tries for an engine: a name and its overrides at time step dt [s]
// (a softness can depend on dt).
struct Variant {
  std::string name;
  std::function<sim::Settings(double dt)> settings;
};

struct EngineEntry {
  std::string name;          // "mujoco": the method's name, the ENGINE: of --set and --tolerance
  std::string description;   // one line for reports
  compare::LineStyle style;  // its line in every report's charts (compare and sweep pages)
  std::function<std::unique_ptr<sim::Engine>()> make;
  // Default verdict tolerances [% of peak] of a kinematic and of a dynamics case (measured and
  // argued in engines.cpp).
  compare::ClassTolerances tolerances, dynamics_tolerances;
  // The settings sweep's variants, the engine's default first (docs/sweep.md).
  std::vector<Variant> variants, dynamics_variants;
  // Joint friction's variants, added to either for a mechanism with it (their settings are the
  // engine's friction settings, which only such a mechanism takes).
  std::vector<Variant> friction_variants;
};

// Every engine, in report order.
const std::vector<EngineEntry>& engine_table();
// The row of that name, or null for a method that is not an engine.
const EngineEntry* find_engine(std::string_view name);
// "mujoco", "bullet": the table's names in order.
std::vector<std::string> engine_names();

// `crosslink engines`: each engine with its settings (default, what it takes, the runs it applies
// to, what it does) and the values its runs report; as Markdown tables (`markdown`), the
// reference of docs/engines.md ("Settings"), one per engine.
std::string engines_listing(bool markdown);
// One engine's Markdown table: | setting | default | takes | runs | what |.
std::string settings_markdown(const EngineEntry& engine);

// Every engine's default tolerances for a kinematic or a dynamics case (compare::Tolerances).
compare::EngineTolerances engine_tolerances(bool dynamics);
// The defaults for `mechanism` (a dynamics case has its own), then its [tolerance] table.
compare::Tolerances default_tolerances(const Mechanism& mechanism);

}  // namespace crosslink::methods
