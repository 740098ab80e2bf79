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
#include "compare/comparison.h"
#include "compare/report.h"
#include "methods/engines.h"
#include "methods/study.h"
#include "methods/sweep_parts.h"
#include "sim/mujoco/mujoco_engine.h"

namespace crosslink::app {
namespace {

namespace fs = std::filesystem;

// The bundled sewing machine: relative to the current directory, else installed
// (<prefix>/share/crosslink/mechanisms), else in the source tree crosslink was built from.
std::string default_mechanism() {
  const fs::path relative = "mechanisms/sewing_machine.toml";
  if (fs::exists(relative)) return relative.string();
  if (const auto share = installed_share(); share && fs::exists(*share / relative))
    return (*share / relative).string();
  return (fs::path(CROSSLINK_SOURCE_DIR) / relative).string();
}

}  // namespace

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
  options.accuracy_pct = methods::parse_accuracy(args.accuracy);
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

}  // namespace crosslink::app
