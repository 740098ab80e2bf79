// A sweep over several definitions, split into shards, and the parts `crosslink merge` joins
// (docs/sweep.md, "Many definitions, shards and merge"; the JSON: docs/json.md).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "methods/settings_sweep.h"

namespace crosslink::app {

// One definition of a sweep: its path as given, its text and the text's FNV-1a 64-bit hash
// (16 hex digits), which a part carries so that merge refuses parts run on different contents.
struct DefinitionFile {
  std::string path;
  std::string text;
  std::string hash;
};

// The definitions named by `paths`, in order: a file as it is, a folder as every *.toml below
// it, sorted by path. Throws std::invalid_argument for a path that is neither, or a folder with
// none.
std::vector<DefinitionFile> definition_files(const std::vector<std::string>& paths);

// --shard I/N: shard I (0 to N - 1) of N, definitions whose index in the list is I modulo N.
struct Shard {
  int index = 0, count = 1;
  bool holds(size_t definition) const {
    return definition % static_cast<size_t>(count) == static_cast<size_t>(index);
  }
};
Shard parse_shard(const std::string& text);  // throws std::invalid_argument naming --shard

// What a part is: the run's shard, its settings (the options that change a row), every
// definition of the whole run (path, hash, text) and the sweeps of its own shard's definitions.
nlohmann::json sweep_document(const Shard& shard, const nlohmann::json& settings,
                              const std::vector<DefinitionFile>& definitions,
                              const std::vector<size_t>& swept,
                              const std::vector<methods::SettingsSweep>& sweeps);

// The outputs of a sweep of `definitions` (one: the page and CSV of a single definition; more:
// those of several, write_sweeps_html / write_sweeps_csv): console summary, --csv, --report,
// --json. `sweeps[k]` is the sweep of `definitions[swept[k]]`. Returns the exit code (1 when a
// pick found no setting).
struct SweepOutputs {
  std::string csv, report, json;
};
int write_sweep_outputs(const SweepOutputs& outputs, const methods::HtmlOptions& html,
                        const nlohmann::json& document,
                        const std::vector<DefinitionFile>& definitions,
                        const std::vector<size_t>& swept,
                        const std::vector<methods::SettingsSweep>& sweeps);

}  // namespace crosslink::app
