// The interface every physics-engine model implements: build a scene from a Mechanism, run it
// at the driver values of an analytic sweep, and return the same Trajectory type, plus what it
// cost and every setting the result depends on.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "analytic/mechanism.h"
#include "analytic/trajectory.h"

namespace crosslink::sim {

// Engine settings as (name, value) text pairs, printed with every result. Each engine documents
// its own names and defaults. Names every engine understands:
//   "dt"            time step [s]
//   "perturb_link"  "<link>:<factor>": scale that link's points in the scene only (a test hook
//                   that builds a deliberately wrong model; never used by default)
//   "max_steps"     the most steps the run may take (default kDefaultMaxSteps); a run that
//                   would take more is refused before it starts
using Settings = std::vector<std::pair<std::string, std::string>>;

// A run's time and memory grow with its steps (Bullet keeps every step's configuration): 2
// million steps are about 5 s of MuJoCo and 240 MB of Bullet history for 15 coordinates.
constexpr long kDefaultMaxSteps = 2'000'000;

struct RunCost {
  double wall_seconds = 0.0;            // total wall time of the run (build + steps)
  double wall_seconds_per_cycle = 0.0;  // stepping time per simulated driver cycle (a dynamics
                                        // case: per simulated second)
  // The same in CPU time of the stepping thread (sim::thread_cpu_seconds): unlike the wall time
  // it does not count the time other processes take the core, so it varies less between runs
  // on a shared machine (the settings sweep's cost).
  double cpu_seconds_per_cycle = 0.0;
  long steps = 0;  // engine steps taken
  double simulated_seconds = 0.0;
};

struct EngineRun {
  Trajectory trajectory;  // same samples (driver values) as the reference sweep
  Settings settings;      // every setting in force, defaults included
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
