// The exact solution as one call: a sweep (or one pose) by Newton-Raphson, the closed-form dyads
// where the chain decomposes, each checking the other, and the [[derived]] quantities located on
// the sweep. `crosslink solve` parses its options into SolveOptions and prints what solve
// returns; the Python module calls the same function and gets the same trajectory
// (docs/python.md).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "analytic/derived/derived.h"
#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"
#include "analytic/reference/budget.h"
#include "analytic/reference/sweep.h"

namespace crosslink::methods {

struct SolveOptions {
  std::string method = "auto";  // auto (the dyads where the chain decomposes), newton or dyads
  std::optional<double> at;     // one pose at this driver value [rad or m; several drivers: s]
  SweepOptions sweep;           // the step and what to do at a limit
  WorkLimits limits;
};

struct Solution {
  Trajectory trajectory;
  std::vector<DerivedValue> derived;  // a sweep's [[derived]] quantities, located on it
  std::string method;                 // which method it is, and why ("newton (asked for)")
};

// Throws std::invalid_argument for an unknown method, or dyads asked for on a chain that does
// not decompose ("method dyads: the chain ..."); DefinitionError (at the driver) for one pose that
// cannot be assembled, with the assembling range where `check` finds it; and as check_sweep_work
// and check_solve_at_work for work beyond the limits, before it starts. One pose that exists but is
// not usable (singular) is returned with its status.
Solution solve(const Mechanism& mechanism, const SolveOptions& options = {});

}  // namespace crosslink::methods
