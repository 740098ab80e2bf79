// What both engine models share when they read a run against the exact reference: the
// reference's link coordinates, the distance between two configurations, and finite-difference
// weights for derivatives at a sample from the step history.
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "analytic/mechanism.h"
#include "analytic/trajectory.h"

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

// CPU time of the calling thread [s] (CLOCK_THREAD_CPUTIME_ID): what a run costs, without the
// time other processes take the core.
double thread_cpu_seconds();

// The setting "max_steps": a positive whole number (std::invalid_argument otherwise).
long parse_max_steps(const std::string& text);

// Refuses (std::runtime_error) a run of `steps` steps of `dt` seconds when that is more than
// `max_steps`, before it starts; the message says how to raise the limit.
void check_steps(double steps, double dt, long max_steps);

// Finite-difference weights (Fornberg 1988) of the value, first and second derivative at x0
// from values at the nodes x (any spacing, x0 inside or outside them).
std::array<std::vector<double>, 3> stencil_weights(double x0, const std::vector<double>& x);

}  // namespace crosslink::sim
