// The values of the settings Bullet, ODE and Simbody declare alike (shared_setting): what the
// watch flags and stops a run by, the test hook, the step budget and joint friction's load. Read,
// resolved, printed and made into the watches here once, so that an engine's own Config holds
// only what is its own. (MuJoCo's thresholds differ: its gap is a cut's, its driver and
// conditioning thresholds other defaults.)
#pragma once

#include <optional>
#include <string>

#include "analytic/model/mechanism.h"
#include "sim/dynamics_run.h"
#include "sim/kinematic_run.h"
#include "sim/settings.h"

namespace crosslink::sim {

struct SharedSettings {
  double gap_threshold = 0.0;     // [m]; 0 (auto): 1e-4 of the size, once resolved
  double divergence_gap = 0.0;    // of the size
  double driver_threshold = 0.0;  // [rad] or [m]; 0 (auto): 1e-4 of driver_watch_unit
  // Samples whose Jacobian is conditioned worse than this fraction of the chain's own (the
  // reference's median rcond, analytic/reference/trust.h) are flagged singular.
  double singular_rcond = 0.0;
  double branch_distance = 0.0;  // of the size, or rad
  double energy_threshold = 0.0;
  double divergence_energy = 0.0;
  std::string perturb_link;  // "": none
  long max_steps = 0;
  bool extrapolated_load = true;  // friction_load: extrapolated, else the last step's

  // From an engine's settings, whose schema declares every one of them.
  explicit SharedSettings(const SettingValues& v);
  SharedSettings() = default;
  // The auto thresholds of `m` (the scene's mechanism) where the settings leave them 0.
  void resolve(const Mechanism& m);

  KinematicWatch kinematic_watch(const Mechanism& m) const;
  DynamicsWatch dynamics_watch(const Mechanism& m, double energy_scale) const;
  // Their values in force as a run of each kind prints them (printed_settings), with the
  // reported mass model, and a dynamics run's driver and energy scale [J]; friction_load only
  // for a mechanism with joint friction.
  RunSettings kinematic_printed(bool friction) const;
  RunSettings dynamics_printed(double energy_scale, bool friction) const;
};

// max_step_angle, step_length's bound on the fastest link's turn in a step [rad] (0: none): the
// value given, or with "auto" the engine's own for the kind of run, which its schema's doc gives.
struct StepAngle {
  std::optional<double> given;
  double kinematic = 0.0, dynamics = 0.0;  // the engine's auto values

  StepAngle() = default;
  StepAngle(const SettingValues& v, double kinematic, double dynamics);
  double of(bool dynamics_run) const {
    return given ? *given : dynamics_run ? dynamics : kinematic;
  }
};

}  // namespace crosslink::sim
