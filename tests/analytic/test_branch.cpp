// [[branch]]: an assembly mode named in the definition instead of drawn (issue 13). Expected
// values come from Norton's closed form of the four-bar (R. L. Norton, Design of Machinery, ch. 4,
// eq. 4.10: theta4 = 2 atan2(-B -/+ sqrt(B^2 - 4AC), 2A), the minus sign the open circuit, the plus
// sign the crossed), independent of the loader, the dyads and Newton.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <regex>
#include <sstream>
#include <string>

#include <fmt/format.h>

#include "analytic/kinematics/branch.h"
#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "tests/common/diagnostics.h"

namespace crosslink {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

std::string read_text(const std::string& name) {
  std::ifstream in(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + name + ".toml");
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The bundled crank-rocker (a = 0.04, b = 0.12, c = 0.08, d = 0.10 m; A at the origin, D on +x),
// its poses removed, starting at theta2 = `start` degrees, with `extra` appended.
std::string undrawn_crank_rocker(const std::string& extra, int start = 0) {
  const std::string undrawn =
      std::regex_replace(read_text("fourbar_crank_rocker"), std::regex("\npose = [^\n]*"), "");
  return std::regex_replace(undrawn, std::regex("\nstart = 0\n"),
                            "\nstart = " + std::to_string(start) + "\n") +
         "\n" + extra;
}

using test::error_of;

// Norton eq. 4.10: the rocker's angle theta4 at crank angle theta2 (both from AD).
double norton_theta4(double theta2, bool open) {
  const double a = 0.04, b = 0.12, c = 0.08, d = 0.10;
  const double k1 = d / a, k2 = d / c, k3 = (a * a - b * b + c * c + d * d) / (2 * a * c);
  const double A = std::cos(theta2) - k1 - k2 * std::cos(theta2) + k3;
  const double B = -2 * std::sin(theta2);
  const double C = k1 - (k2 + 1) * std::cos(theta2) + k3;
  const double root = std::sqrt(B * B - 4 * A * C);
  return 2 * std::atan2(-B + (open ? -root : root), 2 * A);
}

// The rocker's angle over the sweep against Norton's, for the assembly `open` names.
void expect_circuit(const Mechanism& m, bool open) {
  const Trajectory t = sweep(m);
  const int rocker = m.moving_index(m.find_link("rocker"));
  ASSERT_GT(t.samples(), 300);
  for (int i = 0; i < t.samples(); i += 30) {
    const double expected = norton_theta4(t.along(i), open);
    EXPECT_NEAR(std::remainder(t.angle(i, rocker) - expected, 2 * std::numbers::pi), 0.0, 1e-10)
        << "theta2 = " << t.along(i) / kDeg << " deg";  // to Newton's tolerance
  }
}

// The triangle B -> C -> D turns one way all along a Grashof four-bar's circuit (its
// transmission angle never reaches 0 or 180 degrees): clockwise on the open circuit as drawn
// (A at the origin, D on +x), counter-clockwise on the crossed, from any start.
TEST(Branch, TriangleTurnChoosesTheCircuit) {
  const std::string triangle = "[[branch]]\npoints = [\"B\", \"C\", \"D\"]\nturn = ";
  for (const int start : {0, 60, 200}) {
    expect_circuit(parse_mechanism(undrawn_crank_rocker(triangle + "\"cw\"\n", start), "cw.toml"),
                   true);
    expect_circuit(parse_mechanism(undrawn_crank_rocker(triangle + "\"ccw\"\n", start), "ccw.toml"),
                   false);
  }
  // A drawing that agrees is kept as drawn.
  const Mechanism drawn = parse_mechanism(
      read_text("fourbar_crank_rocker") + "\n" + triangle + "\"cw\"\n", "drawn.toml");
  expect_circuit(drawn, true);
  EXPECT_NEAR(drawn.links[static_cast<size_t>(drawn.find_link("coupler"))].pose->z(), 36.336 * kDeg,
              1e-12);
}

// Without poses or [[branch]] the chain still assembles, by the dyads (Newton from links all at
// the origin does not close this one).
TEST(Branch, UndrawnChainAssemblesByItsDyads) {
  const Mechanism m = parse_mechanism(undrawn_crank_rocker(""), "undrawn.toml");
  const Trajectory t = sweep(m);
  EXPECT_TRUE(std::all_of(t.status.begin(), t.status.end(),
                          [](PoseStatus s) { return s == PoseStatus::ok; }));
  const double theta4 = t.angle(0, m.moving_index(m.find_link("rocker")));
  EXPECT_TRUE(
      std::abs(std::remainder(theta4 - norton_theta4(0, true), 2 * std::numbers::pi)) < 1e-10 ||
      std::abs(std::remainder(theta4 - norton_theta4(0, false), 2 * std::numbers::pi)) < 1e-10);
}

// Each named mode holds at the start of the assembly chosen for it.
TEST(Branch, ChosenAssemblyHoldsEveryChoice) {
  const Mechanism m = parse_mechanism(
      undrawn_crank_rocker("[[branch]]\npoints = [\"B\", \"C\", \"D\"]\nturn = \"ccw\"\n"
                           "[[branch]]\npoints = [\"A\", \"B\", \"C\"]\nturn = \"cw\"\n"),
      "both.toml");
  ASSERT_EQ(m.branches.size(), 2u);
  const NewtonSolver newton(m);
  KinematicState state(m);
  ASSERT_EQ(newton.assemble(state).status, PoseStatus::ok);
  for (const BranchChoice& b : m.branches) EXPECT_TRUE(holds(m, b, state.q)) << b.text();
}

TEST(Branch, BadChoicesAreLocatedErrors) {
  const std::string base = undrawn_crank_rocker("");
  const int line = static_cast<int>(std::count(base.begin(), base.end(), '\n')) + 1;
  const auto at = [&](int offset) { return fmt::format("bad.toml:{}:", line + offset); };
  // Contradicting choices: no assembly has both.
  std::string e = error_of(base +
                           "[[branch]]\npoints = [\"B\", \"C\", \"D\"]\nturn = \"cw\"\n"
                           "[[branch]]\npoints = [\"D\", \"C\", \"B\"]\nturn = \"cw\"\n");
  EXPECT_NE(e.find("no assembly at the driver's start value has all of"), std::string::npos) << e;
  // Drawn poses that contradict the choice.
  e = error_of(read_text("fourbar_crank_rocker") +
               "\n[[branch]]\npoints = [\"B\", \"C\", \"D\"]\nturn = \"ccw\"\n");
  EXPECT_NE(e.find("the drawn poses assemble with B -> C -> D turns clockwise"), std::string::npos)
      << e;
  e = error_of(base + "[[branch]]\npoints = [\"B\", \"C\", \"Q\"]\nturn = \"cw\"\n");
  EXPECT_NE(e.find(at(1)), std::string::npos) << e;
  EXPECT_NE(e.find("'Q' is not a named point"), std::string::npos) << e;
  e = error_of(base + "[[branch]]\npoints = [\"B\", \"C\", \"D\"]\nturn = \"left\"\n");
  EXPECT_NE(e.find(at(2)), std::string::npos) << e;
  EXPECT_NE(e.find("'turn' must be \"ccw\" or \"cw\""), std::string::npos) << e;
  e = error_of(base + "[[branch]]\npoints = [\"A\", \"B\", \"C\", \"D\"]\nturn = \"cw\"\n");
  EXPECT_NE(e.find("the names of three points"), std::string::npos) << e;
  e = error_of(base + "[[branch]]\npoints = [\"B\", \"C\"]\nturn = \"cw\"\n");
  EXPECT_NE(e.find("the names of three points"), std::string::npos) << e;
  e = error_of(base + "[[branch]]\npoints = [\"B\", \"B\", \"C\"]\nturn = \"cw\"\n");
  EXPECT_NE(e.find("names 'B' twice"), std::string::npos) << e;
}

// A chain that does not decompose into dyads (the polycentric hinge: its driver is a floating
// link's angle) cannot be re-assembled by name: when its assembly lacks the choice, that is said.
TEST(Branch, ChainWithoutDyadsNeedsPoses) {
  const std::string undrawn =
      std::regex_replace(read_text("polycentric_hinge"), std::regex("\npose = [^\n]*"), "");
  const Mechanism m = parse_mechanism(undrawn, "undrawn.toml");
  const NewtonSolver newton(m);
  KinematicState state(m);
  ASSERT_EQ(newton.assemble(state).status, PoseStatus::ok);
  BranchChoice b;
  for (const auto& p : m.named_points())
    if (b.points.size() < 3 && p.name != "A" && p.name != "H") {  // not the ground's
      b.points.emplace_back(p.link, p.point);
      b.names.push_back(p.name);
    }
  const bool taken = holds(m, b, state.q);
  const std::string e = error_of(
      undrawn + fmt::format("\n[[branch]]\npoints = [\"{}\", \"{}\", \"{}\"]\nturn = \"{}\"\n",
                            b.names[0], b.names[1], b.names[2], taken ? "cw" : "ccw"));
  EXPECT_NE(e.find("[[branch]] needs a chain of dyads"), std::string::npos) << e;
}

}  // namespace
}  // namespace crosslink
