#include "compare/tolerance.h"

#include <fmt/format.h>

#include <charconv>
#include <stdexcept>

#include "analytic/limits.h"

namespace crosslink::compare {

double ClassTolerances::of(Quantity q) const {
  return const_cast<ClassTolerances*>(this)->of(q);
}

double& ClassTolerances::of(Quantity q) {
  switch (q) {
    case Quantity::position:
      return position;
    case Quantity::angle:
      return angle;
    case Quantity::velocity:
      return velocity;
    case Quantity::acceleration:
      return acceleration;
    case Quantity::force:
      return force;
    case Quantity::torque:
      return torque;
    case Quantity::energy:
      return energy;
  }
  return position;
}

std::optional<Quantity> parse_quantity(std::string_view name) {
  for (Quantity q : {Quantity::position, Quantity::angle, Quantity::velocity,
                     Quantity::acceleration, Quantity::force, Quantity::torque, Quantity::energy})
    if (to_string(q) == name) return q;
  return std::nullopt;
}

bool Tolerances::is_engine(std::string_view method) {
  return method == "mujoco" || method == "bullet";
}

namespace {
// Forward dynamics (docs/dynamics.md, "Engines"). A run's error is mostly a phase error that
// grows along it and shows in positions, velocities and accelerations alike (measured within
// 25 % of each other), so they share the kinematic position tolerance, 1e-4 of the scale, and so
// does the energy balance (of the energy scale); accelerations (and forces) are sensitive next
// to singular positions, 10 times looser. Measured at the defaults on IFToMM A02 with N = 2 over
// 10 s (position / velocity / acceleration / force / energy, % of scale): MuJoCo 0.0031 /
// 0.0031 / 0.0038 / 0.011 / 0.0027, Bullet 0.0038 / 0.0038 / 0.0047 / 0.014 / 0.0034.
const ClassTolerances kDynamicsMujoco = {0.01, 0.01, 0.01, 0.1, 0.05, 0.05, 0.01};
const ClassTolerances kDynamicsBullet = {0.01, 0.01, 0.01, 0.1, 0.3, 0.3, 0.01};
}  // namespace

Tolerances::Tolerances(const ToleranceOverrides& from_definition) {
  // Forces and torques: measured at the engines' defaults over every bundled mechanism, without
  // and with gravity (bench/force_accuracy, docs/engines.md "Forces"), worst channel: MuJoCo
  // 0.014 %, Bullet 0.21 % (polycentric hinge near its limits; 0.10 % elsewhere). Energy: only
  // dynamics cases have energy channels (kDynamics*).
  engines_["mujoco"] = {1e-2, 1e-2, 0.1, 1.0, 0.05, 0.05, 1e-2};
  engines_["bullet"] = {1e-2, 1e-2, 0.1, 1.0, 0.3, 0.3, 1e-2};
  exact_["dyads"] = {1e-8, 1e-8, 1e-8, 1e-8, 1e-8, 1e-8, 1e-8};
  exact_["ic"] = {1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6};
  apply_definition(from_definition);
}

Tolerances::Tolerances(const Mechanism& mechanism) {
  engines_["mujoco"] = mechanism.dynamics ? kDynamicsMujoco : Tolerances().engines_["mujoco"];
  engines_["bullet"] = mechanism.dynamics ? kDynamicsBullet : Tolerances().engines_["bullet"];
  exact_ = Tolerances().exact_;
  apply_definition(mechanism.tolerances);
}

void Tolerances::apply_definition(const ToleranceOverrides& from_definition) {
  for (auto& [name, engine] : engines_) {
    if (from_definition.position) engine.position = *from_definition.position;
    if (from_definition.angle) engine.angle = *from_definition.angle;
    if (from_definition.velocity) engine.velocity = *from_definition.velocity;
    if (from_definition.acceleration) engine.acceleration = *from_definition.acceleration;
    if (from_definition.force) engine.force = *from_definition.force;
    if (from_definition.torque) engine.torque = *from_definition.torque;
  }
}

void Tolerances::apply(std::string_view assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string_view::npos)
    throw std::invalid_argument(
        fmt::format("tolerance '{}': expected CLASS=PERCENT or METHOD:CLASS=PERCENT", assignment));
  std::string_view target = assignment.substr(0, eq);
  const std::string_view text = assignment.substr(eq + 1);
  std::string_view method;
  if (const size_t colon = target.find(':'); colon != std::string_view::npos) {
    method = target.substr(0, colon);
    target = target.substr(colon + 1);
  }
  const std::optional<Quantity> quantity = parse_quantity(target);
  if (!quantity)
    throw std::invalid_argument(
        fmt::format("tolerance '{}': unknown quantity class '{}' (valid: position, angle, "
                    "velocity, acceleration, force, torque, energy)",
                    assignment, target));
  double value = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  // The limit of a definition's [tolerance] (infinity would pass every sample).
  if (error != std::errc() || end != text.data() + text.size() || !(value >= 0.0) ||
      !(value <= limits::kTolerance))
    throw std::invalid_argument(
        fmt::format("tolerance '{}': '{}' is not a percentage from 0 to {:g}", assignment, text,
                    limits::kTolerance));
  if (method.empty()) {
    for (auto& [name, engine] : engines_) engine.of(*quantity) = value;
    return;
  }
  if (!is_engine(method) && !exact_.contains(method))
    throw std::invalid_argument(
        fmt::format("tolerance '{}': unknown method '{}' (valid: dyads, ic, mujoco, bullet)",
                    assignment, method));
  method_override_[{std::string(method), *quantity}] = value;
}

double Tolerances::of(std::string_view method, Quantity quantity) const {
  if (const auto it = method_override_.find(std::pair{std::string(method), quantity});
      it != method_override_.end())
    return it->second;
  if (const auto it = exact_.find(method); it != exact_.end()) return it->second.of(quantity);
  if (const auto it = engines_.find(method); it != engines_.end()) return it->second.of(quantity);
  return engines_.at("mujoco").of(quantity);  // another engine: the common defaults
}

}  // namespace crosslink::compare
