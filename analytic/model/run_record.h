// What a method's run carries besides its trajectory, in terms no engine defines: the settings it
// ran with as (name, value) text and what it cost. An engine fills them and the comparator prints
// them: the record lies below both, as the trajectory does (docs/design.md, "Layout").
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace crosslink {

// Settings as (name, value) text pairs, printed with every result.
using RunSettings = std::vector<std::pair<std::string, std::string>>;

struct RunCost {
  double wall_seconds = 0.0;            // total wall time of the run (build + steps)
  double wall_seconds_per_cycle = 0.0;  // stepping time per simulated driver cycle (a dynamics
                                        // case: per simulated second)
  // The same in CPU time of the stepping thread (sim::thread_cpu_seconds): unlike the wall time
  // it does not count the time other processes take the core, so it varies less between runs
  // on a shared machine (the settings sweep's cost).
  double cpu_seconds_per_cycle = 0.0;
  long steps = 0;  // engine steps taken
  // The longest step the run took [s] (an engine's "dt" as a number; 0: no time step, the exact
  // methods), what a rerun at half the step halves.
  double time_step = 0.0;
  // The model evaluations (forward dynamics of the whole model) those steps made: each engine
  // counts its own (MuJoCo: its integrator's stages per step; Bullet: one per step).
  long model_evaluations = 0;
  double simulated_seconds = 0.0;
};

}  // namespace crosslink
