// crosslink: cross-validates the kinematics of planar linkages.
#include <fmt/core.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <functional>
#include <new>
#include <string>

#include "analytic/model/mechanism.h"
#include "app/commands.h"

int main(int argc, char** argv) {
  using namespace crosslink::app;
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
  } catch (const crosslink::DefinitionError& e) {
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
