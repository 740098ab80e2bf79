// Assembly modes by name. A chain closes in several ways at one driver value (a four-bar open or
// crossed); the sweep follows the one it starts on. A definition picks it by drawing the links'
// poses near it, or names it with [[branch]] (BranchChoice): apply_branches finds the start's
// assembly that has every named mode and writes it into the poses, as if drawn there, so that
// every method starts on it. start_modes tells `check` which mode each group took and whether
// the other one closes too.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/model/mechanism.h"

namespace crosslink {

// Whether configuration q (absolute coordinates) has the named mode.
bool holds(const Mechanism& mechanism, const BranchChoice& branch, const Eigen::VectorXd& q);

// The assembly step (load_mechanism: after read_definition), for a definition with [[branch]]
// tables or without drawn poses: when Newton's assembly from the drawing lacks a named mode, or
// there is none (nothing drawn, so nothing to start from), the assembly at the driver's start
// value that has every named mode is found over the modes of the chain's dyads (the fewest
// changed first; the first 12 two-solution groups, 4096 combinations at most) and written into
// the moving links' poses. Throws DefinitionError, at the [[branch]], when drawn poses
// contradict it, when no assembly has them all, or when the chain does not decompose into dyads
// (then only drawn poses choose). A chain that cannot assemble at the start is left to the usual
// reports.
void apply_branches(Mechanism& mechanism);

// The mode a two-solution group of the dyads took at the assembled start.
struct GroupMode {
  std::string group;  // "RRR dyad coupler + rocker (B, C, D)"
  std::string mode;   // "B -> C -> D turns counter-clockwise", or the solver's own description
  // The [[branch]] that names the other mode, when the group is a revolute dyad (three pins).
  std::optional<BranchChoice> other;
  bool other_closes = false;  // the other mode assembles at the start too
};
// Empty when the chain does not decompose or no group has two solutions.
std::vector<GroupMode> start_modes(const Mechanism& mechanism, const KinematicState& assembled);

}  // namespace crosslink
