// A force-closed cam's jump speed (issue 37): the least driver speed at which the contact force
// of its follower first reaches zero, beyond which the follower leaves the cam somewhere in the
// cycle (docs/cams.md, "Contact and the jump").
//
// At a constant driver speed w the motion's rates scale with w and its accelerations with w^2,
// so at a pose the contact force along the common normal is N = A + C w + B w^2: A from the
// loads at rest (a spring's preload, gravity), C from dampers, B from inertia. Three
// kinetostatic solves per pose (the speed 0, w0 and -w0 the definition gives) give A, B and C
// exactly; the least positive root of N over the sweep's poses, refined between samples by
// golden-section search on exact poses, is the jump speed.
#pragma once

#include <optional>
#include <string>

#include "analytic/model/mechanism.h"

namespace crosslink {

struct JumpSpeed {
  std::optional<double> speed;  // the least speed [rad/s or m/s, as the driver's], or none
  double at = 0.0;              // the driver value where N first reaches zero [rad or m]
  std::string reason;           // why there is none
};

// The jump speed of cam joint `joint`: none for a form-closed cam, a driver not at constant
// speed or several drivers, joint friction (N is then not a quadratic in the speed), a follower
// the loads do not hold on at rest, or a contact force that never reaches zero.
JumpSpeed jump_speed(const Mechanism& mechanism, int joint);

}  // namespace crosslink
