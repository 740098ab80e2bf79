// The `crosslink` command line, run as a user would: exit codes, diagnostics on stderr, and the
// JSON and CSV outputs of `solve` (the contract in docs/json.md).
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "tests/common/cli.h"
#include "tests/common/crank_rocker.h"
#include "tests/common/json.h"
#include "tests/common/text.h"

namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

using crosslink::test::CommandRun;
using crosslink::test::crosslink;
using crosslink::test::read_file;
using crosslink::test::scratch_dir;
using crosslink::test::without_timings;

std::string write_definition(const std::string& name, const std::string& text) {
  const std::filesystem::path path = scratch_dir() / name;
  std::ofstream(path) << text;
  return path.string();
}

const char* const kSewing = "mechanisms/sewing_machine.toml";

// The parallelogram fixture drawn at `degrees` (tests/analytic/singular/parallelogram.toml, whose
// change points are at 0 and 180 deg): crank and rocker at the angle, coupler level.
std::string parallelogram_at(double degrees) {
  std::string text = read_file("tests/analytic/singular/parallelogram.toml");
  const double r = degrees * std::acos(-1.0) / 180.0;
  const auto replace = [&](const std::string& from, const std::string& to) {
    text.replace(text.find(from), from.size(), to);
  };
  replace("pose = [0, 0, 45]", fmt::format("pose = [0, 0, {:.17g}]", degrees));
  replace("pose = [28.284271247461902, 28.284271247461902, 0]",
          fmt::format("pose = [{:.17g}, {:.17g}, 0]", 40 * std::cos(r), 40 * std::sin(r)));
  replace("pose = [100, 0, 45]", fmt::format("pose = [100, 0, {:.17g}]", degrees));
  replace("start = 45", fmt::format("start = {:.17g}", degrees));
  return write_definition(fmt::format("parallelogram_{}.toml", degrees), text);
}

// Item 6 of issue 24: drawn at a change point, the drawing cannot say which branch the chain is
// on: refused at [driver] (it was a one-sample sweep and exit 0). Elsewhere `check` names the
// change points inside the sweep, at the values the crank passes them (0, never -0, from -45
// deg; not the one a hair past the cycle's end from 179.99999 deg), and the parallelogram's
// inversion as Norton's double crank. Drawn 1e-7 deg from it (179.9999999), the start is the
// change point to working precision (issue 35): refused too, with its value in full.
TEST(Cli, ChangePointsAsCheckNamesThem) {
  for (const double at : {0.0, 180.0}) {
    const std::string file = parallelogram_at(at);
    for (const std::string command : {"check ", "solve ", "solve --at 10 "}) {
      const CommandRun run = crosslink(command + file);
      EXPECT_EQ(run.exit_code, 2) << command << at;
      EXPECT_NE(run.err.find(file + ":64:1: error: the drawn position"), std::string::npos)
          << command << at << ": " << run.err;
    }
  }
  const CommandRun from_minus_45 = crosslink("check " + parallelogram_at(-45));
  EXPECT_EQ(from_minus_45.exit_code, 0) << from_minus_45.err;
  EXPECT_NE(from_minus_45.out.find("change_point  at driver = 0.000000000 deg"), std::string::npos)
      << from_minus_45.out;
  EXPECT_EQ(from_minus_45.out.find("-0.000"), std::string::npos) << from_minus_45.out;
  EXPECT_NE(from_minus_45.out.find("parallelogram double-crank"), std::string::npos);
  const CommandRun near_180 = crosslink("check " + parallelogram_at(179.99999));
  EXPECT_NE(near_180.out.find("singular positions over the sweep: 2"), std::string::npos)
      << near_180.out;
  const CommandRun nearer = crosslink("check " + parallelogram_at(179.9999999));
  EXPECT_EQ(nearer.exit_code, 2);
  EXPECT_NE(nearer.err.find("driver = 179.9999999 deg, is a change point to working precision"),
            std::string::npos)
      << nearer.err;
}

// `crosslink new KIND FILE` (issue 32 item 5): each starting definition is written, passes
// `check`, and is never written over. The slider-crank's stroke is the closed form
// sqrt((a + b)^2 - e^2) - sqrt((b - a)^2 - e^2) = 80.3147 mm (a = 40, b = 120, offset e = 10).
TEST(Cli, NewWritesAStartingDefinitionThatChecks) {
  for (const std::string kind : {"fourbar", "slider-crank", "five-bar"}) {
    const std::filesystem::path path = scratch_dir() / ("new_" + kind + ".toml");
    std::filesystem::remove(path);
    const CommandRun wrote = crosslink("new " + kind + " \"" + path.string() + "\"");
    EXPECT_EQ(wrote.exit_code, 0) << kind << ": " << wrote.err;
    const CommandRun checked = crosslink("check \"" + path.string() + "\"");
    EXPECT_EQ(checked.exit_code, 0) << kind << ": " << checked.err;
    EXPECT_NE(checked.out.find("\n  ok\n"), std::string::npos) << checked.out;
    const CommandRun again = crosslink("new " + kind + " \"" + path.string() + "\"");
    EXPECT_EQ(again.exit_code, 2) << kind;
    EXPECT_NE(again.err.find("does not overwrite"), std::string::npos) << again.err;
  }
  const double a = 40, b = 120, e = 10;
  const double stroke = std::sqrt((a + b) * (a + b) - e * e) - std::sqrt((b - a) * (b - a) - e * e);
  const CommandRun solved =
      crosslink("solve \"" + (scratch_dir() / "new_slider-crank.toml").string() + "\"");
  EXPECT_NE(solved.out.find(fmt::format("stroke       {:.4f} mm", stroke)), std::string::npos)
      << solved.out;
  EXPECT_EQ(crosslink("new six-bar").exit_code, 2);
}

TEST(Cli, CheckAcceptsTheSewingMachine) {
  const CommandRun run = crosslink(std::string("check ") + kSewing);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("ok"), std::string::npos) << run.out;
}

// Issue 13: `check` says which assembly mode each dyad starts on, who chose it, and how to name
// the other when it closes too. The crank-rocker is drawn on the open circuit, C above AD, so
// B -> C -> D turns clockwise (its description says so).
TEST(Cli, CheckSaysWhichAssemblyModeWasTakenAndThatAnotherExists) {
  const CommandRun drawn = crosslink("check mechanisms/fourbar_crank_rocker.toml");
  ASSERT_EQ(drawn.exit_code, 0) << drawn.err;
  EXPECT_NE(
      drawn.out.find("assembly modes at start (as the poses draw it):\n    RRR dyad coupler + "
                     "rocker (joint C): B -> C -> D turns clockwise; the other mode closes "
                     "too: [[branch]] points = [\"B\", \"C\", \"D\"], turn = \"ccw\"\n"),
      std::string::npos)
      << drawn.out;
  // Without poses: taken by default, and said so.
  std::string undrawn =
      read_file(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/fourbar_crank_rocker.toml");
  for (size_t at; (at = undrawn.find("\npose = ")) != std::string::npos;)
    undrawn.erase(at, undrawn.find('\n', at + 1) - at);
  const CommandRun by_default =
      crosslink("check \"" + write_definition("undrawn.toml", undrawn) + "\"");
  ASSERT_EQ(by_default.exit_code, 0) << by_default.err;
  EXPECT_NE(by_default.out.find("assembly modes at start (by default: no poses drawn, no "
                                "[[branch]]):"),
            std::string::npos)
      << by_default.out;
  // Named: the crossed circuit.
  const CommandRun named = crosslink(
      "check \"" +
      write_definition("named.toml",
                       undrawn + "\n[[branch]]\npoints = [\"B\", \"C\", \"D\"]\nturn = \"ccw\"\n") +
      "\"");
  ASSERT_EQ(named.exit_code, 0) << named.err;
  EXPECT_NE(named.out.find("(as [[branch]] asks: B -> C -> D turns counter-clockwise (line "),
            std::string::npos)
      << named.out;
  EXPECT_NE(named.out.find("B -> C -> D turns counter-clockwise; the other mode closes too: "
                           "[[branch]] points = [\"B\", \"C\", \"D\"], turn = \"cw\""),
            std::string::npos)
      << named.out;
}

TEST(Cli, CheckRejectsABadFileWithItsLocation) {
  // Line 3 names a unit that does not exist; the value starts at column 10.
  const std::string path = write_definition("bad.toml",
                                            "name = \"x\"\n[units]\nlength = \"inch\"\n"
                                            "angle = \"deg\"\n");
  const CommandRun run = crosslink("check \"" + path + "\"");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find(path + ":3:10: error: unknown unit 'inch'"), std::string::npos) << run.err;
  EXPECT_EQ(run.out.find("error"), std::string::npos) << "errors belong on stderr: " << run.out;
}

TEST(Cli, CheckReportsAChainThatCannotAssembleWithTheDriverValue) {
  // Ground AD 0.10, crank AB 0.08 at 180 degrees: |BD| = 0.18 m > BC + CD = 0.04 + 0.05.
  crosslink::test::CrankRockerText open = crosslink::test::crank_rocker(180.0, "speed = 1\n");
  open.moving =
      "\n[[link]]\nname = \"crank\"\npoints = { A = [0, 0], B = [0.08, 0] }\n"
      "pose = [0, 0, 180]\n[[link]]\nname = \"coupler\"\n"
      "points = { B = [0, 0], C = [0.04, 0] }\n[[link]]\nname = \"rocker\"\n"
      "points = { D = [0, 0], C = [0.05, 0] }\n";
  const std::string text = open.text();
  const std::string path = write_definition("open.toml", text);
  const int driver_line = crosslink::test::line_of(text, "[driver]");
  const CommandRun run = crosslink("check \"" + path + "\"");
  EXPECT_EQ(run.exit_code, 2);
  // At the place of the [driver] table, whose start value cannot be assembled.
  EXPECT_NE(run.err.find(fmt::format("{}:{}:1: error: cannot assemble at driver = 180 deg", path,
                                     driver_line)),
            std::string::npos)
      << run.err;
  const CommandRun solve = crosslink("solve \"" + path + "\" --at 180");
  EXPECT_EQ(solve.exit_code, 2);
  EXPECT_NE(solve.err.find(
                fmt::format("{}:{}:1: error: cannot_assemble at driver = 180", path, driver_line)),
            std::string::npos)
      << solve.err;
}

nlohmann::json solve_json(const std::string& args, int expected_exit = 0) {
  const CommandRun run = crosslink(std::string("solve ") + kSewing + " " + args + " --format json");
  EXPECT_EQ(run.exit_code, expected_exit) << run.err;
  try {
    return nlohmann::json::parse(run.out);
  } catch (const nlohmann::json::exception& e) {
    ADD_FAILURE() << "not JSON (" << e.what() << "):\n" << run.out.substr(0, 400);
    return {};
  }
}

TEST(Cli, SolveAtOneValueGivesTheDocumentedJsonInSi) {
  const nlohmann::json j = solve_json("--at 135");
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j.at("status"), "ok");
  EXPECT_EQ(j.at("units"), "SI");
  EXPECT_EQ(j.at("mechanism"), "Sewing machine needle drive");
  EXPECT_NEAR(j.at("driver").get<double>(), 135 * kDeg, 1e-12);
  EXPECT_NEAR(j.at("time").get<double>(), 0.0, 1e-12);  // 135 is the start value
  ASSERT_TRUE(j.at("events").is_array());

  // Every moving link, named point and slider, with every documented field.
  for (const char* link : {"crank", "coupler", "bell_crank", "needle_link", "needle"})
    for (const char* field : {"angle", "omega", "alpha"})
      EXPECT_TRUE(j.at("links").at(link).at(field).is_number()) << link << "." << field;
  EXPECT_FALSE(j.at("links").contains("ground"));
  for (const char* point : {"A", "G", "D", "B", "C", "E", "F"})
    for (const char* field : {"x", "y", "vx", "vy", "ax", "ay"})
      EXPECT_TRUE(j.at("points").at(point).at(field).is_number()) << point << "." << field;
  for (const char* field : {"s", "sdot", "sddot"})
    EXPECT_TRUE(j.at("sliders").at("needle").at(field).is_number()) << field;

  // SI: the crank at 135 degrees = 2.356 rad, 240 rpm = 8 pi rad/s, no angular acceleration.
  const nlohmann::json& crank = j["links"]["crank"];
  EXPECT_NEAR(crank["angle"].get<double>(), 135 * kDeg, 1e-9);
  EXPECT_NEAR(crank["omega"].get<double>(), 8 * kPi, 1e-9);
  EXPECT_NEAR(crank["alpha"].get<double>(), 0.0, 1e-6);
  // B is 1.60 cm from A at 135 degrees: position in m, v = omega x r, a = -omega^2 r.
  const double r = 0.016, w = 8 * kPi, c = std::cos(135 * kDeg), s = std::sin(135 * kDeg);
  const nlohmann::json& b = j["points"]["B"];
  EXPECT_NEAR(b["x"].get<double>(), r * c, 1e-12);
  EXPECT_NEAR(b["y"].get<double>(), r * s, 1e-12);
  EXPECT_NEAR(b["vx"].get<double>(), -w * r * s, 1e-9);
  EXPECT_NEAR(b["vy"].get<double>(), w * r * c, 1e-9);
  EXPECT_NEAR(b["ax"].get<double>(), -w * w * r * c, 1e-6);
  EXPECT_NEAR(b["ay"].get<double>(), -w * w * r * s, 1e-6);
  // Ground points stay put: G = (-1.42, 0) cm.
  EXPECT_NEAR(j["points"]["G"]["x"].get<double>(), -0.0142, 1e-12);
  EXPECT_EQ(j["points"]["G"]["vx"].get<double>(), 0.0);
  // The needle's displacement, printed as 1.12 cm in the notes, in metres.
  EXPECT_NEAR(j["sliders"]["needle"]["s"].get<double>(), 0.0112, 0.0001);
}

TEST(Cli, SolveSweepJsonHasSamples) {
  const nlohmann::json j = solve_json("");
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j.at("status"), "ok");
  const nlohmann::json& samples = j.at("samples");
  // The crank turns fully: 0..360 degrees in 1 degree steps, both ends included.
  ASSERT_EQ(samples.size(), 361u);
  EXPECT_NEAR(samples[0].at("driver").get<double>(), 135 * kDeg, 1e-12);
  EXPECT_NEAR(samples[360].at("driver").get<double>(), 495 * kDeg, 1e-9);
  // One revolution at 240 rpm takes 0.25 s.
  EXPECT_NEAR(samples[360].at("time").get<double>(), 0.25, 1e-12);
  EXPECT_EQ(samples[90].at("status"), "ok");
  EXPECT_TRUE(samples[90].at("links").at("coupler").at("omega").is_number());
  EXPECT_TRUE(j.at("events").is_array());
}

// The default method (dyads) on a coarse grid: each sample is the pose that `--at` and Newton give
// at its value (the issue's report: 130.53 deg for the coupler at 315 deg on a 90-degree grid,
// against 104.09 deg), with no invented events and exit 0.
TEST(Cli, CoarseStepsGiveTheSamePosesAsAt) {
  for (const int step : {45, 60, 90, 120}) {
    const nlohmann::json sweep = solve_json("--step " + std::to_string(step));
    ASSERT_TRUE(sweep.is_object());
    EXPECT_TRUE(sweep.at("events").empty()) << step << ": " << sweep.at("events").dump();
    for (const nlohmann::json& sample : sweep.at("samples")) {
      const double driver = sample.at("driver").get<double>() / kDeg;
      ASSERT_EQ(sample.at("status"), "ok") << step << " at " << driver;
      const nlohmann::json at = solve_json(fmt::format("--at {:.15g} --method newton", driver));
      for (const char* link : {"coupler", "bell_crank", "needle_link"})
        EXPECT_NEAR(std::remainder(sample["links"][link]["angle"].get<double>() -
                                       at["links"][link]["angle"].get<double>(),
                                   2 * kPi),
                    0.0, 1e-9)
            << link << " at " << driver << " on a " << step << "-degree grid";
    }
  }
}

TEST(Cli, SolveCsvHeaderAndRows) {
  const CommandRun run = crosslink(std::string("solve ") + kSewing + " --format csv");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::istringstream lines(run.out);
  std::string header;
  std::getline(lines, header);
  EXPECT_EQ(header.rfind("sample,time,driver,status,", 0), 0u) << header;
  for (const char* channel :
       {",angle.crank,", ",omega.coupler,", ",alpha.needle,", ",x.B,", ",vy.F,", ",a.F,",
        ",s.needle,", ",sdot.needle,", ",sddot.needle,", ",torque.driver,", ",fx.A,", ",fy.needle,",
        ",f.C,", ",fn.needle,", ",moment.needle,", ",shaking_fx.ground,", ",shaking_fy.ground,"})
    EXPECT_NE(header.find(channel), std::string::npos) << channel;
  EXPECT_EQ(header.substr(header.size() - 22), ",shaking_moment.ground");
  const auto fields = [](const std::string& line) {
    return std::count(line.begin(), line.end(), ',') + 1;
  };
  int rows = 0;
  for (std::string line; std::getline(lines, line);) {
    EXPECT_EQ(fields(line), fields(header)) << line.substr(0, 80);
    ++rows;
  }
  EXPECT_EQ(rows, 361);
}

