#include "sim/shared_settings.h"

#include <fmt/format.h>

namespace crosslink::sim {

SharedSettings::SharedSettings(const SettingValues& v)
    : gap_threshold(v.is("gap_threshold", "auto") ? 0.0 : v.number("gap_threshold")),
      divergence_gap(v.number("divergence_gap")),
      driver_threshold(v.is("driver_threshold", "auto") ? 0.0 : v.number("driver_threshold")),
      singular_rcond(v.number("singular_rcond")),
      branch_distance(v.number("branch_distance")),
      energy_threshold(v.number("energy_threshold")),
      divergence_energy(v.number("divergence_energy")),
      perturb_link(v.is("perturb_link", "none") ? "" : v.text("perturb_link")),
      max_steps(v.count("max_steps")),
      extrapolated_load(v.is("friction_load", "extrapolated")) {}

void SharedSettings::resolve(const Mechanism& m) {
  if (gap_threshold == 0.0) gap_threshold = 1e-4 * m.size();
  if (driver_threshold == 0.0) driver_threshold = 1e-4 * driver_watch_unit(m);
}

KinematicWatch SharedSettings::kinematic_watch(const Mechanism& m) const {
  return {gap_threshold, divergence_gap * m.size(), driver_threshold, singular_rcond,
          branch_distance};
}

DynamicsWatch SharedSettings::dynamics_watch(const Mechanism& m, double energy_scale) const {
  return {gap_threshold, divergence_gap * m.size(), singular_rcond,
          energy_scale,  energy_threshold,          divergence_energy};
}

namespace {

RunSettings common(const SharedSettings& s, bool friction) {
  RunSettings values = {{"gap_threshold", format_number(s.gap_threshold)},
                        {"divergence_gap", format_number(s.divergence_gap)},
                        {"singular_rcond", format_number(s.singular_rcond)},
                        {"mass_model", "the definition's (Link::mass)"},
                        {"perturb_link", s.perturb_link},
                        {"max_steps", std::to_string(s.max_steps)}};
  if (friction) values.push_back(friction_load_value(s.extrapolated_load));
  return values;
}

}  // namespace

RunSettings SharedSettings::kinematic_printed(bool friction) const {
  RunSettings values = common(*this, friction);
  values.emplace_back("driver_threshold", format_number(driver_threshold));
  values.emplace_back("branch_distance", format_number(branch_distance));
  return values;
}

RunSettings SharedSettings::dynamics_printed(double energy_scale, bool friction) const {
  RunSettings values = common(*this, friction);
  values.emplace_back("driver",
                      "none: the coordinate moves under the applied effort (forward dynamics)");
  values.emplace_back("energy_threshold", format_number(energy_threshold));
  values.emplace_back("divergence_energy", format_number(divergence_energy));
  values.emplace_back("energy_scale", fmt::format("{:.6g} J", energy_scale));
  return values;
}

StepAngle::StepAngle(const SettingValues& v, double kinematic, double dynamics)
    : kinematic(kinematic), dynamics(dynamics) {
  if (!v.is("max_step_angle", "auto")) given = v.number("max_step_angle");
}

}  // namespace crosslink::sim
