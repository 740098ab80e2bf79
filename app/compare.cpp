// `crosslink compare [FILE] [--engines LIST] [--report out.html] [--csv out.csv]
// [--json out.json] ...`: every method against the exact analytic sweep, with verdicts. Exit 0
// when every verdict passes, 1 when one fails, 2 on bad input. Without FILE it compares the
// bundled sewing machine. See docs/compare.md.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analytic/loader.h"
#include "app/commands.h"
#include "app/files.h"
#include "compare/comparison.h"
#include "compare/report.h"
#include "methods/engines.h"
#include "methods/jobs.h"
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

// The settings of `engine` among all --set KEY=VALUE and ENGINE:KEY=VALUE, in order.
sim::Settings settings_for(const std::string& engine, const std::vector<std::string>& all) {
  sim::Settings out;
  for (const std::string& s : all) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument(fmt::format("setting '{}': expected KEY=VALUE", s));
    std::string key = s.substr(0, eq);
    if (const size_t colon = key.find(':'); colon != std::string::npos) {
      if (key.substr(0, colon) != engine) continue;
      key = key.substr(colon + 1);
    }
    out.emplace_back(key, s.substr(eq + 1));
  }
  return out;
}

// Every --set before anything runs (bad input, exit 2): an ENGINE: prefix names an engine, and
// each engine takes what it would be given: a bare KEY=VALUE goes to every engine that runs,
// ENGINE:KEY=VALUE to that engine whether it runs or not.
void check_settings(const Mechanism& m, const std::vector<std::string>& all,
                    const std::vector<std::string>& runs) {
  const std::vector<std::string> engines = methods::engine_names();
  std::map<std::string, std::vector<std::string>> prefixed;
  for (const std::string& s : all) {
    (void)settings_for("", {s});  // KEY=VALUE
    const std::string key = s.substr(0, s.find('='));
    if (const size_t colon = key.find(':'); colon != std::string::npos) {
      const std::string engine = key.substr(0, colon);
      if (std::find(engines.begin(), engines.end(), engine) == engines.end())
        throw std::invalid_argument(fmt::format("--set {}: '{}' is not an engine (engines: {})", s,
                                                engine, fmt::join(engines, ", ")));
      prefixed[engine].push_back(s);
    }
  }
  for (const std::string& engine : engines) {
    const bool running = std::find(runs.begin(), runs.end(), engine) != runs.end();
    try {
      methods::check_engine_settings(engine, m,
                                     settings_for(engine, running ? all : prefixed[engine]));
    } catch (const std::invalid_argument& e) {
      // A name one engine knows (or only reports) may be meant for another engine alone.
      const std::string_view what = e.what();
      const bool bare =
          running &&
          (what.starts_with("unknown") || what.ends_with("is reported by the run, not set")) &&
          std::any_of(all.begin(), all.end(), [](const std::string& s) {
            return s.substr(0, s.find('=')).find(':') == std::string::npos;
          });
      throw std::invalid_argument(fmt::format(
          "--set: {}{}", e.what(),
          bare ? "; a bare KEY=VALUE goes to every engine that runs, ENGINE:KEY=VALUE to one"
               : ""));
    }
  }
}

