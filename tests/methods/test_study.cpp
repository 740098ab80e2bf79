// The comparison study in the library (methods/study.h): the same Comparison as `crosslink
// compare` prints, for a front end that is not the command line.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "analytic/model/loader.h"
#include "compare/report.h"
#include "methods/study.h"
#include "tests/common/cli.h"
#include "tests/common/json.h"

namespace crosslink {
namespace {

// The library's run_compare and the command on one definition with the same options: the same
// JSON document, verdicts, every sample and the step probe's rerun included.
void expect_same_as_command(const std::string& path, const methods::CompareOptions& options,
                            const std::string& args) {
  const Mechanism m = load_mechanism(path);
  const compare::Comparison cmp = methods::run_compare(m, options);
  const test::CommandRun run = test::crosslink("compare " + path + " --json - " + args);
  ASSERT_EQ(run.exit_code, cmp.pass() ? 0 : 1) << run.err;
  EXPECT_EQ(test::without_timings(nlohmann::json::parse(run.out)).dump(1),
            test::without_timings(compare::to_json(cmp)).dump(1));
}

TEST(Study, LibraryCompareIsTheCommands) {
  methods::CompareOptions options;
  options.methods = {"analytic", "dyads", "ic", "mujoco", "bullet", "ode", "simbody"};
  expect_same_as_command("mechanisms/fourbar_crank_rocker.toml", options,
                         "--engines analytic,dyads,ic,mujoco,bullet,ode,simbody --jobs 2");
}

TEST(Study, AFailingEngineIsRerunAtHalfItsStep) {
  // A tolerance no engine meets at its step: the study reruns MuJoCo at half its time step.
  methods::CompareOptions options;
  options.methods = {"analytic", "mujoco"};
  options.tolerances = {"mujoco:position=1e-9"};
  options.settings = {"dt=1e-3"};
  const Mechanism m = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  const compare::Comparison cmp = methods::run_compare(m, options);
  ASSERT_EQ(cmp.step_probes.size(), 1u);
  const compare::StepProbe& probe = cmp.step_probes.front();
  EXPECT_TRUE(probe.ok) << probe.message;
  EXPECT_EQ(probe.half_dt, probe.dt / 2.0);
  EXPECT_EQ(probe.dt, cmp.method("mujoco")->cost.time_step);
  // A first-order step: half the step, about half the position error.
  EXPECT_LT(probe.half_pct, 0.75 * probe.pct);
  expect_same_as_command(
      "mechanisms/fourbar_crank_rocker.toml", options,
      "--engines analytic,mujoco --tolerance mujoco:position=1e-9 --set dt=1e-3");
}

TEST(Study, RefusesBeforeAnyWork) {
  const Mechanism m = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  methods::CompareOptions options;
  options.methods = {"analytic", "working_model"};
  EXPECT_THROW(methods::check_compare(m, options), std::invalid_argument);
  options.methods = {"analytic", "mujoco"};
  options.settings = {"havok:dt=1e-3"};
  EXPECT_THROW(methods::check_compare(m, options), std::invalid_argument);
  options.settings = {"dt"};
  EXPECT_THROW(methods::check_compare(m, options), std::invalid_argument);
  options.settings = {};
  options.tolerances = {"speed=1"};
  EXPECT_THROW(methods::check_compare(m, options), std::invalid_argument);
  options.tolerances = {};
  EXPECT_NO_THROW(methods::check_compare(m, options));
}

TEST(Study, EngineSettingsRouteByPrefix) {
  const sim::Settings s =
      methods::engine_settings("ode", {"dt=1e-3", "mujoco:integrator=RK4", "ode:erp=0.5"}, 10);
  const sim::Settings expected = {{"max_steps", "10"}, {"dt", "1e-3"}, {"erp", "0.5"}};
  EXPECT_EQ(s, expected);
}

}  // namespace
}  // namespace crosslink
