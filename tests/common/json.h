// JSON documents of two runs compared with what varies from run to run left out.
#pragma once

#include <nlohmann/json.hpp>
#include <regex>
#include <string>

namespace crosslink::test {

// A JSON document without its timing keys (any key naming seconds) and texts ("...; 0.0011 s",
// the reference's cross-check), as scripts/behaviour-diff.py compares them.
inline nlohmann::json without_timings(const nlohmann::json& j) {
  if (j.is_string())
    return std::regex_replace(j.get<std::string>(), std::regex("; [0-9.e+-]+ s\\b"), "; T s");
  if (j.is_object()) {
    nlohmann::json out = nlohmann::json::object();
    for (const auto& [key, value] : j.items())
      if (key.find("seconds") == std::string::npos) out[key] = without_timings(value);
    return out;
  }
  if (j.is_array()) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& value : j) out.push_back(without_timings(value));
    return out;
  }
  return j;
}

}  // namespace crosslink::test
