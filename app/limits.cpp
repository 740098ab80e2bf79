// The options that bound a command's work, shared by every subcommand (analytic/reference/budget.h
// for the exact solver, sim/engine.h for the engines).
#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "app/commands.h"
#include "app/options.h"
#include "methods/jobs.h"

namespace crosslink::app {

CLI::Validator number_in(double low, double high, bool low_open) {
  constexpr double kLargest = std::numeric_limits<double>::max();
  std::string range = fmt::format("a number in {}{:g}, {:g}]", low_open ? '(' : '[', low, high);
  if (low == -kLargest && high == kLargest) range = "a finite number";
  if (low == 0.0 && high == kLargest) range = low_open ? "a positive number" : "0 or more";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double value = 0.0;
        // NaN fails every comparison, so it passes CLI::Range: refused here, with infinities.
        if (!CLI::detail::lexical_cast(text, value) || !std::isfinite(value) ||
            !(low_open ? value > low : value >= low) || !(value <= high))
          return fmt::format("{} is not {}", text, range);
        return {};
      },
      range);
}

void add_max_samples(CLI::App& cmd, WorkLimits& limits) {
  cmd.add_option("--max-samples", limits.max_samples,
                 "the most samples, and continuation steps, of one exact sweep or solve; more "
                 "is refused before any work")
      ->check(number_in(1.0, 1e18))
      ->capture_default_str();
}

void add_max_solves(CLI::App& cmd, WorkLimits& limits) {
  cmd.add_option("--max-solves", limits.max_solves,
                 "the most pose solves of one exact simulation (a dynamics case); a run that "
                 "reaches it stops there, its remaining samples not_reached")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
}

void add_max_steps(CLI::App& cmd, long& max_steps) {
  cmd.add_option("--max-steps", max_steps,
                 "the most steps of one engine run; a run that would take more is refused before "
                 "it starts")
      ->check(number_in(1.0, 1e18))
      ->capture_default_str();
}

void add_jobs(CLI::App& cmd, int& jobs) {
  jobs = methods::default_jobs();
  cmd.add_option("--jobs", jobs,
                 "threads the runs share (default: the machine's cores); results are the same "
                 "for every N, 1 runs them in turn")
      ->check(CLI::Range(1, methods::kMaxJobs));
}

}  // namespace crosslink::app
