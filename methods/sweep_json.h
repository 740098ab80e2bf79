// A settings sweep as JSON (`crosslink sweep --json`, the parts of a sharded sweep that
// `crosslink merge` joins): every row's measured values, so that the CSV, the console and the
// HTML page can be written again from it. The fronts, orders, IFToMM limits and picks are derived
// from the rows (analyse(), select_settings()), so a sweep read back draws the same ones.
// docs/json.md, "crosslink sweep --json".
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "methods/settings_sweep.h"

namespace crosslink::methods {

// The rows and the reference's sampling of one definition's sweep, with the derived fronts and
// work written for a reader (not read back).
nlohmann::json sweep_to_json(const SettingsSweep& sweep);

// The sweep of `mechanism` from sweep_to_json()'s object, analysed again; with `accuracy_pct`
// the cheapest setting of each of `engines` picked again. Throws std::invalid_argument naming
// the field at fault.
SettingsSweep sweep_from_json(const nlohmann::json& j, const Mechanism& mechanism,
                              const std::vector<std::string>& engines,
                              std::optional<double> accuracy_pct);

}  // namespace crosslink::methods
