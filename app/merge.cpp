// `crosslink merge PART... [--csv OUT] [--report OUT.html] [--json OUT]`: joins the JSON parts of a
// sweep split into shards (`crosslink sweep ... --shard I/N --json PART`) into the outputs a
// single run over every definition writes, after checking that the parts fit together: the same
// crosslink version, settings and definitions (path and hash of each), and every shard of N
// exactly once (methods::merge_parts). Exit 0; 1 when a pick found no setting; 2 on parts that do
// not fit. Also the outputs `sweep` shares with it (app/sweep_parts.h). See docs/sweep.md.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <sstream>

#include "app/commands.h"
#include "app/files.h"
#include "app/sweep_parts.h"
#include "methods/engines.h"
#include "methods/sweep_json.h"

namespace crosslink::app {

int write_sweep_outputs(const SweepOutputs& outputs, const methods::HtmlOptions& html,
                        const nlohmann::json& document,
                        const std::vector<methods::DefinitionFile>& definitions,
                        const std::vector<size_t>& swept,
                        const std::vector<methods::SettingsSweep>& sweeps) {
  const bool several = definitions.size() > 1;
  std::vector<methods::SweptDefinition> set;
  for (size_t i = 0; i < sweeps.size(); ++i) {
    if (i > 0) fmt::print("\n");
    if (several) fmt::print("{}\n", definitions[swept[i]].path);
    methods::print_sweep(sweeps[i], stdout);
    set.push_back({definitions[swept[i]].path, &sweeps[i]});
  }
  // One definition: its own CSV and page, as a sweep of one file has always written them.
  if (!outputs.csv.empty()) {
    std::ostringstream text;
    if (several)
      methods::write_sweeps_csv(set, text);
    else if (!sweeps.empty())
      methods::write_sweep_csv(sweeps.front(), text);
    write_file(outputs.csv, text.str());
    fmt::print("csv: {}\n", outputs.csv);
  }
  if (!outputs.report.empty()) {
    std::ostringstream page;
    if (several)
      methods::write_sweeps_html(set, html, page);
    else if (!sweeps.empty())
      methods::write_sweep_html(sweeps.front(), html, page);
    write_file(outputs.report, page.str());
    fmt::print("report: {}\n", outputs.report);
  }
  if (!outputs.json.empty()) {
    write_file(outputs.json, document.dump(1) + "\n");
    fmt::print("json: {}\n", outputs.json);
  }
  for (const methods::SettingsSweep& sweep : sweeps)
    for (const methods::Selection& s : sweep.selections)
      if (!s.found) return kExitFail;
  return kExitOk;
}

int run_merge(const MergeArgs& args) {
  std::vector<std::pair<std::string, nlohmann::json>> parts;
  for (const std::string& path : args.parts) parts.emplace_back(path, methods::read_part(path));
  const methods::MergedSweep merged = methods::merge_parts(parts);
  compare::HtmlOptions html;
  html.asset_dirs = installed_asset_dirs();
  return write_sweep_outputs({args.csv, args.report, args.json}, html, merged.document,
                             merged.definitions, merged.shards.swept, merged.shards.sweeps);
}

}  // namespace crosslink::app