// Each engine with a failing channel rerun at half its time step (its settings' dt), every
// engine at once: one failing channel's max % of peak there (compare::StepProbe).
std::vector<compare::StepProbe> probe_steps(const Mechanism& m, const compare::Comparison& cmp,
                                            const std::vector<std::string>& names,
                                            const std::vector<sim::Settings>& settings,
                                            const compare::Tolerances& tolerances, int jobs) {
  std::vector<compare::StepProbe> probes;
  std::vector<sim::Settings> halved;
  for (size_t k = 0; k < names.size(); ++k) {
    const compare::MethodRun* run = cmp.method(names[k]);
    if (!run || !run->ok || !methods::find_engine(names[k])) continue;
    // The failing channel of the least differentiated class, the largest there: a position's
    // difference shows the step's order where an acceleration's is noisy, or saturated once
    // the motions part (a chaotic one's).
    const auto rank = [](Quantity q) {
      return q == Quantity::position || q == Quantity::angle ? 0
             : q == Quantity::velocity                       ? 1
             : q == Quantity::acceleration                   ? 2
                                                             : 3;
    };
    compare::StepProbe probe;
    probe.method = names[k];
    int best = 4;
    for (const compare::ChannelResult& c : cmp.channels) {
      if (c.method != names[k] || c.verdict != compare::Verdict::fail) continue;
      const int r = rank(c.metrics.quantity);
      if (r < best || (r == best && c.metrics.max_pct_of_peak > probe.pct)) {
        best = r;
        probe.channel = c.metrics.channel;
        probe.pct = c.metrics.max_pct_of_peak;
      }
    }
    const auto dt = std::find_if(run->settings.begin(), run->settings.end(),
                                 [](const auto& kv) { return kv.first == "dt"; });
    if (probe.channel.empty() || dt == run->settings.end()) continue;  // passes, or no step
    probe.dt = std::stod(dt->second);
    probe.half_dt = probe.dt / 2.0;
    sim::Settings half = settings[k];
    std::erase_if(half, [](const auto& kv) { return kv.first == "dt"; });
    half.emplace_back("dt", fmt::format("{:.17g}", probe.half_dt));
    probes.push_back(std::move(probe));
    halved.push_back(std::move(half));
  }
  methods::run_jobs(jobs, probes.size(), [&](size_t k) {
    compare::StepProbe& probe = probes[k];
    compare::MethodRun run = methods::run_method(probe.method, m, cmp.reference(), halved[k]);
    if (!run.ok) {
      probe.message = run.message;
      return;
    }
    const compare::Comparison half =
        compare::compare_methods(m, {cmp.reference(), std::move(run)}, tolerances);
    for (const compare::ChannelResult& c : half.channels)
      if (c.metrics.channel == probe.channel && c.metrics.usable > 0) {
        probe.ok = true;
        probe.half_pct = c.metrics.max_pct_of_peak;
      }
    if (!probe.ok) probe.message = "no usable sample of " + probe.channel + " at half the step";
  });
  return probes;
}

