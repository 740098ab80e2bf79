#include "compare/tolerance.h"

#include <fmt/format.h>

#include <charconv>
#include <stdexcept>
#include <utility>

#include "analytic/model/limits.h"

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
    case Quantity::jerk:  // only the exact kinematics report it (a cam follower's): no class
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

bool Tolerances::is_engine(std::string_view method) const {
  return engine(method) != nullptr;
}

Tolerances::Tolerances(EngineTolerances engines, const ToleranceOverrides& from_definition)
    : engines_(std::move(engines)) {
  exact_["dyads"] = {1e-8, 1e-8, 1e-8, 1e-8, 1e-8, 1e-8, 1e-8};
  exact_["ic"] = {1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6, 1e-6};
  apply_definition(from_definition);
}

void Tolerances::apply_definition(const ToleranceOverrides& from_definition) {
  for (ClassTolerances* engine : engine_rows()) {
    if (from_definition.position) engine->position = *from_definition.position;
    if (from_definition.angle) engine->angle = *from_definition.angle;
    if (from_definition.velocity) engine->velocity = *from_definition.velocity;
    if (from_definition.acceleration) engine->acceleration = *from_definition.acceleration;
    if (from_definition.force) engine->force = *from_definition.force;
    if (from_definition.torque) engine->torque = *from_definition.torque;
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
    for (ClassTolerances* engine : engine_rows()) engine->of(*quantity) = value;
    return;
  }
  if (!is_engine(method) && !exact_.contains(method))
    throw std::invalid_argument(fmt::format("tolerance '{}': unknown method '{}' (valid: {})",
                                            assignment, method, valid_methods()));
  method_override_[{std::string(method), *quantity}] = value;
}

std::vector<ClassTolerances*> Tolerances::engine_rows() {
  std::vector<ClassTolerances*> rows = {&engines_.others};
  for (auto& [name, engine] : engines_.engines) rows.push_back(&engine);
  return rows;
}

const ClassTolerances* Tolerances::engine(std::string_view method) const {
  for (const auto& [name, t] : engines_.engines)
    if (name == method) return &t;
  return nullptr;
}

std::string Tolerances::valid_methods() const {
  std::string out;
  for (const auto& [name, t] : exact_) out += (out.empty() ? "" : ", ") + name;
  for (const auto& [name, t] : engines_.engines) out += ", " + name;
  return out;
}

double Tolerances::of(std::string_view method, Quantity quantity) const {
  if (const auto it = method_override_.find(std::pair{std::string(method), quantity});
      it != method_override_.end())
    return it->second;
  if (const auto it = exact_.find(method); it != exact_.end()) return it->second.of(quantity);
  if (const ClassTolerances* e = engine(method)) return e->of(quantity);
  return engines_.others.of(quantity);
}

}  // namespace crosslink::compare
