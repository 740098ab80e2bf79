// The command line's grammar: every subcommand's options and the options they share, parsed by
// CLI11 in this one file (the header costs seconds of compile time in each file that includes
// it), into the arguments the subcommands run on (app/commands.h).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <new>
#include <string>

#include "analytic/model/limits.h"
#include "analytic/model/mechanism.h"
#include "app/commands.h"
#include "methods/engines.h"
#include "methods/jobs.h"

namespace crosslink::app {
namespace {

// The check of a numeric option: a finite number from `low` (excluded when `low_open`) to
// `high`; NaN, infinities and values out of range are refused before any work (exit 2), the
// message naming the option.
CLI::Validator number_in(double low = -std::numeric_limits<double>::max(),
                         double high = std::numeric_limits<double>::max(), bool low_open = false) {
  constexpr double kLargest = std::numeric_limits<double>::max();
  std::string range = fmt::format("a number in {}{:g}, {:g}]", low_open ? '(' : '[', low, high);
  if (low == -kLargest && high == kLargest) range = "a finite number";
  if (low == 0.0 && high == kLargest) range = low_open ? "a positive number" : "0 or more";
  return CLI::Validator(
      [=](std::string& text) -> std::string {
        double value = 0.0;
        // NaN fails every comparison, so it passes CLI::Range: refused here, with infinities.
        if (!CLI::detail::lexical_cast(text, value) || !std::isfinite(value) ||
            !(low_open ? value > low : value >= low) || !(value <= high))
          return fmt::format("{} is not {}", text, range);
        return {};
      },
      range);
}

// The limits on a command's work: --max-samples on every command, --max-solves on those that
// simulate a dynamics case, --max-steps on those that run engines (analytic/reference/budget.h
// for the exact solver, sim/engine.h for the engines).
void add_max_samples(CLI::App& cmd, WorkLimits& limits) {
  cmd.add_option("--max-samples", limits.max_samples,
                 "the most samples, and continuation steps, of one exact sweep or solve; more "
                 "is refused before any work")
      ->check(number_in(1.0, 1e18))
      ->capture_default_str();
}

void add_max_solves(CLI::App& cmd, WorkLimits& limits) {
  cmd.add_option("--max-solves", limits.max_solves,
                 "the most pose solves of one exact simulation (a dynamics case); a run that "
                 "reaches it stops there, its remaining samples not_reached")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
}

void add_max_steps(CLI::App& cmd, long& max_steps) {
  cmd.add_option("--max-steps", max_steps,
                 "the most steps of one engine run; a run that would take more is refused before "
                 "it starts")
      ->check(number_in(1.0, 1e18))
      ->capture_default_str();
}

// --jobs N: the threads of a compare or sweep (methods/jobs.h), set to the machine's cores.
void add_jobs(CLI::App& cmd, int& jobs) {
  jobs = methods::default_jobs();
  cmd.add_option("--jobs", jobs,
                 "threads the runs share (default: the machine's cores); results are the same "
                 "for every N, 1 runs them in turn")
      ->check(CLI::Range(1, methods::kMaxJobs));
}

// A positive step, time or time step.
CLI::Validator positive_number() {
  return number_in(0.0, std::numeric_limits<double>::max(), true);
}

// Each registers its subcommand on `app` and sets `run` to its action.
void add_check(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand("check", "Validate a mechanism definition and report on it");
  auto path = std::make_shared<std::string>();
  auto limits = std::make_shared<WorkLimits>();
  cmd->add_option("FILE", *path, "mechanism definition (.toml)")->required();
  add_max_samples(*cmd, *limits);
  cmd->callback(
      [&run, path, limits] { run = [path, limits] { return run_check(*path, *limits); }; });
}

void add_solve(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand("solve", "Exact kinematics at one driver value or over a sweep");
  auto args = std::make_shared<SolveArgs>();
  cmd->add_option("FILE", args->path, "mechanism definition (.toml)")->required();
  cmd->add_option("--at", args->at, "driver value, in the file's units (default: whole sweep)")
      ->check(number_in());
  cmd->add_option("--step", args->step, "sweep step in the file's units (default 1 degree)")
      ->check(positive_number());
  cmd->add_option("--format", args->format, "output format")
      ->check(CLI::IsMember({"table", "json", "csv"}));
  cmd->add_option("--method", args->method,
                  "dyads (closed form), newton, or auto (dyads when the chain decomposes)")
      ->check(CLI::IsMember({"dyads", "newton", "auto"}));
  cmd->add_option("--at-limit", args->at_limit,
                  "at a limit of the assembling range (a toggle): stop, or reverse the driver "
                  "as a real rocker would and follow the loop back on the other assembly mode")
      ->check(CLI::IsMember({"stop", "reverse"}));
  cmd->add_option("--columns", args->columns,
                  "the sweep table's columns, comma-separated: channel names (x.C, sddot.needle) "
                  "and kinds (alpha: every link's); default "
                  "angle,omega,alpha,s,sdot,sddot,jerk,angular_jerk but for the "
                  "driven crank and links held by a prismatic joint to the ground");
  cmd->add_option("--svg", args->svg,
                  "write the drawing as SVG: the links at --at (or the sweep's start), the "
                  "paths of the moving points over the sweep");
  cmd->add_option("--animate", args->animate,
                  "with --svg: animate the drawing over the sweep, SECONDS per sweep (SMIL)");
  cmd->add_flag("--ic", args->ic,
                "with --at: instantaneous centres (Kennedy–Aronhold) and their velocities");
  add_max_samples(*cmd, args->limits);
  cmd->callback([&run, args] { run = [args] { return run_solve(*args); }; });
}

void add_simulate(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand(
      "simulate",
      "Exact forward dynamics of a dynamics case ([dynamics]), with its energy balance");
  auto args = std::make_shared<SimulateArgs>();
  cmd->add_option("FILE", args->path, "mechanism definition (.toml) with a [dynamics] table")
      ->required();
  cmd->add_option("--duration", args->duration, "simulated time [s] (default: the case's)")
      ->check(number_in(0.0, limits::kDuration, true));
  cmd->add_option("--at", args->at, "the state at this time [s] only")
      ->check(number_in(0.0, limits::kDuration));
  cmd->add_option("--format", args->format, "output format")
      ->check(CLI::IsMember({"table", "json", "csv"}));
  cmd->add_option("--integrator", args->integrator,
                  "rkf78 (Runge-Kutta-Fehlberg 7(8), the default) or dopri5 (Dormand-Prince "
                  "5(4), dense output): two independent integrations")
      ->check(CLI::IsMember({"rkf78", "dopri5"}));
  cmd->add_option("--tolerance", args->tolerance,
                  "absolute and relative error per step (default 1e-13)")
      ->check(number_in(1e-15, 1e-2));
  cmd->get_option("--duration")->excludes(cmd->get_option("--at"));
  add_max_samples(*cmd, args->limits);
  add_max_solves(*cmd, args->limits);
  cmd->callback([&run, args] { run = [args] { return run_simulate(*args); }; });
}

void add_compare(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand(
      "compare", "Compare every method against the exact sweep: verdicts, reports, exit code");
  auto args = std::make_shared<CompareArgs>();
  args->engines = fmt::format("{}", fmt::join(methods::method_names(), ","));
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

void add_sweep(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand(
      "sweep", "Speed against accuracy: every engine over a grid of its settings");
  auto args = std::make_shared<SweepArgs>();
  args->engines = fmt::format("{}", fmt::join(methods::engine_names(), ","));
  cmd->add_option("FILE", args->paths,
                  "mechanism definitions (.toml), or folders of them (every *.toml below)")
      ->required();
  cmd->add_option(
         "--engines", args->engines,
         "engines, comma-separated: " + fmt::format("{}", fmt::join(methods::engine_names(), ",")))
      ->capture_default_str();
  std::string defaults;
  for (double dt : methods::default_time_steps())
    defaults += fmt::format("{}{:g}", defaults.empty() ? "" : ",", dt);
  cmd->add_option("--dt", args->dts,
                  "time steps [s], comma-separated (default " + defaults +
                      "); each is snapped so samples fall on step boundaries")
      ->delimiter(',')
      ->check(positive_number());
  cmd->add_option("--report", args->report, "write a self-contained HTML report");
  cmd->add_option("--csv", args->csv, "write one row per engine setting as CSV (SI)");
  cmd->add_option("--json", args->json,
                  "write the sweep as JSON: the part `crosslink merge` joins (docs/json.md)");
  cmd->add_option("--shard", args->shard,
                  "I/N: sweep only shard I (0 to N-1) of N, the definitions whose index is I "
                  "modulo N; its --json is a part for `crosslink merge`");
  cmd->add_option("--accuracy", args->accuracy,
                  "X or X%: the cheapest setting per engine meeting X % of peak on every class");
  cmd->add_option("--step", args->step, "reference sweep step in the file's units (default 1 deg)")
      ->check(positive_number());
  cmd->add_option("--repeat", args->repeat,
                  "time each setting N times, the cost is the median (the errors do not change)")
      ->check(CLI::Range(1, kMaxRepeat))
      ->capture_default_str();
  cmd->add_flag("--quiet", args->quiet, "no progress lines on stderr");
  add_max_samples(*cmd, args->limits);
  add_max_steps(*cmd, args->max_steps);
  add_jobs(*cmd, args->jobs);
  cmd->callback([&run, args] { run = [args] { return run_sweep(*args); }; });
}

void add_merge(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand(
      "merge", "Join the JSON parts of a sweep split into shards into one run's outputs");
  auto args = std::make_shared<MergeArgs>();
  cmd->add_option("PART", args->parts, "the parts: `crosslink sweep ... --shard I/N --json PART`")
      ->required();
  cmd->add_option("--csv", args->csv, "write the CSV a single run writes");
  cmd->add_option("--report", args->report, "write the HTML report a single run writes");
  cmd->add_option("--json", args->json, "write the JSON a single run writes (shard 0/1)");
  cmd->callback([&run, args] { run = [args] { return run_merge(*args); }; });
}

// `crosslink engines [--markdown]`: every engine of the engine table (methods/engines.h) with
// each setting it takes through --set: its default, the values it takes and what it does.
void add_engines(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand(
      "engines", "List every engine and its settings (--set ENGINE:KEY=VALUE): default, values");
  auto markdown = std::make_shared<bool>(false);
  cmd->add_flag("--markdown", *markdown, "as Markdown tables (docs/engines.md, \"Settings\")");
  cmd->callback([&run, markdown] {
    run = [markdown] {
      fmt::print("{}", methods::engines_listing(*markdown));
      return 0;
    };
  });
}

void add_new(CLI::App& app, std::function<int()>& run) {
  auto* cmd = app.add_subcommand(
      "new", "Write a commented starting definition to edit: fourbar, slider-crank or five-bar");
  auto kind = std::make_shared<std::string>();
  auto file = std::make_shared<std::string>();
  cmd->add_option("KIND", *kind, "fourbar | slider-crank | five-bar")
      ->required()
      ->check(CLI::IsMember({"fourbar", "slider-crank", "five-bar"}));
  cmd->add_option("FILE", *file, "where to write it (default: KIND.toml); never overwritten");
  cmd->callback([&run, kind, file] { run = [kind, file] { return run_new(*kind, *file); }; });
}

}  // namespace

int run_command_line(int argc, char** argv) {
  CLI::App app{
      "crosslink: exact kinematics of planar linkages, cross-validated against physics "
      "engines"};
  app.set_version_flag("--version", std::string("crosslink ") + CROSSLINK_VERSION);
  app.require_subcommand(1);
  std::function<int()> run;
  add_check(app, run);
  add_solve(app, run);
  add_simulate(app, run);
  add_compare(app, run);
  add_sweep(app, run);
  add_merge(app, run);
  add_engines(app, run);
  add_new(app, run);
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitBadInput;
  }
  try {
    return run();
  } catch (const DefinitionError& e) {
    fmt::print(stderr, "{}\n", e.what());
    return kExitBadInput;
  } catch (const std::bad_alloc&) {
    // Written without allocating: there may be no memory left for a formatted message.
    std::fputs(
        "crosslink: error: out of memory: the command asked for more than this machine gives "
        "(fewer samples: --max-samples, --step; docs/robustness.md)\n",
        stderr);
    return kExitBadInput;
  } catch (const std::exception& e) {
    fmt::print(stderr, "crosslink: error: {}\n", e.what());
    return kExitBadInput;
  }
}

}  // namespace crosslink::app
