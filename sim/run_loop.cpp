#include "sim/run_loop.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace crosslink::sim {

std::vector<double> steps_per_interval(const Trajectory& reference, const Span& span,
                                       double wanted) {
  std::vector<double> out;
  for (int i = span.first + 1; i <= span.last; ++i)
    out.push_back(
        std::max(1.0, std::ceil((reference.time(i) - reference.time(i - 1)) / wanted - 1e-9)));
  return out;
}

std::vector<double> planned_steps(const Trajectory& reference, Span& span, double wanted,
                                  double extra, long max_steps) {
  for (int i = 1; i < reference.samples(); ++i)
    if (!(reference.time(i) > reference.time(i - 1)))
      throw std::runtime_error("the reference's times do not increase");
  span = usable_span(reference);
  std::vector<double> per_interval = steps_per_interval(reference, span, wanted);
  check_steps(std::accumulate(per_interval.begin(), per_interval.end(), 0.0) + extra, wanted,
              max_steps);
  return per_interval;
}

TimeGrid sample_grid(const Trajectory& reference, const Span& span,
                     const std::vector<double>& per_interval, InnerTimes inner, long roll,
                     double roll_dt) {
  const double t0 = reference.time(span.first), t_end = reference.time(span.last);
  TimeGrid grid;
  grid.sample_step.assign(static_cast<size_t>(reference.samples()), -1);
  for (long k = roll; k >= 0; --k) grid.time.push_back(t0 - static_cast<double>(k) * roll_dt);
  grid.sample_step[static_cast<size_t>(span.first)] = roll;
  for (int i = span.first + 1; i <= span.last; ++i) {
    const double interval = reference.time(i) - reference.time(i - 1);
    const long n = static_cast<long>(per_interval[static_cast<size_t>(i - span.first - 1)]);
    const double h = interval / static_cast<double>(n);
    for (long k = 1; k <= n; ++k) {
      const double inside =
          inner == InnerTimes::step_multiples
              ? reference.time(i - 1) + static_cast<double>(k) * h
              : reference.time(i - 1) + interval * static_cast<double>(k) / static_cast<double>(n);
      grid.time.push_back(k == n ? reference.time(i) : inside);
    }
    grid.sample_step[static_cast<size_t>(i)] = static_cast<long>(grid.time.size()) - 1;
    if (h > grid.dt) {
      grid.dt = h;
      grid.steps_per_sample = n;
    }
  }
  for (long k = 1; k <= roll; ++k) grid.time.push_back(t_end + static_cast<double>(k) * roll_dt);
  return grid;
}

void record_cost(long steps, long evaluations, double simulated, double cycle,
                 const SteppingClock& stepping, Clock::time_point begin, RunCost& cost) {
  cost.steps = steps;
  cost.model_evaluations = evaluations;
  cost.simulated_seconds = simulated;
  if (simulated > 0.0) {
    cost.wall_seconds_per_cycle = stepping.wall_seconds * cycle / simulated;
    cost.cpu_seconds_per_cycle = stepping.cpu_seconds * cycle / simulated;
  }
  cost.wall_seconds = std::chrono::duration<double>(Clock::now() - begin).count();
}

}  // namespace crosslink::sim
