// The fields and units of a definition's [[derived]] quantities (docs/mechanism-format.md,
// "Derived quantities"): what the loader checks a [[reference]] or [expect.derived] against, and
// how every output prints a field in the file's units. Their values: analytic/derived/derived.h.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/model/mechanism.h"

namespace crosslink {

// How a field is measured, so it is printed in the file's unit and judged in its class.
enum class DerivedUnit {
  channel,  // the unit of the quantity's channel (a stroke of s.ram: length)
  driver,   // a driver value (rad or m)
  ratio,    // a pure number
  length,   // m
  angle,    // rad
  speed,    // the driver's speed (rad/s or m/s), in its law's unit
};

// The unit of field `field` of a quantity of kind `kind`.
DerivedUnit derived_field_unit(DerivedSpec::Kind kind, std::string_view field);

// The SI factor of a field as the file writes it (its value / factor is in file units), and the
// unit's name ("mm", "deg", "" for a ratio).
double derived_factor(const Mechanism& mechanism, const DerivedSpec& spec, DerivedUnit unit);
std::string derived_unit_name(const Mechanism& mechanism, const DerivedSpec& spec,
                              DerivedUnit unit);

// The unit of "Q" or "Q.field" named in [[reference]] or [expect.derived], or nullopt when no
// [[derived]] has that name or field. `spec` receives the quantity.
std::optional<DerivedUnit> derived_unit_of(const Mechanism& mechanism, std::string_view quantity,
                                           const DerivedSpec** spec = nullptr);
// The names of the fields a kind of quantity has, its own value first.
std::vector<std::string> derived_fields(DerivedSpec::Kind kind);

}  // namespace crosslink
