// MuJoCo 2.2.2 model of a Mechanism (see docs/engines.md for the scene and its settings).
//
// Settings (name: default; every one is echoed in EngineRun::settings with its value in force):
//   dt              "auto": the largest step that divides the reference's sample interval and
//                   turns no link by more than `max_step_angle` per step; or a step [s], rounded
//                   down so that samples fall on step boundaries
//   max_step_angle  0.0025 [rad] (only with dt = auto)
//   integrator      Euler (Euler | RK4 | implicit)
//   solver          Newton (Newton | CG | PGS)
//   iterations      20      constraint solver iterations per step
//   tolerance       1e-10   constraint solver tolerance
//   solref          "deadbeat" = (-1/dt^2, -1/dt): closes a loop gap in one Euler step; or two
//                   numbers (MuJoCo's solref) for the loop <connect> constraints
//   solimp          "0.9999 0.9999 0.001 0.5 2" (loop constraints)
//   driver_solref   "deadbeat"; driver_solimp "0.9999 0.9999 0.001 0.5 2" (driver equality)
//   gap_threshold   1e-4 x mechanism size [m]: samples whose largest cut-joint gap since the
//                   previous sample exceeds it are flagged PoseStatus::loop_gap
//   driver_threshold 1e-3 [rad] or 1e-3 x size [m]: a driven joint further than this from its
//                   target has lost the driver (PoseStatus::diverged, run not ok)
//   perturb_link    none | "<link>:<factor>" (test hook: that link's points scaled; the scene is
//                   assembled for the scaled linkage, a valid but wrong model)
//   force_read      centred | raw: constraint forces at the sampled pose's own velocity (O(dt^2)),
//                   or MuJoCo's efc_force as solved, velocity terms half a step behind (O(dt));
//                   docs/engines.md, "Forces"
//   driver_armature auto | a rotor inertia [kg m^2, or kg for a slide] on the driven tree joint,
//                   its share of the effort taken back out: auto tops the joint's own inertia up
//                   to 1e-2 of the generalised inertia the driver moves (a light crank on a heavy
//                   load); docs/engines.md, "Forces"
//   singular_rcond  auto: 1e-5 (kinematic), 0.03 (dynamics): samples whose constraint Jacobian at
//                   the engine's configuration is conditioned worse than this fraction of the
//                   chain's own (analytic/reference/trust.h, typical_rcond) are flagged singular
// A dynamics case ([dynamics]; docs/engines.md, "Forward dynamics") runs without the driver
// equality and adds:
//   start           auto | staggered | exact: the velocity at the start, v0 - h/2 a0 (auto for
//                   Euler and implicit) or v0 (auto for RK4)
//   readout         auto | differences | state: central differences of the step positions, or
//                   MuJoCo's state and mj_forward at the sample (auto for RK4)
//   energy_threshold  1e-3: |energy.error| over the energy scale beyond which a note is given
//   divergence_energy 1: beyond it the run stops, diverged
#pragma once

#include <memory>
#include <string>

#include "sim/engine.h"

namespace crosslink::sim {

std::unique_ptr<Engine> make_mujoco_engine();

// The MJCF text of the scene the engine would run for this reference and these settings (the
// bodies at the reference's first sample). Throws std::runtime_error when MuJoCo cannot realise
// the mechanism or a setting is invalid.
std::string mujoco_mjcf(const Mechanism& mechanism, const Trajectory& reference,
                        const Settings& settings);

}  // namespace crosslink::sim
