// Four-bar analysis: a chain of four links joined in a loop by four revolutes, one of them the
// ground. Its Grashof class and the transmission angle over a sweep.
#pragma once

#include <optional>
#include <string>
#include <string_view>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink {

enum class Grashof {
  grashof,       // s + l < p + q: the shortest link turns fully relative to the others
  change_point,  // s + l = p + q: branches meet where all four pivots are collinear
  non_grashof,   // s + l > p + q: no link turns fully (triple-rocker)
};
std::string_view to_string(Grashof g);  // "Grashof" | "change point" | "non-Grashof"

struct FourBar {
  // Links: the ground, the input (next to the ground, carrying the driver when it can), the
  // coupler, the output (the other link next to the ground).
  int ground = -1, input = -1, coupler = -1, output = -1;
  // Pivot names: A (ground-input), B (input-coupler), C (coupler-output), D (output-ground).
  std::string a, b, c, d;
  double ground_length = 0, input_length = 0, coupler_length = 0, output_length = 0;  // [m]
  Grashof grashof = Grashof::grashof;
  std::string inversion;  // crank-rocker, double-crank, double-rocker, triple-rocker, ...
  std::string explain(const Mechanism& m) const;  // "Grashof crank-rocker (s + l = ... )"
};

// The four-bar structure of a mechanism, or nothing when it is not one.
std::optional<FourBar> four_bar(const Mechanism& mechanism);

// The angle at `vertex` between the directions to p and to q, in [0, pi].
double interior_angle(const Eigen::Vector2d& vertex, const Eigen::Vector2d& p,
                      const Eigen::Vector2d& q);

// Transmission angle at one sample: the angle at C between the coupler (C->B) and the output
// (C->D), in [0, pi]. 0 or pi: coupler and output in line (a toggle for an input driver).
double transmission_angle(const FourBar& fb, const Trajectory& t, int row);

struct TransmissionRange {
  double min = 0, min_at = 0;  // [rad], driver value [rad or m]
  double max = 0, max_at = 0;
  int samples = 0;  // usable (ok or singular) samples it was taken over
};
// Extremes of the transmission angle over the sweep's samples (ok and singular ones).
std::optional<TransmissionRange> transmission_range(const FourBar& fb, const Trajectory& t);

}  // namespace crosslink
