#include "analytic/kinematics/continuation.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace crosslink {

double continuation_step(const Driver& driver, double size) {
  return (driver.angular() ? 1.0 : size) * std::numbers::pi / 180.0;
}

double continuation_step(const Mechanism& mechanism) {
  return continuation_step(mechanism.swept(), mechanism.size());
}

double timed_substeps(const Mechanism& mechanism, double t0, double t1) {
  double parts = 1.0;
  for (const Driver& driver : mechanism.drivers) {
    const double moved = std::abs(driver.at_time(t1).value - driver.at_time(t0).value);
    parts = std::max(parts, std::ceil(moved / continuation_step(driver, mechanism.size())));
  }
  return parts;
}

}  // namespace crosslink
