// The subcommands of the `crosslink` command line. Each returns the process exit code:
// 0 success, 1 a failed verdict, 2 bad input (message on stderr).
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace crosslink::app {

constexpr int kExitOk = 0;
constexpr int kExitFail = 1;
constexpr int kExitBadInput = 2;

// Each registers its subcommand on `app` and sets `run` to its action.
void add_check(CLI::App& app, std::function<int()>& run);
void add_solve(CLI::App& app, std::function<int()>& run);
void add_compare(CLI::App& app, std::function<int()>& run);

}  // namespace crosslink::app
