// `crosslink sweep FILE [--engines mujoco,bullet] [--dt LIST] [--report out.html]
// [--csv out.csv] [--accuracy X%] [--repeat N]`: speed against accuracy. Every engine over a grid
// of its settings against the exact sweep (a dynamics case: the exact simulation), with the CPU
// cost per cycle (median of --repeat runs), the max % of peak per quantity class (a dynamics
// case: also at the end of the run, and of the energy), the loop gap, the status, the Pareto
// front and the observed order of convergence in dt. Exit 0; 1 when --accuracy finds no setting
// for an engine; 2 on bad input. See docs/sweep.md.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <optional>

#include "app/commands.h"
#include "app/files.h"
#include "app/sweep_parts.h"
#include "methods/settings_sweep.h"
#include "methods/study.h"
#include "methods/sweep_parts.h"

namespace crosslink::app {

ProgressLines::ProgressLines() : ProgressLines(stderr, ::isatty(::fileno(stderr)) != 0) {}

ProgressLines::ProgressLines(std::FILE* out, bool terminal) : out_(out), terminal_(terminal) {}

methods::Progress ProgressLines::progress() {
  return
      [this](int index, int total, const methods::GridPoint& point) { run(index, total, point); };
}

void ProgressLines::run(int index, int total, const methods::GridPoint& point) {
  if (terminal_) {
    // Back to the line's start, the new text, the rest of the old one cleared.
    fmt::print(out_, "\r[{}/{}] {} dt={:.3g} {} ...\033[K", index, total, point.engine, point.dt,
               point.variant);
    std::fflush(out_);
    rewritten_ = true;
    return;
  }
  // The grid runs time step by time step, every variant of an engine at each: a series ends with
  // its engine's grid (or timing round), seen when another engine starts or a series it holds
  // comes back to a time step it has run.
  const auto same = [&](const Series& s) {
    return s.engine == point.engine && s.variant == point.variant;
  };
  const auto it = std::find_if(open_.begin(), open_.end(), same);
  if (!open_.empty() &&
      (open_.front().engine != point.engine ||
       (it != open_.end() && std::find(it->dts.begin(), it->dts.end(), point.dt) != it->dts.end())))
    finish();
  auto series = std::find_if(open_.begin(), open_.end(), same);
  if (series == open_.end())
    series = open_.insert(open_.end(), {point.engine, point.variant, {}, 0, 0});
  series->dts.push_back(point.dt);
  series->index = index;
  series->total = total;
}

void ProgressLines::finish() {
  if (rewritten_) fmt::print(out_, "\n");
  rewritten_ = false;
  // In the order they finished (a series whose first time step diverged starts late).
  std::sort(open_.begin(), open_.end(),
            [](const Series& a, const Series& b) { return a.index < b.index; });
  for (const Series& s : open_)
    fmt::print(out_, "[{}/{}] {} {}: {} run{}, dt {:.3g} to {:.3g} s\n", s.index, s.total, s.engine,
               s.variant, s.dts.size(), s.dts.size() == 1 ? "" : "s",
               *std::max_element(s.dts.begin(), s.dts.end()),
               *std::min_element(s.dts.begin(), s.dts.end()));
  open_.clear();
  std::fflush(out_);
}

int run_sweep(const SweepArgs& args) {
  const methods::Shard shard = methods::parse_shard(args.shard);
  const bool from_stdin =
      std::find(args.paths.begin(), args.paths.end(), std::string("-")) != args.paths.end();
  if (from_stdin && (args.paths.size() > 1 || !args.json.empty() || !args.shard.empty()))
    throw std::invalid_argument(
        "a definition from standard input ('-') is swept alone, without --json or --shard (a "
        "part names its definitions' files)");
  // Standard input is read by the loader alone.
  const std::vector<methods::DefinitionFile> definitions =
      from_stdin ? std::vector<methods::DefinitionFile>{{"-", "", ""}}
                 : methods::definition_files(args.paths);
  const methods::SweepRun run{.engines = split(args.engines),
                              .dts = args.dts,
                              .step = args.step,
                              .repeat = args.repeat,
                              .accuracy = args.accuracy,
                              .max_steps = args.max_steps,
                              .limits = args.limits,
                              .jobs = args.jobs};

  // Every definition of the shard is read and its options checked before any runs; then an
  // unwritable report fails before the long part.
  methods::ShardSweeps swept = methods::prepare_shard(definitions, shard, run);
  compare::HtmlOptions html;
  html.asset_dirs = installed_asset_dirs();
  if (!args.report.empty()) {
    std::string searched;
    if (!compare::find_report_assets(html.asset_dirs, &searched))
      throw std::invalid_argument(fmt::format(
          "--report: the chart scripts are missing (looked in {}); run scripts/setup.sh",
          searched));
  }
  std::optional<ProgressLines> lines;
  methods::sweep_shard(
      swept,
      [&](size_t k, methods::SettingsSweepOptions& options) {
        if (definitions.size() > 1 && !args.quiet)
          fmt::print(stderr, "definition {} of {}: {}\n", k + 1, definitions.size(),
                     definitions[k].path);
        lines.emplace();
        if (!args.quiet) options.progress = lines->progress();
      },
      [&] { lines->finish(); });
  const nlohmann::json document = methods::sweep_document(shard, methods::sweep_settings(run),
                                                          definitions, swept.swept, swept.sweeps);
  return write_sweep_outputs({args.csv, args.report, args.json}, html, document, definitions,
                             swept.swept, swept.sweeps);
}

}  // namespace crosslink::app
