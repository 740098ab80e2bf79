// What both engine models share when they read a run against the exact reference: the
// reference's link coordinates, the distance between two configurations, and finite-difference
// weights for derivatives at a sample from the step history.
#pragma once

#include <Eigen/Core>
#include <array>
#include <functional>
#include <string>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"
#include "sim/forces.h"

namespace crosslink::sim {

// Absolute coordinates (x, y, theta per moving link) of reference sample `row`: each link's
// frame from its angle and one of its named points.
Eigen::VectorXd reference_coordinates(const Mechanism& m, const Trajectory& reference, int row);

// Absolute coordinates and their first two time derivatives at reference sample `row`: each
// link's angle, omega and alpha, and its frame origin's motion from one of its named points.
struct ReferenceState {
  Eigen::VectorXd q, qdot, qddot;
};
ReferenceState reference_state(const Mechanism& m, const Trajectory& reference, int row);

// Largest difference between two configurations: positions per `size`, angles modulo 2 pi.
double configuration_distance(const Eigen::VectorXd& a, const Eigen::VectorXd& b, double size);

// "" or why an engine scene's configuration `read` back is not the start `q_start` it was built
// at (off by 1e-9 of the size or more).
std::string start_mismatch(const Mechanism& m, const Eigen::VectorXd& read,
                           const Eigen::VectorXd& q_start);

// CPU time of the calling thread [s] (CLOCK_THREAD_CPUTIME_ID): what a run costs, without the
// time other processes take the core.
double thread_cpu_seconds();
// Refuses (std::runtime_error) a run of `steps` steps of `dt` seconds when that is more than
// `max_steps`, before it starts; the message says how to raise the limit.
void check_steps(double steps, double dt, long max_steps);

// The reference's usable samples (PoseStatus::ok): an engine starts at the first and stops at the
// last, never driven outside them; samples outside keep the reference's flag, interior flagged
// samples (a change point on a sample) are run through. std::runtime_error when there is no
// sample, or a single one, to run over.
struct Span {
  int first = -1, last = -1;
};
Span usable_span(const Trajectory& reference);

// Finite-difference weights (Fornberg 1988) of the value, first and second derivative at x0
// from values at the nodes x (any spacing, x0 inside or outside them).
std::array<std::vector<double>, 3> stencil_weights(double x0, const std::vector<double>& x);

// A pose of the step history (absolute coordinates), by step.
using PoseAt = std::function<Eigen::Ref<const Eigen::VectorXd>(long step)>;

// The steps a sample on (or nearest) step `at` is differenced over: 3-point central over
// at - 1 .. at + 1 where those steps exist, else the 4 nearest steps, one-sided. Step 0, the exact
// start, is never in a stencil: it lacks the O(dt^2) residual every later step has, so a stencil
// through it would see that residual as an acceleration (docs/engines.md).
std::vector<long> difference_stencil(long at, long last_step);

// Position, velocity and acceleration at time t from the poses of `steps` (state.q, qdot, qddot).
void difference_state(double t, const std::vector<long>& steps,
                      const std::vector<double>& step_time, const PoseAt& pose, Eigen::VectorXd& q,
                      Eigen::VectorXd& qdot, Eigen::VectorXd& qddot);

// Plan stage of a kinematic run: what each sample is read from, fixed before the first step.
// Its difference stencil (difference_stencil() of the step on it, or nearest it), its force
// stencil (force_stencil()), which poses' forces are read, and so the step that completes it.
struct SamplePlan {
  std::vector<std::vector<long>> stencil;  // per sample; empty outside the usable span
  std::vector<ForceStencil> forces;        // per sample; empty without forces
  std::vector<bool> read_forces;           // per step: whether its pose's forces are read
  // The step after which sample i can be written: its last pose, and the step leaving its last
  // force pose.
  long complete_at(int i) const;
};
SamplePlan plan_samples(const Trajectory& reference, Span span,
                        const std::vector<double>& step_time, const std::vector<long>& sample_step,
                        bool with_forces);

// The velocity at pose k > 0 from the poses before it (a one-sided difference of poses
// max(0, k - 2) .. k): what the loads and dampers see before the step that leaves pose k.
void recent_velocity(long k, const std::vector<double>& step_time, const PoseAt& pose,
                     Eigen::VectorXd& velocity);

}  // namespace crosslink::sim
