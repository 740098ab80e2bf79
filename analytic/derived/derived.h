// Derived quantities of a sweep ([[derived]]): what a designer reads off a linkage (a stroke and
// its ends, a quick return's time ratio, dead points, toggles, extreme transmission angles, a
// coupler path's straightness, a channel's extremes), as numbers with the driver values where
// they occur.
//
// Two ways, one set of definitions (docs/mechanism-format.md, "Derived quantities"):
//   exact    every event is located on the exact solution: a reversal of a position, angle or
//            velocity channel by bisection on its exact rate (d channel / d driver, from the
//            velocity or acceleration solve), an extreme of any other channel by golden-section
//            search on its exact value, each pose by Newton from the sweep sample beside it;
//            toggles are the sweep's own (located by the tracer to ~1e-12).
//   sampled  from a method's samples alone (an engine's): each extreme by the vertex of the
//            parabola through the extreme sample and its two neighbours, a value at an interval
//            end by linear interpolation. On a smooth channel sampled every h the vertex's
//            driver value is off by O(h^2) and its value by O(h^3) relative to the channel's
//            curvature; the comparator applies the same estimate to the reference's own samples,
//            so that a method is judged on its own error, and reports the estimate's error
//            against the exact value beside it.
// A quantity that does not exist (no reversal inside the interval, a time ratio of a sweep that
// is not a constant-speed cycle, a method without samples) has no value and says why.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/model/derived_spec.h"
#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink {

struct DerivedField {
  std::string name;  // "stroke", "max", "at_max", ...
  DerivedUnit unit = DerivedUnit::channel;
  std::optional<double> value;  // SI; none: it does not exist (DerivedValue::reason)
  // A location (at_max, at_min): the other driver values where the extreme's value is the same
  // within rounding (1e-9 of the channel's magnitude): a tie, each as much the location as value.
  std::vector<double> ties = {};
};

struct DerivedValue {
  const DerivedSpec* spec = nullptr;
  std::vector<DerivedField> fields;  // fields[0]: the quantity's own value
  std::string reason;                // why the values do not exist (empty when they do)
  // The field named `name` ("" or the quantity's name: the first), or nullptr.
  const DerivedField* field(std::string_view name) const;
};

// Every [[derived]] quantity of `mechanism` from `sweep`, an exact sweep (sweep(), or the
// reference of a comparison): its toggles are the sweep's events.
std::vector<DerivedValue> derived_exact(const Mechanism& mechanism, const Trajectory& sweep);

// The same from the samples of any method's trajectory (on the reference's driver values).
std::vector<DerivedValue> derived_sampled(const Mechanism& mechanism, const Trajectory& samples);

// The value of "Q" or "Q.field" among `values`, or nullopt.
std::optional<double> derived_value(const std::vector<DerivedValue>& values,
                                    std::string_view quantity);

}  // namespace crosslink
