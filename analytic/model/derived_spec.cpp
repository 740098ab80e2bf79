#include "analytic/model/derived_spec.h"

#include <algorithm>

#include "analytic/model/trajectory.h"
#include "analytic/model/units_text.h"

namespace crosslink {

std::vector<std::string> derived_fields(DerivedSpec::Kind kind) {
  using K = DerivedSpec::Kind;
  switch (kind) {
    case K::extremes:
      return {"max", "at_max", "min", "at_min"};
    case K::stroke:
      return {"stroke", "min", "at_min", "max", "at_max"};
    case K::time_ratio:
      return {"ratio", "increasing", "decreasing", "at_min", "at_max"};
    case K::dead_points:
      return {"at_min", "at_max", "min", "max"};
    case K::toggles:
      return {"toggle1", "toggle2"};
    case K::transmission:
      return {"min", "at_min", "max", "at_max"};
    case K::straightness:
      return {"deviation", "extent", "direction"};
    case K::circularity:
      return {"deviation", "radius", "centre_x", "centre_y", "extent"};
    case K::jump_speed:
      return {"speed", "at"};
    case K::least_radius:
      return {"radius", "at"};
  }
  return {};
}

DerivedUnit derived_field_unit(DerivedSpec::Kind kind, std::string_view field) {
  using K = DerivedSpec::Kind;
  if (field.starts_with("at_") || field.starts_with("toggle") || field == "increasing" ||
      field == "decreasing" || field == "at")
    return DerivedUnit::driver;
  if (kind == K::jump_speed) return DerivedUnit::speed;
  if (kind == K::least_radius) return DerivedUnit::length;
  if (kind == K::time_ratio) return DerivedUnit::ratio;
  if (kind == K::straightness)
    return field == "direction" ? DerivedUnit::angle : DerivedUnit::length;
  if (kind == K::circularity) return field == "extent" ? DerivedUnit::angle : DerivedUnit::length;
  return DerivedUnit::channel;
}

double derived_factor(const Mechanism& m, const DerivedSpec& spec, DerivedUnit unit) {
  switch (unit) {
    case DerivedUnit::driver:
      return driver_unit_of(m).scale;
    case DerivedUnit::ratio:
      return 1.0;
    case DerivedUnit::length:
      return m.units.length;
    case DerivedUnit::angle:
      return m.units.angle;
    case DerivedUnit::speed:
      return m.swept().law.speed_unit.si;
    case DerivedUnit::channel:
      break;
  }
  return Trajectory::unit_in(m.units, spec.channel).si;
}

std::string derived_unit_name(const Mechanism& m, const DerivedSpec& spec, DerivedUnit unit) {
  switch (unit) {
    case DerivedUnit::driver:
      return driver_unit_of(m).name;
    case DerivedUnit::ratio:
      return "";
    case DerivedUnit::length:
      return m.units.length_name;
    case DerivedUnit::angle:
      return m.units.angle_name;
    case DerivedUnit::speed:
      return m.swept().law.speed_unit.name;
    case DerivedUnit::channel:
      break;
  }
  return Trajectory::unit_in(m.units, spec.channel).name;
}

std::optional<DerivedUnit> derived_unit_of(const Mechanism& m, std::string_view quantity,
                                           const DerivedSpec** spec) {
  const size_t dot = quantity.find('.');
  const std::string_view name = quantity.substr(0, dot);
  for (const DerivedSpec& s : m.derived) {
    if (s.name != name) continue;
    const std::vector<std::string> fields = derived_fields(s.kind);
    std::string field =
        dot == std::string_view::npos ? fields.front() : std::string(quantity.substr(dot + 1));
    if (s.kind == DerivedSpec::Kind::toggles && field.starts_with("toggle")) field = "toggle1";
    if (std::find(fields.begin(), fields.end(), field) == fields.end()) return std::nullopt;
    if (spec) *spec = &s;
    return derived_field_unit(s.kind, field);
  }
  return std::nullopt;
}

std::string_view to_string(DerivedSpec::Kind kind) {
  using K = DerivedSpec::Kind;
  switch (kind) {
    case K::extremes:
      return "extremes";
    case K::stroke:
      return "stroke";
    case K::time_ratio:
      return "time_ratio";
    case K::dead_points:
      return "dead_points";
    case K::toggles:
      return "toggles";
    case K::transmission:
      return "transmission";
    case K::straightness:
      return "straightness";
    case K::circularity:
      return "circularity";
    case K::jump_speed:
      return "jump_speed";
    case K::least_radius:
      return "least_radius";
  }
  return "";
}

}  // namespace crosslink
