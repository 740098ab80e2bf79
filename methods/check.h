// `crosslink check`'s report on a loaded definition, as one call: what it is (links, joints,
// drivers, mobility, the closed-form groups), whether and how it assembles, its assembling range,
// singular positions and jump speeds, the design summary and its claims judged. The command
// prints it; the Python module returns it (docs/python.md).
#pragma once

#include <optional>
#include <string>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"
#include "analytic/reference/budget.h"
#include "analytic/reference/sweep.h"

namespace crosslink::methods {

// The report (`out`, the command's stdout), the error when the drawn position cannot be
// assembled or a dynamics case cannot start (`err`), and the command's exit code.
struct CheckReport {
  static constexpr int kClaimFails = 1;   // a claim of the definition does not hold
  static constexpr int kCannotStart = 2;  // the drawn position cannot be assembled
  int exit_code = 0;
  std::string out, err;
  // The sweep its singular positions come from (solve's default sweep with the same options),
  // for a caller that goes on to solve; none at rest or when the chain cannot start.
  std::optional<Trajectory> sweep;
};
// Throws as check_sweep_work does. `sweep`: the options of its assembling range and sweep (the
// command's are the defaults; the fuzz target bounds its grid and tracer).
CheckReport check_report(const Mechanism& mechanism, const WorkLimits& limits,
                         const SweepOptions& sweep = {});

}  // namespace crosslink::methods