// The fields of one CSV record (RFC 4180: a field in double quotes may hold commas, and "" is a
// quote), read independently of crosslink's writer.
std::vector<std::string> rfc4180_fields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      fields.back() += '"';
      ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

// `text` with every `from` replaced by `to`.
std::string replaced_all(std::string text, const std::string& from, const std::string& to) {
  for (size_t at = 0; (at = text.find(from, at)) != std::string::npos; at += to.size())
    text.replace(at, from.size(), to);
  return text;
}

// A link named with a comma and a quote shifted every column of the CSV header (65 header
// fields against 62 in each row): every CSV writer quotes its names (RFC 4180).
TEST(Cli, CsvNamesWithCommasAndQuotesStayOneField) {
  const std::string fourbar =
      write_definition("comma.toml", replaced_all(read_file("mechanisms/fourbar_crank_rocker.toml"),
                                                  "\"rocker\"", "\"rock,\\\"er\""));
  // A01 for 20 of its 2000 seconds: the names are the point, not the benchmark's span.
  const std::string pendulum =
      write_definition("comma_pendulum.toml",
                       replaced_all(replaced_all(read_file("mechanisms/iftomm_a01_pendulum.toml"),
                                                 "\"pendulum\"", "\"pend,\\\"ulum\""),
                                    "duration = 2000 ", "duration = 20 "));
  ASSERT_NE(read_file(pendulum).find("duration = 20 "), std::string::npos);
  const std::filesystem::path compare_csv = scratch_dir() / "comma_compare.csv";
  struct Case {
    std::string command, csv_file, name;
  };
  for (const Case& c :
       {Case{"solve \"" + fourbar + "\" --format csv", "", "angle.rock,\"er"},
        Case{"simulate \"" + pendulum + "\" --format csv", "", "angle.pend,\"ulum"},
        Case{"compare \"" + fourbar + "\" --engines analytic,dyads --csv " + compare_csv.string(),
             compare_csv.string(), "angle.rock,\"er"}}) {
    const CommandRun run = crosslink(c.command);
    ASSERT_EQ(run.exit_code, 0) << c.command << ": " << run.err;
    std::istringstream lines(c.csv_file.empty() ? run.out : read_file(c.csv_file));
    std::string header;
    std::getline(lines, header);
    const size_t columns = rfc4180_fields(header).size();
    const std::vector<std::string> names = rfc4180_fields(header);
    const bool in_header = std::find(names.begin(), names.end(), c.name) != names.end();
    int rows = 0, named = 0;
    for (std::string line; std::getline(lines, line); ++rows) {
      const std::vector<std::string> fields = rfc4180_fields(line);
      EXPECT_EQ(fields.size(), columns) << c.command << ": " << line.substr(0, 120);
      named += std::find(fields.begin(), fields.end(), c.name) != fields.end();
    }
    EXPECT_GT(rows, 1) << c.command;
    // solve and simulate name channels in the header, compare in a column of each row.
    EXPECT_TRUE(in_header || named > 0) << c.command << ": no field '" << c.name << "' in\n"
                                        << header;
  }
}

// A header of 100,000 dotted keys (200 kB) crashed the TOML parser with SIGSEGV: now every
// command that reads it exits 2 with a located message.
TEST(Cli, AHostileHeaderIsBadInputNotACrash) {
  std::string header = "[a";
  for (int k = 1; k < 100000; ++k) header += ".a";
  const std::string path = write_definition("hostile.toml", header + "]\n");
  for (const char* command : {"check", "solve", "compare", "sweep"}) {
    const CommandRun run = crosslink(std::string(command) + " \"" + path + "\"");
    EXPECT_EQ(run.exit_code, 2) << command << ": " << run.err.substr(0, 300);
    EXPECT_NE(run.err.find(path + ":1:33: error: a key of more than 16 dotted parts"),
              std::string::npos)
        << command << ": " << run.err.substr(0, 300);
  }
}

// The sewing machine with `line` added to its [driver] table; `line_number` gets its line.
std::string sewing_with(const std::string& name, const std::string& line, int* line_number) {
  std::string text = read_file(kSewing);
  *line_number = crosslink::test::line_of(text, "\nspeed = 240") + 1;
  text.insert(text.find("\nspeed = 240") + 1, line + "\n");
  return write_definition(name, text);
}

// The issue's typo, range = [-30, 1e9] degrees at 1-degree steps, made check and solve run for
// ever: now refused at once, at the range, with the count, the limit and the option.
TEST(Cli, ARangeTypoIsRefusedBeforeAnyWork) {
  int line = 0;
  const std::string path = sewing_with("typo.toml", "range = [-30, 1e9]", &line);
  for (const char* command : {"check", "solve", "compare", "sweep"}) {
    const CommandRun run = crosslink(std::string(command) + " \"" + path + "\"");
    EXPECT_EQ(run.exit_code, 2) << command;
    EXPECT_NE(run.err.find(path + ":" + std::to_string(line) +
                           ":9: error: driver.range = [-30, 1e+09] deg at a step of 1 deg asks "
                           "for 1000000031 samples: the limit is 100000 (raise it with "
                           "--max-samples N)"),
              std::string::npos)
        << command << ": " << run.err;
  }
}

// --max-samples on every command: the sewing machine's 361 samples at 1 degree (a full turn,
// both ends) pass a limit of 361 and are refused at 360, naming the step.
TEST(Cli, MaxSamplesSetsTheLimit) {
  for (const char* command : {"check", "solve", "compare", "sweep"}) {
    const std::string base = std::string(command) + " " + kSewing + " --max-samples ";
    const CommandRun refused = crosslink(base + "360");
    EXPECT_EQ(refused.exit_code, 2) << command;
    EXPECT_NE(refused.err.find("the default step of 1 degree asks for 361 samples: the limit is "
                               "360 (raise it with --max-samples N)"),
              std::string::npos)
        << command << ": " << refused.err;
  }
  EXPECT_EQ(crosslink(std::string("check ") + kSewing + " --max-samples 361").exit_code, 0);
  // 2-degree steps: 181 samples.
  const CommandRun coarse =
      crosslink(std::string("solve ") + kSewing + " --step 2 --max-samples 181 --format csv");
  EXPECT_EQ(coarse.exit_code, 0) << coarse.err;
  EXPECT_EQ(std::count(coarse.out.begin(), coarse.out.end(), '\n'), 1 + 181);
}

TEST(Cli, SolveAtAFarOrNonFiniteValueIsRefused) {
  // From the drawn 135 degrees to 1e7 degrees: 27,777 turns, skipped (the crank turns fully),
  // and 145 degrees, plus the turn that shows the chain back at its pose, in steps of at most 1
  // degree.
  const CommandRun far = crosslink(std::string("solve ") + kSewing + " --at 1e7 --max-samples 504");
  EXPECT_EQ(far.exit_code, 2);
  EXPECT_NE(far.err.find("--at 1e+07 deg asks for 505 continuation steps"), std::string::npos)
      << far.err;
  EXPECT_EQ(crosslink(std::string("solve ") + kSewing + " --at 1e7").exit_code, 0);
  const CommandRun nan = crosslink(std::string("solve ") + kSewing + " --at nan");
  EXPECT_EQ(nan.exit_code, 2);
  EXPECT_NE(nan.err.find("--at: nan is not a finite number"), std::string::npos) << nan.err;
}

// Every numeric option of every command refuses NaN, infinities and values out of its range
// before any work, exit 2, naming the option: `simulate --tolerance nan` wrote every sample ok
// with a 54 % energy error (rkf78), or never ended (dopri5). Each case here would otherwise run
// (or, for --at nan, fail later without the option's name).
TEST(Cli, EveryNumericOptionRefusesNanInfinityAndOutOfRange) {
  const std::string fourbar = " mechanisms/fourbar_crank_rocker.toml ";
  const std::string pendulum = " mechanisms/iftomm_a01_pendulum.toml ";
  for (const auto& [command, option] : std::vector<std::pair<std::string, std::string>>{
           {"check" + fourbar + "--max-samples nan", "--max-samples"},
           {"check" + fourbar + "--max-samples 1e300", "--max-samples"},
           {"solve" + fourbar + "--at inf", "--at"},
           {"solve" + fourbar + "--step nan", "--step"},
           {"solve" + fourbar + "--step -1", "--step"},
           {"solve" + fourbar + "--step 0", "--step"},
           {"solve" + fourbar + "--step inf", "--step"},
           {"simulate" + pendulum + "--tolerance nan", "--tolerance"},
           {"simulate" + pendulum + "--tolerance inf", "--tolerance"},
           {"simulate" + pendulum + "--tolerance 0.5", "--tolerance"},
           {"simulate" + pendulum + "--duration nan", "--duration"},
           {"simulate" + pendulum + "--duration 0", "--duration"},
           {"simulate" + pendulum + "--at inf", "--at"},
           {"simulate" + pendulum + "--at -1", "--at"},
           {"compare" + fourbar + "--engines analytic --at nan", "--at"},
           {"compare" + fourbar + "--engines analytic --step nan", "--step"},
           {"compare" + fourbar + "--engines analytic --tolerance velocity=nan", "--tolerance"},
           {"compare" + fourbar + "--engines analytic --tolerance velocity=inf", "--tolerance"},
           {"compare" + fourbar + "--engines analytic --tolerance dyads:angle=1e7", "--tolerance"},
           {"compare" + fourbar + "--engines analytic --accuracy inf", "--accuracy"},
           {"compare" + fourbar + "--engines analytic --accuracy nan%", "--accuracy"},
           {"compare" + fourbar + "--engines analytic --max-steps nan", "--max-steps"},
           {"compare" + fourbar + "--engines analytic --max-steps 1e300", "--max-steps"},
           {"sweep" + fourbar + "--dt 1e-3,nan", "--dt"},
           {"sweep" + fourbar + "--dt inf", "--dt"},
           {"sweep" + fourbar + "--step inf", "--step"},
           {"sweep" + fourbar + "--repeat nan", "--repeat"},
           {"sweep" + fourbar + "--accuracy 1e300", "--accuracy"},
           {"sweep" + fourbar + "--max-samples -5", "--max-samples"}}) {
    const CommandRun run = crosslink(command);
    EXPECT_EQ(run.exit_code, 2) << command << ": " << run.err;
    EXPECT_NE(run.err.find(option), std::string::npos) << command << ": " << run.err;
    EXPECT_EQ(run.out.find("verdict"), std::string::npos) << command << ": nothing runs";
  }
}

// An explicit engine time step is refused before any engine runs when it would take more steps
// than --max-steps: the sewing machine's turn lasts 0.25 s, so dt = 1e-9 s is 2.5e8 steps.
TEST(Cli, AnEngineTimeStepBeyondMaxStepsIsRefused) {
  const CommandRun compare =
      crosslink(std::string("compare ") + kSewing + " --engines analytic,mujoco --set dt=1e-9");
  EXPECT_EQ(compare.exit_code, 2);
  EXPECT_NE(compare.err.find("dt = 1e-09 s takes 250000000 steps over the run: the limit is "
                             "2000000 steps (raise it with --max-steps N"),
            std::string::npos)
      << compare.err;
  const CommandRun sweep =
      crosslink(std::string("sweep ") + kSewing + " --dt 1e-4 --max-steps 2000");
  EXPECT_EQ(sweep.exit_code, 2);
  EXPECT_NE(sweep.err.find("--dt 0.0001: dt = 0.0001 s takes 2500 steps over the run: the limit is "
                           "2000 steps"),
            std::string::npos)
      << sweep.err;
}

// A step the engine chooses itself (dt auto) is held to the same limit by the engine: the run
// is refused, and the comparison fails saying why.
TEST(Cli, AnEngineRefusesARunBeyondMaxSteps) {
  const CommandRun run = crosslink(std::string("compare ") + kSewing +
                                   " --engines analytic,mujoco,bullet --max-steps 100");
  EXPECT_EQ(run.exit_code, 1) << run.err;
  EXPECT_GE(static_cast<int>(std::count(run.out.begin(), run.out.end(), '\n')), 1);
  size_t found = 0;
  for (size_t at = 0; (at = run.out.find("the limit is 100 steps", at)) != std::string::npos; ++at)
    ++found;
  EXPECT_GE(found, 2u) << "both engines should say so:\n" << run.out;
}

// The bundled crank-rocker four-bar (mechanisms/fourbar_crank_rocker.toml, m and deg, drawn at
// crank angle 0) with its motion law replaced by `law`, the [driver] table's last keys.
std::string crank_rocker_with(const std::string& name, const std::string& law) {
  const std::string text = read_file("mechanisms/fourbar_crank_rocker.toml");
  return write_definition(name, text.substr(0, text.find("speed = 240")) + law);
}

// Issue 13: check shows the driver's speed as the file wrote it.
TEST(Cli, CheckShowsTheDriverSpeedInTheFilesUnit) {
  const CommandRun rpm = crosslink(std::string("check ") + kSewing);  // speed = 240, rpm
  EXPECT_NE(rpm.out.find(", constant speed 240 rpm\n"), std::string::npos) << rpm.out;
  const CommandRun deg = crosslink(
      "check \"" + crank_rocker_with("deg_s.toml", "speed = -90\nspeed_unit = \"deg/s\"\n") + "\"");
  EXPECT_NE(deg.out.find(", constant speed -90 deg/s\n"), std::string::npos) << deg.out;
  const CommandRun rad =
      crosslink("check \"" + crank_rocker_with("rad_s.toml", "speed = 2.5\n") + "\"");
  EXPECT_NE(rad.out.find(", constant speed 2.5 rad/s\n"), std::string::npos) << rad.out;
  // A slider's speed is in the file's length unit per second (speed = 100, in mm).
  const CommandRun slider = crosslink("check mechanisms/singular/slider_crank_from_slider.toml");
  EXPECT_NE(slider.out.find(", constant speed 100 mm/s\n"), std::string::npos) << slider.out;
  // A dynamics case has no motion law: its [dynamics] table (rate 0, a 3-row effort, 2 s).
  const CommandRun dynamics = crosslink("check mechanisms/slider_crank_spring_motor.toml");
  EXPECT_NE(dynamics.out.find(", free coordinate (dynamics): initial rate 0 rad/s, applied effort "
                              "table of 3 rows, 2 s\n"),
            std::string::npos)
      << dynamics.out;
  EXPECT_EQ(dynamics.out.find("constant speed"), std::string::npos) << dynamics.out;
}

// Issue 13: every CSV number is written in the shortest form that reads back as the same double.
// A field is checked two ways: it reads back as the value solve's JSON holds for the same sample
// (nlohmann writes every double so that it reads back exactly), and a stream's default (%g) format
// with one significant digit fewer does not read back as the same double (so no shorter text would
// do).
int significant_digits(const std::string& field) {
  std::string digits;
  for (const char c : field) {
    if (c == 'e' || c == 'E') break;
    if (std::isdigit(static_cast<unsigned char>(c)) && !(digits.empty() && c == '0')) digits += c;
  }
  while (!digits.empty() && digits.back() == '0') digits.pop_back();
  return static_cast<int>(digits.size());
}

bool is_shortest(const std::string& field) {
  const double value = std::stod(field);
  const int digits = significant_digits(field);
  if (digits <= 1) return true;
  std::ostringstream shorter;
  shorter << std::setprecision(digits - 1) << value;
  return std::stod(shorter.str()) != value;
}

std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  for (std::string field; std::getline(in, field, ',');) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

