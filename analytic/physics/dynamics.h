// Exact forward dynamics of a [dynamics] case: the reference that engines' free and
// torque-driven motion is measured against. Below, one free coordinate; with several drivers each
// is a free coordinate d_i, S = dq/dd has one column per driver (a velocity solve at its unit
// rate, the others' 0) and (S^T M S) dddot = efforts(t) + S^T (Q - M qddot0) (docs/dynamics.md,
// "Several free coordinates"; a pose next to a singular position ends such a run).
//
// The driver names the independent coordinate d. At any (d, ddot) the Newton solver gives the
// pose, s = dq/dd (the velocity solve at unit rate) and qddot0 (the acceleration solve with
// d's acceleration zero), so qddot = qddot0 + s dddot. The equations of motion projected on s,
// along which the constraint forces do no work, give the minimal-coordinate equation
//   (s^T M s) dddot = effort(t) + s^T (Q - M qddot0),
// with Q - M qddot from Kinetostatics::generalised_forces (the code the kinetostatics tests
// check): s^T M s = s^T (g(qddot0) - g(qddot0 + s)). The state (d, ddot, w) is integrated by
// Boost.Odeint's adaptive Runge-Kutta methods with dense output at the sample times; w is the
// work done by the applied effort, the loads and the dampers, so that the energy balance
//   kinetic + potential - initial energy - w = 0
// measures the integration's error rather than being assumed.
//
// The pose follows its branch by continuation from the last one solved, in steps of at most
// continuation_step(), each Newton correction small against the predicted motion; a step that
// lands on another branch, or a coordinate where the chain cannot close, ends the run with the
// time it happened (flagged samples from there on), never a silent jump.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink {

// A start whose constraint Jacobian is this badly conditioned (reciprocal condition, as the
// Newton solver scales it) is a singular position of the coordinate (the sweep takes rcond below
// 1e-6 as at a change point): a toggle, or a change point. There the other coordinates' rates
// are not determined by the coordinate's, so no consistent initial velocity exists.
inline constexpr double kSingularStartRcond = 1e-6;

// Why a dynamics case cannot start at its drawn pose of reciprocal condition `rcond` ("" when
// it can): `crosslink check` reports it at the [dynamics] table, and simulate() refuses it.
std::string singular_start(const Mechanism& m, double rcond);

struct SimulationOptions {
  double duration = 0.0;  // [s]; 0: the case's
  double interval = 0.0;  // between samples [s]; 0: the case's
  // "rkf78": Runge-Kutta-Fehlberg 7(8), stepped to each sample; "dopri5": Dormand-Prince 5(4)
  // with dense output. Two independent integrations of the same equation; rkf78 is the
  // reference (on A02 a third of dopri5's evaluations, and half its energy error).
  std::string integrator = "rkf78";
  double tolerance = 1e-13;  // absolute and relative, per step
  // The most pose solves of the run (each evaluation of the equation of motion solves its pose,
  // in continuation steps when the coordinate moved far): the integrator's work cannot be
  // foreseen (its steps follow the motion), so a run that reaches the limit stops there, its
  // remaining samples not_reached, with an event that names the limit (--max-solves).
  long max_solves = kDefaultMaxSolves;
  static constexpr long kDefaultMaxSolves = 6'000'000;
};

struct Simulation {
  Trajectory trajectory;  // samples in time; forces with the applied effort as the driver's
  // Per sample [J]: kinetic and potential energy, and the work done on the mechanism since t = 0
  // by the applied effort, the loads and the dampers.
  Eigen::VectorXd kinetic, potential, work;
  double initial_energy = 0.0;
  bool ok = true;
  std::string message;       // why the run stopped early
  long evaluations = 0;      // of the equation of motion
  long solves = 0;           // of a pose (options.max_solves bounds them)
  bool over_budget = false;  // stopped by options.max_solves
  // Joint friction: each instant the sliding stopped (the coordinate's rate reached zero), as
  // (time [s], coordinate), located to 1e-14 of the time; after the last, held at rest when
  // `held`.
  std::vector<std::pair<double, double>> stops;
  bool held = false;

  // The largest of the energies (kinetic, potential, work, initial) over the run [J]: the scale
  // of the balance (one sample's energies may all be near 0: a pendulum at rest at the level of
  // its pivot).
  double energy_scale = 0.0;

  // kinetic + potential - initial - work at sample k [J], and its magnitude over energy_scale.
  double energy_balance(int k) const {
    return kinetic(k) + potential(k) - initial_energy - work(k);
  }
  double energy_error(int k) const;
};

// Integrates a [dynamics] case (throws std::invalid_argument for a mechanism without one, and
// DefinitionError at its [dynamics] table for one that cannot start: no assembly, or a singular
// start). A run that stops later keeps its samples up to there, the rest not_reached.
Simulation simulate(const Mechanism& mechanism, const SimulationOptions& options = {});

}  // namespace crosslink
