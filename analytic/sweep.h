// Driver sweeps: follow one assembly branch continuously over the driver's cycle or its
// assembling range, sampling position, velocity and acceleration on a regular grid.
#pragma once

#include <optional>
#include <utility>

#include "analytic/newton.h"
#include "analytic/trajectory.h"

namespace crosslink {

struct SweepOptions {
  // Grid step of the driver [rad or m]; 0 = 1 degree for angles, 1/360 of the range for sliders.
  double step = 0.0;
  // Sweep this driver interval instead of the cycle or the assembling range [rad or m].
  std::optional<std::pair<double, double>> range;
  NewtonOptions newton;
};

// Where the chain can be assembled, found by continuation from the drawn position.
struct AssemblingRange {
  bool full_cycle = false;  // the driver turns (or runs) through its whole cycle
  double lower = 0.0;       // limits when not full_cycle [rad or m]
  double upper = 0.0;
  std::string explain(const Mechanism& mechanism) const;  // in the file's units
};

// Continuation over the driver from the drawn position to find its assembling range. Limits are
// located by bisection to `tolerance` in the driver coordinate.
AssemblingRange assembling_range(const Mechanism& mechanism, const SweepOptions& options = {},
                                 double tolerance = 1e-9);

// The exact sweep: samples at start + k*step (in the direction of the driver's speed) over one
// cycle when the driver can complete it, else over the assembling range, else over
// options.range. For a polynomial or table law, samples are equally spaced in time over the
// law's duration. Each sample's status says whether it is usable; events list limits and jumps.
Trajectory sweep(const Mechanism& mechanism, const SweepOptions& options = {});

// The exact state at one driver value, reached by continuation from the drawn position so it
// lies on the drawn branch. The driver's rate and acceleration are those of the motion law at
// the first time it passes the value (constant speed: the speed, zero).
Trajectory solve_at(const Mechanism& mechanism, double driver_value,
                    const SweepOptions& options = {});

}  // namespace crosslink