TEST(Cli, CsvNumbersAreShortestAndReadBackExactly) {
  const CommandRun csv = crosslink(std::string("solve ") + kSewing + " --format csv");
  ASSERT_EQ(csv.exit_code, 0) << csv.err;
  const nlohmann::json json = solve_json("");
  ASSERT_TRUE(json.contains("samples"));
  std::istringstream lines(csv.out);
  std::string line;
  std::getline(lines, line);
  const std::vector<std::string> header = csv_fields(line);
  int row = 0, compared = 0, numbers = 0;
  for (; std::getline(lines, line); ++row) {
    const std::vector<std::string> fields = csv_fields(line);
    ASSERT_EQ(fields.size(), header.size()) << line.substr(0, 80);
    const nlohmann::json& sample = json.at("samples").at(static_cast<size_t>(row));
    for (size_t c = 1; c < fields.size(); ++c) {
      if (fields[c].empty() || header[c] == "status") continue;
      ++numbers;
      EXPECT_TRUE(is_shortest(fields[c]))
          << header[c] << " = " << fields[c] << " (row " << row << ")";
      // The same value in the JSON document, where the schema has it.
      const std::string& name = header[c];
      const std::string kind = name.substr(0, name.find('.'));
      const std::string object = name.substr(name.find('.') + 1);
      const nlohmann::json* expected = nullptr;
      if (name == "time" || name == "driver")
        expected = &sample.at(name);
      else if (kind == "angle" || kind == "omega" || kind == "alpha")
        expected = &sample.at("links").at(object).at(kind);
      else if (kind == "x" || kind == "y" || kind == "vx" || kind == "vy" || kind == "ax" ||
               kind == "ay")
        expected = &sample.at("points").at(object).at(kind);
      else if (kind == "s" || kind == "sdot" || kind == "sddot")
        expected = &sample.at("sliders").at(object).at(kind);
      if (!expected) continue;
      ASSERT_TRUE(expected->is_number()) << name << " row " << row;
      EXPECT_EQ(std::stod(fields[c]), expected->get<double>())
          << name << " = " << fields[c] << " (row " << row << ")";
      ++compared;
    }
  }
  EXPECT_EQ(row, 361);
  EXPECT_GT(compared, 361 * 20);
  EXPECT_GT(numbers, compared);

  // compare --csv: every number, and the driver values are solve's.
  const std::string path = (scratch_dir() / "compare.csv").string();
  const CommandRun compare = crosslink(std::string("compare ") + kSewing +
                                       " --engines analytic,dyads --csv \"" + path + "\"");
  ASSERT_EQ(compare.exit_code, 0) << compare.err;
  std::istringstream compare_lines(read_file(path));
  std::getline(compare_lines, line);
  EXPECT_EQ(line,
            "method,channel,quantity,sample,driver,reference_status,method_status,in_verdict,"
            "reason,reference,value,difference,pct_of_peak,local_pct,time");
  int compare_rows = 0;
  while (std::getline(compare_lines, line)) {
    const std::vector<std::string> fields = csv_fields(line);
    ASSERT_EQ(fields.size(), 15u) << line;
    for (const size_t c : {4, 9, 10, 11, 12, 13, 14}) {
      if (fields[c].empty()) continue;
      EXPECT_TRUE(is_shortest(fields[c])) << line;
    }
    const int k = std::stoi(fields[3]);
    EXPECT_EQ(std::stod(fields[4]),
              json.at("samples").at(static_cast<size_t>(k)).at("driver").get<double>())
        << line;
    ++compare_rows;
  }
  EXPECT_GT(compare_rows, 361);
}

// The trust issue: a value that does not exist is never a number, in any output. A non-Grashof
// four-bar swept over a range past its toggle (78.28 deg) has samples that cannot assemble
// (no value at all) and, at the toggles, samples with a position but no rates or forces.
TEST(Cli, NoOutputHoldsANumberForAValueThatDoesNotExist) {
  std::string text = read_file("mechanisms/singular/fourbar_non_grashof.toml");
  text.replace(text.find("speed_unit = \"rpm\""), 18, "speed_unit = \"rpm\"\nrange = [0, 90]");
  const std::string file = write_definition("past_toggles.toml", text);
  // A value exists for a status and a quantity as docs/json.md says.
  const auto exists = [](const std::string& status, const std::string& kind) {
    const bool position =
        kind == "x" || kind == "y" || kind == "angle" || kind == "s" || kind == "mu";
    return status == "ok" || (status == "singular" && position);
  };
  // Over the range past the toggles, and over the assembling range (a sample on each toggle).
  int cannot = 0, singular = 0;
  std::string line;
  for (const std::string& swept :
       {file, std::string("mechanisms/singular/fourbar_non_grashof.toml")}) {
    const CommandRun csv = crosslink("solve " + swept + " --method newton --format csv");
    ASSERT_EQ(csv.exit_code, 0) << csv.err;
    std::istringstream lines(csv.out);
    std::getline(lines, line);
    const std::vector<std::string> header = csv_fields(line);
    while (std::getline(lines, line)) {
      const std::vector<std::string> f = csv_fields(line);
      ASSERT_EQ(f.size(), header.size());
      cannot += f[3] == "cannot_assemble";
      singular += f[3] == "singular";
      for (size_t c = 4; c < f.size(); ++c)
        EXPECT_EQ(!f[c].empty(), exists(f[3], header[c].substr(0, header[c].find('.'))))
            << header[c] << " at " << f[2] << " (" << f[3] << ")";
    }
  }
  EXPECT_GT(cannot, 0);
  EXPECT_GT(singular, 0);

  const std::string path = (scratch_dir() / "past_toggles.csv").string();
  const CommandRun compare =
      crosslink("compare " + file + " --engines analytic,dyads --csv \"" + path + "\"");
  ASSERT_LE(compare.exit_code, 1) << compare.err;
  std::istringstream rows(read_file(path));
  std::getline(rows, line);
  int checked = 0;
  while (std::getline(rows, line)) {
    const std::vector<std::string> f = csv_fields(line);
    ASSERT_EQ(f.size(), 15u);
    const std::string kind = f[1].substr(0, f[1].find('.'));
    const bool position = f[2] == "position" || f[2] == "angle";
    const bool has_ref = exists(f[5], position ? "x" : kind);
    const bool has_value = exists(f[6], position ? "x" : kind);
    EXPECT_EQ(!f[9].empty(), has_ref) << line;
    EXPECT_EQ(!f[10].empty(), has_value) << line;
    if (!has_ref || !has_value) {
      EXPECT_TRUE(f[11].empty() && f[12].empty()) << line;
    }
    // Every sample out of the verdict says why; every sample in it has no reason.
    EXPECT_EQ(f[7] == "0", !f[8].empty()) << line;
    checked += !has_ref;
  }
  EXPECT_GT(checked, 0);

  const CommandRun json = crosslink("solve " + file + " --method newton --format json");
  ASSERT_EQ(json.exit_code, 0) << json.err;
  int nulls = 0;
  const nlohmann::json document = nlohmann::json::parse(json.out);
  for (const nlohmann::json& sample : document.at("samples"))
    for (const auto& [name, link] : sample.at("links").items())
      for (const char* kind : {"angle", "omega", "alpha"}) {
        const bool is_number = link.at(kind).is_number();
        EXPECT_EQ(is_number, exists(sample.at("status"), kind)) << name << "." << kind;
        nulls += !is_number;
      }
  EXPECT_GT(nulls, 0);
}

// Issue 13: a constant angular acceleration of the driver, a key of its own beside the speed it
// starts from. The crank-rocker's crank from 60 rpm (omega0 = 2 pi rad/s) at alpha = 10 rad/s^2,
// by both exact methods: over the default cycle, one turn (alpha T^2 / 2 + omega0 T = 2 pi),
// every sample follows theta = theta0 + omega0 t + alpha t^2 / 2 (theta0 = 0), and the crank pin
// B (AB = 0.04 m along the crank) moves on its circle: v = omega k x AB,
// a = alpha k x AB - omega^2 AB.
TEST(Cli, ADriverAtConstantAccelerationFollowsItsClosedForm) {
  const std::string path = crank_rocker_with(
      "accelerating.toml", "speed = 60\nspeed_unit = \"rpm\"\nacceleration = 10\n");
  const double omega0 = 2.0 * kPi, alpha = 10.0, ab = 0.04;
  const double turn = (-omega0 + std::sqrt(omega0 * omega0 + 4.0 * kPi * alpha)) / alpha;
  const CommandRun check = crosslink("check \"" + path + "\"");
  EXPECT_EQ(check.exit_code, 0) << check.err;
  EXPECT_NE(check.out.find(fmt::format(
                "constant acceleration 10 rad/s^2 from speed 60 rpm, over {:.6g} s", turn)),
            std::string::npos)
      << check.out;
  for (const char* method : {"newton", "dyads"}) {
    const CommandRun run =
        crosslink("solve \"" + path + "\" --format json --method " + std::string(method));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const nlohmann::json samples = nlohmann::json::parse(run.out).at("samples");
    ASSERT_EQ(samples.size(), 361u);
    EXPECT_NEAR(samples.back().at("time").get<double>(), turn, 1e-12);
    EXPECT_NEAR(samples.back().at("driver").get<double>(), 2.0 * kPi, 1e-12);
    for (const nlohmann::json& s : samples) {
      ASSERT_EQ(s.at("status"), "ok");
      const double t = s.at("time").get<double>();
      const double theta = omega0 * t + 0.5 * alpha * t * t, omega = omega0 + alpha * t;
      EXPECT_NEAR(s.at("driver").get<double>(), theta, 1e-12) << method << " t = " << t;
      const nlohmann::json& crank = s.at("links").at("crank");
      EXPECT_NEAR(std::remainder(crank.at("angle").get<double>() - theta, 2.0 * kPi), 0.0, 1e-9);
      EXPECT_NEAR(crank.at("omega").get<double>(), omega, 1e-9) << method << " t = " << t;
      EXPECT_NEAR(crank.at("alpha").get<double>(), alpha, 1e-9) << method << " t = " << t;
      const nlohmann::json& b = s.at("points").at("B");
      const double c = std::cos(theta), n = std::sin(theta);
      EXPECT_NEAR(b.at("vx").get<double>(), -omega * ab * n, 1e-9);
      EXPECT_NEAR(b.at("vy").get<double>(), omega * ab * c, 1e-9);
      EXPECT_NEAR(b.at("ax").get<double>(), -alpha * ab * n - omega * omega * ab * c, 1e-9);
      EXPECT_NEAR(b.at("ay").get<double>(), alpha * ab * c - omega * omega * ab * n, 1e-9);
    }
  }
  // A single pose: the drawn position, where the rate and acceleration are the given ones.
  const CommandRun at = crosslink("solve \"" + path + "\" --at 0 --format json");
  ASSERT_EQ(at.exit_code, 0) << at.err;
  const nlohmann::json pose = nlohmann::json::parse(at.out);
  EXPECT_EQ(pose.at("time").get<double>(), 0.0);
  EXPECT_NEAR(pose.at("links").at("crank").at("omega").get<double>(), omega0, 1e-12);
  EXPECT_NEAR(pose.at("links").at("crank").at("alpha").get<double>(), alpha, 1e-12);
}

// "path:line:col" of `marker` in the file at `path`, plus `offset` characters.
std::string place_in(const std::string& path, const std::string& marker, size_t offset = 0) {
  const std::string text = read_file(path);
  const size_t at = text.find(marker) + offset;
  const size_t line_start = text.rfind('\n', at);
  return fmt::format("{}:{}:{}", path, 1 + std::count(text.begin(), text.begin() + at, '\n'),
                     at - (line_start == std::string::npos ? 0 : line_start + 1) + 1);
}

// Issue 13: speed 0 states a position problem, one pose at rest: `solve --at` gives it with
// every rate zero (at rest), the same pose as at any speed; a sweep is refused at the key.
TEST(Cli, SpeedZeroIsASinglePoseAtRest) {
  const std::string path = crank_rocker_with("at_rest.toml", "speed = 0\n");
  const CommandRun at = crosslink("solve \"" + path + "\" --at 30 --format json");
  ASSERT_EQ(at.exit_code, 0) << at.err;
  const nlohmann::json pose = nlohmann::json::parse(at.out);
  const CommandRun turning =
      crosslink("solve mechanisms/fourbar_crank_rocker.toml --at 30 --format json");
  ASSERT_EQ(turning.exit_code, 0) << turning.err;
  const nlohmann::json moving = nlohmann::json::parse(turning.out);
  EXPECT_EQ(pose.at("status"), "ok");
  EXPECT_EQ(pose.at("time").get<double>(), 0.0);
  EXPECT_NEAR(pose.at("links").at("crank").at("angle").get<double>(), 30.0 * kDeg, 1e-12);
  for (const auto& [name, link] : pose.at("links").items()) {
    EXPECT_NEAR(link.at("angle").get<double>(),
                moving.at("links").at(name).at("angle").get<double>(), 1e-12)
        << name;
    EXPECT_EQ(link.at("omega").get<double>(), 0.0) << name;
    EXPECT_EQ(link.at("alpha").get<double>(), 0.0) << name;
  }
  for (const auto& [name, point] : pose.at("points").items())
    for (const char* rate : {"vx", "vy", "ax", "ay"})
      EXPECT_EQ(point.at(rate).get<double>(), 0.0) << name << " " << rate;

  const std::string speed = place_in(path, "speed = 0", 8);  // the value
  for (const std::string command : {"solve", "compare"}) {
    const CommandRun sweep = crosslink(command + " \"" + path + "\"");
    EXPECT_EQ(sweep.exit_code, 2) << command;
    EXPECT_NE(sweep.err.find(speed + ": error: [driver] 'speed' = 0 states one pose at rest"),
              std::string::npos)
        << command << ": " << sweep.err;
  }
  const CommandRun check = crosslink("check \"" + path + "\"");
  EXPECT_EQ(check.exit_code, 0) << check.err;
  EXPECT_NE(check.out.find("constant speed 0 rad/s"), std::string::npos) << check.out;
  EXPECT_NE(check.out.find("assembly at start: ok"), std::string::npos) << check.out;
  EXPECT_NE(check.out.find("speed 0: one pose at rest"), std::string::npos) << check.out;
}

// Issue 13: compare's console gives the results first and the methods' settings after them, and
// counts apart the channels whose values the definition prescribes. The crank-rocker
// (mechanisms/fourbar_crank_rocker.toml) has 3 moving links (3 channels each: angle, omega,
// alpha) and 4 points (8 each: x, y, vx, vy, v, ax, ay, a), 41 kinematic channels, and the
// transmission angle mu.C, all of which the dyads compute; A and D are on the ground (16
// channels) and the crank is driven against the ground (3): 19 prescribed, 23 computed.
TEST(Cli, CompareShowsResultsFirstAndCountsPrescribedChannelsApart) {
  const std::string json = (scratch_dir() / "crank_rocker.json").string();
  const std::string html = (scratch_dir() / "crank_rocker.html").string();
  const CommandRun run =
      crosslink("compare mechanisms/fourbar_crank_rocker.toml --engines analytic,dyads --json \"" +
                json + "\" --report \"" + html + "\"");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const size_t summary = run.out.find("summary per quantity class");
  const size_t methods = run.out.find("\nmethods\n");
  const size_t settings = run.out.find("newton.tolerance=");
  const size_t verdict = run.out.find("verdict: ");
  ASSERT_NE(summary, std::string::npos) << run.out;
  ASSERT_NE(methods, std::string::npos) << run.out;
  EXPECT_LT(summary, methods) << run.out;
  EXPECT_LT(methods, settings) << run.out;
  EXPECT_LT(settings, verdict) << run.out;
  // The summary's pass/fail counts computed channels only: the dyads' positions are x and y of B
  // and C (those of A and D, on the ground, are prescribed); their angles, the coupler's, the
  // rocker's and mu.C (the crank's is driven).
  for (const std::string row : {"position      dyads", "angle         dyads"}) {
    const size_t at = run.out.find(row);
    ASSERT_NE(at, std::string::npos) << run.out;
    const std::string line = run.out.substr(at, run.out.find('\n', at) - at);
    EXPECT_TRUE(line.ends_with(row[0] == 'p' ? " 4/0" : " 3/0")) << line;
  }
  const std::string counts =
      "23 channel comparisons: 23 pass, 0 fail, 0 n/a; 19 more of values the definition "
      "prescribes (ground points, the driven coordinate): 19 pass, 0 fail, 0 n/a";
  EXPECT_NE(run.out.find("verdict: PASS (" + counts + ")\n"), std::string::npos)
      << run.out.substr(verdict);
  // The report's verdict line counts them as the console does.
  EXPECT_NE(read_file(html).find("PASS</b> (" + counts + ")"), std::string::npos);
  // The JSON marks each channel.
  const nlohmann::json document = nlohmann::json::parse(read_file(json));
  int prescribed = 0;
  for (const nlohmann::json& c : document.at("channels")) {
    const std::string name = c.at("channel");
    const bool expected = name.substr(name.find('.') + 1) == "A" ||
                          name.substr(name.find('.') + 1) == "D" || name.ends_with(".crank");
    EXPECT_EQ(c.at("prescribed").get<bool>(), expected) << name;
    prescribed += expected;
  }
  EXPECT_EQ(prescribed, 19);
}

