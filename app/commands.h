// The subcommands of the `crosslink` command line. Each returns the process exit code:
// 0 success, 1 a failed verdict, 2 bad input (message on stderr).
#pragma once

#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "analytic/reference/budget.h"
#include "analytic/reference/sweep.h"
#include "methods/registry.h"
#include "methods/settings_sweep.h"

namespace crosslink::methods {
struct GridPoint;
}

namespace crosslink::app {

constexpr int kExitOk = 0;
constexpr int kExitFail = 1;
constexpr int kExitBadInput = 2;

// The command line (app/options.cpp, the one file that includes the parser, CLI11): parses
// argv into one subcommand's arguments and runs it; returns the process exit code.
int run_command_line(int argc, char** argv);

// Each subcommand, run on its parsed arguments (the files of the same names).
int run_check(const std::string& path, const WorkLimits& limits);

struct SolveArgs {
  std::string path;
  std::optional<double> at;
  std::string format = "table";
  double step = 0.0;
  std::string method = "auto";    // dyads | newton | auto (dyads when the chain decomposes)
  bool ic = false;                // print the instantaneous centres (with --at)
  std::string at_limit = "stop";  // at a limit of the assembling range: stop | reverse
  std::string columns;            // the sweep table's channels (table_channels)
  std::string svg;                // the drawing to write (compare::drawing_svg)
  double animate = 0.0;           // with svg: seconds per sweep of an animated drawing
  WorkLimits limits;
};
int run_solve(const SolveArgs& args);

struct SimulateArgs {
  std::string path;
  std::optional<double> duration, at;
  std::string format = "table";
  std::string integrator = "rkf78";
  double tolerance = 1e-13;
  WorkLimits limits;
};
int run_simulate(const SimulateArgs& args);

struct CompareArgs {
  std::string path;
  std::string engines;  // default: every method (methods::method_names)
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
int run_compare(CompareArgs args);

// --repeat's bound: the grid's size multiplies the work.
constexpr int kMaxRepeat = 100;
struct SweepArgs {
  std::vector<std::string> paths;
  std::string engines;  // default: every engine (methods::engine_names)
  std::vector<double> dts;
  std::string report, csv, json, accuracy, shard;
  double step = 0.0;
  int repeat = 3;
  int jobs = 1;
  bool quiet = false;
  WorkLimits limits;
  long max_steps = sim::kDefaultMaxSteps;
};
int run_sweep(const SweepArgs& args);

// `crosslink merge`: the parts a sharded sweep wrote, and what to write.
struct MergeArgs {
  std::vector<std::string> parts;
  std::string csv, report, json;
};
int run_merge(const MergeArgs& args);

// `crosslink new KIND [FILE]` (app/new.cpp).
int run_new(const std::string& kind, const std::string& file);

// The progress of a long search on stderr: on a terminal one line each run rewrites; otherwise
// (a log, a CI job) one line per finished series, an engine variant over its time steps (a
// timing round of it: "(timing)"), when its engine's grid or round ends. finish() ends the line
// or writes the series still open.
class ProgressLines {
 public:
  ProgressLines();  // stderr; a terminal when isatty says so
  ProgressLines(std::FILE* out, bool terminal);
  methods::Progress progress();  // the callback; this object must outlive it
  void finish();

 private:
  struct Series {
    std::string engine, variant;
    std::vector<double> dts;
    int index = 0, total = 0;  // of its last run
  };
  void run(int index, int total, const methods::GridPoint& point);
  std::FILE* out_;
  bool terminal_;
  bool rewritten_ = false;  // a terminal line is open
  std::vector<Series> open_;
};

}  // namespace crosslink::app
