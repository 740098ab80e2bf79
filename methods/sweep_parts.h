// A settings sweep over several definitions, split into shards, and the parts a merge joins
// (docs/sweep.md, "Many definitions, shards and merge"; the JSON: docs/json.md). `crosslink sweep`
// and `crosslink merge` print and write what these return; the Python module calls the same, so a
// part is the same document whichever front end (or Dask task, or Slurm array task) wrote it.
#pragma once

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "analytic/reference/budget.h"
#include "methods/settings_sweep.h"

namespace crosslink::methods {

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

// Shard I (0 to N - 1) of N: the definitions whose index in the list is I modulo N.
struct Shard {
  int index = 0, count = 1;
  bool holds(size_t definition) const {
    return definition % static_cast<size_t>(count) == static_cast<size_t>(index);
  }
};
Shard parse_shard(const std::string& text);  // "I/N"; throws std::invalid_argument naming --shard

// "X" or "X%" in % of peak (nullopt for empty text; throws std::invalid_argument naming
// --accuracy otherwise): compare's and sweep's --accuracy.
std::optional<double> parse_accuracy(const std::string& text);

// The options of a sweep, as the command line gives them: each changes a row, so a part records
// them (sweep_settings) and merge refuses parts whose differ.
struct SweepRun {
  std::vector<std::string> engines = engine_names();
  std::vector<double> dts;  // empty: default_time_steps()
  double step = 0.0;        // in each definition's units along its sweep; 0: the default
  int repeat = 3;
  std::string accuracy;  // "" or --accuracy's text
  long max_steps = sim::kDefaultMaxSteps;
  WorkLimits limits;
  int jobs = 1;
};
nlohmann::json sweep_settings(const SweepRun& run);

// A shard's sweeps, in two steps: prepare_shard reads every definition it holds and checks its
// options, before any runs (a caller checks its own outputs between); sweep_shard then sweeps
// them in order, `starting(k, options)` before definition k's (to print its name, set its
// progress), `finished()` after each. The sweeps point into `mechanisms`, which moves with them.
struct ShardSweeps {
  std::vector<Mechanism> mechanisms;
  std::vector<size_t> swept;                  // the definitions' indices
  std::vector<SettingsSweepOptions> options;  // per swept definition (none merged)
  std::vector<SettingsSweep> sweeps;
};
ShardSweeps prepare_shard(const std::vector<DefinitionFile>& definitions, const Shard& shard,
                          const SweepRun& run);
void sweep_shard(ShardSweeps& shard,
                 const std::function<void(size_t, SettingsSweepOptions&)>& starting = {},
                 const std::function<void()>& finished = {});

// What a part is: the run's shard, its settings, every definition of the whole run (path, hash,
// text) and the sweeps of its own shard's definitions.
nlohmann::json sweep_document(const Shard& shard, const nlohmann::json& settings,
                              const std::vector<DefinitionFile>& definitions,
                              const std::vector<size_t>& swept,
                              const std::vector<SettingsSweep>& sweeps);

// The parts of one sweep, each (its name for messages, its document), joined: the checks that
// they fit together (the same crosslink version, settings and definitions, each hash against its
// text, every shard of N exactly once), then every definition's sweep from its shard's part.
// Throws std::invalid_argument naming the part at fault.
struct MergedSweep {
  std::vector<DefinitionFile> definitions;
  ShardSweeps shards;       // every definition's, in order
  nlohmann::json document;  // the one-shard document a single run writes
};
MergedSweep merge_parts(const std::vector<std::pair<std::string, nlohmann::json>>& parts);

// A part read from a file or text, checked to be one (every field merge reads).
nlohmann::json read_part(const std::string& path);
nlohmann::json part_of(const nlohmann::json& document, const std::string& name);

}  // namespace crosslink::methods
