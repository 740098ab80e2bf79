// `crosslink engines [--markdown]`: every engine of the engine table (methods/engines.h) with
// each setting it takes through --set: its default, the values it takes and what it does.
#include <fmt/core.h>

#include "app/commands.h"
#include "app/options.h"
#include "methods/engines.h"

namespace crosslink::app {

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

}  // namespace crosslink::app
