// The exact methods' sweeps of one definition at one grid, as several test suites compare them.
#pragma once

#include <map>
#include <string>

#include "analytic/kinematics/dyads.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/sweep.h"

namespace crosslink::test {

// "newton": the sweep at `step` (0: the default); "dyads": the closed form at its samples, with
// forces, when the chain decomposes.
inline std::map<std::string, Trajectory> exact_sweeps(const Mechanism& m, double step) {
  SweepOptions options;
  options.step = step;
  std::map<std::string, Trajectory> out;
  out["newton"] = sweep(m, options);
  if (decompose(m).complete) out["dyads"] = dyad_sweep(m, out.at("newton"), true);
  return out;
}

}  // namespace crosslink::test