int run_compare(CompareArgs args) {
  if (args.path.empty()) args.path = default_mechanism();
  const Mechanism m = load_mechanism(args.path);
  // A dynamics case ([dynamics]) is compared in time against its exact simulation.
  const bool dynamics = m.dynamics.has_value();
  if (dynamics && args.step != 0.0)
    throw std::invalid_argument(
        "--step: a dynamics case is sampled at its [dynamics] interval, not swept");

  // Methods: the reference first, then the others asked for, in the order given.
  std::vector<std::string> names = split(args.engines, ',');
  for (const std::string& n : names)
    if (std::find(methods::method_names().begin(), methods::method_names().end(), n) ==
        methods::method_names().end())
      throw std::invalid_argument(fmt::format("--engines: unknown method '{}' (valid: {})", n,
                                              fmt::join(methods::method_names(), ", ")));
  compare::Tolerances tolerances = methods::default_tolerances(m);
  const std::optional<double> accuracy = parse_accuracy(args.accuracy);
  if (accuracy)  // the accuracy asked for is the engines' tolerance; --tolerance still wins
    for (const char* q :
         {"position", "angle", "velocity", "acceleration", "force", "torque", "energy"})
      tolerances.apply(fmt::format("{}={:.17g}", q, *accuracy));
  for (const std::string& t : args.tolerances) {
    try {
      tolerances.apply(t);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("--tolerance: {}", e.what()));
    }
  }
  std::vector<std::string> given = names;  // what the settings go to: the export too
  if (!args.export_mjcf.empty()) given.push_back("mujoco");
  check_settings(m, args.settings, given);

  SweepOptions options;
  const double driver_scale = m.driver().angular() ? m.units.angle : m.units.length;
  if (args.step != 0.0) options.step = args.step * driver_scale;  // 0: the default
  if (!dynamics) check_sweep_work(m, options, args.limits);
  if (dynamics) check_simulation_work(m, {}, "", args.limits);
  check_reference_work(m, args.limits);
  // --at: a driver value in the file's units; with several drivers a time [s], as solve's.
  const double at_scale = m.several_drivers() ? 1.0 : driver_scale;
  if (args.at && !dynamics)  // the report draws the pose there (solve_at)
    check_solve_at_work(m, *args.at * at_scale, {}, args.limits);
  std::vector<compare::MethodRun> runs;
  runs.push_back(dynamics ? methods::run_simulation(m, {.max_solves = args.limits.max_solves})
                          : methods::run_reference(m, options));
  // An explicit time step is refused before any engine runs when it would take too many steps.
  const Trajectory& reference = runs.front().trajectory;
  const double span =
      reference.samples() > 1 ? reference.time(reference.samples() - 1) - reference.time(0) : 0.0;
  for (const std::string& n : names) {
    if (!methods::find_engine(n)) continue;
    const sim::Settings settings = with_max_steps(args.max_steps, settings_for(n, args.settings));
    std::optional<double> dt;
    long max_steps = args.max_steps;
    for (const auto& [key, value] : settings) {  // numbers: checked above
      if (key == "dt") dt = value == "auto" ? std::optional<double>() : std::stod(value);
      if (key == "max_steps") max_steps = std::stol(value);
    }
    if (dt) check_engine_steps(span, *dt, max_steps, fmt::format("--set dt={:g} ({})", *dt, n));
  }
  if (!args.export_mjcf.empty()) {
    // The scene MuJoCo runs, under the same step budget (--max-steps) as its run.
    const std::string mjcf =
        sim::mujoco_mjcf(m, runs.front().trajectory,
                         with_max_steps(args.max_steps, settings_for("mujoco", args.settings)));
    write_file(args.export_mjcf, mjcf);
  }
  // Each method's settings first (an --accuracy search runs engine by engine, its runs over the
  // threads, and says what it chose in order), then every method at once, each into its slot.
  std::vector<std::string> others;
  std::vector<sim::Settings> others_settings;
  for (const std::string& n : names) {
    if (n == "analytic") continue;
    sim::Settings settings = with_max_steps(args.max_steps, settings_for(n, args.settings));
    if (accuracy && methods::find_engine(n))
      settings = cheapest_settings(m, options, runs.front(), n, *accuracy, settings,
                                   args.json == "-" ? stderr : stdout, args.jobs);
    others.push_back(n);
    others_settings.push_back(std::move(settings));
  }
  const size_t first = runs.size();
  runs.resize(first + others.size());
  methods::run_jobs(args.jobs, others.size(), [&](size_t k) {
    runs[first + k] = methods::run_method(others[k], m, runs.front(), others_settings[k]);
  });

  compare::Comparison cmp = compare::compare_methods(m, std::move(runs), tolerances);
  cmp.step_probes = probe_steps(m, cmp, others, others_settings, tolerances, args.jobs);

  const bool json_stdout = args.json == "-";
  compare::print_console(cmp, json_stdout ? stderr : stdout, {.all = args.all});
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
    if (args.at) html.at = *args.at * at_scale;
    html.asset_dirs = installed_asset_dirs();
    if (args.step != 0.0) html.step = options.step;
    html.tolerances = args.tolerances;
    html.settings = args.settings;
    html.accuracy = accuracy;
    html.styles = methods::method_styles();
    std::ostringstream page;
    compare::write_html(cmp, html, page);
    write_file(args.report, page.str());
    fmt::print(json_stdout ? stderr : stdout, "report: {}\n", args.report);
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