// The trust issue: a comparison with forces shows their verdicts on the console summary like
// every other class, and says which samples it kept out of which verdicts and why: the
// change-point four-bar's samples on and beside its two change points (all channels), and for
// the forces also those within about 4 degrees, where its conditioning falls below 0.15 of its
// own (docs/compare.md); the JSON and CSV say the same per channel.
TEST(Cli, CompareShowsForceVerdictsAndWhatItKeptOut) {
  const std::string json = (scratch_dir() / "change_point.json").string();
  const CommandRun run =
      crosslink("compare mechanisms/fourbar_change_point.toml --engines analytic,mujoco --json \"" +
                json + "\"");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* row : {"force         mujoco", "torque        mujoco"})
    EXPECT_NE(run.out.find(row), std::string::npos) << row << "\n" << run.out;
  const size_t kept = run.out.find("kept out of verdicts");
  ASSERT_NE(kept, std::string::npos) << run.out;
  const std::string block = run.out.substr(kept, run.out.find("\nmethods\n") - kept);
  EXPECT_NE(block.find("mujoco angle, velocity, acceleration, position: 6 of 361 samples (4 "
                       "beside_singular, 2"),
            std::string::npos)
      << block;
  EXPECT_NE(block.find("mujoco torque, force:"), std::string::npos) << block;
  EXPECT_NE(block.find("ill_conditioned"), std::string::npos) << block;
  const nlohmann::json document = nlohmann::json::parse(read_file(json));
  for (const nlohmann::json& c : document.at("channels")) {
    int excluded = 0;
    for (const nlohmann::json& e : c.at("excluded")) excluded += e.at("samples").get<int>();
    EXPECT_EQ(c.at("usable_samples").get<int>() + excluded, 361) << c.at("channel");
    const std::string q = c.at("quantity");
    if (q == "force" || q == "torque")
      EXPECT_GT(excluded, 6) << c.at("channel");
    else
      EXPECT_EQ(excluded, 6) << c.at("channel");
  }
}

// Issue 13: solve's sweep table shows what the notes ask for, in the file's units: each link's
// angle, omega and alpha and each slider's s, sdot, sddot by default, or the --columns chosen.
TEST(Cli, SolveSweepTableShowsTheChosenColumnsInFileUnits) {
  const CommandRun table = crosslink(std::string("solve ") + kSewing);
  ASSERT_EQ(table.exit_code, 0) << table.err;
  std::istringstream lines(table.out);
  std::string title, header, units;
  std::getline(lines, title);
  std::getline(lines, header);
  std::getline(lines, units);
  std::vector<std::string> names, unit_names;
  for (std::istringstream in(header); in >> title;) names.push_back(title);
  for (std::istringstream in(units); in >> title;) unit_names.push_back(title);
  for (const char* column : {"angle.coupler", "omega.coupler", "alpha.coupler", "s.needle",
                             "sdot.needle", "sddot.needle"})
    EXPECT_NE(std::find(names.begin(), names.end(), column), names.end()) << header;
  // Units: the definition's cm and deg (the first unit is the driver's). "turns" (the crank
  // from 135 to 495 deg passes one turn) and "status" have none.
  ASSERT_EQ(names[1], "turns") << header;
  ASSERT_EQ(unit_names.size() + 2, names.size()) << units;
  EXPECT_EQ(unit_names[0], "[deg]");
  const auto unit_of = [&](const std::string& column) {
    const auto at = std::find(names.begin(), names.end(), column) - names.begin();
    return unit_names[static_cast<size_t>(at - 2)];
  };
  EXPECT_EQ(unit_of("alpha.coupler"), "[rad/s^2]");
  EXPECT_EQ(unit_of("sddot.needle"), "[cm/s^2]");
  // The row at 135 deg holds the values of solve --at 135 (SI there), in cm and to 4 decimals.
  const nlohmann::json at = solve_json("--at 135");
  bool found = false;
  for (std::string line; std::getline(lines, line) && !line.empty();) {  // the table's rows
    std::istringstream in(line);
    std::vector<std::string> fields;
    for (std::string f; in >> f;) fields.push_back(f);
    if (fields.empty() || std::abs(std::stod(fields[0]) - 135.0) > 1e-9) continue;
    found = true;
    const auto field = [&](const std::string& column) {
      return std::stod(fields[static_cast<size_t>(std::find(names.begin(), names.end(), column) -
                                                  names.begin())]);
    };
    EXPECT_NEAR(field("sddot.needle"),
                at.at("sliders").at("needle").at("sddot").get<double>() / 0.01, 1e-4);
    EXPECT_NEAR(field("alpha.coupler"), at.at("links").at("coupler").at("alpha").get<double>(),
                1e-4);
  }
  EXPECT_TRUE(found) << "no row at 135 deg";

  const CommandRun chosen =
      crosslink(std::string("solve ") + kSewing + " --columns x.F,vy,alpha.coupler");
  ASSERT_EQ(chosen.exit_code, 0) << chosen.err;
  std::istringstream chosen_lines(chosen.out);
  std::getline(chosen_lines, title);
  std::getline(chosen_lines, header);
  std::vector<std::string> chosen_names;
  for (std::istringstream in(header); in >> title;) chosen_names.push_back(title);
  ASSERT_GE(chosen_names.size(), 6u) << header;  // driver, turns, status, then the columns
  EXPECT_EQ(chosen_names[3], "x.F");
  EXPECT_EQ(chosen_names[4].rfind("vy.", 0), 0u);
  EXPECT_EQ(chosen_names.back(), "alpha.coupler");

  const CommandRun unknown = crosslink(std::string("solve ") + kSewing + " --columns speed");
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("--columns: 'speed' is neither a channel"), std::string::npos)
      << unknown.err;
  const CommandRun single = crosslink(std::string("solve ") + kSewing + " --at 135 --columns x.F");
  EXPECT_EQ(single.exit_code, 2);
}

// Issue 13: an engine setting that does not exist, or a value an engine cannot take, is bad input
// (exit 2) before anything runs, naming the setting and the ones the engine knows; it used to
// fail the engine's run (exit 1) under a verdict that said otherwise.
TEST(Cli, AnUnknownSettingIsBadInputBeforeAnyRun) {
  const std::string compare = std::string("compare ") + kSewing;
  const CommandRun typo = crosslink(compare + " --set mujoco:dtt=1");
  EXPECT_EQ(typo.exit_code, 2) << typo.out;
  EXPECT_NE(typo.err.find("unknown MuJoCo setting \"dtt\" (known: dt, max_step_angle,"),
            std::string::npos)
      << typo.err;
  EXPECT_EQ(typo.out.find("verdict"), std::string::npos) << "nothing runs:\n" << typo.out;
  // A bare key goes to every engine that runs: MuJoCo's integrator is not Bullet's.
  const CommandRun bare = crosslink(compare + " --engines analytic,bullet --set integrator=RK4");
  EXPECT_EQ(bare.exit_code, 2);
  EXPECT_NE(bare.err.find("unknown Bullet setting \"integrator\" (known: formulation,"),
            std::string::npos)
      << bare.err;
  // A value a run reports is not input: Bullet's steps_per_sample is a setting, MuJoCo's the
  // count its run reports.
  const CommandRun reported = crosslink(compare + " --set steps_per_sample=3");
  EXPECT_EQ(reported.exit_code, 2);
  EXPECT_NE(reported.err.find("MuJoCo setting \"steps_per_sample\" is reported by the run, not "
                              "set; a bare KEY=VALUE goes to every engine that runs"),
            std::string::npos)
      << reported.err;
  // ENGINE:KEY is checked whether that engine runs or not; the prefix must be an engine.
  const CommandRun idle = crosslink(compare + " --engines analytic --set bullet:erp=2");
  EXPECT_EQ(idle.exit_code, 2);
  EXPECT_NE(idle.err.find("setting erp = \"2\": expected a number in (0, 1]"), std::string::npos)
      << idle.err;
  const CommandRun prefix = crosslink(compare + " --engines analytic --set adams:dt=1");
  EXPECT_EQ(prefix.exit_code, 2);
  // The engine table's names, in its order (more engines follow MuJoCo and Bullet).
  EXPECT_NE(prefix.err.find("'adams' is not an engine (engines: mujoco, bullet"), std::string::npos)
      << prefix.err;
  const CommandRun value = crosslink(compare + " --engines analytic,mujoco --set dt=fast");
  EXPECT_EQ(value.exit_code, 2);
  EXPECT_NE(value.err.find("setting dt = \"fast\": expected a positive number"), std::string::npos)
      << value.err;
}

// A value an engine cannot take is bad input (exit 2) before anything runs, not a failed verdict
// (exit 1): out of its range, not a whole number, beyond an int (3e9 iterations ran Bullet with
// -2147483648 and passed), or a link the definition does not have. ENGINE:KEY is checked
// whether that engine runs or not, so none of these runs an engine.
TEST(Cli, AnEngineSettingsValueIsCheckedBeforeAnyRun) {
  const std::string compare =
      "compare mechanisms/fourbar_crank_rocker.toml --engines analytic --set ";
  for (const auto& [setting, expected] : std::vector<std::pair<std::string, std::string>>{
           {"mujoco:dt=-1", "setting dt = \"-1\": expected a positive number"},
           {"bullet:dt=0", "setting dt = \"0\": expected a positive number"},
           {"mujoco:max_step_angle=0", "setting max_step_angle = \"0\": expected a positive"},
           {"bullet:max_step_angle=-1", "setting max_step_angle = \"-1\": expected 0 or a"},
           {"bullet:iterations=3e9",
            "setting iterations = \"3e9\": expected a whole number "
            "from 1 to 1000000"},
           {"mujoco:iterations=1e300", "setting iterations = \"1e300\": expected a whole"},
           {"mujoco:iterations=2.5", "setting iterations = \"2.5\": expected a whole"},
           {"bullet:steps_per_sample=1e300",
            "setting steps_per_sample = \"1e300\": expected a whole number from 1 to 2147483647"},
           {"bullet:perturb_link=nosuch:2",
            "setting perturb_link = \"nosuch:2\": expected \"<moving link>:<positive factor>\" "
            "(moving links: crank, coupler, rocker)"},
           {"mujoco:perturb_link=coupler:-1", "setting perturb_link = \"coupler:-1\""},
           {"mujoco:singular_rcond=2",
            "setting singular_rcond = \"2\": expected a number in [0, 1]"},
           {"bullet:divergence_gap=0", "setting divergence_gap = \"0\": expected a positive"},
           {"mujoco:tolerance=nan", "setting tolerance = \"nan\": expected 0 or a positive"},
           {"mujoco:integrator=Newton",
            "setting integrator = \"Newton\": expected Euler, RK4 or implicit"}}) {
    const CommandRun run = crosslink(compare + setting);
    EXPECT_EQ(run.exit_code, 2) << setting << ": " << run.err;
    EXPECT_NE(run.err.find(expected), std::string::npos) << setting << ": " << run.err;
    EXPECT_EQ(run.out.find("verdict"), std::string::npos) << setting << ": nothing runs";
  }
}

// The settings grid of `sweep` multiplies its work: --repeat and the --dt list are bounded too.
TEST(Cli, TheSweepGridIsBounded) {
  const CommandRun repeat = crosslink(std::string("sweep ") + kSewing + " --repeat 101");
  EXPECT_EQ(repeat.exit_code, 2);
  EXPECT_NE(repeat.err.find("--repeat: Value 101 not in range 1 to 100"), std::string::npos)
      << repeat.err;
  std::string dts = "1e-3";
  for (int k = 1; k < 51; ++k) dts += ",1e-3";
  const CommandRun grid = crosslink(std::string("sweep ") + kSewing + " --dt " + dts);
  EXPECT_EQ(grid.exit_code, 2);
  EXPECT_NE(grid.err.find("--dt: 51 time steps: the limit is 50"), std::string::npos) << grid.err;
}

// `crosslink simulate`: the exact dynamics in the schema of `solve --at` plus the energy
// (docs/json.md). Andrews' squeezer against the Test Set for IVP Solvers' reference at 0.03 s
// (problem "andrews", subroutine solut): beta = 15.81077119629904, epsilon = 1.048080741042263.
nlohmann::json simulate_json(const std::string& args) {
  const CommandRun run = crosslink("simulate " + args + " --format json");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  try {
    return nlohmann::json::parse(run.out);
  } catch (const nlohmann::json::exception& e) {
    ADD_FAILURE() << "not JSON (" << e.what() << "):\n" << run.out.substr(0, 400);
    return {};
  }
}

TEST(Cli, SimulateAtGivesTheSolveSchemaPlusTheEnergy) {
  const nlohmann::json j = simulate_json("mechanisms/andrews_squeezer.toml --at 0.03");
  ASSERT_TRUE(j.is_object());
  EXPECT_EQ(j.at("status"), "ok");
  EXPECT_EQ(j.at("units"), "SI");
  EXPECT_NEAR(j.at("time").get<double>(), 0.03, 1e-15);
  const nlohmann::json& links = j.at("links");
  EXPECT_NEAR(links.at("body1").at("angle").get<double>(), 15.81077119629904, 1e-8 * 15.81);
  EXPECT_NEAR(links.at("body7").at("angle").get<double>(), 1.048080741042263, 1e-8);
  // The same fields as solve --at's document.
  const nlohmann::json solve = solve_json("--at 135");
  for (const auto& [key, value] : solve.items()) EXPECT_TRUE(j.contains(key)) << key;
  for (const char* field : {"x", "y", "vx", "vy", "ax", "ay"})
    EXPECT_TRUE(j.at("points").at("D").at(field).is_number()) << field;
  // The driver's multiplier along the simulated motion is the motor torque that drives it.
  EXPECT_NEAR(j.at("forces").at("driver").get<double>(), 0.033, 1e-10 * 0.033);
  EXPECT_TRUE(j.at("forces").at("joints").at("E3").at("fx").is_number());
  // The energy balance: kinetic + potential - initial - work of the motor torque.
  const nlohmann::json& e = j.at("energy");
  const double balance = e.at("kinetic").get<double>() + e.at("potential").get<double>() -
                         e.at("initial").get<double>() - e.at("work").get<double>();
  EXPECT_NEAR(e.at("balance").get<double>(), balance, 1e-15);
  EXPECT_LT(std::abs(balance), 1e-10 * e.at("kinetic").get<double>());
  // The motor's work: 0.033 N m over the crank's turn (beta - beta0).
  EXPECT_NEAR(e.at("work").get<double>(),
              0.033 * (links["body1"]["angle"].get<double>() + 0.0617138900142764), 1e-12);
}

TEST(Cli, SimulateRunAsJsonAndCsv) {
  const nlohmann::json j = simulate_json("mechanisms/andrews_squeezer.toml --duration 0.01");
  ASSERT_TRUE(j.is_object());
  ASSERT_EQ(j.at("samples").size(), 21u);  // 0.01 s at the case's interval of 0.5 ms
  EXPECT_NEAR(j["samples"][20]["time"].get<double>(), 0.01, 1e-15);
  EXPECT_TRUE(j["samples"][20]["energy"]["balance"].is_number());
  const CommandRun csv =
      crosslink("simulate mechanisms/andrews_squeezer.toml --duration 0.01 --format csv");
  ASSERT_EQ(csv.exit_code, 0) << csv.err;
  std::istringstream lines(csv.out);
  std::string header;
  std::getline(lines, header);
  EXPECT_EQ(header.rfind("sample,time,driver,status,", 0), 0u) << header;
  EXPECT_NE(header.find(",energy.kinetic,energy.potential,energy.work,energy.balance"),
            std::string::npos)
      << header;
  int rows = 0;
  for (std::string line; std::getline(lines, line);) ++rows;
  EXPECT_EQ(rows, 21);
}

TEST(Cli, SimulateRefusesWhatItCannotRun) {
  const CommandRun kinematic = crosslink(std::string("simulate ") + kSewing);
  EXPECT_EQ(kinematic.exit_code, 2);
  EXPECT_NE(kinematic.err.find("not a dynamics case"), std::string::npos) << kinematic.err;
  const CommandRun longer = crosslink("simulate mechanisms/andrews_squeezer.toml --duration 1e6");
  EXPECT_EQ(longer.exit_code, 2);
  EXPECT_NE(longer.err.find("--max-samples"), std::string::npos) << longer.err;
  const CommandRun negative = crosslink("simulate mechanisms/andrews_squeezer.toml --at -1");
  EXPECT_EQ(negative.exit_code, 2);
  EXPECT_NE(negative.err.find("--at"), std::string::npos) << negative.err;
}

