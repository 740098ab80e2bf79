// Verdict tolerances: the largest allowed "max % of peak" (see metrics.h) per method and per
// quantity class.
//
// The exact methods' defaults (in % of the reference's peak over the cycle):
//   method      position  angle    velocity  acceleration  force  torque
//   dyads       1e-8      1e-8     1e-8      1e-8          1e-8   1e-8   both exact
//   ic          -         -        1e-6      -             -      -      velocities only
// The engines' defaults are given by the caller (EngineTolerances: the engine table,
// methods/engines.h, and docs/compare.md): the comparator knows no engine.
// Overrides, later wins:
//   1. the definition's [tolerance] table (Mechanism::tolerances): engines only, since the
//      exact methods must agree to round-off whatever the mechanism;
//   2. the command line: "velocity=0.5" (engines) or "dyads:velocity=1e-6" (one method).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink::compare {

// Tolerance of one method, per quantity class [% of peak].
struct ClassTolerances {
  double position = 0.0, angle = 0.0, velocity = 0.0, acceleration = 0.0, force = 0.0, torque = 0.0;
  double energy = 0.0;
  double of(Quantity q) const;
  double& of(Quantity q);
};

// The engines' default tolerances, by engine name in report order.
struct EngineTolerances {
  std::vector<std::pair<std::string, ClassTolerances>> engines;
  ClassTolerances others;  // a method neither exact nor one of `engines` (a run from elsewhere)
};

class Tolerances {
 public:
  // The exact methods' defaults and `engines`', then the definition's [tolerance] table (on every
  // engine and `others`).
  explicit Tolerances(EngineTolerances engines = {},
                      const ToleranceOverrides& from_definition = {});
  // "class=value" or "method:class=value"; throws std::invalid_argument on bad text.
  void apply(std::string_view assignment);
  double of(std::string_view method, Quantity quantity) const;

  bool is_engine(std::string_view method) const;  // one of the engines given

 private:
  void apply_definition(const ToleranceOverrides& from_definition);
  std::vector<ClassTolerances*> engine_rows();  // every engine's and others'
  const ClassTolerances* engine(std::string_view method) const;
  std::string valid_methods() const;  // "dyads, ic, " and the engines

  std::map<std::string, ClassTolerances, std::less<>> exact_;  // dyads, ic: fixed defaults
  // The engines and others: defaults, then [tolerance], then "class=v".
  EngineTolerances engines_;
  std::map<std::pair<std::string, Quantity>, double, std::less<>> method_override_;
};

// Parses a quantity class name; nullopt for anything else.
std::optional<Quantity> parse_quantity(std::string_view name);

}  // namespace crosslink::compare
