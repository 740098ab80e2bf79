// `crosslink compare [FILE] [--engines LIST] [--report out.html] [--csv out.csv]
// [--json out.json] ...`: every method against the exact analytic sweep, with verdicts. Exit 0
// when every verdict passes, 1 when one fails, 2 on bad input. Without FILE it compares the
// bundled sewing machine. See docs/compare.md.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analytic/model/loader.h"
#include "analytic/model/units_text.h"
#include "app/commands.h"
#include "app/files.h"
#include "app/options.h"
#include "compare/comparison.h"
#include "compare/report.h"
#include "methods/engines.h"
#include "methods/study.h"
#include "sim/mujoco/mujoco_engine.h"

namespace crosslink::app {
namespace {

namespace fs = std::filesystem;

struct CompareArgs {
  std::string path;
  std::string engines = fmt::format("{}", fmt::join(methods::method_names(), ","));
  std::string report, csv, json;
  std::string export_mjcf;  // write the MuJoCo scene (MJCF) it runs
  std::optional<double> at;
  double step = 0.0;
  std::vector<std::string> tolerances;  // "velocity=0.5", "dyads:velocity=1e-6"
  std::vector<std::string> settings;    // "dt=1e-4", "mujoco:dt=1e-4"
  std::string accuracy;                 // "1" or "1%": cheapest engine settings (sweep.cpp)
  bool all = false;
  int jobs = 1;
  WorkLimits limits;
  long max_steps = sim::kDefaultMaxSteps;
};

// The bundled sewing machine: relative to the current directory, else installed
// (<prefix>/share/crosslink/mechanisms), else in the source tree crosslink was built from.
std::string default_mechanism() {
  const fs::path relative = "mechanisms/sewing_machine.toml";
  if (fs::exists(relative)) return relative.string();
  if (const auto share = installed_share(); share && fs::exists(*share / relative))
    return (*share / relative).string();
  return (fs::path(CROSSLINK_SOURCE_DIR) / relative).string();
}

int run_compare(CompareArgs args) {
  if (args.path.empty()) args.path = default_mechanism();
  const Mechanism m = load_mechanism(args.path);
  // The options in SI: a step or --at in the file's units along the sweep's axis (a time [s] with
  // several drivers).
  const double axis_scale = axis_unit_of(m).scale;
  methods::CompareOptions options;
  options.methods = split(args.engines, ',');
  options.tolerances = args.tolerances;
  options.settings = args.settings;
  options.accuracy_pct = parse_accuracy(args.accuracy);
  options.step = args.step * axis_scale;  // 0: the default
  if (args.at) options.at = *args.at * axis_scale;
  options.limits = args.limits;
  options.max_steps = args.max_steps;
  options.jobs = args.jobs;
  const bool json_stdout = args.json == "-";
  std::FILE* const console = json_stdout ? stderr : stdout;
  ProgressLines lines;
  options.progress = lines.progress();
  options.chose = [&](const methods::Selection& s) {
    lines.finish();
    fmt::print(console, "{}\n", s.summary());
  };
  if (!args.export_mjcf.empty()) {  // the settings go to MuJoCo's scene too
    std::vector<std::string> given = options.methods;
    given.push_back("mujoco");
    methods::check_setting_texts(m, options.settings, given);
  }

  const compare::Comparison cmp = methods::run_compare(m, options);
  if (!args.export_mjcf.empty())  // the scene MuJoCo runs, under the same step budget
    write_file(args.export_mjcf,
               sim::mujoco_mjcf(m, cmp.reference().trajectory,
                                methods::engine_settings("mujoco", args.settings, args.max_steps)));

  compare::print_console(cmp, console, {.all = args.all});
  if (!args.json.empty()) {
    const std::string text = compare::to_json(cmp).dump(2) + "\n";
    if (json_stdout)
      fmt::print("{}", text);
    else
      write_file(args.json, text);
  }
  if (!args.csv.empty()) {
    std::ostringstream csv;
    compare::write_csv(cmp, csv);
    write_file(args.csv, csv.str());
  }
  if (!args.report.empty()) {
    compare::HtmlOptions html;
    html.drawing = methods::drawing(m, options.at);
    html.asset_dirs = installed_asset_dirs();
    if (args.step != 0.0) html.step = options.step;
    html.tolerances = args.tolerances;
    html.settings = args.settings;
    html.accuracy = options.accuracy_pct;
    html.styles = methods::method_styles();
    std::ostringstream page;
    compare::write_html(cmp, html, page);
    write_file(args.report, page.str());
    fmt::print(console, "report: {}\n", args.report);
  }
  // Nothing compared is no PASS: the command asked for no comparison (docs/compare.md).
  if (cmp.nothing_compared()) return kExitBadInput;
  return cmp.pass() ? kExitOk : kExitFail;
}

}  // namespace

void add_compare(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand(
      "compare", "Compare every method against the exact sweep: verdicts, reports, exit code");
  auto args = std::make_shared<CompareArgs>();
  cmd->add_option("FILE", args->path,
                  "mechanism definition (.toml); default: the bundled sewing machine");
  cmd->add_option(
         "--engines", args->engines,
         "methods, comma-separated: " + fmt::format("{}", fmt::join(methods::method_names(), ",")))
      ->capture_default_str();
  cmd->add_option("--report", args->report, "write a self-contained HTML report");
  cmd->add_option("--csv", args->csv, "write every sample of every comparison as CSV (SI)");
  cmd->add_option("--json", args->json, "write the JSON document (SI; '-' for stdout)");
  cmd->add_option("--at", args->at,
                  "driver value of the report's drawing, in the file's units (default: start); "
                  "with several drivers a time [s] (default: 0)")
      ->check(number_in());
  cmd->add_option("--step", args->step, "sweep step in the file's units (default 1 degree)")
      ->check(positive_number());
  cmd->add_option("--tolerance", args->tolerances,
                  "CLASS=PERCENT for the engines, or METHOD:CLASS=PERCENT (repeatable); classes: "
                  "position, angle, velocity, acceleration, force, torque, energy");
  cmd->add_option("--set", args->settings,
                  "engine setting KEY=VALUE, or ENGINE:KEY=VALUE (repeatable), e.g. dt=1e-4");
  cmd->add_option("--accuracy", args->accuracy,
                  "X or X%: run each engine at its cheapest setting meeting X % of peak on every "
                  "class (searched coarse to fine, docs/sweep.md); X becomes the engines' "
                  "tolerance");
  cmd->add_option("--export-mjcf", args->export_mjcf,
                  "write the MuJoCo scene (MJCF) that runs alone in MuJoCo's own viewer: it starts "
                  "at the definition's start and a clock turns the driver");
  cmd->add_flag("--all", args->all, "list every channel and method instead of the summary");
  add_max_samples(*cmd, args->limits);
  add_max_solves(*cmd, args->limits);
  add_max_steps(*cmd, args->max_steps);
  add_jobs(*cmd, args->jobs);
  cmd->callback([&run, args] { run = [args] { return run_compare(*args); }; });
}

}  // namespace crosslink::app
