// A settings sweep to JSON and back (methods/sweep_json.h).
#include "methods/sweep_json.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace crosslink::methods {

namespace {

using nlohmann::json;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// A value that does not exist is null, never a number.
json number(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

double number_of(const json& j, const char* key) {
  if (!j.contains(key)) throw std::invalid_argument(fmt::format("missing \"{}\"", key));
  const json& v = j.at(key);
  if (v.is_null()) return kNaN;
  if (!v.is_number()) throw std::invalid_argument(fmt::format("\"{}\": not a number", key));
  return v.get<double>();
}

json class_values(const ClassValues& values) {
  json j = json::object();
  for (ErrorClass c : kErrorClasses)
    j[std::string(to_string(c))] = number(values[static_cast<size_t>(c)]);
  return j;
}

ClassValues class_values_of(const json& j, const char* key) {
  if (!j.contains(key) || !j.at(key).is_object())
    throw std::invalid_argument(fmt::format("\"{}\": expected an object of classes", key));
  ClassValues out = kNoValues;
  for (ErrorClass c : kErrorClasses)
    out[static_cast<size_t>(c)] = number_of(j.at(key), std::string(to_string(c)).c_str());
  return out;
}

json settings_json(const sim::Settings& settings) {
  json j = json::array();
  for (const auto& [name, value] : settings) j.push_back({name, value});
  return j;
}

sim::Settings settings_of(const json& j) {
  sim::Settings out;
  for (const json& pair : j) out.emplace_back(pair.at(0).get<std::string>(), pair.at(1));
  return out;
}

// A count: an integer from `least` up (0.5 or -5 samples are refused, never cast).
int count_of(const json& j, const char* key, int least = 0) {
  if (!j.contains(key)) throw std::invalid_argument(fmt::format("missing \"{}\"", key));
  const json& v = j.at(key);
  if (!v.is_number_integer() || v.get<long long>() < least ||
      v.get<long long>() > std::numeric_limits<int>::max())
    throw std::invalid_argument(
        fmt::format("\"{}\": expected a whole number from {}, got {}", key, least, v.dump()));
  return v.get<int>();
}

// An engine this crosslink knows, or "analytic" (the exact methods' rows).
std::string engine_of(const json& j) {
  const std::string name = j.at("engine").get<std::string>();
  const std::vector<std::string> known = engine_names();
  if (name != "analytic" && std::find(known.begin(), known.end(), name) == known.end())
    throw std::invalid_argument(fmt::format("\"engine\": unknown engine '{}' (known: analytic, {})",
                                            name, fmt::join(known, ", ")));
  return name;
}

RunStatus status_of(const std::string& text) {
  for (RunStatus s : {RunStatus::ok, RunStatus::flagged, RunStatus::diverged})
    if (to_string(s) == text) return s;
  throw std::invalid_argument(fmt::format("\"status\": unknown status '{}'", text));
}

json row_json(const SweepRow& r) {
  json j;
  j["engine"] = r.engine;
  j["variant"] = r.variant;
  j["dt"] = number(r.dt);
  j["settings"] = settings_json(r.settings);
  j["overrides"] = settings_json(r.overrides);
  j["wall_s_per_cycle"] = number(r.wall_s_per_cycle);
  j["cpu_s_per_cycle"] = number(r.cpu_s_per_cycle);
  j["repeats"] = r.repeats;
  j["max_pct"] = class_values(r.max_pct);
  j["raw_pct"] = class_values(r.raw_pct);
  j["end_pct"] = class_values(r.end_pct);
  j["max_pct_energy"] = number(r.energy_pct);
  j["tip_position_error"] = number(r.tip_position_error);
  j["tip_velocity_error"] = number(r.tip_velocity_error);
  j["max_loop_gap"] = number(r.max_loop_gap);
  j["status"] = std::string(to_string(r.status));
  j["flagged_samples"] = r.flagged_samples;
  j["samples"] = r.samples;
  j["message"] = r.message;
  j["evaluations_per_step"] = number(r.evaluations_per_step);
  // Derived (analyse()), for a reader: not read back.
  j["work"] = number(r.work());
  json front = json::object();
  for (ErrorClass c : kErrorClasses)
    front[std::string(to_string(c))] = r.pareto[static_cast<size_t>(c)];
  j["pareto"] = front;
  return j;
}

SweepRow row_of(const json& j) {
  SweepRow r;
  r.engine = engine_of(j);
  r.variant = j.at("variant").get<std::string>();
  r.dt = number_of(j, "dt");
  r.settings = settings_of(j.at("settings"));
  r.overrides = settings_of(j.at("overrides"));
  r.wall_s_per_cycle = number_of(j, "wall_s_per_cycle");
  r.cpu_s_per_cycle = number_of(j, "cpu_s_per_cycle");
  r.repeats = count_of(j, "repeats");
  r.max_pct = class_values_of(j, "max_pct");
  r.raw_pct = class_values_of(j, "raw_pct");
  r.end_pct = class_values_of(j, "end_pct");
  r.energy_pct = number_of(j, "max_pct_energy");
  r.tip_position_error = number_of(j, "tip_position_error");
  r.tip_velocity_error = number_of(j, "tip_velocity_error");
  r.max_loop_gap = number_of(j, "max_loop_gap");
  r.status = status_of(j.at("status").get<std::string>());
  r.samples = count_of(j, "samples");
  r.flagged_samples = count_of(j, "flagged_samples");
  if (r.flagged_samples > r.samples)
    throw std::invalid_argument(
        fmt::format("\"flagged_samples\": {} of {} samples", r.flagged_samples, r.samples));
  r.message = j.at("message").get<std::string>();
  r.evaluations_per_step = number_of(j, "evaluations_per_step");
  return r;
}

}  // namespace

json sweep_to_json(const SettingsSweep& sweep) {
  json j;
  j["dynamics"] = sweep.dynamics;
  j["sample_interval"] = number(sweep.sample_interval);
  j["samples"] = sweep.samples;
  j["skipped"] = sweep.skipped;
  j["rows"] = json::array();
  for (const SweepRow& r : sweep.rows) j["rows"].push_back(row_json(r));
  return j;
}

SettingsSweep sweep_from_json(const json& j, const Mechanism& mechanism,
                              const std::vector<std::string>& engines,
                              std::optional<double> accuracy_pct) {
  SettingsSweep sweep;
  sweep.mechanism = &mechanism;
  try {
    sweep.dynamics = j.at("dynamics").get<bool>();
    sweep.sample_interval = number_of(j, "sample_interval");
    sweep.samples = count_of(j, "samples");
    sweep.skipped = j.at("skipped").get<std::vector<std::string>>();
    if (!j.at("rows").is_array()) throw std::invalid_argument("\"rows\": expected an array");
    for (const json& row : j.at("rows")) {
      try {
        sweep.rows.push_back(row_of(row));
      } catch (const std::invalid_argument& e) {
        throw std::invalid_argument(fmt::format("row {}: {}", sweep.rows.size() + 1, e.what()));
      }
    }
  } catch (const json::exception& e) {
    throw std::invalid_argument(e.what());
  }
  analyse(sweep);
  if (accuracy_pct) select_settings(sweep, engines, *accuracy_pct);
  return sweep;
}

}  // namespace crosslink::methods
