// The dyads' sweep: the closed forms of analytic/kinematics/dyads.h marched along the grid of a
// Newton sweep, the reference's second exact method (analytic/reference/trust.h compares them).
#pragma once

#include "analytic/kinematics/dyads.h"
#include "analytic/model/trajectory.h"
#include "analytic/reference/sweep.h"

namespace crosslink {

// The closed-form sweep at the driver values of a Newton sweep `grid` (sweep() with the same
// options), method "dyads". Modes start from the assembled drawing and are followed from the
// sample nearest the driver's start value outward, in substeps of at most continuation_step(),
// each halved while continuity cannot tell a group's two assemblies apart: a sample's value does
// not depend on the grid's step. Mode changes are events at the driver value where they happen.
// With `forces`, also the kinetostatics at each closed-form pose (the multipliers, with J
// factorised there: about five times the closed form's own cost, so only where they are printed).
Trajectory dyad_sweep(const Mechanism& mechanism, const Trajectory& grid, bool forces = false);
Trajectory dyad_sweep(const Mechanism& mechanism, const SweepOptions& options = {});

}  // namespace crosslink
