// Issue 35, item 8, the engines' side: every engine run ends, and ends cleanly. A setting inside
// its declared range runs or is refused with what the user wrote (exit 2), never an abort; an
// engine that cannot realise a definition says why in the mechanism's words; every run is
// bounded by its work budget (max_steps), named when hit. Each case runs `crosslink` as a user
// would (tests/common/cli.h).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "tests/common/cli.h"

namespace crosslink::test {
namespace {

const std::string kFourbar = "mechanisms/fourbar_crank_rocker.toml";

// The bundled crank-rocker with the given "mass = ..." / "inertia = ..." lines replaced, written
// to this process's scratch folder as `name`.
std::filesystem::path fourbar_with(const std::string& name,
                                   const std::vector<std::pair<std::string, std::string>>& lines) {
  std::string text = read_file(std::string(CROSSLINK_SOURCE_DIR) + "/" + kFourbar);
  for (const auto& [from, to] : lines) {
    const size_t at = text.find("\n" + from + "\n");
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at + 1, from.size(), to);
  }
  const std::filesystem::path path = scratch_dir() / name;
  std::ofstream(path) << text;
  return path;
}

// Simbody asserts 0 < accuracy < 1 (Integrator::setAccuracy) and aborted the process at the
// declared range's closed end, 1: the range is now open there, so 1 is refused before any run,
// with every integrator (CPodes too); just inside it runs.
TEST(CleanEnds, SimbodyAccuracyOfOneIsRefusedNotAborted) {
  for (const char* integrator : {"merson", "cpodes"}) {
    const CommandRun run =
        crosslink("compare " + kFourbar + " --engines simbody --set simbody:accuracy=1" +
                  " --set simbody:integrator=" + integrator);
    EXPECT_EQ(run.exit_code, 2) << integrator << "\n" << run.err;
    EXPECT_NE(run.err.find("setting accuracy = \"1\": expected a number in (0, 1)"),
              std::string::npos)
        << run.err;
  }
  const CommandRun inside =
      crosslink("compare " + kFourbar + " --engines simbody --set simbody:accuracy=0.999");
  EXPECT_EQ(inside.exit_code, 0) << inside.err;
  const CommandRun cpodes =
      crosslink("compare " + kFourbar + " --engines simbody --set simbody:integrator=cpodes");
  EXPECT_EQ(cpodes.exit_code, 0) << cpodes.err;
}

// --export-mjcf plans the scene MuJoCo would run under --max-steps, as the run does: the
// four-bar's cycle (0.25 s) at dt = 1e-7 takes 2.5 million steps, over the default 2 million
// (refused, no file) and within the 4 million asked (written). A01's 2000 s at MuJoCo's default
// step, 3.5 million steps, show the same, at the cost of its exact reference (a minute under the
// sanitizers).
TEST(CleanEnds, ExportMjcfTakesMaxSteps) {
  const std::filesystem::path xml = scratch_dir() / "fourbar.xml";
  std::filesystem::remove(xml);
  const std::string command = "compare " + kFourbar +
                              " --engines analytic --set mujoco:dt=1e-7 --export-mjcf \"" +
                              xml.string() + "\"";
  const CommandRun over = crosslink(command);
  EXPECT_EQ(over.exit_code, 2) << over.err;
  std::smatch steps;  // at least the cycle over dt; the run's first and last samples add a few
  ASSERT_TRUE(std::regex_search(
      over.err, steps, std::regex("takes ([0-9]+) steps over the run: the limit is 2000000 steps")))
      << over.err;
  EXPECT_GE(std::stol(steps[1]), 2500000);
  EXPECT_LT(std::stol(steps[1]), 2600000);
  EXPECT_FALSE(std::filesystem::exists(xml));
  const CommandRun run = crosslink(command + " --max-steps 4000000");
  EXPECT_EQ(run.err.find("the limit is"), std::string::npos) << run.err;
  ASSERT_TRUE(std::filesystem::exists(xml)) << run.err;
  EXPECT_NE(read_file(xml).find("<mujoco model=\"Grashof crank-rocker four-bar\">"),
            std::string::npos);
}

// A step count past any limit is refused with the count in a few digits, not 300.
TEST(CleanEnds, AStepCountPastAnyLimitIsWrittenShort) {
  const CommandRun run = crosslink("compare " + kFourbar + " --engines ode --set ode:dt=1e-300");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--set dt=1e-300 (ode): dt = 1e-300 s takes 2.5e+299 steps over the run: "
                         "the limit is 2000000 steps"),
            std::string::npos)
      << run.err;
  EXPECT_FALSE(std::regex_search(run.err, std::regex("[0-9]{20}"))) << run.err;
}

// A massless driven crank (legal) gets 1e-6 of the lightest link in ODE's scene, 1.5e6 below the
// coupler, and ODE's step fails in its own assertion: the run says so in the mechanism's words.
TEST(CleanEnds, OdeSaysWhichLinksMassesItCannotResolve) {
  const std::filesystem::path file =
      fourbar_with("massless_crank.toml",
                   {{"mass = 0.0157", "mass = 0"}, {"inertia = 2.22417e-06", "inertia = 0"}});
  const CommandRun run = crosslink("compare \"" + file.string() + "\" --engines ode");
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_NE(run.out.find("the links' masses are 1.5e+06 apart (link 'crank', massless (in the "
                         "scene 3.14e-08 kg, 1e-6 of the lightest link) against link 'coupler' "
                         "0.0471 kg), more than ODE's constraint solve resolves at cfm = 1e-10"),
            std::string::npos)
      << run.out;
  // The remedy it names runs.
  const CommandRun remedy =
      crosslink("compare \"" + file.string() + "\" --engines ode --set ode:cfm=1e-6");
  EXPECT_EQ(remedy.exit_code, 0) << remedy.out;
}