// A dynamics case's work limit is located like a kinematic one: at the key that asked for the
// work ([dynamics] 'duration': 0.03 s at 0.0005 s is 61 samples), or naming the option.
TEST(Cli, ADynamicsCasesWorkLimitIsLocatedAtItsDuration) {
  const std::string path = "mechanisms/andrews_squeezer.toml";
  const CommandRun run = crosslink("simulate " + path + " --max-samples 60");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find(place_in(path, "duration = ", 11) +
                         ": error: [dynamics] 'duration' = 0.03 s at the case's interval of "
                         "0.0005 s asks for 61 samples: the limit is 60 (raise it with "
                         "--max-samples N)"),
            std::string::npos)
      << run.err;
  EXPECT_EQ(crosslink("simulate " + path + " --max-samples 61 --format csv").exit_code, 0);
  const CommandRun option = crosslink("simulate " + path + " --duration 0.06 --max-samples 61");
  EXPECT_EQ(option.exit_code, 2);
  EXPECT_NE(option.err.find(path + ": --duration 0.06 s at the case's interval of 0.0005 s asks "
                                   "for 121 samples: the limit is 61"),
            std::string::npos)
      << option.err;
}

// A dynamics case started at a singular position (the slider-crank driven from its slider, at
// its outer toggle): check, simulate and compare all refuse it at its [dynamics] table, exit 2.
TEST(Cli, ADynamicsCaseStartedAtAToggleIsRefusedWhereItIsDefined) {
  std::string text = read_file("mechanisms/singular/slider_crank_from_slider.toml");
  text.replace(text.find("start = 60"), 10, "start = 79.372539331937716");
  text.replace(text.find("speed = 100"), 11, "# speed");
  text = text.substr(0, text.find("[expect]")) +
         "[dynamics]\nduration = 0.1\ninterval = 0.01\nrate = 100\n";
  const std::string path = write_definition("toggle_start.toml", text);
  const int line = static_cast<int>(std::count(text.begin(), text.end(), '\n')) - 3;
  for (const std::string command : {"check", "simulate", "compare"}) {
    const CommandRun run = crosslink(command + " \"" + path + "\"");
    EXPECT_EQ(run.exit_code, 2) << command;
    EXPECT_NE(run.err.find(fmt::format("toggle_start.toml:{}:1: error: ", line)), std::string::npos)
        << command << ": " << run.err;
    EXPECT_NE(run.err.find("is a singular position of the coordinate"), std::string::npos)
        << command << ": " << run.err;
  }
}

// Issue 13: --version, and a definition read from standard input ("-").
TEST(Cli, VersionAndStandardInput) {
  const CommandRun version = crosslink("--version");
  EXPECT_EQ(version.exit_code, 0);
  EXPECT_EQ(version.out.rfind("crosslink ", 0), 0u) << version.out;
  const CommandRun piped = crosslink("check - < mechanisms/fourbar_crank_rocker.toml");
  EXPECT_EQ(piped.exit_code, 0) << piped.err;
  EXPECT_NE(piped.out.find("mobility: M = 3(n-1) - 2 j1 - j2"), std::string::npos) << piped.out;
  const std::string bad = (scratch_dir() / "bad.toml").string();
  std::ofstream(bad) << "name = \"x\"\n[units]\nlength = \"m\"\nangle = \"deg\"\n[[link]]\n";
  const CommandRun error = crosslink("check - < \"" + bad + "\"");
  EXPECT_EQ(error.exit_code, 2);
  EXPECT_EQ(error.err.rfind("<stdin>:", 0), 0u) << error.err;
}

// Issue 23, item 3. `solve --at` outside the driver's assembling range printed a pose of blanks at
// "t = 0 s" (the JSON and CSV a sample of nulls): an error in every format, naming the value and
// the range `check` reports, nothing on stdout. The non-Grashof four-bar (crank a = 40, coupler
// b = 30, rocker c = 35, ground d = 60 mm) cannot close past the toggles where coupler and rocker
// are in line: cos theta = (a^2 + d^2 - (b + c)^2) / (2 a d).
TEST(Cli, SolveAtOutsideTheAssemblingRangeNamesTheRange) {
  const double a = 40, b = 30, c = 35, d = 60;
  const double limit = std::acos((a * a + d * d - (b + c) * (b + c)) / (2 * a * d)) / kDeg;
  const std::string path = "mechanisms/singular/fourbar_non_grashof.toml";
  const std::string expected = fmt::format(
      "{}:{}:1: error: cannot_assemble at driver = 100 deg: outside the driver's assembling "
      "range, {:.6f} to {:.6f} deg",
      path, crosslink::test::line_of(read_file(path), "[driver]"), -limit, limit);
  for (const char* format : {"table", "json", "csv"}) {
    const CommandRun run = crosslink("solve " + path + " --at 100 --format " + format);
    EXPECT_EQ(run.exit_code, 2) << format;
    EXPECT_EQ(run.out, "") << format;
    EXPECT_NE(run.err.find(expected), std::string::npos) << format << ": " << run.err;
  }
}

// `solve --at` of a definition with masses prints the forces the sweep has, the same channels in
// the same units (the file's: N, N mm), against the sweep's own sample at the drawn 30 degrees.
TEST(Cli, SolveAtPrintsTheForcesOfTheSweep) {
  const std::string path = "mechanisms/singular/fourbar_non_grashof.toml";
  const CommandRun sweep = crosslink("solve " + path + " --format csv");
  ASSERT_EQ(sweep.exit_code, 0) << sweep.err;
  std::istringstream lines(sweep.out);
  std::string line;
  std::getline(lines, line);
  const std::vector<std::string> header = csv_fields(line);
  std::vector<std::string> at_start;
  while (std::getline(lines, line))
    if (const std::vector<std::string> f = csv_fields(line); std::stod(f[2]) == 30 * kDeg)
      at_start = f;
  ASSERT_EQ(at_start.size(), header.size());
  const CommandRun at = crosslink("solve " + path + " --at 30");
  ASSERT_EQ(at.exit_code, 0) << at.err;
  int forces = 0;
  for (size_t c = 0; c < header.size(); ++c) {
    const std::string kind = header[c].substr(0, header[c].find('.'));
    const bool torque = kind == "torque" || kind == "shaking_moment";
    if (!torque && kind != "fx" && kind != "fy" && kind != "f" && kind != "shaking_fx" &&
        kind != "shaking_fy")
      continue;
    ++forces;
    const size_t row = at.out.find("\n" + header[c] + " ");
    ASSERT_NE(row, std::string::npos) << header[c] << " not in\n" << at.out;
    std::istringstream fields(at.out.substr(row + 1 + header[c].size()));
    double value = 0;
    std::string unit;
    fields >> value >> std::ws;
    std::getline(fields, unit);
    EXPECT_EQ(unit, torque ? "N mm" : "N") << header[c];
    // Four decimals in N, or N mm for a torque (1 N m = 1000 N mm).
    EXPECT_NEAR(value, std::stod(at_start[c]) * (torque ? 1000 : 1), 0.5e-4) << header[c];
  }
  EXPECT_EQ(forces, 1 + 3 * 4 + 3);  // torque, fx fy f of the four joints, the shaking
}

// Driver values past one turn: within the turn, the whole turns counted, on the console; JSON
// and CSV keep the value as swept (docs/json.md). The sewing machine's crank starts at 135 deg.
TEST(Cli, ADriverPastOneTurnShowsTheAngleWithinItsTurn) {
  const CommandRun second = crosslink(std::string("solve ") + kSewing + " --at 548.37");
  ASSERT_EQ(second.exit_code, 0) << second.err;
  EXPECT_NE(second.out.find(fmt::format("driver = {:.4f} deg +1 turn ", 548.37 - 360)),
            std::string::npos)
      << second.out.substr(0, 200);
  const CommandRun back = crosslink(std::string("solve ") + kSewing + " --at -400");
  ASSERT_EQ(back.exit_code, 0) << back.err;
  EXPECT_NE(back.out.find(fmt::format("driver = {:.4f} deg -1 turn ", -400 + 360.0)),
            std::string::npos)
      << back.out.substr(0, 200);
  const nlohmann::json j = solve_json("--at 548.37");
  EXPECT_NEAR(j.at("driver").get<double>(), 548.37 * kDeg, 1e-12);
  // The sweep from 135 to 495 deg: 400 deg is 40 deg in the column of turns' +1.
  const CommandRun table = crosslink(std::string("solve ") + kSewing);
  ASSERT_EQ(table.exit_code, 0) << table.err;
  EXPECT_NE(table.out.find("    driver turns   status"), std::string::npos)
      << table.out.substr(0, 300);
  EXPECT_NE(table.out.find(fmt::format("\n{:>10.4f}    +1       ok ", 400 - 360.0)),
            std::string::npos);
  EXPECT_NE(table.out.find(fmt::format("\n{:>10.4f}     0       ok ", 200.0)), std::string::npos);
}

// A sample past the limit of the assembling range (an explicit range beyond the toggle) has no
// pose; its time is still its own, (driver - start) / speed, as the Newton sweep's. The dyads kept
// the time of the last pose they solved (0.1333 s on every sample past 78.28 deg), and `solve
// --at` out of range said "t = 0 s".
TEST(Cli, ASamplePastTheLimitHasItsOwnTime) {
  std::string text = read_file("mechanisms/singular/fourbar_non_grashof.toml");
  text.replace(text.find("speed_unit = \"rpm\""), 18, "speed_unit = \"rpm\"\nrange = [0, 90]");
  const std::string file = write_definition("past_the_limit.toml", text);
  const double start = 30 * kDeg, speed = 2 * kPi;  // 60 rpm
  std::vector<std::vector<std::string>> runs[2];
  const char* const methods[2] = {"dyads", "newton"};
  for (int k = 0; k < 2; ++k) {
    const CommandRun csv = crosslink("solve " + file + " --method " + methods[k] + " --format csv");
    ASSERT_EQ(csv.exit_code, 0) << csv.err;
    std::istringstream lines(csv.out);
    std::string line;
    std::getline(lines, line);
    while (std::getline(lines, line)) runs[k].push_back(csv_fields(line));
  }
  ASSERT_EQ(runs[0].size(), runs[1].size());
  int past = 0;
  for (size_t r = 0; r < runs[0].size(); ++r) {
    const double driver = std::stod(runs[0][r][2]), time = std::stod(runs[0][r][1]);
    EXPECT_NEAR(time, (driver - start) / speed, 1e-15) << "dyads sample " << r;
    EXPECT_EQ(runs[0][r][1], runs[1][r][1]) << "sample " << r;
    past += runs[0][r][3] == "cannot_assemble";
  }
  EXPECT_GT(past, 0);
}

// `sweep` wrote a line per run (273 on the sewing machine). In a log (stderr not a terminal):
// one line per finished series, an engine variant over its time steps; on a terminal one line
// that every run rewrites.
TEST(Cli, SweepProgressIsALinePerSeriesInALogAndOneLineOnATerminal) {
  const std::string args = std::string(" sweep mechanisms/fourbar_crank_rocker.toml ") +
                           "--engines bullet --dt 2.8e-3,3.5e-4 --repeat 1";
  const CommandRun log = crosslink(args);
  ASSERT_EQ(log.exit_code, 0) << log.err;
  // The series: the variants of the orders table, each run at both time steps.
  const size_t orders = log.out.find("Observed order");
  ASSERT_NE(orders, std::string::npos);
  std::istringstream table(log.out.substr(orders));
  std::string line;
  std::getline(table, line);
  int series = 0;
  while (std::getline(table, line) && line.rfind("  bullet ", 0) == 0) ++series;
  ASSERT_GT(series, 1);
  std::istringstream lines(log.err);
  int progress = 0;
  while (std::getline(lines, line)) {
    EXPECT_NE(line.find(": 2 runs, dt 0.00278 to 0.000347 s"), std::string::npos) << line;
    ++progress;
  }
  EXPECT_EQ(progress, series) << log.err;

  if (std::system("command -v script >/dev/null 2>&1") != 0)
    GTEST_SKIP() << "no `script` to give the command a terminal";
  const std::filesystem::path typescript = scratch_dir() / "typescript.txt";
  const int code = std::system(("script -qec '\"" + std::string(CROSSLINK_BINARY) + "\"" + args +
                                "' \"" + typescript.string() + "\" >/dev/null 2>&1")
                                   .c_str());
  ASSERT_TRUE(WIFEXITED(code) && WEXITSTATUS(code) == 0) << code;
  const std::string screen = read_file(typescript);
  // Every run rewrote the line ("\r[k/N] ..."), and no progress line was ended but the last.
  const int runs = 2 * series;
  EXPECT_NE(screen.find(fmt::format("\r[{}/{}] ", runs, runs)), std::string::npos) << screen;
  std::istringstream rows(screen);
  int progress_lines = 0;
  while (std::getline(rows, line))
    progress_lines += line.find(fmt::format("/{}] ", runs)) != std::string::npos;
  EXPECT_EQ(progress_lines, 1) << screen;
}

// `sweep` said `ok` of a series whose error grows as its step shrinks: MuJoCo RK4 against a
// per-step driver target (docs/sweep.md: accelerations grow as 1 / dt). Such a series says so on
// the console and in the CSV's message; Euler's falls at second order and says nothing.
TEST(Cli, SweepFlagsASeriesWhoseErrorDoesNotFallWithTheStep) {
  const std::string csv = (scratch_dir() / "rk4.csv").string();
  const CommandRun run = crosslink(
      "sweep mechanisms/fourbar_crank_rocker.toml --engines mujoco --dt 2e-4,1e-4,5e-5 "
      "--repeat 1 --quiet --csv \"" +
      csv + "\"");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::istringstream lines(read_file(csv));
  std::string line;
  std::getline(lines, line);
  const std::vector<std::string> header = rfc4180_fields(line);
  const auto column = [&](const std::string& name) {
    return static_cast<size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  // Per variant, the acceleration errors coarse to fine and the messages.
  std::map<std::string, std::vector<double>> acceleration;
  std::map<std::string, std::string> message;
  while (std::getline(lines, line)) {
    const std::vector<std::string> f = rfc4180_fields(line);
    if (f[0] != "mujoco" || f[column("status")] != "ok") continue;
    acceleration[f[column("variant")]].push_back(std::stod(f[column("max_pct_acceleration")]));
    message[f[column("variant")]] = f[column("message")];
  }
  const std::string rk4 = "RK4/Newton, driver watch 0.05 rad", euler = "Euler/Newton";
  ASSERT_EQ(acceleration[rk4].size(), 3u) << run.out;
  ASSERT_EQ(acceleration[euler].size(), 3u) << run.out;
  // The measured errors themselves: RK4's grows from the coarsest step to the finest, Euler's
  // falls.
  EXPECT_GT(acceleration[rk4].back(), acceleration[rk4].front());
  EXPECT_LT(acceleration[euler].back(), acceleration[euler].front() / 4);
  EXPECT_NE(message[rk4].find("acceleration"), std::string::npos) << message[rk4];
  EXPECT_NE(message[rk4].find("error does not fall as dt shrinks"), std::string::npos)
      << message[rk4];
  EXPECT_EQ(message[euler].find("does not fall"), std::string::npos) << message[euler];
  EXPECT_NE(run.out.find("ok; velocity, acceleration, force error does not fall as dt shrinks"),
            std::string::npos)
      << run.out;
}

// The verdict line names the [[reference]] values shown beside it and how many are within their
// printed rounding, as the JSON's rows count them: with the reference alone and printed values,
// "PASS (0 channel comparisons ...)" said nothing of what was shown.
TEST(Cli, TheVerdictLineCountsTheReferenceValuesItShows) {
  const std::string json = (scratch_dir() / "sewing_references.json").string();
  const CommandRun run = crosslink(
      "compare mechanisms/sewing_machine.toml --engines analytic,dyads "
      "--json \"" +
      json + "\"");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json document = nlohmann::json::parse(read_file(json));
  const nlohmann::json& rows = document.at("references");
  ASSERT_FALSE(rows.empty());
  int within = 0;
  for (const nlohmann::json& r : rows)
    within += r.at("within_rounding").is_boolean() && r.at("within_rounding").get<bool>() ? 1 : 0;
  EXPECT_NE(run.out.find(fmt::format("; {} [[reference]] value{} beside the exact ones, {} within "
                                     "their printed rounding (shown, not judged))\n",
                                     rows.size(), rows.size() == 1 ? "" : "s", within)),
            std::string::npos)
      << run.out.substr(run.out.find("verdict: "));
}

// A failing engine is rerun at half its time step: on the double pendulum, whose engines fail by
// their discretisation, Bullet's failing position falls with the step (order above 1/2); on the
// sewing machine with a coupler 1 % long in the engine's scene, a modelling difference that no
// step takes out, it stays (order 0, to the step's small share of it).
TEST(Cli, TheStepProbeTellsTheStepsErrorFromAModellingDifference) {
  struct Case {
    const char* command;
    double low, high;  // the order expected
  };
  for (const Case& c :
       {Case{"compare mechanisms/dynamics/double_pendulum_mbdyn.toml --engines analytic,bullet",
             0.5, 3.0},
        Case{"compare mechanisms/sewing_machine.toml --engines analytic,bullet --set "
             "perturb_link=coupler:1.01",
             -0.1, 0.1}}) {
    const std::string json = (scratch_dir() / "step_probe.json").string();
    const CommandRun run = crosslink(std::string(c.command) + " --json \"" + json + "\"");
    ASSERT_EQ(run.exit_code, 1) << c.command << "\n" << run.out << run.err;
    const nlohmann::json probes = nlohmann::json::parse(read_file(json)).at("step_probes");
    ASSERT_EQ(probes.size(), 1u) << c.command;
    const nlohmann::json& p = probes[0];
    EXPECT_EQ(p.at("method"), "bullet");
    ASSERT_TRUE(p.at("ok").get<bool>()) << p.dump();
    EXPECT_DOUBLE_EQ(p.at("half_dt").get<double>(), p.at("dt").get<double>() / 2.0);
    const double order = p.at("order").get<double>();
    EXPECT_GT(order, c.low) << c.command;
    EXPECT_LT(order, c.high) << c.command;
    EXPECT_NE(run.out.find("step probe: bullet at half its step"), std::string::npos) << run.out;
  }
}

// `compare` with the reference alone printed "PASS (0 channel comparisons)": nothing was
// compared, which is no pass; exit 2 as for a command line that asks for nothing to judge.
TEST(Cli, CompareWithTheReferenceAloneHasNothingToCompare) {
  const CommandRun run =
      crosslink("compare mechanisms/fourbar_crank_rocker.toml --engines analytic");
  EXPECT_EQ(run.exit_code, 2) << run.out << run.err;
  EXPECT_NE(run.out.find("verdict: NOTHING TO COMPARE (only the reference, analytic, ran"),
            std::string::npos)
      << run.out;
  EXPECT_EQ(run.out.find("PASS"), std::string::npos) << run.out;
}

// --jobs (issue 22): the runs of a sweep or a comparison over a pool of threads give what one
// thread gives. A second run of the same command is the independent source: the engines are
// deterministic, so a serial run is the expected result of a parallel one, field by field; only
// the timings (cost columns, *seconds* keys) differ between any two runs.

// The CSV with the named columns blanked.
std::string without_columns(const std::string& csv, const std::vector<std::string>& names) {
  std::istringstream lines(csv);
  std::string line, out;
  std::vector<size_t> blank;
  for (bool header = true; std::getline(lines, line); header = false) {
    std::vector<std::string> f = rfc4180_fields(line);
    if (header)
      for (size_t c = 0; c < f.size(); ++c)
        if (std::find(names.begin(), names.end(), f[c]) != names.end()) blank.push_back(c);
    for (size_t c : blank)
      if (!header && c < f.size()) f[c].clear();
    for (size_t c = 0; c < f.size(); ++c) out += (c ? "|" : "") + f[c];
    out += "\n";
  }
  return out;
}

// The JSON of a sweep without its costs: the cost keys and the timings in texts.
nlohmann::json without_costs(const nlohmann::json& j) {
  if (j.is_object()) {
    nlohmann::json out = nlohmann::json::object();
    for (const auto& [key, value] : j.items())
      if (key != "wall_s_per_cycle" && key != "cpu_s_per_cycle") out[key] = without_costs(value);
    return out;
  }
  if (j.is_array()) {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& value : j) out.push_back(without_costs(value));
    return out;
  }
  return without_timings(j);
}

