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
#include <filesystem>
#include <fstream>
#include <sstream>

#include "analytic/model/limits.h"
#include "analytic/model/loader.h"
#include "analytic/model/units_text.h"
#include "app/commands.h"
#include "app/files.h"
#include "app/sweep_parts.h"
#include "methods/settings_sweep.h"
#include "methods/study.h"

namespace crosslink::app {

std::optional<double> parse_accuracy(const std::string& text) {
  if (text.empty()) return std::nullopt;
  std::string number = text;
  if (number.back() == '%') number.pop_back();
  size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(number, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  // It becomes the engines' tolerance: the same limit.
  if (used == 0 || used != number.size() || !(value > 0.0) || !(value <= limits::kTolerance))
    throw std::invalid_argument(
        fmt::format("--accuracy: expected a positive percentage of peak up to {:g} such as 1 or "
                    "0.5%, got '{}'",
                    limits::kTolerance, text));
  return value;
}

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

namespace {

namespace fs = std::filesystem;

// The grid's size multiplies the work: bounded like every other input.
constexpr size_t kMaxTimeSteps = 50;

// The options that change a row: a part records them and merge refuses parts whose differ.
nlohmann::json sweep_settings(const SweepArgs& args) {
  nlohmann::json j;
  j["engines"] = split(args.engines);
  j["dt"] = args.dts.empty() ? methods::default_time_steps() : args.dts;
  j["step"] = args.step;
  j["repeat"] = args.repeat;
  j["accuracy"] = args.accuracy;
  j["max_steps"] = args.max_steps;
  j["max_samples"] = args.limits.max_samples;
  return j;
}

// One definition's sweep options, checked. `several`: one of many, where --step applies to the
// kinematic cases and a dynamics case keeps its interval.
methods::SettingsSweepOptions sweep_options(const Mechanism& m, const SweepArgs& args,
                                            bool several) {
  // A dynamics case: against its exact simulation, over its duration (docs/sweep.md).
  const bool dynamics = m.dynamics.has_value();
  if (dynamics && args.step != 0.0 && !several)
    throw std::invalid_argument(
        "--step: a dynamics case is sampled at its [dynamics] interval, not swept");
  methods::SettingsSweepOptions options;
  options.engines = split(args.engines);
  for (const std::string& e : options.engines)
    if (!methods::find_engine(e))
      throw std::invalid_argument(
          fmt::format("--engines: '{}' has no settings to sweep (engines: {})", e,
                      fmt::join(methods::engine_names(), ", ")));
  if (!args.dts.empty()) options.dts = args.dts;
  if (options.dts.size() > kMaxTimeSteps)
    throw std::invalid_argument(
        fmt::format("--dt: {} time steps: the limit is {}", options.dts.size(), kMaxTimeSteps));
  for (double dt : options.dts) {
    // The reference covers at most one cycle (a dynamics case: its duration); the defaults are
    // left to the engines' own check.
    const double span = dynamics ? m.dynamics->duration : m.cycle_period();
    if (!args.dts.empty() && span > 0.0)
      methods::check_time_step(span, dt, args.max_steps, fmt::format("--dt {:g}", dt));
  }
  if (args.step != 0.0 && !dynamics)  // 0: the default
    options.sweep.step = args.step * axis_unit_of(m).scale;
  if (!dynamics) check_sweep_work(m, options.sweep, args.limits);
  options.base = {{"max_steps", std::to_string(args.max_steps)}};
  options.repeat = args.repeat;
  options.jobs = args.jobs;
  options.accuracy_pct = parse_accuracy(args.accuracy);
  return options;
}

}  // namespace

int run_sweep(const SweepArgs& args) {
  const Shard shard = parse_shard(args.shard);
  const bool from_stdin =
      std::find(args.paths.begin(), args.paths.end(), std::string("-")) != args.paths.end();
  if (from_stdin && (args.paths.size() > 1 || !args.json.empty() || !args.shard.empty()))
    throw std::invalid_argument(
        "a definition from standard input ('-') is swept alone, without --json or --shard (a "
        "part names its definitions' files)");
  // Standard input is read by the loader alone.
  const std::vector<DefinitionFile> definitions =
      from_stdin ? std::vector<DefinitionFile>{{"-", "", ""}} : definition_files(args.paths);
  const bool several = definitions.size() > 1;
  std::vector<size_t> swept;
  for (size_t k = 0; k < definitions.size(); ++k)
    if (shard.holds(k)) swept.push_back(k);
  // Every definition of the shard is read and its options checked before any runs.
  std::vector<Mechanism> mechanisms;
  mechanisms.reserve(swept.size());
  std::vector<methods::SettingsSweepOptions> options;
  for (size_t k : swept) {
    mechanisms.push_back(load_mechanism(definitions[k].path));
    options.push_back(sweep_options(mechanisms.back(), args, several));
  }

  // Fail on an unwritable report before the long part.
  compare::HtmlOptions html;
  html.asset_dirs = installed_asset_dirs();
  if (!args.report.empty()) {
    std::string searched;
    if (!compare::find_report_assets(html.asset_dirs, &searched))
      throw std::invalid_argument(fmt::format(
          "--report: the chart scripts are missing (looked in {}); run scripts/setup.sh",
          searched));
  }

  std::vector<methods::SettingsSweep> sweeps;
  for (size_t i = 0; i < swept.size(); ++i) {
    if (several && !args.quiet)
      fmt::print(stderr, "definition {} of {}: {}\n", swept[i] + 1, definitions.size(),
                 definitions[swept[i]].path);
    ProgressLines lines;
    if (!args.quiet) options[i].progress = lines.progress();
    sweeps.push_back(methods::run_settings_sweep(mechanisms[i], options[i]));
    lines.finish();
  }
  const nlohmann::json document =
      sweep_document(shard, sweep_settings(args), definitions, swept, sweeps);
  return write_sweep_outputs({args.csv, args.report, args.json}, html, document, definitions, swept,
                             sweeps);
}

}  // namespace crosslink::app