// Masses 1e18 apart (coupler 1e9 kg, rocker 1e-9 kg): Simbody's steps fall to 1e-6 s, each with
// a projection onto the loops, and the run went on for 19 minutes. Its work (step attempts and
// projections) is projected over the run and stopped, naming max_steps, as soon as it would pass
// it.
TEST(CleanEnds, SimbodyStopsWhenItsWorkWouldPassMaxSteps) {
  const std::filesystem::path file =
      fourbar_with("mass_ratio.toml", {{"mass = 0.0471", "mass = 1e9"},
                                       {"inertia = 5.69125e-05", "inertia = 1e9"},
                                       {"mass = 0.0314", "mass = 1e-9"},
                                       {"inertia = 1.70083e-05", "inertia = 1e-12"}});
  const CommandRun run =
      crosslink("compare \"" + file.string() + "\" --engines simbody --max-steps 100000");
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_NE(run.out.find("Simbody's work would exceed max_steps = 100000 steps, the most of one "
                         "run (raise it with --max-steps N): at its rate so far the run takes "
                         "about "),
            std::string::npos)
      << run.out;
}

// max_steps bounds Simbody's own work, its step attempts and projections: at accuracy 1e-13 the
// crank-rocker's 2536 reported poses (the plan's check, passed) take some 4600 internal steps,
// so max_steps = 4000 stops the run, projected or reached, never past it.
TEST(CleanEnds, SimbodyMaxStepsCountsItsInternalWork) {
  const CommandRun run =
      crosslink("compare " + kFourbar +
                " --engines simbody --set simbody:accuracy=1e-13 --set simbody:max_steps=4000");
  EXPECT_EQ(run.exit_code, 1) << run.err;
  std::smatch m;
  const std::string& out = run.out;
  ASSERT_TRUE(std::regex_search(
      out, m,
      std::regex("Simbody's work (reached|would exceed) max_steps = 4000 steps, the most of one "
                 "run \\(raise it with --max-steps N\\)[^(]*\\(?([0-9]+) step attempts and "
                 "([0-9]+) projections")))
      << out;
  const long work = std::stol(m[2]) + std::stol(m[3]);
  EXPECT_LE(work, 4000) << m[0];
  if (m[1] == "reached") {
    EXPECT_EQ(work, 4000) << m[0];
  }
}

// MuJoCo's solref is (timeconst, dampratio), both positive, or the direct (-stiffness,
// -damping); solimp (dmin, dmax, width, midpoint, power) with impedances in (0, 1): values
// outside are refused at --set, naming the setting and what it takes.
TEST(CleanEnds, MujocoRefusesSolrefAndSolimpOutsideTheirMeaning) {
  const std::vector<std::pair<std::string, std::string>> refused = {
      {"solref=0 0", "setting solref = \"0 0\": expected a timeconst > 0, or a stiffness > 0"},
      {"solref=0.02 -1",
       "setting solref = \"0.02 -1\": expected a positive dampratio after a positive timeconst"},
      {"solref=-1 1", "setting solref = \"-1 1\": expected a damping >= 0"},
      {"driver_solref=0 0", "setting driver_solref = \"0 0\": expected a timeconst > 0"},
      {"solimp=2 2 2 2 2", "setting solimp = \"2 2 2 2 2\": expected dmin (the 1st) in (0, 1)"},
      {"solimp=0.9 1 0.001", "setting solimp = \"0.9 1 0.001\": expected dmax (the 2nd) in (0, 1)"},
      {"solimp=0.9 0.95 0", "setting solimp = \"0.9 0.95 0\": expected a positive width (the 3rd)"},
      {"solimp=0.9 0.95 0.001 1.5", "expected midpoint (the 4th) in [0, 1]"},
      {"driver_solimp=0.9 0.95 0.001 0.5 0.5", "expected power (the 5th) 1 or more"},
  };
  for (const auto& [set, message] : refused) {
    const CommandRun run =
        crosslink("compare " + kFourbar + " --engines mujoco --set \"mujoco:" + set + "\"");
    EXPECT_EQ(run.exit_code, 2) << set;
    EXPECT_NE(run.err.find(message), std::string::npos) << set << "\n" << run.err;
  }
  // The direct format with damping 0 is MuJoCo's (perfectly elastic), and -1 -1 a soft one: both
  // run (the loops give way under stiffness 1: the run ends diverged, with its loop gap).
  for (const char* set : {"solref=-1e8 0", "solref=-1 -1"}) {
    const CommandRun run =
        crosslink("compare " + kFourbar + " --engines mujoco --set \"mujoco:" + set + "\"");
    EXPECT_NE(run.exit_code, 2) << set << "\n" << run.err;
    EXPECT_NE(run.exit_code, -1) << set;
  }
}

}  // namespace
}  // namespace crosslink::test