std::string csv_without_costs(const std::string& path) {
  // The engines' rank orders them by CPU time: a cost too.
  return std::regex_replace(
      without_columns(read_file(path), {"wall_s_per_cycle", "cpu_s_per_cycle", "rank"}),
      std::regex("; [0-9.e+-]+ s\\b"), "; T s");
}

// Three definitions (a kinematic one, one with forces, a dynamics case) at a cheap setting: a
// single run, and the same split into two and three shards and merged.
TEST(Cli, MergedShardsWriteTheSweepOfOneRun) {
  const std::filesystem::path dir = scratch_dir() / "merge";
  std::filesystem::create_directories(dir);
  const std::string definitions =
      "mechanisms/fourbar_crank_rocker.toml "
      "mechanisms/published/khurmi_slider_crank_gas_force.toml "
      "mechanisms/andrews_squeezer.toml";
  const std::string common = "--engines mujoco --dt 1e-3 --repeat 1 --quiet";
  const std::string settings = common + " --step 10";
  const auto out = [&](const std::string& name) { return (dir / name).string(); };
  CommandRun run =
      crosslink(fmt::format("sweep {} {} --csv {} --json {} --report {}", definitions, settings,
                            out("single.csv"), out("single.json"), out("single.html")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string single_csv = csv_without_costs(out("single.csv"));
  const nlohmann::json single_json = nlohmann::json::parse(read_file(out("single.json")));
  // One row per setting of each definition, led by its path; a page with a section of each.
  EXPECT_EQ(single_csv.substr(0, single_csv.find('|')), "definition");
  for (const char* name :
       {"fourbar_crank_rocker", "khurmi_slider_crank_gas_force", "andrews_squeezer"})
    EXPECT_TRUE(std::regex_search(
        single_csv, std::regex(fmt::format("\nmechanisms/([a-z]+/)?{}\\.toml\\|mujoco\\|", name))))
        << name;
  const std::string page = read_file(out("single.html"));
  for (const char* id :
       {"id=\"d0-cost-position\"", "id=\"d1-render-status\"", "id=\"d2-dt-velocity\""})
    EXPECT_NE(page.find(id), std::string::npos) << id;

  for (int n : {2, 3}) {
    std::string parts;
    for (int i = 0; i < n; ++i) {
      const std::string part = out(fmt::format("part{}of{}.json", i, n));
      run = crosslink(
          fmt::format("sweep {} {} --shard {}/{} --json {}", definitions, settings, i, n, part));
      ASSERT_EQ(run.exit_code, 0) << run.err;
      parts += " " + part;
    }
    run = crosslink(fmt::format(
        "merge{} --csv {} --json {} --report {}", parts, out(fmt::format("merged{}.csv", n)),
        out(fmt::format("merged{}.json", n)), out(fmt::format("merged{}.html", n))));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_EQ(csv_without_costs(out(fmt::format("merged{}.csv", n))), single_csv) << n;
    EXPECT_EQ(without_costs(nlohmann::json::parse(read_file(out(fmt::format("merged{}.json", n))))),
              without_costs(single_json))
        << n;
  }
  // The page and the CSV are functions of the part: merged from the single run's own JSON they
  // are that run's, byte for byte.
  run = crosslink(fmt::format("merge {} --csv {} --report {}", out("single.json"), out("again.csv"),
                              out("again.html")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(read_file(out("again.csv")), read_file(out("single.csv")));
  EXPECT_TRUE(read_file(out("again.html")) == page);

  // Parts that do not fit: each refused with exit 2 and a message saying why.
  const auto refused = [&](const std::string& parts, const std::string& why) {
    const CommandRun r = crosslink("merge " + parts + " --csv " + out("refused.csv"));
    EXPECT_EQ(r.exit_code, 2) << parts;
    EXPECT_NE(r.err.find(why), std::string::npos) << r.err;
  };
  refused(out("part0of2.json"), "shard 1/2 is missing");
  refused(out("part0of2.json") + " " + out("part0of2.json"), "shard 0/2 given twice");
  refused(out("part0of3.json") + " " + out("part1of2.json"), "is a shard of 3");
  // Other settings.
  run = crosslink(fmt::format("sweep {} {} --step 20 --shard 1/2 --json {}", definitions, common,
                              out("other_step.json")));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  refused(out("part0of2.json") + " " + out("other_step.json"), "differ from");
  // A definition whose text changed (a comment more), under the same path.
  const std::filesystem::path copy = dir / "copy";
  for (const char* f : {"mechanisms/fourbar_crank_rocker.toml",
                        "mechanisms/published/khurmi_slider_crank_gas_force.toml",
                        "mechanisms/andrews_squeezer.toml"}) {
    std::filesystem::create_directories((copy / f).parent_path());
    std::ofstream(copy / f) << read_file(std::filesystem::path(CROSSLINK_SOURCE_DIR) / f)
                            << (std::string(f).find("crank_rocker") != std::string::npos
                                    ? "# changed\n"
                                    : "");
  }
  run = crosslink(
      fmt::format("sweep {} {} --shard 1/2 --json {}", definitions, settings, out("changed.json")),
      copy);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  refused(out("part0of2.json") + " " + out("changed.json"), "definitions differ");
  // Another crosslink version; a file that is no part.
  nlohmann::json other = nlohmann::json::parse(read_file(out("part1of2.json")));
  other["crosslink"] = "0.0.1";
  std::ofstream(out("other_version.json")) << other.dump();
  refused(out("part0of2.json") + " " + out("other_version.json"), "written by crosslink");
  std::ofstream(out("not_a_part.json")) << "{\"rows\": []}";
  refused(out("not_a_part.json"), "not a part of a sweep");
  // A bad shard.
  run = crosslink(fmt::format("sweep {} {} --shard 2/2", definitions, settings));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--shard: expected I/N"), std::string::npos) << run.err;
}

TEST(Cli, SweepOverTwoThreadsWritesTheCsvOfOne) {
  std::map<int, std::string> csv, out, err;
  for (int jobs : {1, 2}) {
    const std::string path = (scratch_dir() / fmt::format("jobs{}.csv", jobs)).string();
    const CommandRun run = crosslink(fmt::format(
        "sweep mechanisms/fourbar_crank_rocker.toml --engines mujoco,bullet --dt 1e-3,2e-4 "
        "--repeat 2 --accuracy 1 --jobs {} --csv \"{}\"",
        jobs, path));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    // The cost columns (and the engines' rank, which orders them by CPU time), and the time in
    // the reference's cross-check text.
    csv[jobs] = std::regex_replace(
        without_columns(read_file(path), {"wall_s_per_cycle", "cpu_s_per_cycle", "rank"}),
        std::regex("; [0-9.e+-]+ s\\b"), "; T s");
    out[jobs] = run.out;
    err[jobs] = run.err;
  }
  EXPECT_GT(std::count(csv[1].begin(), csv[1].end(), '\n'), 20) << csv[1];  // both engines ran
  EXPECT_EQ(csv[2], csv[1]);
  // The progress lines (a log's: one per series) come whole and in the grid's order, as a
  // serial run writes them, however the runs finish.
  EXPECT_NE(err[1].find("mujoco Euler/Newton: 2 runs"), std::string::npos) << err[1];
  EXPECT_EQ(err[2], err[1]);
  // The console's choices (their costs aside) are the same too.
  const auto chose = [](const std::string& text) {
    std::string lines;
    std::istringstream in(text);
    for (std::string line; std::getline(in, line);)
      if (line.find("chose") != std::string::npos)
        lines += line.substr(0, line.find(" runs:")) + "\n";
    return lines;
  };
  EXPECT_FALSE(chose(out[1]).empty()) << out[1];
  EXPECT_EQ(chose(out[2]), chose(out[1]));
}

TEST(Cli, CompareOverTwoThreadsWritesTheJsonAndCsvOfOne) {
  std::map<int, nlohmann::json> json;
  std::map<int, std::string> csv;
  for (int jobs : {1, 2}) {
    const std::string j = (scratch_dir() / fmt::format("compare{}.json", jobs)).string(),
                      c = (scratch_dir() / fmt::format("compare{}.csv", jobs)).string();
    const CommandRun run = crosslink(
        fmt::format("compare mechanisms/fourbar_crank_rocker.toml --jobs {} --json \"{}\" "
                    "--csv \"{}\"",
                    jobs, j, c));
    ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
    json[jobs] = without_timings(nlohmann::json::parse(read_file(j)));
    csv[jobs] = read_file(c);
  }
  EXPECT_EQ(json[2], json[1]);
  EXPECT_EQ(csv[2], csv[1]);
  EXPECT_NE(csv[1].find("bullet"), std::string::npos);  // every method ran
  EXPECT_NE(csv[1].find("mujoco"), std::string::npos);
}

TEST(Cli, JobsMustBeAPositiveCount) {
  for (const char* jobs : {"0", "-1", "1.5", "x", "1025"}) {
    const CommandRun run =
        crosslink(std::string("compare mechanisms/fourbar_crank_rocker.toml --jobs ") + jobs);
    EXPECT_EQ(run.exit_code, 2) << jobs << run.out;
    EXPECT_NE(run.err.find("--jobs"), std::string::npos) << jobs << run.err;
  }
}

// Issue 20 item 4: with several drivers `check` counts the singular positions the timed sweep
// located and lists each with its time and kind (it said "none (3 of 361 samples flagged)" and
// then listed one); `solve`'s JSON events carry the kind. The 3-RRR's turning path meets one, a
// direct singularity, at 2.383692193572 s (the closed form, tests/analytic/test_parallel.cpp).
TEST(Cli, CheckListsEachSingularPositionOfSeveralDriversWithItsKind) {
  const CommandRun run = crosslink("check mechanisms/drivers/three_rrr_turning.toml");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("singular positions over the sweep: 1 ("), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("    direct        at t = 2.3836921"), std::string::npos) << run.out;
  EXPECT_EQ(run.out.find("over the sweep: none"), std::string::npos) << run.out;
  const CommandRun json =
      crosslink("solve mechanisms/drivers/three_rrr_turning.toml --format json");
  EXPECT_EQ(json.exit_code, 0) << json.err;
  const nlohmann::json j = nlohmann::json::parse(json.out);
  int direct = 0;
  for (const nlohmann::json& e : j.at("events")) {
    if (!e.contains("singularity")) continue;
    EXPECT_EQ(e.at("singularity"), "direct") << e;
    EXPECT_EQ(e.at("kind"), "singular") << e;
    EXPECT_FALSE(e.contains("chain")) << e;
    EXPECT_NEAR(e.at("time").get<double>(), 2.383692193572, 1e-8) << e;
    ++direct;
  }
  EXPECT_EQ(direct, 1) << j.at("events");
}

// Issue 20 item 4: with several drivers the report's drawing takes --at as a time, as solve
// --at does (it read the value as the first driver's, in the file's degrees, and drew the pose
// at 0.25 deg = 0.0044 s), and its charts mark each singular position with its kind.
TEST(Cli, TheReportDrawsSeveralDriversAtATime) {
  const std::string file = "mechanisms/drivers/fivebar_two_cranks.toml";
  const std::string html = (scratch_dir() / "fivebar_two_cranks.html").string();
  crosslink("compare " + file + " --engines analytic --at 0.25 --report \"" + html + "\"");
  const std::string page = read_file(html);
  const CommandRun at = crosslink("solve " + file + " --at 0.25 --format json");
  ASSERT_EQ(at.exit_code, 0) << at.err;
  const nlohmann::json c = nlohmann::json::parse(at.out).at("points").at("C");
  const std::smatch drawn = [&] {
    std::smatch m;
    std::regex_search(
        page, m, std::regex(R"(\{"kind":"moving","name":"C","x":([-0-9.e]+),"y":([-0-9.e]+)\})"));
    return m;
  }();
  ASSERT_EQ(drawn.size(), 3u) << "no point C in the drawing";
  EXPECT_NEAR(std::stod(drawn[1]) / 1000, c.at("x").get<double>(), 1e-12);  // mm in the page
  EXPECT_NEAR(std::stod(drawn[2]) / 1000, c.at("y").get<double>(), 1e-12);
  EXPECT_NE(page.find(R"x("kind":"inverse singularity (driver left)")x"), std::string::npos);
  EXPECT_NE(page.find(R"x("kind":"inverse singularity (driver right)")x"), std::string::npos);
}

// The data of `compare FILE --engines ENGINES --report`'s page (its `const REPORT = ...`); the
// test fails where the command does.
nlohmann::json report_data(const std::string& file, const std::string& engines) {
  const std::string html =
      (scratch_dir() / (std::filesystem::path(file).stem().string() + "_report.html")).string();
  const CommandRun run =
      crosslink("compare " + file + " --engines " + engines + " --report \"" + html + "\"");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  const std::string page = read_file(html);
  const size_t from = page.find("const REPORT = ") + std::string("const REPORT = ").size();
  return nlohmann::json::parse(page.substr(from, page.find(";</script>", from) - from));
}

// Issue 32 item 4: the report marks the design summary's dead points on its charts and drawing,
// each where the closed form puts it (the offset slider-crank's, crank r = 0.04, rod l = 0.12,
// offset e = 0.01 m: extended at asin(e/(l+r)), folded at 180 deg + asin(e/(l-r))), the stroke's
// ends on the slider's chart (sqrt((l-r)^2-e^2) and sqrt((l+r)^2-e^2)), and draws the path of
// every moving named point, not of the ground's.
TEST(Cli, TheReportMarksTheDeadPointsAndTheStroke) {
  const nlohmann::json r = report_data("mechanisms/slider_crank_offset.toml", "analytic,dyads");
  const double r_ = 0.04, l = 0.12, e = 0.01, deg = 180.0 / std::numbers::pi;
  std::map<std::string, double> dead;
  for (const nlohmann::json& d : r.at("dead_points"))
    dead[d.at("label").get<std::string>()] = d.at("driver").get<double>();
  ASSERT_EQ(dead.size(), 2u) << r.at("dead_points");
  EXPECT_NEAR(dead.at("dead point: s.slider max"), std::asin(e / (l + r_)) * deg, 1e-6);
  EXPECT_NEAR(dead.at("dead point: s.slider min"), 180.0 + std::asin(e / (l - r_)) * deg, 1e-6);
  ASSERT_EQ(r.at("strokes").size(), 1u);
  const nlohmann::json& stroke = r.at("strokes")[0];
  EXPECT_EQ(stroke.at("channel"), "s.slider");
  EXPECT_NEAR(stroke.at("min").get<double>(), std::sqrt((l - r_) * (l - r_) - e * e), 1e-12);
  EXPECT_NEAR(stroke.at("max").get<double>(), std::sqrt((l + r_) * (l + r_) - e * e), 1e-12);
  EXPECT_EQ(r.at("paths"), nlohmann::json::array({"B", "C"}));
}

// The drawing's guides (and slots' chords) of one line or slot, in order.
std::vector<nlohmann::json> drawn_guides(const nlohmann::json& report, const std::string& line) {
  std::vector<nlohmann::json> guides;
  for (const nlohmann::json& g : report.at("drawing").at("guides"))
    if (g.at("line") == line) guides.push_back(g);
  return guides;
}

// A drawn element's point (x, y) or its end (x2, y2).
Eigen::Vector2d vertex(const nlohmann::json& element, const char* x, const char* y) {
  return Eigen::Vector2d(element.at(x).get<double>(), element.at(y).get<double>());
}

// A spline slot is drawn from end to end as chords along its centreline, in the rocker's frame
// at the pose drawn: the first chord starts at S1, the last ends at S7, and every vertex lies
// within a millimetre of the arc the points were taken from (radius 0.12 m about the rocker's C:
// the spline's free ends bend it off by up to 0.5 mm), in order along the chord.
TEST(Cli, TheReportDrawsASplineSlotThroughItsPoints) {
  const nlohmann::json r = report_data("mechanisms/cams/spline_slot_rocker.toml", "analytic,ic");
  const std::vector<nlohmann::json> chords = drawn_guides(r, "slot");
  ASSERT_EQ(chords.size(), 48u);
  // The rocker where the drawing puts it: D, and C at 0.08 m along its x axis (m: the file's).
  std::map<std::string, Eigen::Vector2d> drawn;
  for (const nlohmann::json& p : r.at("drawing").at("points"))
    drawn[p.at("name").get<std::string>()] = vertex(p, "x", "y");
  const Eigen::Vector2d d = drawn.at("D"), c = drawn.at("C");
  const double theta = std::atan2(c.y() - d.y(), c.x() - d.x());
  const auto world = [&](double x, double y) {
    return Eigen::Vector2d(d.x() + std::cos(theta) * x - std::sin(theta) * y,
                           d.y() + std::sin(theta) * x + std::cos(theta) * y);
  };
  const Eigen::Vector2d s1 = world(0.100837781, 0.118176930), s7 = world(-0.038176930, 0.020837781);
  EXPECT_LT((vertex(chords.front(), "x", "y") - s1).norm(), 1e-12);
  EXPECT_LT((vertex(chords.back(), "x2", "y2") - s7).norm(), 1e-12);
  // Each vertex, taken back to the rocker's frame and its chord S1-S7, further along the chord
  // than the one before, and the S points on the drawn curve.
  const Eigen::Vector2d first(0.100837781, 0.118176930),
      along = (Eigen::Vector2d(-0.038176930, 0.020837781) - first).normalized();
  double x_before = -1.0;
  for (size_t i = 0; i < chords.size(); ++i) {
    EXPECT_TRUE(chords[i].at("moving").get<bool>());
    if (i > 0) {
      EXPECT_EQ(vertex(chords[i], "x", "y"), vertex(chords[i - 1], "x2", "y2")) << i;
    }
    const Eigen::Vector2d v = vertex(chords[i], "x", "y") - d;
    const Eigen::Vector2d local(std::cos(theta) * v.x() + std::sin(theta) * v.y(),
                                -std::sin(theta) * v.x() + std::cos(theta) * v.y());
    const double x = along.dot(local - first),
                 y = along.x() * (local - first).y() - along.y() * (local - first).x();
    EXPECT_GT(x, x_before) << i;
    EXPECT_LE(y, 1e-12) << i;  // the arc bulges away from C, to the chord's right
    EXPECT_NEAR((vertex(chords[i], "x", "y") - c).norm(), 0.12, 1e-3) << i;  // near the arc
    x_before = x;
  }
}

// An arc slot has no ends (the pin may go round it): its whole circle, 0.12 m about the rocker's
// C in curved_slot_rocker.toml, as 48 equal chords that close.
TEST(Cli, TheReportDrawsAnArcSlotAsItsCircle) {
  const nlohmann::json r = report_data("mechanisms/cams/curved_slot_rocker.toml", "analytic,ic");
  const std::vector<nlohmann::json> chords = drawn_guides(r, "slot");
  ASSERT_EQ(chords.size(), 48u);
  Eigen::Vector2d c = Eigen::Vector2d::Constant(std::nan(""));
  for (const nlohmann::json& p : r.at("drawing").at("points"))
    if (p.at("name") == "C") c = vertex(p, "x", "y");
  const double chord = 2.0 * 0.12 * std::sin(std::numbers::pi / 48.0);
  for (size_t i = 0; i < chords.size(); ++i) {
    EXPECT_TRUE(chords[i].at("moving").get<bool>());
    const Eigen::Vector2d a = vertex(chords[i], "x", "y"), b = vertex(chords[i], "x2", "y2");
    // Each chord starts where the one before ends, and the last ends where the first starts.
    EXPECT_LT((a - vertex(chords[(i + 47) % 48], "x2", "y2")).norm(), 1e-12) << i;
    EXPECT_NEAR((a - c).norm(), 0.12, 1e-12) << i;
    EXPECT_NEAR((b - a).norm(), chord, 1e-12) << i;
  }
}

// Issue 32 item 6: the drawing to take away. The crank-rocker's crank A = (0, 0) to B, 40 mm
// long, drawn at theta2 = 0 and swept at 1 degree: the SVG's crank segment ends at B = (0.04, 0)
// (y down in SVG), each moving point's path is one polyline, and the animation's frames put B at
// 0.04 (cos k deg, -sin k deg) for every sample k.
TEST(Cli, SolveDrawsTheMechanismAsSvgAndAnimatesIt) {
  const std::string file = "mechanisms/fourbar_crank_rocker.toml";
  const std::string still = (scratch_dir() / "crank_rocker.svg").string();
  const CommandRun run = crosslink("solve " + file + " --svg \"" + still + "\"");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string svg = read_file(still);
  EXPECT_EQ(svg.rfind("<?xml", 0), 0u);
  const auto count = [&](const std::string& text, const std::string& what) {
    size_t n = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
    return n;
  };
  EXPECT_EQ(count(svg, "<line "), 3u) << svg;      // crank, coupler, rocker
  EXPECT_EQ(count(svg, "<polyline "), 2u) << svg;  // the paths of B and C
  EXPECT_NE(svg.find("<line x1=\"0\" y1=\"0\" x2=\"0.04\" y2=\"0\""), std::string::npos) << svg;
  EXPECT_EQ(svg.find("<animate"), std::string::npos);

  const std::string moving = (scratch_dir() / "crank_rocker_animated.svg").string();
  ASSERT_EQ(crosslink("solve " + file + " --svg \"" + moving + "\" --animate 4").exit_code, 0);
  const std::string animated = read_file(moving);
  const std::string crank = animated.substr(animated.find("<title>crank</title>"));
  for (const char* axis : {"x2", "y2"}) {
    const std::string key = std::string("<animate attributeName=\"") + axis + "\" dur=\"4s\"";
    const size_t at = crank.find(key);
    ASSERT_NE(at, std::string::npos) << crank.substr(0, 400);
    const size_t from = crank.find("values=\"", at) + 8;
    std::stringstream values(crank.substr(from, crank.find('"', from) - from));
    std::string v;
    int k = 0;
    for (; std::getline(values, v, ';'); ++k) {
      const double angle = k * std::numbers::pi / 180.0;
      const double exact =
          axis == std::string("x2") ? 0.04 * std::cos(angle) : -0.04 * std::sin(angle);
      ASSERT_NEAR(std::stod(v), exact, 1e-7) << axis << " at sample " << k;
    }
    EXPECT_EQ(k, 361) << axis;
  }
  // An animation needs the drawing and the sweep.
  EXPECT_EQ(crosslink("solve " + file + " --animate 4").exit_code, 2);
  EXPECT_EQ(crosslink("solve " + file + " --at 30 --svg \"" + still + "\" --animate 4").exit_code,
            2);
}

// An element of a drawing by its title: from its opening tag to its closing one.
std::string svg_element(const std::string& svg, const std::string& title) {
  const size_t at = svg.find("<title>" + title + "</title>");
  if (at == std::string::npos) return "";
  const size_t from = svg.rfind("\n", at) + 1;
  return svg.substr(from, svg.find("\n", at) - from);
}
// An attribute of the element's opening tag, or each frame of its animation.
std::string svg_attribute(const std::string& element, const std::string& name) {
  size_t at = element.find(" " + name + "=\"");
  if (at == std::string::npos) return "";
  at += name.size() + 3;
  return element.substr(at, element.find('"', at) - at);
}
std::vector<std::string> svg_frames(const std::string& element, const std::string& name) {
  const size_t at = element.find("<animate attributeName=\"" + name + "\"");
  if (at == std::string::npos) return {};
  std::stringstream values(svg_attribute(element.substr(at), "values"));
  std::vector<std::string> out;
  for (std::string v; std::getline(values, v, ';');) out.push_back(v);
  return out;
}
std::vector<Eigen::Vector2d> svg_points(const std::string& text) {
  std::stringstream in(text);
  std::vector<Eigen::Vector2d> out;
  for (std::string xy; in >> xy;) {
    const size_t comma = xy.find(',');
    out.emplace_back(std::stod(xy.substr(0, comma)), std::stod(xy.substr(comma + 1)));
  }
  return out;
}

// The drawing to take away draws what the report draws: a slot on a moving link and a cam's
// profile with its roller, in place at every frame. Held by the definitions' geometry, against
// the points the drawing puts: the curved slot's every vertex 0.12 m from its centre C, the
// eccentric disc's 0.09 m from its centre X, the roller 0.03 m about the follower's C, 0.12 m
// from X (the disc and the roller touch), the follower's line through D = (0, 0.01); to the
// drawing's six digits.
TEST(Cli, TheSvgDrawsSlotsAndCamsInPlace) {
  const auto drawn = [](const std::string& file, bool animate) {
    const std::string svg = (scratch_dir() / "slots_and_cams.svg").string();
    const CommandRun run =
        crosslink("solve " + file + " --svg \"" + svg + "\"" + (animate ? " --animate 4" : ""));
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return read_file(svg);
  };
  // Each frame of a circle's centre.
  const auto centres = [](const std::string& element) {
    std::vector<Eigen::Vector2d> out;
    const std::vector<std::string> x = svg_frames(element, "cx"), y = svg_frames(element, "cy");
    for (size_t f = 0; f < x.size() && f < y.size(); ++f)
      out.emplace_back(std::stod(x[f]), std::stod(y[f]));
    return out;
  };
  const auto expect_on_circle = [](const std::vector<Eigen::Vector2d>& vertices,
                                   const Eigen::Vector2d& centre, double radius,
                                   const std::string& what) {
    ASSERT_FALSE(vertices.empty()) << what;
    EXPECT_EQ(vertices.front(), vertices.back()) << what << ": closed";
    for (const Eigen::Vector2d& v : vertices)
      ASSERT_NEAR((v - centre).norm(), radius, 2e-6) << what;
  };

  const std::string slot_rocker = drawn("mechanisms/cams/curved_slot_rocker.toml", true);
  const std::string slot = svg_element(slot_rocker, "slot");
  const std::vector<Eigen::Vector2d> c = centres(svg_element(slot_rocker, "C"));
  const std::vector<std::string> slot_frames = svg_frames(slot, "points");
  ASSERT_EQ(c.size(), 361u);
  ASSERT_EQ(slot_frames.size(), c.size()) << slot;
  expect_on_circle(svg_points(svg_attribute(slot, "points")), c[0], 0.12, "slot at the start");
  for (size_t f = 0; f < c.size(); ++f)
    expect_on_circle(svg_points(slot_frames[f]), c[f], 0.12, fmt::format("slot, frame {}", f));

  const std::string cam = drawn("mechanisms/cams/eccentric_roller_spring.toml", true);
  const std::string profile = svg_element(cam, "contact profile");
  const std::string roller = svg_element(cam, "contact roller");
  const std::vector<Eigen::Vector2d> x = centres(svg_element(cam, "X"));
  const std::vector<Eigen::Vector2d> follower = centres(svg_element(cam, "C"));
  const std::vector<Eigen::Vector2d> rolling = centres(roller);
  const std::vector<std::string> profile_frames = svg_frames(profile, "points");
  ASSERT_EQ(x.size(), 361u);
  ASSERT_EQ(profile_frames.size(), x.size()) << profile.substr(0, 400);
  ASSERT_EQ(rolling.size(), follower.size());
  EXPECT_EQ(svg_attribute(roller, "r"), "0.03");
  for (size_t f = 0; f < x.size(); ++f) {
    const std::vector<Eigen::Vector2d> disc = svg_points(profile_frames[f]);
    EXPECT_EQ(disc.size(), 361u);
    expect_on_circle(disc, x[f], 0.09, fmt::format("disc, frame {}", f));
    EXPECT_NEAR((rolling[f] - follower[f]).norm(), 0.0, 2e-6) << "roller, frame " << f;
    EXPECT_NEAR((rolling[f] - x[f]).norm(), 0.12, 2e-6) << "roller, frame " << f;
  }
  // Still, at the start: the disc about X, inside the frame; the follower's line dashed through D.
  const std::string still = drawn("mechanisms/cams/eccentric_roller_spring.toml", false);
  const std::string x_still = svg_element(still, "X");
  const Eigen::Vector2d x0(std::stod(svg_attribute(x_still, "cx")),
                           std::stod(svg_attribute(x_still, "cy")));
  const std::vector<Eigen::Vector2d> disc =
      svg_points(svg_attribute(svg_element(still, "contact profile"), "points"));
  expect_on_circle(disc, x0, 0.09, "disc at the start");
  const std::vector<double> box = [&] {
    std::stringstream in(svg_attribute(still.substr(still.find("<svg ")), "viewBox"));
    std::vector<double> out(4);
    for (double& v : out) in >> v;
    return out;
  }();
  for (const Eigen::Vector2d& v : disc) {
    EXPECT_GT(v.x(), box[0]);
    EXPECT_LT(v.x(), box[0] + box[2]);
    EXPECT_GT(v.y(), box[1]);
    EXPECT_LT(v.y(), box[1] + box[3]);
  }
  const std::vector<Eigen::Vector2d> axis =
      svg_points(svg_attribute(svg_element(still, "follower_axis"), "points"));
  ASSERT_EQ(axis.size(), 2u);
  EXPECT_FALSE(svg_attribute(svg_element(still, "follower_axis"), "stroke-dasharray").empty());
  for (const Eigen::Vector2d& v : axis) EXPECT_NEAR(v.y(), -0.01, 1e-9);
}

// A link is drawn as the convex hull of its points, in the report and the drawing alike
// (compare::link_segments): the 3-RRR platform as its triangle C1 C2 C3, its centre P a point
// inside, not a corner of a dented quadrilateral; the spline slot's rocker as the outline of its
// nine points, closed, every point on it or inside.
TEST(Cli, TheDrawingOutlinesALinkByTheHullOfItsPoints) {
  const auto drawn = [](const std::string& file) {
    const std::string svg = (scratch_dir() / "hull.svg").string();
    const CommandRun run = crosslink("solve " + file + " --svg \"" + svg + "\"");
    EXPECT_EQ(run.exit_code, 0) << run.err;
    return read_file(svg);
  };
  // The link's drawn lines, and where the drawing puts a named point.
  const auto edges = [](const std::string& svg, const std::string& link) {
    std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> out;
    std::stringstream lines(svg);
    for (std::string line; std::getline(lines, line);)
      if (line.rfind("<line ", 0) == 0 &&
          line.find("<title>" + link + "</title>") != std::string::npos)
        out.emplace_back(Eigen::Vector2d(std::stod(svg_attribute(line, "x1")),
                                         std::stod(svg_attribute(line, "y1"))),
                         Eigen::Vector2d(std::stod(svg_attribute(line, "x2")),
                                         std::stod(svg_attribute(line, "y2"))));
    return out;
  };
  const auto point = [](const std::string& svg, const std::string& name) {
    const std::string dot = svg_element(svg, name);
    if (svg_attribute(dot, "cx").empty())  // a ground pivot: its triangle's apex
      return svg_points(svg_attribute(dot, "points")).front();
    return Eigen::Vector2d(std::stod(svg_attribute(dot, "cx")),
                           std::stod(svg_attribute(dot, "cy")));
  };

  const std::string platform = drawn("mechanisms/drivers/three_rrr_turning.toml");
  const auto triangle = edges(platform, "platform");
  ASSERT_EQ(triangle.size(), 3u) << platform;
  for (const char* corner : {"C1", "C2", "C3"}) {
    int ends = 0;
    for (const auto& [a, b] : triangle)
      ends += (a == point(platform, corner)) + (b == point(platform, corner));
    EXPECT_EQ(ends, 2) << corner;
  }
  for (const auto& [a, b] : triangle) {
    EXPECT_NE(a, point(platform, "P"));
    EXPECT_NE(b, point(platform, "P"));
  }

  const std::string rocker = drawn("mechanisms/cams/spline_slot_rocker.toml");
  const auto outline = edges(rocker, "rocker");
  ASSERT_GE(outline.size(), 3u) << rocker;
  for (size_t i = 0; i < outline.size(); ++i)  // closed, each edge starting where one ended
    EXPECT_EQ(outline[i].first, outline[(i + outline.size() - 1) % outline.size()].second) << i;
  for (const char* name : {"C", "D", "S1", "S2", "S3", "S4", "S5", "S6", "S7"}) {
    const Eigen::Vector2d p = point(rocker, name);
    // Inside every edge, counterclockwise in the link's frame, so clockwise as SVG's y runs down
    // (to the drawing's six digits).
    for (const auto& [a, b] : outline) {
      const Eigen::Vector2d u = b - a, v = p - a;
      EXPECT_LE(u.x() * v.y() - u.y() * v.x(), 1e-6 * u.norm()) << name;
    }
  }
}

// Issue 20 item 3: a gear pair whose one gear's angle is known gives the other's, so the geared
// five-bar decomposes into closed-form groups (it fell back to Newton), and `check` says so; so
// does a rack and pinion whose pinion is placed.
TEST(Cli, CheckReportsTheGearedFiveBarsDecomposition) {
  const CommandRun run = crosslink("check mechanisms/gears/geared_fivebar.toml");
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("closed-form dyads (3 groups):"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("gear angle from crank2"), std::string::npos) << run.out;
  // A driven pinion moves its rack: two input links, the rack's point at the pinion's travel.
  const CommandRun rack = crosslink("check mechanisms/gears/ryan_rack_and_pinion.toml");
  EXPECT_EQ(rack.exit_code, 0) << rack.err;
  EXPECT_NE(rack.out.find("closed-form dyads (2 groups):"), std::string::npos) << rack.out;
  EXPECT_NE(rack.out.find("input link rack (pin on ground at the travel from pinion pinion + "
                          "angle from ground)"),
            std::string::npos)
      << rack.out;
}

// Issue 35, item 6. An engine runs over the reference's usable samples only; the samples outside
// (the non-Grashof four-bar's toggles at both ends, flagged singular by the reference) keep the
// reference's flag but hold no engine value. They were written as 0 (MuJoCo's angle.crank 0
// against -78.28 deg at the ends) and entered its [[derived]] extremes as 0: now an empty field,
// and no derived value from samples that were not computed.
TEST(Cli, AnEngineSampleOutsideItsRunIsEmptyNotZero) {
  const std::string path = write_definition(
      "non_grashof_derived.toml", read_file("mechanisms/singular/fourbar_non_grashof.toml") +
                                      "\n[[derived]]\nname = \"crank\"\nquantity = \"extremes\"\n"
                                      "channel = \"angle.crank\"\n\n[[derived]]\nname = \"rise\"\n"
                                      "quantity = \"extremes\"\nchannel = \"y.C\"\n");
  const std::string csv = (scratch_dir() / "non_grashof.csv").string();
  const CommandRun run =
      crosslink("compare \"" + path + "\" --engines analytic,mujoco --csv \"" + csv + "\"");
  if (run.out.find("mujoco    not run") != std::string::npos) GTEST_SKIP() << "no MuJoCo";
  ASSERT_NE(run.exit_code, 2) << run.err;
  std::istringstream lines(read_file(csv));
  std::string line;
  std::getline(lines, line);
  const std::vector<std::string> header = rfc4180_fields(line);
  const auto column = [&](const char* name) {
    return static_cast<size_t>(std::find(header.begin(), header.end(), name) - header.begin());
  };
  const size_t method = column("method"), channel = column("channel"), sample = column("sample"),
               reference = column("reference"), value = column("value");
  ASSERT_LT(value, header.size());
  int compared = 0, empty_at_ends = 0, derived_rows = 0;
  int last = -1;
  std::vector<std::vector<std::string>> crank;
  while (std::getline(lines, line)) {
    const std::vector<std::string> f = rfc4180_fields(line);
    ASSERT_EQ(f.size(), header.size()) << line;
    if (f[method] != "mujoco") continue;
    if (f[channel].starts_with("derived:")) {
      // Its samples stop before the interval's ends: no extreme from them (empty), never one
      // read off a placeholder.
      EXPECT_EQ(f[value], "") << line;
      derived_rows += f[channel].starts_with("derived:crank.") ||
                      f[channel].starts_with("derived:rise.");  // the design summary's aside
      continue;
    }
    if (f[channel] != "angle.crank") continue;
    crank.push_back(f);
    last = std::max(last, std::stoi(f[sample]));
  }
  for (const std::vector<std::string>& f : crank) {
    const int k = std::stoi(f[sample]);
    ASSERT_FALSE(f[reference].empty()) << "the reference's position exists at every sample";
    if (f[value].empty()) {
      empty_at_ends += k == 0 || k == last;
      continue;
    }
    // A value written is the engine's: the crank follows its driver (tolerance 1e-2 % of pi).
    const double d = std::remainder(std::stod(f[value]) - std::stod(f[reference]), 2 * kPi);
    EXPECT_LT(std::abs(d), 1e-3) << "sample " << k << ": " << f[value] << " vs " << f[reference];
    ++compared;
  }
  EXPECT_GT(compared, 100);
  EXPECT_EQ(empty_at_ends, 2);  // both toggles: outside MuJoCo's run
  EXPECT_EQ(derived_rows, 8);   // min, at_min, max, at_max of both quantities
  EXPECT_EQ(run.out.find("FAIL: derived"), std::string::npos) << run.out;
}

// Issue 35, item 7. Messages speak the file's units: the non-Grashof four-bar is in deg and mm.
// Its toggles are where coupler (30) and rocker (35) are in line: cos(theta) = (40^2 + 60^2 -
// 65^2) / (2 40 60), theta = +-78.2802 deg (was printed as -1.36623 rad). MuJoCo's usable samples
// are given in deg, its loop gaps in mm (a gap threshold of 1e-12 m is 1e-09 mm).
TEST(Cli, MessagesGiveDriverValuesAndLengthsInTheFilesUnits) {
  const double toggle = std::acos((40.0 * 40 + 60.0 * 60 - 65.0 * 65) / (2 * 40.0 * 60)) / kDeg;
  const std::string file = "mechanisms/singular/fourbar_non_grashof.toml";
  const CommandRun solve = crosslink("solve " + file);
  ASSERT_EQ(solve.exit_code, 0) << solve.err;
  const std::regex note(
      "note: singular at driver = (-?[0-9.]+) deg: toggle: dead point at "
      "driver = (-?[0-9.]+) deg");
  int notes = 0;
  for (std::sregex_iterator it(solve.err.begin(), solve.err.end(), note), end; it != end; ++it) {
    EXPECT_NEAR(std::abs(std::stod((*it)[1])), toggle, 1e-6) << it->str();
    EXPECT_NEAR(std::abs(std::stod((*it)[2])), toggle, 1e-6) << it->str();
    ++notes;
  }
  EXPECT_EQ(notes, 2) << solve.err;

  const CommandRun compare =
      crosslink("compare " + file + " --engines analytic,mujoco --set mujoco:gap_threshold=1e-12");
  if (compare.out.find("mujoco    not run") != std::string::npos) GTEST_SKIP() << "no MuJoCo";
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      compare.out, m,
      std::regex("usable\\s+samples\\s+[0-9]+\\s+\\.\\.\\s+[0-9]+\\s+\\(driver\\s+="
                 "\\s+(-?[0-9.]+)\\s+deg\\s+\\.\\.\\s+driver\\s+=\\s+"
                 "(-?[0-9.]+)\\s+deg\\)")))
      << compare.out;
  for (int i : {1, 2}) {
    EXPECT_LT(std::abs(std::stod(m[i])), toggle) << m[0];
    EXPECT_GT(std::abs(std::stod(m[i])), toggle - 2.0) << m[0];  // the next samples in, 1 deg apart
  }
  // The reference's step as --step takes it, in the file's unit (was 0.0349066, radians).
  const CommandRun stepped = crosslink("compare " + file + " --engines analytic --step 2");
  EXPECT_TRUE(std::regex_search(stepped.out, std::regex("step=2\\s+deg\\s"))) << stepped.out;
  // (The console wraps its notes at 100 columns: any space may be a line break.)
  EXPECT_TRUE(std::regex_search(compare.out, std::regex(">\\s+threshold\\s+1e-09\\s+mm\\)")))
      << compare.out;
}

// Issue 35, item 8. merge reads every field of a part before using it and names the part in each
// refusal: a shard index of 0.5 (was taken as 0), a row of -5 samples, an unknown engine (its
// CSV then held dt=nan), a missing field.
TEST(Cli, MergeRefusesAPartWithAFieldOutOfItsRangeNamingThePart) {
  const std::filesystem::path dir = scratch_dir() / "merge_fields";
  std::filesystem::create_directories(dir);
  const std::string part = (dir / "part.json").string();
  CommandRun run = crosslink(
      "sweep mechanisms/fourbar_crank_rocker.toml --engines mujoco --dt "
      "1e-3 --repeat 1 --quiet --step 10 --shard 0/1 --json " +
      part);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json good = nlohmann::json::parse(read_file(part));
  run = crosslink("merge " + part);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  int n = 0;
  const auto refused = [&](nlohmann::json bad, const std::string& why) {
    const std::string path = (dir / fmt::format("bad{}.json", n++)).string();
    std::ofstream(path) << bad.dump();
    const CommandRun r = crosslink("merge " + path);
    EXPECT_EQ(r.exit_code, 2) << why << ": " << r.out;
    EXPECT_NE(r.err.find(path), std::string::npos) << why << ": the part is not named: " << r.err;
    EXPECT_NE(r.err.find(why), std::string::npos) << r.err;
  };
  nlohmann::json bad = good;
  bad["shard"]["index"] = 0.5;
  refused(bad, "\"index\"");
  bad = good;
  bad["shard"]["index"] = 1;
  refused(bad, "\"index\"");
  bad = good;
  bad["shard"]["count"] = 0;
  refused(bad, "\"count\"");
  bad = good;
  bad["sweeps"][0]["rows"].back()["samples"] = -5;
  refused(bad, "\"samples\"");
  bad = good;
  bad["sweeps"][0]["rows"].back()["engine"] = "physx";
  refused(bad, "unknown engine 'physx'");
  bad = good;
  bad["sweeps"][0]["definition"] = 1.5;
  refused(bad, "\"definition\"");
  bad = good;
  bad.erase("shard");
  refused(bad, "\"shard\"");
}

// Issue 35, item 6. Outputs differ between two runs only where they say they measure time: the
// analytic,newton row's settings ended with the time its dyads check took.
TEST(Cli, TwoSweepsDifferOnlyInTheirCostColumns) {
  std::string first;
  for (int i = 0; i < 2; ++i) {
    const std::string csv = (scratch_dir() / fmt::format("twice{}.csv", i)).string();
    const CommandRun run = crosslink(
        "sweep mechanisms/fourbar_crank_rocker.toml --engines mujoco "
        "--dt 1e-3 --repeat 1 --quiet --step 10 --csv " +
        csv);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    // The columns that say they measure time, and the rank, which orders by them.
    const std::string text =
        without_columns(read_file(csv), {"wall_s_per_cycle", "cpu_s_per_cycle", "rank"});
    EXPECT_NE(text.find("cross_check=dyads on"), std::string::npos) << text.substr(0, 2000);
    if (i == 0)
      first = text;
    else
      EXPECT_EQ(text, first);
  }
}

// Issue 35, item 8: a [[driver]] named "a,b" was reported to give a CSV header of 80 fields for
// 78 per row. The header names its channels angle.a,b and torque.a,b quoted (RFC 4180): 78
// fields read as RFC 4180, 80 only when split at every comma. A guard: every row has the
// header's fields, and the driver's channels are one field each.
TEST(Cli, ADriverNamedWithACommaIsOneCsvFieldPerChannel) {
  const std::string path = write_definition(
      "comma_driver.toml", replaced_all(read_file("mechanisms/drivers/fivebar_two_cranks.toml"),
                                        "name = \"left\"", "name = \"a,b\""));
  const CommandRun run = crosslink("solve \"" + path + "\" --format csv");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::istringstream lines(run.out);
  std::string line;
  std::getline(lines, line);
  const std::vector<std::string> header = rfc4180_fields(line);
  for (const char* name : {"angle.a,b", "torque.a,b"})
    EXPECT_NE(std::find(header.begin(), header.end(), name), header.end()) << name << ": " << line;
  int rows = 0;
  for (; std::getline(lines, line); ++rows) ASSERT_EQ(rfc4180_fields(line).size(), header.size());
  EXPECT_GT(rows, 10);
}

// Issue 35, item 8. A reference at rest (the A01 pendulum without gravity, 10 ns, an effort of
// 1e-300 N m) moves no energy: its energy scale is 0, and a % of it is not a number. Its energy
// channels have no % and no verdict (n/a, null), never a % of a scale of 1 J, 1e308 % or inf %.
TEST(Cli, AReferenceAtRestHasNoPercentOfAZeroPeak) {
  std::string text = read_file("mechanisms/iftomm_a01_pendulum.toml");
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"gravity = [0, -9.81]", "gravity = [0, 0]"},
           {"duration = 2000", "duration = 1e-8"},
           {"interval = 0.5", "interval = 1e-9"},
           {"rate = 0", "rate = 0\neffort = 1e-300"}})
    text = replaced_all(text, from, to);
  const std::string path = write_definition("at_rest.toml", text);
  const std::string json = (scratch_dir() / "at_rest.json").string();
  const CommandRun run =
      crosslink("compare \"" + path + "\" --engines analytic,mujoco --json \"" + json + "\"");
  if (run.out.find("mujoco    not run") != std::string::npos) GTEST_SKIP() << "no MuJoCo";
  ASSERT_EQ(run.exit_code, 0) << run.err << run.out;
  const nlohmann::json j = nlohmann::json::parse(read_file(json));
  int energy = 0;
  for (const nlohmann::json& c : j["channels"]) {
    if (c["quantity"] != "energy") continue;
    EXPECT_EQ(c["verdict"], "n/a") << c.dump();
    EXPECT_TRUE(c["max_pct_of_peak"].is_null()) << c.dump();
    EXPECT_TRUE(c["rms_pct_of_peak"].is_null()) << c.dump();
    ++energy;
  }
  EXPECT_EQ(energy, 4);
  EXPECT_TRUE(std::regex_search(run.out, std::regex("energy +mujoco +energy\\.[a-z]+ +n/a ")))
      << run.out;
  EXPECT_EQ(run.out.find("inf"), std::string::npos) << run.out;
  EXPECT_FALSE(std::regex_search(run.out, std::regex("e\\+[0-9]{3}"))) << run.out;  // 1e+308
}

}  // namespace
