// The interface every physics-engine model implements: build a scene from a Mechanism, run it
// at the driver values of an analytic sweep, and return the same Trajectory type, plus what it
// cost and every setting the result depends on.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/run_record.h"
#include "analytic/model/trajectory.h"
#include "sim/settings.h"

namespace crosslink::sim {

// Engine settings as (name, value) text pairs, printed with every result. Each engine declares
// its names, defaults and values once (Engine::settings_schema). Names every engine understands,
// in the same units, so that one bare --set reaches them all:
//   "dt"                time step [s], or auto
//   "max_steps"         the most steps the run may take (default kDefaultMaxSteps); a run that
//                       would take more is refused before it starts
//   "gap_threshold"     a loop gap [m] beyond which a sample is loop_gap, or auto
//   "driver_threshold"  a driven coordinate further from its law [rad, or m for a slider] is
//                       lost, or auto
//   "singular_rcond"    the fraction of the chain's own conditioning below which a sample is
//                       singular
//   "perturb_link"      "<link>:<factor>": scale that link's points in the scene only (a test
//                       hook that builds a deliberately wrong model; default none)
using Settings = RunSettings;

using crosslink::RunCost;  // sim::RunCost: the run record every engine fills

struct EngineRun {
  Trajectory trajectory;  // same samples (driver values) as the reference sweep
  // Every setting in force, defaults included, and the values the run reports: its schema's
  // entries for its kind of run, in the schema's order (printed_settings).
  Settings settings;
  RunCost cost;
  bool ok = true;       // false: the run diverged or could not be built
  std::string message;  // why not ok, or notes (e.g. the samples outside a limited sweep)
};

// `reference` is the exact sweep: the engine starts from its first sample's configuration
// (assembled) and is sampled at each of its driver values / times.
class Engine {
 public:
  virtual ~Engine() = default;
  virtual std::string name() const = 0;  // "mujoco", "bullet"
  // Every setting the engine takes: parsed, checked and listed from this one declaration.
  virtual const SettingSchema& settings_schema() const = 0;
  // Whether the engine can realise this mechanism, and why not.
  virtual bool supports(const Mechanism& mechanism, std::string* why) const = 0;
  // Throws std::invalid_argument, before any run, for a setting the engine does not know
  // (naming it and the settings it knows) or a value it cannot take (out of its range, not a
  // whole number, a link `mechanism` does not have).
  virtual void check_settings(const Mechanism& mechanism, const Settings& overrides) const = 0;
  virtual EngineRun run(const Mechanism& mechanism, const Trajectory& reference,
                        const Settings& overrides) const = 0;
};

}  // namespace crosslink::sim
