// The step rule every continuation shares (Newton's sweep, the dyads' march, forward dynamics'
// reference): how far a driver may move between two solves.
#pragma once

#include "analytic/model/mechanism.h"

namespace crosslink {

// The longest step any continuation takes between two solves, whatever the output grid's step:
// 1 degree of an angular driver; for a slider, the arc its mechanism's size sweeps in 1 degree.
// Output samples are reached in such substeps, so a sample's value does not depend on the grid.
// Of one driver (`size`: its mechanism's), or of the swept driver (the axis is not timed).
double continuation_step(const Driver& driver, double size);
double continuation_step(const Mechanism& mechanism);
// A sweep in time's substeps from t0 to t1: as many as the driver that moves most needs so that
// no driver moves more than its continuation step between two solves (at least 1).
double timed_substeps(const Mechanism& mechanism, double t0, double t1);

}  // namespace crosslink
