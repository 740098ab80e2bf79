// What every engine's run loop shares where only time and cost are concerned: the time grid its
// steps follow between the reference's samples, the clock around its steps, and the cost it
// reports (RunCost). Each engine passes its own step length, pre-roll and span of simulated time
// as data; the backend (build, drive, load, step, read) stays in the engine's folder
// (docs/decisions.md, "Run loop").
#pragma once

#include <chrono>
#include <vector>

#include "analytic/model/run_record.h"
#include "analytic/model/trajectory.h"
#include "sim/sampling.h"

namespace crosslink::sim {

using Clock = std::chrono::steady_clock;

// Steps per sample interval of the usable span: the fewest equal steps no longer than `wanted`
// (at least one), as doubles (they may be astronomical: counted before a grid takes memory, for
// check_steps()).
std::vector<double> steps_per_interval(const Trajectory& reference, const Span& span,
                                       double wanted);

// The steps per interval of the reference's usable span (set in `span`) for a run of `wanted`
// steps, and `extra` more. std::runtime_error when the reference's times do not increase, there
// is no span to run over (usable_span()), or the steps are more than `max_steps` (check_steps()).
std::vector<double> planned_steps(const Trajectory& reference, Span& span, double wanted,
                                  double extra, long max_steps);

// Where the steps inside a sample interval (t0, t1] of n steps fall: at t0 + k h with h = (t1 -
// t0) / n (MuJoCo's), or at t0 + (t1 - t0) k / n (Bullet's). The two round differently in the
// last bit; each engine keeps its own so that its runs stay bit-identical.
enum class InnerTimes { step_multiples, interval_fractions };

// Step times over the usable span, each sample interval split into its steps_per_interval(), so
// that samples fall on step boundaries; with `roll` steps of `roll_dt` before the first sample
// and after the last (a periodic sweep's pre-roll: 0 for none).
struct TimeGrid {
  std::vector<double> time;       // time at the end of step k (k = 0: the start)
  std::vector<long> sample_step;  // per sample: its step; -1 outside the usable span
  double dt = 0.0;                // the longest step inside the span [s]
  long steps_per_sample = 1;      // in the interval of the (first) longest step
};
TimeGrid sample_grid(const Trajectory& reference, const Span& span,
                     const std::vector<double>& per_interval, InnerTimes inner, long roll = 0,
                     double roll_dt = 0.0);

// The wall and CPU time (of the stepping thread, thread_cpu_seconds()) of a run's steps: started
// when made, read by stop().
class SteppingClock {
 public:
  SteppingClock() : wall_start_(Clock::now()), cpu_start_(thread_cpu_seconds()) {}
  void stop() {
    wall_seconds = std::chrono::duration<double>(Clock::now() - wall_start_).count();
    cpu_seconds = thread_cpu_seconds() - cpu_start_;
  }
  double wall_seconds = 0.0, cpu_seconds = 0.0;

 private:
  Clock::time_point wall_start_;
  double cpu_start_;
};

// What a run cost (RunCost): `steps` taken, the model `evaluations` they made, `simulated`
// seconds (the engine's span: to the last step taken, or the whole grid), the stepping time per
// simulated `cycle` seconds (0 when nothing was simulated), and the wall time since `begin`.
void record_cost(long steps, long evaluations, double simulated, double cycle,
                 const SteppingClock& stepping, Clock::time_point begin, RunCost& cost);

}  // namespace crosslink::sim
