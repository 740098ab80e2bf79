// What `crosslink sweep` and `crosslink merge` write of a sweep over definitions (the sweep, its
// shards and parts: methods/sweep_parts.h; docs/sweep.md).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "methods/settings_sweep.h"
#include "methods/sweep_parts.h"

namespace crosslink::app {

// The outputs of a sweep of `definitions` (one: the page and CSV of a single definition; more:
// those of several, write_sweeps_html / write_sweeps_csv): console summary, --csv, --report,
// --json. `sweeps[k]` is the sweep of `definitions[swept[k]]`. Returns the exit code (1 when a
// pick found no setting).
struct SweepOutputs {
  std::string csv, report, json;
};
int write_sweep_outputs(const SweepOutputs& outputs, const methods::HtmlOptions& html,
                        const nlohmann::json& document,
                        const std::vector<methods::DefinitionFile>& definitions,
                        const std::vector<size_t>& swept,
                        const std::vector<methods::SettingsSweep>& sweeps);

}  // namespace crosslink::app
