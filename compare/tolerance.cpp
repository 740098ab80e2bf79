#include "compare/tolerance.h"

#include <fmt/format.h>

#include <charconv>
#include <stdexcept>

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
  }
  return position;
}

std::optional<Quantity> parse_quantity(std::string_view name) {
  for (Quantity q : {Quantity::position, Quantity::angle, Quantity::velocity,
                     Quantity::acceleration, Quantity::force, Quantity::torque})
    if (to_string(q) == name) return q;
  return std::nullopt;
}

bool Tolerances::is_engine(std::string_view method) {
  return method == "mujoco" || method == "bullet";
}

Tolerances::Tolerances(const ToleranceOverrides& from_definition) {
  engine_ = {1e-2, 1e-2, 0.1, 1.0, 1.0, 1.0};
  exact_["dyads"] = {1e-8, 1e-8, 1e-8, 1e-8, 1e-8, 1e-8};
  exact_["ic"] = {1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6};
  if (from_definition.position) engine_.position = *from_definition.position;
  if (from_definition.angle) engine_.angle = *from_definition.angle;
  if (from_definition.velocity) engine_.velocity = *from_definition.velocity;
  if (from_definition.acceleration) engine_.acceleration = *from_definition.acceleration;
  if (from_definition.force) engine_.force = *from_definition.force;
  if (from_definition.torque) engine_.torque = *from_definition.torque;
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
                    "velocity, acceleration, force, torque)",
                    assignment, target));
  double value = 0.0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !(value >= 0.0))
    throw std::invalid_argument(
        fmt::format("tolerance '{}': '{}' is not a non-negative percentage", assignment, text));
  if (method.empty()) {
    engine_.of(*quantity) = value;
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
  const auto it = exact_.find(method);
  return (it == exact_.end() ? engine_ : it->second).of(quantity);
}

}  // namespace crosslink::compare
