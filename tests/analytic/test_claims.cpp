// A definition's own claims ([expect], [expect.derived]) judged against the exact solution
// (analytic/derived/claims.h): the closed forms the bundled files state hold, and a claim 1 % off,
// a toggle too many or a wrong Grashof class does not, at its own line.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <fstream>
#include <regex>

#include "analytic/derived/claims.h"
#include "analytic/model/loader.h"
#include "tests/common/cli.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

std::vector<Claim> claims_of(const std::string& text, const std::string& name) {
  const Mechanism m = parse_mechanism(text, name);
  std::vector<SingularPosition> singular;
  const Trajectory t = sweep(m, {}, singular);
  return judge_claims(m, derived_exact(m, t), singular);
}

const Claim& find(const std::vector<Claim>& claims, std::string_view what) {
  for (const Claim& c : claims)
    if (c.what == what) return c;
  throw std::runtime_error("no claim " + std::string(what));
}

const std::string kWhitworth = "mechanisms/published/whitworth_quick_return.toml";
const std::string kNonGrashof = "mechanisms/singular/fourbar_non_grashof.toml";

// Every bundled claim is a closed form derived beside it in its file: every one holds.
TEST(Claims, TheBundledClosedFormsHold) {
  int judged = 0;
  for (const std::string& file :
       {kWhitworth, kNonGrashof, std::string("mechanisms/singular/slider_crank_from_slider.toml"),
        std::string("mechanisms/singular/fourbar_change_point_crank_rocker.toml")}) {
    for (const Claim& c : claims_of(test::source_text(file), file)) {
      EXPECT_TRUE(c.holds) << file << ": " << c.what << " claimed " << c.claimed << ", computed "
                           << c.computed;
      ++judged;
    }
  }
  EXPECT_EQ(judged, 14);
}

// The Whitworth ram's stroke is 150 mm (the file's closed form): claimed 1 % more, it does not hold
// at its line; a stated tolerance of 2 % takes it.
TEST(Claims, AStrokeOnePercentOffDoesNotHold) {
  std::string text = test::source_text(kWhitworth);
  text = std::regex_replace(text, std::regex("\nram_stroke = 150 "), "\nram_stroke = 151.5 ");
  const std::vector<Claim> claims = claims_of(text, "w.toml");
  const Claim& stroke = find(claims, "[expect.derived] 'ram_stroke'");
  EXPECT_FALSE(stroke.holds);
  EXPECT_EQ(stroke.claimed, "151.5 mm");
  EXPECT_EQ(stroke.computed, "150 mm");
  EXPECT_EQ(stroke.where.line, test::line_of(text, "\nram_stroke = ") + 1);
  EXPECT_TRUE(find(claims, "[expect.derived] 'Q'").holds);

  const std::string loose = std::regex_replace(text, std::regex("\n\\[expect.derived\\]"),
                                               "\n[expect]\ntolerance = 2\n\n[expect.derived]");
  EXPECT_TRUE(find(claims_of(loose, "w.toml"), "[expect.derived] 'ram_stroke'").holds);
}

// The non-Grashof four-bar's limits are its toggles at +-acos(...) = +-78.28 deg: a toggle too
// many, a limit 1e-6 off and the wrong class each fail.
TEST(Claims, WrongSingularBehaviourDoesNotHold) {
  std::string text = test::source_text(kNonGrashof);
  text =
      std::regex_replace(text, std::regex("\ntoggles = \\[([^\\]]*)\\]"), "\ntoggles = [$1, 10]");
  text = std::regex_replace(text, std::regex("\nlimits = \\[-78.280239694211232"),
                            "\nlimits = [-78.2803");
  text = std::regex_replace(text, std::regex("grashof = \"non-Grashof\""), "grashof = \"Grashof\"");
  const std::vector<Claim> claims = claims_of(text, "n.toml");
  const Claim& toggles = find(claims, "[expect] 'toggles'");
  EXPECT_FALSE(toggles.holds);
  EXPECT_EQ(toggles.where.line, test::line_of(text, "\ntoggles = ") + 1);
  EXPECT_FALSE(find(claims, "[expect] 'limits'").holds);
  const Claim& grashof = find(claims, "[expect] 'grashof'");
  EXPECT_FALSE(grashof.holds);
  EXPECT_EQ(grashof.computed, "non-Grashof");
  EXPECT_TRUE(find(claims, "[expect] 'change_points'").holds);  // [] claimed, none found
}

TEST(Claims, ABadToleranceIsRefusedAtItsKey) {
  const std::string text = test::source_text(kNonGrashof) + "";
  const std::string bad =
      std::regex_replace(text, std::regex("\n\\[expect\\]\n"), "\n[expect]\ntolerance = -1\n");
  try {
    (void)parse_mechanism(bad, "n.toml");
    FAIL() << "a negative tolerance was taken";
  } catch (const DefinitionError& e) {
    EXPECT_NE(std::string(e.what()).find("[expect] 'tolerance'"), std::string::npos) << e.what();
  }
}

// The command: each claim on stdout, one that does not hold at its file:line on stderr, exit 1.
TEST(Claims, CheckFailsOnAClaimThatDoesNotHold) {
  std::string text = test::source_text(kWhitworth);
  text = std::regex_replace(text, std::regex("\nram_stroke = 150 "), "\nram_stroke = 151.5 ");
  const std::filesystem::path path = test::scratch_dir() / "whitworth_wrong.toml";
  std::ofstream(path) << text;
  const test::CommandRun run = test::crosslink("check \"" + path.string() + "\"");
  EXPECT_EQ(run.exit_code, 1) << run.out << run.err;
  EXPECT_NE(
      run.err.find(fmt::format("{}:{}:14: error: [expect.derived] 'ram_stroke' does not hold: "
                               "claimed 151.5 mm, computed 150 mm",
                               path.string(), test::line_of(text, "\nram_stroke = ") + 1)),
      std::string::npos)
      << run.err;
  EXPECT_NE(run.out.find("claims ([expect], tolerance 1e-07 %, the default): 3 of 4 hold"),
            std::string::npos)
      << run.out;
  EXPECT_EQ(run.out.find("\n  ok\n"), std::string::npos) << run.out;
  const test::CommandRun right = test::crosslink("check " + kWhitworth);
  EXPECT_EQ(right.exit_code, 0) << right.err;
  EXPECT_NE(right.out.find("4 of 4 hold"), std::string::npos) << right.out;
}

}  // namespace
}  // namespace crosslink
