// Values in messages (warnings, events, notes, errors) as the definition's file writes them: a
// driver value in its deg or rad, mm, cm or m; a length in the file's length unit; a time in s.
// Every message speaks the file's units (docs/compare.md, "Units in messages").
#pragma once

#include <fmt/format.h>

#include <algorithm>
#include <string>

#include "analytic/model/mechanism.h"

namespace crosslink {

struct DriverUnit {
  double scale = 1.0;  // SI per file unit
  std::string name;    // "deg", "rad", "mm", ...
  // "12.5 deg" from a value in SI (rad or m).
  std::string text(double si, int digits = 10) const {
    return fmt::format("{:.{}g} {}", si / scale, digits, name);
  }
};

// The unit of a driver's value as the file gives it (of the swept driver: the axis is not timed).
inline DriverUnit driver_unit_of(const Driver& d, const Units& u) {
  return d.angular() ? DriverUnit{u.angle, u.angle_name} : DriverUnit{u.length, u.length_name};
}
inline DriverUnit driver_unit_of(const Mechanism& m) {
  return driver_unit_of(m.swept(), m.units);
}
// The unit of a position along the sweep's axis: the swept driver's, or seconds.
inline DriverUnit axis_unit_of(const Mechanism& m) {
  return m.axis().timed() ? DriverUnit{1.0, "s"} : driver_unit_of(m);
}

// The sweep's start as a message gives it: "driver = 30 deg", or, the sweep in time,
// "t = 0 s (crank2 = 30 deg, crank5 = 90 deg)".
inline std::string start_text(const Mechanism& m, int digits = 6) {
  if (!m.axis().timed()) return "driver = " + driver_unit_of(m).text(m.swept().start, digits);
  std::string starts;
  for (const Driver& d : m.drivers)
    starts += (starts.empty() ? "" : ", ") + d.name + " = " +
              driver_unit_of(d, m.units).text(d.start, digits);
  return "t = 0 s (" + starts + ")";
}
// Where the sweep's start is written: the swept driver's table; the sweep in time, the first
// [[driver]] table (every driver starts at t = 0).
inline const SourceLocation& start_where(const Mechanism& m) {
  return m.drivers[static_cast<size_t>(std::max(m.axis().driver, 0))].where;
}

// A length [m] in the file's length unit: "0.012 mm".
inline std::string length_text(const Mechanism& m, double metres, int digits = 3) {
  return fmt::format("{:.{}g} {}", metres / m.units.length, digits, m.units.length_name);
}

// Where a sample or event lies along a sweep: "driver = 12.5 deg", or, where the sweep runs in
// time (several drivers, a dynamics case), "t = 2.5 s". `position` is the driver value [SI] or the
// time [s] (Trajectory::Event::driver).
inline std::string sweep_position_text(const Mechanism& m, double position, int digits = 10) {
  if (m.dynamics.has_value() || m.axis().timed())
    return fmt::format("t = {:.{}g} s", position, digits);
  return "driver = " + driver_unit_of(m).text(position, digits);
}

}  // namespace crosslink
