// A [[reference]] row with its own 'tolerance' is judged by `crosslink compare` (and so by
// crosslink_add_check, which runs it); rows without one are shown beside the exact values, and a
// run that judged nothing says so instead of PASS. The values are the Wanzer needle bar's
// printed ones (ME 481 H05): the notes' Newton geometry to 4 decimals, and V_G = 365 mm/s
// (Working Model) and 370 mm/s (instantaneous centres by ruler), 4.5 % and 3.2 % from the exact
// 382.12 mm/s (docs/wanzer.md, docs/engines-measured.md).
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>

#include "tests/common/cli.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

const std::string kWanzer = "mechanisms/wanzer_needle_bar.toml";

// The Wanzer file with `tolerance` lines after the values named, written to a scratch file.
std::string with_tolerances(const std::vector<std::pair<std::string, std::string>>& values) {
  std::string text = test::source_text(kWanzer);
  for (const auto& [value, tolerance] : values)
    text = std::regex_replace(text, std::regex("\nvalue = " + value + "\n"),
                              "\nvalue = " + value + "\ntolerance = " + tolerance + "\n");
  const std::filesystem::path path = test::scratch_dir() / "wanzer_judged.toml";
  std::ofstream(path) << text;
  return path.string();
}

TEST(References, ARowWithATolerancePassesOrFailsTheCompare) {
  // Working Model within 5 % holds; the instantaneous centres within 2 % do not (3.2 %).
  const std::string path = with_tolerances({{"-365", "5"}, {"-370", "2"}});
  const test::CommandRun run = test::crosslink("compare \"" + path + "\" --engines analytic");
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(run.out.find("pass (5 %)"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("FAIL (2 %)"), std::string::npos) << run.out;
  // At its place in the file: the IC row's [[reference]] table, three lines above its value.
  const int line = test::line_of(test::read_file(path), "value = -370") - 3;
  EXPECT_NE(test::flattened(run.out).find("FAIL: [[reference]] vy.G at driver = 0.00 deg (" + path +
                                          ":" + std::to_string(line) +
                                          ":1): printed -370, exact -382.12: 3.17 % from it > "
                                          "its tolerance 2 %"),
            std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("2 [[reference]] values judged: 1 hold, 1 fail"), std::string::npos);

  const test::CommandRun json =
      test::crosslink("compare \"" + path + "\" --engines analytic --json -");
  const nlohmann::json doc = nlohmann::json::parse(json.out);
  int judged = 0;
  for (const nlohmann::json& r : doc["references"]) {
    if (r["tolerance"].is_null()) {
      EXPECT_TRUE(r["verdict"].is_null());
      continue;
    }
    ++judged;
    EXPECT_EQ(r["verdict"], r["tolerance"] == 5.0 ? "pass" : "fail") << r.dump();
  }
  EXPECT_EQ(judged, 2);
}

TEST(References, ARowJudgedToItsPrintedRounding) {
  // The notes print E and G to 4 decimals: within half of 1e-4 mm of the exact values.
  const std::string holds =
      with_tolerances({{"19.9279", "\"rounding\""}, {"-41.2603", "\"rounding\""}});
  const test::CommandRun pass = test::crosslink("compare \"" + holds + "\" --engines analytic");
  EXPECT_EQ(pass.exit_code, 0) << pass.out << pass.err;
  EXPECT_NE(pass.out.find("verdict: PASS"), std::string::npos) << pass.out;
  // One digit off in the last place is beyond the rounding.
  std::string text = test::read_file(holds);
  text = std::regex_replace(text, std::regex("value = 19.9279\n"), "value = 19.9278\n");
  std::ofstream(holds) << text;
  const test::CommandRun fail = test::crosslink("compare \"" + holds + "\" --engines analytic");
  EXPECT_EQ(fail.exit_code, 1) << fail.out;
  EXPECT_NE(test::flattened(fail.out).find("printed 19.9278, exact 19.9279: beyond its printed "
                                           "rounding (+-5e-05)"),
            std::string::npos)
      << fail.out;
}

TEST(References, NothingJudgedIsNoPass) {
  const test::CommandRun run = test::crosslink("compare " + kWanzer + " --engines analytic");
  EXPECT_EQ(run.exit_code, 2) << run.out;
  EXPECT_EQ(run.out.find("PASS"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("verdict: NOTHING TO COMPARE"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("8 [[reference]] values shown, not judged"), std::string::npos) << run.out;
}

TEST(References, ABadToleranceIsRefusedAtItsPlace) {
  const std::string path = with_tolerances({{"-365", "\"roughly\""}});
  const test::CommandRun run = test::crosslink("compare \"" + path + "\" --engines analytic");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find(path + ":"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("[[reference]] 'tolerance'"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace crosslink
