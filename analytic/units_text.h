// Values in messages (warnings, events, notes, errors) as the definition's file writes them: a
// driver value in its deg or rad, mm, cm or m; a length in the file's length unit; a time in s.
// Every message speaks the file's units (docs/compare.md, "Units in messages").
#pragma once

#include <fmt/format.h>

#include <string>

#include "analytic/mechanism.h"

namespace crosslink {

struct DriverUnit {
  double scale = 1.0;  // SI per file unit
  std::string name;    // "deg", "rad", "mm", ...
  // "12.5 deg" from a value in SI (rad or m).
  std::string text(double si, int digits = 10) const {
    return fmt::format("{:.{}g} {}", si / scale, digits, name);
  }
};

// The unit of a driver's value as the file gives it (its first driver's with several).
inline DriverUnit driver_unit_of(const Driver& d, const Units& u) {
  return d.angular() ? DriverUnit{u.angle, u.angle_name} : DriverUnit{u.length, u.length_name};
}
inline DriverUnit driver_unit_of(const Mechanism& m) {
  return driver_unit_of(m.driver(), m.units);
}

// A length [m] in the file's length unit: "0.012 mm".
inline std::string length_text(const Mechanism& m, double metres, int digits = 3) {
  return fmt::format("{:.{}g} {}", metres / m.units.length, digits, m.units.length_name);
}

// Where a sample or event lies along a sweep: "driver = 12.5 deg", or, where the sweep runs in
// time (several drivers, a dynamics case), "t = 2.5 s". `position` is the driver value [SI] or the
// time [s] (Trajectory::Event::driver).
inline std::string sweep_position_text(const Mechanism& m, double position, int digits = 10) {
  if (m.dynamics.has_value() || m.several_drivers())
    return fmt::format("t = {:.{}g} s", position, digits);
  return "driver = " + driver_unit_of(m).text(position, digits);
}

}  // namespace crosslink
