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
// The command line's parser: CLI11, a heavy header, only where options are declared
// (app/options.h).
namespace CLI {
class App;
}

namespace crosslink::app {

constexpr int kExitOk = 0;
constexpr int kExitFail = 1;
constexpr int kExitBadInput = 2;

// Each registers its subcommand on `app` and sets `run` to its action.
void add_check(CLI::App& app, std::function<int()>& run);
void add_solve(CLI::App& app, std::function<int()>& run);
void add_simulate(CLI::App& app, std::function<int()>& run);
void add_compare(CLI::App& app, std::function<int()>& run);
void add_sweep(CLI::App& app, std::function<int()>& run);
void add_merge(CLI::App& app, std::function<int()>& run);
void add_engines(CLI::App& app, std::function<int()>& run);
void add_new(CLI::App& app, std::function<int()>& run);

// `crosslink merge` (app/merge.cpp): the parts a sharded sweep wrote, and what to write.
struct MergeArgs {
  std::vector<std::string> parts;
  std::string csv, report, json;
};
int run_merge(const MergeArgs& args);

// `crosslink check` on a loaded definition: the report (stdout), the error when the drawn
// position cannot be assembled (stderr), and the exit code. Throws as check_sweep_work does.
// `sweep`: the options of its assembling range and sweep (the command's are the defaults; the
// fuzz target bounds its grid and tracer).
struct CheckReport {
  int exit_code = kExitOk;
  std::string out, err;
  // The sweep its singular positions come from (solve's default sweep with the same options),
  // for a caller that goes on to solve; none at rest or when the chain cannot start.
  std::optional<Trajectory> sweep;
};
CheckReport check_report(const Mechanism& mechanism, const WorkLimits& limits,
                         const SweepOptions& sweep = {});

// Shared by sweep and compare (app/sweep.cpp): "--accuracy X" or "X%" in % of peak (nullopt for
// empty text; throws std::invalid_argument otherwise), and the progress line of a long search.
std::optional<double> parse_accuracy(const std::string& text);
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
