// Verdict tolerances: the largest allowed "max % of peak" (see metrics.h) per method and per
// quantity class.
//
// Defaults (in % of the reference's peak over the cycle):
//   method      position  angle    velocity  acceleration  force  torque
//   dyads       1e-8      1e-8     1e-8      1e-8          1e-8   1e-8   both exact
//   ic          -         -        1e-6      -             -      -      velocities only
//   mujoco      1e-2      1e-2     0.1       1             0.05   0.05   closed loops vs exact
//   bullet      1e-2      1e-2     0.1       1             0.3    0.3    (forces: measured, see
//                                                                        tolerance.cpp)
//   energy (energy.* channels, dynamics cases only): 1e-2 for both engines
// A dynamics case ([dynamics]; Tolerances(const Mechanism&)) has its own engine defaults:
//   method      position  angle    velocity  acceleration  force  torque  energy
//   mujoco      1e-2      1e-2     1e-2      0.1           0.05   0.05    1e-2
//   bullet      1e-2      1e-2     1e-2      0.1           0.3    0.3     1e-2
// (measured and argued in tolerance.cpp and docs/dynamics.md).
// Overrides, later wins:
//   1. the definition's [tolerance] table (Mechanism::tolerances): engines only, since the
//      exact methods must agree to round-off whatever the mechanism;
//   2. the command line: "velocity=0.5" (engines) or "dyads:velocity=1e-6" (one method).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>

#include "analytic/mechanism.h"
#include "analytic/trajectory.h"

namespace crosslink::compare {

// Tolerance of one method, per quantity class [% of peak].
struct ClassTolerances {
  double position = 0.0, angle = 0.0, velocity = 0.0, acceleration = 0.0, force = 0.0, torque = 0.0;
  double energy = 0.0;
  double of(Quantity q) const;
  double& of(Quantity q);
};

class Tolerances {
 public:
  // The defaults above, then the definition's [tolerance] table.
  explicit Tolerances(const ToleranceOverrides& from_definition = {});
  // The defaults for the mechanism (a dynamics case has its own: see kDynamics below), then its
  // [tolerance] table.
  explicit Tolerances(const Mechanism& mechanism);
  // "class=value" or "method:class=value"; throws std::invalid_argument on bad text.
  void apply(std::string_view assignment);
  double of(std::string_view method, Quantity quantity) const;

  static bool is_engine(std::string_view method);  // mujoco, bullet

 private:
  void apply_definition(const ToleranceOverrides& from_definition);

  std::map<std::string, ClassTolerances, std::less<>> exact_;  // dyads, ic: fixed defaults
  // mujoco, bullet: defaults, then [tolerance], then "class=v"
  std::map<std::string, ClassTolerances, std::less<>> engines_;
  std::map<std::pair<std::string, Quantity>, double, std::less<>> method_override_;
};

// Parses a quantity class name; nullopt for anything else.
std::optional<Quantity> parse_quantity(std::string_view name);

}  // namespace crosslink::compare
