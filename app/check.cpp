// `crosslink check FILE`: the report methods::check_report makes, on stdout, its error on stderr.
#include <fmt/format.h>

#include "analytic/model/loader.h"
#include "app/commands.h"
#include "methods/check.h"

namespace crosslink::app {

int run_check(const std::string& path, const WorkLimits& limits) {
  const methods::CheckReport report = methods::check_report(load_mechanism(path), limits);
  fmt::print("{}", report.out);
  fmt::print(stderr, "{}", report.err);
  return report.exit_code;
}

}  // namespace crosslink::app
