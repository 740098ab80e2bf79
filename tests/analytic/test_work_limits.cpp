// The work and memory limits of the commands (docs/robustness.md), run as a user would. Each
// fixture of tests/analytic/data/work_limits/ is a reproduction of issue 24 that ran for
// minutes to days, took gigabytes, or wrote where it should not; each test sets a small limit
// and checks the located error, never running the long case.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>

#include "tests/common/cli.h"
#include "tests/common/sanitizers.h"
#include "tests/common/text.h"

namespace {

using crosslink::test::CommandRun;
using crosslink::test::crosslink;
using crosslink::test::read_file;
using crosslink::test::scratch_dir;

constexpr double kDeg = std::numbers::pi / 180.0;

std::string fixture(const std::string& name) {
  return std::string(CROSSLINK_SOURCE_DIR) + "/tests/analytic/data/work_limits/" + name;
}

// The line of `table` ("[dynamics]") in a definition: where its errors are located.
int line_of(const std::string& path, const std::string& table) {
  const int before = crosslink::test::line_of(read_file(path), "\n" + table + "\n");
  return before == 0 ? -1 : before + 1;
}

// A run that would take days (A01 at t = 1e9 s) stops at --max-solves with the case's [dynamics]
// table as the place and the option that raises the limit.
TEST(WorkLimits, SimulateStopsAtItsSolveLimitWithAPlace) {
  const std::string file = "mechanisms/iftomm_a01_pendulum.toml";
  const CommandRun run = crosslink("simulate " + file + " --at 1e9 --max-solves 20000");
  EXPECT_EQ(run.exit_code, 2) << run.err;
  const std::string place = file + ":" + std::to_string(line_of(file, "[dynamics]")) + ":";
  EXPECT_NE(run.err.find(place), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("--max-solves"), std::string::npos) << run.err;
  // The same file with 11 samples over 1e9 s: the samples reached, then not_reached.
  const CommandRun samples = crosslink("simulate \"" + fixture("a01_pendulum_duration_1e9.toml") +
                                       "\" --max-solves 20000 --format csv");
  EXPECT_EQ(samples.exit_code, 2) << samples.err;
  EXPECT_NE(samples.out.find(",ok,"), std::string::npos) << samples.out;
  EXPECT_NE(samples.out.find(",not_reached,"), std::string::npos) << samples.out;
}

// compare's exact simulation is bounded as simulate's: by --max-samples before it starts (it
// ignored it: a01_pendulum_999951_samples.toml ran in full), and by --max-solves as it runs.
TEST(WorkLimits, CompareOfADynamicsCaseKeepsToItsLimits) {
  const CommandRun samples = crosslink("compare \"" + fixture("a01_pendulum_999951_samples.toml") +
                                       "\" --engines analytic --max-samples 10");
  EXPECT_EQ(samples.exit_code, 2) << samples.err;
  EXPECT_NE(samples.err.find("--max-samples"), std::string::npos) << samples.err;
  // A centre of mass at 10 km: rkf78's steps collapse under the round-off of the accelerations.
  const std::string com = fixture("a02_coupler_com_10km.toml");
  const CommandRun solves =
      crosslink("compare \"" + com + "\" --engines analytic --max-solves 5000");
  EXPECT_EQ(solves.exit_code, 2) << solves.err;
  EXPECT_NE(solves.err.find(":" + std::to_string(line_of(com, "[dynamics]")) + ":"),
            std::string::npos)
      << solves.err;
  EXPECT_NE(solves.err.find("--max-solves"), std::string::npos) << solves.err;
}

// A reference at 5e9 degrees on a crank that turns fully is the pose at 5e9 mod 360 = 320
// degrees (5e9 = 13,888,888 turns + 320), its crank's angle 5e9 degrees: solved a whole number
// of turns nearer the start instead of by 5e9 one-degree steps (1.5 h).
TEST(WorkLimits, AFarValueOfAFullyTurningDriverIsTheSamePoseTurnsAway) {
  const CommandRun near =
      crosslink("solve mechanisms/fourbar_crank_rocker.toml --at 320 --format json");
  ASSERT_EQ(near.exit_code, 0) << near.err;
  const CommandRun far =
      crosslink("solve mechanisms/fourbar_crank_rocker.toml --at 5e9 --format json");
  ASSERT_EQ(far.exit_code, 0) << far.err;
  const nlohmann::json a = nlohmann::json::parse(near.out), b = nlohmann::json::parse(far.out);
  EXPECT_DOUBLE_EQ(b["links"]["crank"]["angle"].get<double>(), 5e9 * kDeg);
  EXPECT_DOUBLE_EQ(b["driver"].get<double>(), 5e9 * kDeg);
  // 5e9 degrees in radians is itself known only to its last bit, 1.5e-8 rad: the pose is 320
  // degrees to that (the rocker turns at most 1.5 times as fast as the crank).
  const double bit = std::nextafter(5e9 * kDeg, 1e300) - 5e9 * kDeg, near_enough = 4.0 * bit;
  for (const char* link : {"coupler", "rocker"})
    EXPECT_NEAR(b["links"][link]["angle"].get<double>(), a["links"][link]["angle"].get<double>(),
                near_enough)
        << link;
  // Rates and accelerations move with the pose by up to omega^2 r per radian (63 m/s^2 here).
  for (const char* point : {"B", "C"})
    for (const char* v : {"x", "y", "vx", "vy", "ax", "ay"}) {
      const double expected = a["points"][point][v].get<double>();
      EXPECT_NEAR(b["points"][point][v].get<double>(), expected, 100.0 * near_enough)
          << point << " " << v;
    }

  // compare's [[reference]] at 5e9 deg: its exact value is the one at 320 deg (the typo's 60 deg
  // fails its tolerance: exit 1, not bad input).
  const CommandRun compared =
      crosslink("compare \"" + fixture("fourbar_reference_at_5e9_deg.toml") +
                "\" --engines analytic --json -");
  ASSERT_NE(compared.exit_code, 2) << compared.err;
  const nlohmann::json doc = nlohmann::json::parse(compared.out);
  ASSERT_EQ(doc["references"].size(), 1u);
  EXPECT_NEAR(doc["references"][0]["exact"].get<double>(),
              a["links"]["rocker"]["angle"].get<double>(), near_enough);
}

// solve --format json writes each sample as it is made: the text is the document's (as a DOM
// writes it, byte for byte) and the memory that of the samples, not of a DOM of them (70 kB a
// sample on the A02 chain at N = 10: 3.6 GB for its 49,951-sample range).
TEST(WorkLimits, SolveJsonIsWrittenSampleBySample) {
  const CommandRun run = crosslink("solve mechanisms/sewing_machine.toml --format json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.out, nlohmann::json::parse(run.out).dump(2) + "\n");

  // 4,000 samples of A02 N = 10 (about 280 MB as a DOM).
  std::string text = read_file(fixture("a02_10_range_49951_samples.toml"));
  const std::string from = "range = ", to = "range = [90, 130]\n";
  const size_t at = text.find("\n" + from);
  ASSERT_NE(at, std::string::npos);
  text.replace(at + 1, text.find('\n', at + 1) - at, to);
  const std::filesystem::path path = scratch_dir() / "a02_10_4000_samples.toml";
  std::ofstream(path) << text;
  const CommandRun a02 = crosslink("solve \"" + path.string() + "\" --step 0.01 --format json");
  ASSERT_EQ(a02.exit_code, 0) << a02.err;
  rusage usage{};
  ASSERT_EQ(getrusage(RUSAGE_CHILDREN, &usage), 0);
  const double megabytes = static_cast<double>(usage.ru_maxrss) / 1024.0;  // kB on Linux
  std::printf("[ solve A02 N=10, 4001 samples, JSON ] %zu MB of text, peak memory %.0f MB\n",
              a02.out.size() >> 20, megabytes);
  // AddressSanitizer keeps 256 MB of freed blocks in quarantine and adds its shadow memory, so its
  // peak measures the sanitizer; the Release suite holds the bound.
  if (!CROSSLINK_ADDRESS_SANITIZER) {
    EXPECT_LT(megabytes, 120.0);
  }
  EXPECT_EQ(nlohmann::json::parse(a02.out)["samples"].size(), 4001u);
}

// The samples' memory is bounded too: A02 at N = 40 swept at 0.0037 degrees is within
// --max-samples (97,298 samples) but holds about 1,500 values a sample (26 GB as a JSON document,
// an uncaught std::bad_alloc under a 4 GB cap): refused before any work.
TEST(WorkLimits, ASweepOfALongChainIsBoundedByItsValues) {
  const CommandRun run =
      crosslink("solve mechanisms/scaling/iftomm_a02_nfourbar_40.toml --step 0.0037 --format json");
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_TRUE(run.out.empty());
  EXPECT_NE(run.err.find("values each"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("--max-samples"), std::string::npos) << run.err;
}

// An engine scene works at any size the loader accepts: the crank-rocker scaled by 1e-5 (links of
// 1e-6 m, inertias of 2e-16 kg m^2, under MuJoCo's mjMINVAL) was refused by MuJoCo, and the verdict
// line read "FAIL (70 channel comparisons: 70 pass, 0 fail ...)".
TEST(WorkLimits, AnEngineSceneWorksAtAWatchsSize) {
  const CommandRun run = crosslink("compare \"" + fixture("fourbar_scaled_1e-5.toml") +
                                   "\" --engines analytic,mujoco --json -");
  ASSERT_NE(run.exit_code, 2) << run.err;
  const nlohmann::json doc = nlohmann::json::parse(run.out);
  bool ran = false;
  for (const nlohmann::json& method : doc["methods"])
    if (method["name"] == "mujoco") {
      ran = true;
      EXPECT_TRUE(method["ok"].get<bool>()) << method.dump();
    }
  EXPECT_TRUE(ran);
  const size_t verdict = run.err.find("verdict: ");
  ASSERT_NE(verdict, std::string::npos) << run.err;
  // Whatever it says, a FAIL names what failed.
  if (run.err.compare(verdict, 15, "verdict: FAIL (") == 0) {
    const std::string line = run.err.substr(verdict, run.err.find('\n', verdict) - verdict);
    EXPECT_TRUE(line.find("method mujoco") != std::string::npos || run.err.find("FAIL: ") < verdict)
        << line;
  }
}

// MuJoCo's warnings become the run's notes: `compare --json -` writes JSON alone on stdout
// (MuJoCo printed "WARNING: Nan, Inf or huge value in QACC ..." before it) and no MUJOCO_LOG.TXT
// appears in the folder it runs from.
TEST(WorkLimits, MujocoWarningsAreNotesAndNoLogIsWritten) {
  const std::filesystem::path folder = scratch_dir() / "mujoco_warning";
  std::filesystem::create_directories(folder);
  std::filesystem::remove(folder / "MUJOCO_LOG.TXT");
  const CommandRun run =
      crosslink("compare \"" + fixture("polycentric_load_1e12_mujoco_warning.toml") +
                    "\" --engines analytic,mujoco --json -",
                folder);
  ASSERT_NE(run.exit_code, 2) << run.err;
  nlohmann::json doc;
  ASSERT_NO_THROW(doc = nlohmann::json::parse(run.out)) << run.out.substr(0, 300);
  EXPECT_FALSE(std::filesystem::exists(folder / "MUJOCO_LOG.TXT"));
  EXPECT_NE(run.err.find("MuJoCo warning"), std::string::npos) << run.err;
}

}  // namespace
