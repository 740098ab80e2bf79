// The options every subcommand shares (app/limits.cpp), for the files that declare a
// subcommand's options: the only ones that include CLI11 (it costs seconds per file to compile).
#pragma once

#include <CLI/CLI.hpp>
#include <limits>

#include "app/commands.h"

namespace crosslink::app {

// The limits on a command's work (app/limits.cpp): --max-samples on every command, --max-solves
// on those that simulate a dynamics case, --max-steps on those that run engines.
void add_max_samples(CLI::App& cmd, WorkLimits& limits);
// The check of a numeric option: a finite number from `low` (excluded when `low_open`) to
// `high`; NaN, infinities and values out of range are refused before any work (exit 2), the
// message naming the option.
CLI::Validator number_in(double low = -std::numeric_limits<double>::max(),
                         double high = std::numeric_limits<double>::max(), bool low_open = false);
// A positive step, time or time step.
inline CLI::Validator positive_number() {
  return number_in(0.0, std::numeric_limits<double>::max(), true);
}
void add_max_solves(CLI::App& cmd, WorkLimits& limits);
void add_max_steps(CLI::App& cmd, long& max_steps);
// --jobs N: the threads of a compare or sweep (methods/jobs.h), set to the machine's cores.
void add_jobs(CLI::App& cmd, int& jobs);

}  // namespace crosslink::app
