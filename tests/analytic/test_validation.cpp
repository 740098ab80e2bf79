// Validation of bad definitions: one test per error class. Each writes a small definition with
// one fault and checks that a diagnostic points at the faulty line (and column, where a single
// value is at fault) and says what was expected. Expected locations are found in the test's own
// text (the line holding the fault), not taken from the loader's output.
//
// The base definition is a crank-rocker four-bar (Grashof: 0.04 + 0.12 <= 0.08 + 0.10):
//
//            C           coupler BC 0.12, rocker DC 0.08,
//           / \          crank AB 0.04, ground AD 0.10 (m)
//          B   \         (C above AD at crank angle 60 degrees)
//         /     \        .
//        A-------D       .
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "analytic/kinematics/newton.h"
#include "analytic/model/limits.h"
#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "tests/common/crank_rocker.h"
#include "tests/common/diagnostics.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

// The shared crank-rocker (tests/common/crank_rocker.h), drawn at 60 degrees, in parts.
const test::CrankRockerText kBase = test::crank_rocker();
const std::string kHeader = kBase.header, kGround = kBase.ground, kMoving = kBase.moving,
                  kJoints = kBase.joints, kDriver = kBase.driver;

std::string four_bar() {
  return kHeader + kGround + kMoving + kJoints + kDriver;
}

// 1-based line and column of the n-th (0-based) occurrence of `marker` in `text`.
struct Place {
  int line = 0;
  int column = 0;
};
Place place_of(const std::string& text, const std::string& marker, int nth = 0) {
  size_t at = text.find(marker);
  for (int i = 0; i < nth && at != std::string::npos; ++i) at = text.find(marker, at + 1);
  EXPECT_NE(at, std::string::npos) << "test fault: '" << marker << "' not in the definition";
  if (at == std::string::npos) return {};
  const size_t line_start = text.rfind('\n', at);
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + at, '\n'));
  const int column =
      static_cast<int>(at - (line_start == std::string::npos ? 0 : line_start + 1)) + 1;
  return {line, column};
}

using test::diagnostics_of;
using test::replaced;

// The diagnostic whose message holds every one of `phrases`; fails the test when none does.
const Diagnostic* find(const std::vector<Diagnostic>& found,
                       const std::vector<std::string>& phrases) {
  for (const Diagnostic& d : found) {
    bool all = true;
    for (const std::string& p : phrases) all = all && d.message.find(p) != std::string::npos;
    if (all) return &d;
  }
  std::string list;
  for (const Diagnostic& d : found) list += "\n  " + d.str();
  ADD_FAILURE() << "no diagnostic holds all expected phrases; got:" << list;
  return nullptr;
}

// Expects a diagnostic holding `phrases` at `where` (column 0: any column on that line).
void expect_diagnostic(const std::string& text, Place where,
                       const std::vector<std::string>& phrases) {
  const std::vector<Diagnostic> found = diagnostics_of(text);
  const Diagnostic* d = find(found, phrases);
  if (!d) return;
  EXPECT_EQ(d->where.line, where.line) << d->str();
  if (where.column > 0) {
    EXPECT_EQ(d->where.column, where.column) << d->str();
  }
  EXPECT_EQ(d->str().rfind(fmt::format("bad.toml:{}:", where.line), 0), 0u) << d->str();
}

TEST(Validation, BaseFourBarIsValid) {
  const Mechanism m = parse_mechanism(four_bar(), "good.toml");
  EXPECT_EQ(m.links.size(), 4u);
  EXPECT_EQ(mobility(m).mobility, 1);
}

TEST(Validation, TomlSyntaxError) {
  // An array left open inside an inline table.
  const std::string text = replaced(four_bar(), "D = [0.10, 0] }", "D = [0.10, 0 }");
  const std::vector<Diagnostic> found = diagnostics_of(text);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].where.line, place_of(text, "D = [0.10, 0 }").line) << found[0].str();
  EXPECT_GT(found[0].where.column, 0);
  EXPECT_NE(found[0].message.find("TOML syntax"), std::string::npos) << found[0].message;
}

TEST(Validation, DuplicatePointIsASyntaxErrorAtTheSecondName) {
  // A link's points form one TOML table, so a repeated point name is a redefined key.
  const std::string text = replaced(four_bar(), "B = [0.04, 0] }", "B = [0.04, 0], A = [1, 1] }");
  const std::vector<Diagnostic> found = diagnostics_of(text);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].where.line, place_of(text, "A = [1, 1]").line) << found[0].str();
  EXPECT_NE(found[0].message.find("'A'"), std::string::npos) << found[0].message;
}

TEST(Validation, UnknownKey) {
  const std::string text =
      replaced(four_bar(), "name = \"crank\"\n", "name = \"crank\"\ncolour = \"red\"\n");
  expect_diagnostic(text, place_of(text, "colour"),
                    {"unknown key 'colour'", "link #2", "valid keys: name, ground, points"});
}

TEST(Validation, UnknownKeyAtTopLevel) {
  const std::string text = replaced(four_bar(), "[units]", "[unit]");
  // At the key itself, inside the brackets.
  expect_diagnostic(text, place_of(text, "unit]"), {"unknown key 'unit'", "units"});
}

TEST(Validation, UnknownLinkInJointListsValidNames) {
  const std::string text =
      replaced(four_bar(), "[\"crank\", \"coupler\"]", "[\"crank\", \"cuopler\"]");
  expect_diagnostic(text, place_of(text, "\"cuopler\""),
                    {"unknown link 'cuopler'", "valid links: ground, crank, coupler, rocker"});
}

TEST(Validation, DuplicateLinkName) {
  // The second "crank" is the fault, even though joints only ever find the first.
  const std::string text = replaced(four_bar(), "name = \"rocker\"", "name = \"crank\"");
  expect_diagnostic(text, place_of(text, "[[link]]", 3), {"duplicate link name 'crank'"});
}

TEST(Validation, DuplicateJointName) {
  std::string text = replaced(four_bar(), "point = \"B\"", "point = \"B\"\nname = \"pin\"");
  text = replaced(text, "point = \"C\"", "point = \"C\"\nname = \"pin\"");
  expect_diagnostic(text, place_of(text, "[[joint]]", 2), {"duplicate joint name 'pin'"});
}

TEST(Validation, JointPointNotOnItsLinkListsThePoints) {
  // B is on crank and coupler, not on the rocker. (A TOML table lists its keys sorted.)
  const std::string text = replaced(four_bar(), "links = [\"coupler\", \"rocker\"]\npoint = \"C\"",
                                    "links = [\"coupler\", \"rocker\"]\npoint = \"B\"");
  const Place at = place_of(text, "point = \"B\"", 1);
  expect_diagnostic(text, {at.line, at.column + 8},
                    {"point 'B' is not on link 'rocker'", "its points: C, D"});
}

TEST(Validation, DegenerateLineTowardItsOwnPoint) {
  const std::string text =
      replaced(four_bar(), "D = [0.10, 0] }\n",
               "D = [0.10, 0] }\nlines = { guide = { through = \"A\", toward = \"A\" } }\n");
  const Place at = place_of(text, "toward = \"A\"");
  expect_diagnostic(text, {at.line, at.column + 9}, {"line 'guide'", "degenerate"});
}

TEST(Validation, ZeroLengthLineBetweenCoincidentPoints) {
  const std::string text = replaced(
      four_bar(), "D = [0.10, 0] }\n",
      "D = [0.10, 0], E = [0, 0] }\nlines = { guide = { through = \"A\", toward = \"E\" } }\n");
  const Place at = place_of(text, "toward = \"E\"");
  expect_diagnostic(text, {at.line, at.column + 9}, {"line 'guide'", "'A' and 'E'"});
}

TEST(Validation, MissingDriver) {
  const std::string text = kHeader + kGround + kMoving + kJoints;
  const std::vector<Diagnostic> found = diagnostics_of(text);
  const Diagnostic* d = find(found, {"[driver]"});
  ASSERT_NE(d, nullptr);
  // Nothing to point at inside the file: the nearest place is its first line.
  EXPECT_EQ(d->str().rfind("bad.toml:1:1: error:", 0), 0u) << d->str();
}

// Every missing top-level piece is reported at the file's first line, like the driver.
TEST(Validation, MissingTopLevelTablesAtLineOne) {
  const std::string header_without_units = "name = \"four-bar\"\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"[units]", header_without_units + kGround + kMoving + kJoints + kDriver},
      {"[[link]]", kHeader + kDriver},
      {"[[joint]]", kHeader + kGround + kMoving + kDriver},
      {"'name'", replaced(four_bar(), "name = \"four-bar\"\n", "")},
  };
  for (const auto& [missing, text] : cases) {
    const std::vector<Diagnostic> found = diagnostics_of(text);
    const Diagnostic* d = find(found, {missing});
    ASSERT_NE(d, nullptr) << missing;
    EXPECT_EQ(d->str().rfind("bad.toml:1:1: error:", 0), 0u) << d->str();
  }
}

// Without a [driver] table, the mobility count still has a place. A second pin at A makes
// M = 3(4-1) - 2*5 = -1.
TEST(Validation, MobilityWithoutADriverTableHasAPlace) {
  const std::string text = kHeader + kGround + kMoving + kJoints +
                           "[[joint]]\ntype = \"revolute\"\nname = \"A2\"\n"
                           "links = [\"ground\", \"crank\"]\npoint = \"A\"\n";
  const std::vector<Diagnostic> found = diagnostics_of(text);
  const Diagnostic* d = find(found, {"mobility -1"});
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->str().rfind("bad.toml:1:1: error:", 0), 0u) << d->str();
}

// A slider-crank: crank AB, connecting rod BC, piston on the ground's line through A.
const std::string kSliderCrank = R"(name = "slider-crank"
[units]
length = "mm"
angle = "deg"

[[link]]
name = "ground"
ground = true
points = { A = [0, 0] }
lines = { stroke = { through = "A", angle = 0 } }

[[link]]
name = "crank"
points = { A = [0, 0], B = [30, 0] }
pose = [0, 0, 90]

[[link]]
name = "rod"
points = { B = [0, 0], C = [100, 0] }
pose = [0, 30, -17.46]

[[link]]
name = "piston"
points = { C = [0, 0] }
pose = [95.39, 0, 0]

[[joint]]
type = "revolute"
links = ["ground", "crank"]
point = "A"

[[joint]]
type = "revolute"
links = ["crank", "rod"]
point = "B"

[[joint]]
type = "revolute"
links = ["rod", "piston"]
point = "C"

[[joint]]
type = "prismatic"
name = "piston"
guide = "ground"
line = "stroke"
slider = "piston"
point = "C"

[driver]
type = "joint_angle"
joint = "A"
to = "B"
start = 90
speed = 100
speed_unit = "rpm"
)";

TEST(Validation, SliderCrankIsValid) {
  const Mechanism m = parse_mechanism(kSliderCrank, "good.toml");
  EXPECT_EQ(mobility(m).mobility, 1);
}

TEST(Validation, JointAngleDriverOnAPrismaticJoint) {
  const std::string text =
      replaced(kSliderCrank, "joint = \"A\"\nto = \"B\"", "joint = \"piston\"\nto = \"B\"");
  const Place at = place_of(text, "joint = \"piston\"");
  expect_diagnostic(text, {at.line, at.column + 8}, {"revolute", "'piston' is prismatic"});
}

TEST(Validation, UnknownLengthUnitListsValidUnits) {
  const std::string text = replaced(four_bar(), "length = \"m\"", "length = \"inch\"");
  const Place at = place_of(text, "\"inch\"");
  expect_diagnostic(text, at, {"unknown unit 'inch'", "mm, cm, m"});
}

TEST(Validation, UnknownSpeedUnitListsValidUnits) {
  const std::string text = replaced(four_bar(), "speed_unit = \"rad/s\"", "speed_unit = \"rps\"");
  const Place at = place_of(text, "\"rps\"");
  expect_diagnostic(text, at, {"unknown unit 'rps'", "rad/s, deg/s, rpm, rev/s"});
}

// Issue 13: a constant acceleration of the driver from its start speed, and its errors at their
// places.
TEST(Validation, DriverAccelerationIsReadAndItsErrorsAreLocated) {
  // 10 rad/s and 5 deg/s^2 (0.0873 rad/s^2): one turn takes T with 0.0436 T^2 + 10 T = 2 pi.
  const std::string good = replaced(four_bar(), "speed_unit = \"rad/s\"",
                                    "speed_unit = \"rad/s\"\nacceleration = 5\n"
                                    "acceleration_unit = \"deg/s^2\"");
  const Mechanism m = parse_mechanism(good, "good.toml");
  const double alpha = 5.0 * std::numbers::pi / 180.0;
  EXPECT_EQ(m.drivers[0].law.kind, MotionLaw::Kind::constant_acceleration);
  EXPECT_DOUBLE_EQ(m.drivers[0].law.acceleration, alpha);
  EXPECT_NEAR(
      10.0 * m.drivers[0].law.duration + 0.5 * alpha * std::pow(m.drivers[0].law.duration, 2),
      2.0 * std::numbers::pi, 1e-12);

  const std::string no_speed =
      replaced(four_bar(), "speed = 10\nspeed_unit = \"rad/s\"", "acceleration = 5");
  Place value = place_of(no_speed, "acceleration = 5");
  value.column += 15;  // at the value
  expect_diagnostic(no_speed, value, {"'acceleration' needs 'speed'", "speed = 0 from rest"});
  const std::string unit = replaced(four_bar(), "speed_unit = \"rad/s\"",
                                    "speed_unit = \"rad/s\"\nacceleration = 5\n"
                                    "acceleration_unit = \"g\"");
  expect_diagnostic(unit, place_of(unit, "\"g\""),
                    {"unknown unit 'g'", "rad/s^2, deg/s^2, rpm/s, rev/s^2"});
  // From 10 rad/s at -10 rad/s^2 the crank stops after 5 rad, before a turn: a duration is
  // needed to say how long the cycle is.
  const std::string stops =
      replaced(four_bar(), "speed_unit = \"rad/s\"", "speed_unit = \"rad/s\"\nacceleration = -10");
  expect_diagnostic(stops, place_of(stops, "-10"),
                    {"speed 10 rad/s, acceleration -10 rad/s^2", "stops before it turns once",
                     "give 'duration'"});
  EXPECT_NO_THROW(parse_mechanism(stops + "duration = 1.5\n", "good.toml"));
  const std::string fast = replaced(four_bar(), "speed_unit = \"rad/s\"",
                                    "speed_unit = \"rad/s\"\nacceleration = 1e300");
  expect_diagnostic(fast, place_of(fast, "1e300"), {"'acceleration' in [driver]", "too large"});
}

TEST(Validation, OverConstrainedTriangle) {
  // Three links pinned in a triangle: a structure, M = 3(3-1) - 2*3 = 0.
  const std::string text = kHeader + R"(
[[link]]
name = "ground"
ground = true
points = { A = [0, 0], C = [0.10, 0] }

[[link]]
name = "crank"
points = { A = [0, 0], B = [0.05, 0] }
pose = [0, 0, 60]

[[link]]
name = "strut"
points = { B = [0, 0], C = [0.05, 0] }
pose = [0.025, 0.0433, -60]

[[joint]]
type = "revolute"
links = ["ground", "crank"]
point = "A"

[[joint]]
type = "revolute"
links = ["crank", "strut"]
point = "B"

[[joint]]
type = "revolute"
links = ["strut", "ground"]
point = "C"
)" + kDriver;
  expect_diagnostic(
      text, place_of(text, "[driver]"),
      {"mobility 0", "3(3-1) - 2*3 - 0 = 0", "over-constrained", "1 freedom too few"});
}

TEST(Validation, UnderConstrainedFiveBar) {
  // Ground and four moving links in one loop: M = 3(5-1) - 2*5 = 2, one more than one driver.
  const std::string text = kHeader + R"(
[[link]]
name = "ground"
ground = true
points = { A = [0, 0], E = [0.10, 0] }

[[link]]
name = "crank"
points = { A = [0, 0], B = [0.04, 0] }

[[link]]
name = "left"
points = { B = [0, 0], C = [0.06, 0] }

[[link]]
name = "right"
points = { C = [0, 0], D = [0.06, 0] }

[[link]]
name = "rocker"
points = { D = [0, 0], E = [0.05, 0] }

[[joint]]
type = "revolute"
links = ["ground", "crank"]
point = "A"

[[joint]]
type = "revolute"
links = ["crank", "left"]
point = "B"

[[joint]]
type = "revolute"
links = ["left", "right"]
point = "C"

[[joint]]
type = "revolute"
links = ["right", "rocker"]
point = "D"

[[joint]]
type = "revolute"
links = ["rocker", "ground"]
point = "E"
)" + kDriver;
  expect_diagnostic(text, place_of(text, "[driver]"),
                    {"mobility 2", "3(5-1) - 2*5 - 0 = 2", "under-constrained", "1 freedom more"});
}

TEST(Validation, TwoGrounds) {
  const std::string text =
      replaced(four_bar(), "name = \"rocker\"", "name = \"rocker\"\nground = true");
  expect_diagnostic(text, place_of(text, "[[link]]", 3),
                    {"link 'rocker' is a second ground", "first is 'ground'"});
}

TEST(Validation, NoGround) {
  const std::string text = replaced(four_bar(), "ground = true\n", "");
  // Points at the first link, where `ground = true` is expected.
  expect_diagnostic(text, place_of(text, "[[link]]"), {"no link has ground = true"});
}

// The fuzz campaign's crash: [[reference]] rows name the ground's outputs, and without a ground
// the loader read links[-1] (a sanitizer abort; std::bad_alloc with no place in Release).
TEST(Validation, NoGroundWithReferencesIsLocated) {
  const std::string text = replaced(four_bar(), "ground = true\n", "") + R"(
[[reference]]
quantity = "omega.coupler"
at = 60
value = 1
source = "test"
)";
  expect_diagnostic(text, place_of(text, "[[link]]"), {"no link has ground = true"});
}

TEST(Validation, LinkNotConnectedToGround) {
  const std::string text = four_bar() + R"(
[[link]]
name = "idler"
points = { P = [0, 0] }
)";
  const std::vector<Diagnostic> found = diagnostics_of(text);
  const Diagnostic* d = find(found, {"link 'idler' is not connected to the ground"});
  ASSERT_NE(d, nullptr);
  EXPECT_EQ(d->where.line, place_of(text, "[[link]]", 4).line) << d->str();
  // The loose link is the one fault: no second, derived complaint about the mobility.
  EXPECT_EQ(found.size(), 1u);
}

TEST(Validation, ReferenceWithUnknownQuantityKind) {
  const std::string text = four_bar() + R"(
[[reference]]
quantity = "speed.coupler"
at = 60
value = 1.0
source = "test"
)";
  expect_diagnostic(text, place_of(text, "\"speed.coupler\""),
                    {"unknown quantity 'speed.coupler'", "omega", "sddot"});
}

TEST(Validation, ReferenceToUnknownLink) {
  const std::string text = four_bar() + R"(
[[reference]]
quantity = "omega.coupling"
at = 60
value = 1.0
source = "test"
)";
  expect_diagnostic(text, place_of(text, "\"omega.coupling\""),
                    {"'omega.coupling'", "valid names: crank, coupler, rocker, A, D, B, C"});
}

// A kind its object does not have: before, "sdot.B" of a point was accepted, compared with
// nothing ("-") and the comparison passed.
TEST(Validation, ReferenceToAChannelItsObjectDoesNotHave) {
  for (const auto& [quantity, kinds] : std::vector<std::pair<std::string, std::string>>{
           {"sdot.B", "those of 'B': x.B, y.B, vx.B, vy.B, v.B, ax.B, ay.B, a.B"},
           {"omega.B", "those of 'B'"},
           {"x.coupler", "those of 'coupler': angle.coupler, omega.coupler, alpha.coupler"},
           {"s.coupler", "those of 'coupler'"}}) {
    const std::string text = four_bar() + fmt::format(R"(
[[reference]]
quantity = "{}"
at = 60
value = 1.0
source = "test"
)",
                                                      quantity);
    expect_diagnostic(text, place_of(text, "\"" + quantity + "\""),
                      {fmt::format("'{}' is no channel of this mechanism", quantity), kinds});
  }
}

// Issue 13: a reference keeps its value as printed, and the unit of its last digit: a
// difference under half of it is within the printed rounding.
TEST(Validation, ReferenceKeepsItsPrintedValueAndPrecision) {
  const std::string text = four_bar() + R"(
[[reference]]
quantity = "omega.coupler"
at = 60
value = -12.00
source = "as printed"

[[reference]]
quantity = "angle.coupler"
at = 60
value = 57.3
precision = 0.5
source = "read off a drawing"
)";
  const Mechanism m = parse_mechanism(text, "good.toml");
  ASSERT_EQ(m.references.size(), 2u);
  EXPECT_EQ(m.references[0].printed, "-12.00");
  EXPECT_DOUBLE_EQ(m.references[0].precision, 0.01);  // rad/s: no unit factor
  EXPECT_TRUE(m.references[0].within_rounding(-12.004));
  EXPECT_FALSE(m.references[0].within_rounding(-12.006));
  EXPECT_EQ(m.references[1].printed, "57.3");
  EXPECT_NEAR(m.references[1].precision, 0.5 * std::acos(-1.0) / 180.0, 1e-15);  // degrees
}

TEST(Validation, PoseOnTheGroundIsAnError) {
  const std::string text =
      replaced(four_bar(), "ground = true", "ground = true\npose = [0, 0, 10]");
  expect_diagnostic(text, place_of(text, "[0, 0, 10]"),
                    {"link 'ground' is the ground", "takes no 'pose'"});
}

TEST(Validation, InchesAndFeet) {
  for (const auto& [unit, metres] : {std::pair{"in", 0.0254}, {"ft", 0.3048}}) {
    const Mechanism m = parse_mechanism(
        replaced(four_bar(), "length = \"m\"", fmt::format("length = \"{}\"", unit)), "good.toml");
    EXPECT_DOUBLE_EQ(m.units.length, metres) << unit;
    EXPECT_EQ(m.units.length_name, unit);
  }
}

// A four-bar drawn where it cannot close: ground 0.10, crank 0.08, coupler 0.04, rocker 0.05.
// With the crank at 180 degrees, |BD| = 0.18 m, longer than coupler + rocker = 0.09 m. (It does
// close near 0 degrees, where |BD| = 0.02 m.)
std::string open_four_bar() {
  std::string text = replaced(four_bar(), "B = [0.04, 0]", "B = [0.08, 0]");
  text = replaced(text, "C = [0.12, 0]", "C = [0.04, 0]");
  text = replaced(text, "C = [0.08, 0]", "C = [0.05, 0]");
  text = replaced(text, "pose = [0, 0, 60]", "pose = [0, 0, 180]");
  text = replaced(text, "start = 60", "start = 180");
  return text;
}

TEST(Validation, CannotAssembleIsAStatusNeverANaN) {
  const Mechanism m = parse_mechanism(open_four_bar(), "open.toml");
  const NewtonSolver solver(m);
  KinematicState state(m);
  const SolveReport report = solver.assemble(state);
  EXPECT_EQ(report.status, PoseStatus::cannot_assemble);
  EXPECT_FALSE(report.message.empty());
  EXPECT_TRUE(std::isfinite(report.residual));
  EXPECT_TRUE(std::isfinite(report.rcond));
  EXPECT_TRUE(state.q.allFinite());
  EXPECT_TRUE(state.qdot.allFinite());
  EXPECT_TRUE(state.qddot.allFinite());
  // The message says why: the loop gap left at the closest approach.
  EXPECT_NE(report.message.find("loop gap"), std::string::npos) << report.message;
}

// ---------------------------------------------------------------------------------------------
// Limits (analytic/model/limits.h): what reaches the TOML parser, counts, magnitudes. Each fault is
// refused at its place, and the message states the limit.

TEST(Limits, ADefinitionOverOneMebibyteIsRefusedAtLineOne) {
  // Valid TOML all through: a comment long enough to take the file over 1 MiB.
  const std::string text = four_bar() + "# " + std::string(1 << 20, 'x') + "\n";
  const std::vector<Diagnostic> found = diagnostics_of(text);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].str().rfind("bad.toml:1:1: error:", 0), 0u) << found[0].str();
  EXPECT_NE(found[0].message.find("1048576 bytes"), std::string::npos) << found[0].message;
}

TEST(Limits, ADottedHeaderOfTooManyPartsIsRefusedWhereItPassesTheLimit) {
  // [a.a.a...] of 100,000 parts crashed toml++ (stack overflow). The 16th dot starts the 17th
  // part: after "[" and 15 times "a.", then "a", it is at column 1 + 15 * 2 + 2 = 33.
  std::string header = "[a";
  for (int k = 1; k < 100000; ++k) header += ".a";
  const std::string text = four_bar() + header + "]\n";
  const std::vector<Diagnostic> found = diagnostics_of(text);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].where.line, place_of(text, "[a.a").line) << found[0].str();
  EXPECT_EQ(found[0].where.column, 33) << found[0].str();
  EXPECT_NE(found[0].message.find("more than 16 dotted parts"), std::string::npos);
}

TEST(Limits, SixteenDottedPartsAreAccepted) {
  // At the limit the key reaches the loader, which does not know it: a different error.
  std::string key = "a";
  for (int k = 1; k < 16; ++k) key += ".a";
  const std::vector<Diagnostic> found = diagnostics_of(four_bar() + key + " = 1\n");
  ASSERT_EQ(found.size(), 1u);
  EXPECT_NE(found[0].message.find("unknown key 'a'"), std::string::npos) << found[0].str();
}

TEST(Limits, NestingDeeperThanSixteenLevelsIsRefused) {
  // The 17th opening bracket of the value after "x = " is at column 5 + 16.
  const std::string text = four_bar() + "x = " + std::string(17, '[') + std::string(17, ']') + "\n";
  const std::vector<Diagnostic> found = diagnostics_of(text);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].where.line, place_of(text, "x = [").line) << found[0].str();
  EXPECT_EQ(found[0].where.column, 5 + 16) << found[0].str();
  EXPECT_NE(found[0].message.find("deeper than 16 levels"), std::string::npos);
}

TEST(Limits, DotsAndBracketsInStringsAndCommentsDoNotCount) {
  const std::string dots(200, '.');
  const std::string description = dots + "[[[[\\\"" + std::string(40, '{');
  const std::string text =
      replaced(four_bar(), "name = \"four-bar\"",
               "name = \"four-bar\"\ndescription = \"" + description + "\"  # " + dots +
                   std::string(40, '[') + "\ncitation = '''" + dots + "\n" + dots + "'''");
  const Mechanism m = parse_mechanism(text, "good.toml");
  EXPECT_EQ(m.description, dots + "[[[[\"" + std::string(40, '{'));
}

// Ground and n moving links, each pinned to the ground at a point of its own.
std::string many_links(int n) {
  std::string text =
      kHeader + "[[link]]\nname = \"ground\"\nground = true\npoints = { P0 = [0, 0] }\n";
  for (int k = 1; k <= n; ++k)
    text += fmt::format("[[link]]\nname = \"l{}\"\npoints = {{ P{} = [{}, 0] }}\n", k, k, k);
  return text;
}

TEST(Limits, MoreLinksThanTheLimitAreRefusedAtTheFirstPastIt) {
  // Ground and kLinks moving links make kLinks + 1 [[link]] tables; the one at index kLinks is
  // the fault.
  constexpr int n = limits::kLinks;
  const std::string text = many_links(n);
  const std::vector<Diagnostic> found = diagnostics_of(text);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].where.line, place_of(text, "[[link]]", n).line) << found[0].str();
  EXPECT_NE(found[0].message.find(fmt::format("{} [[link]] tables: the limit is {}", n + 1, n)),
            std::string::npos)
      << found[0].message;
  // kLinks pass the count and fail later, for want of joints.
  const std::vector<Diagnostic> fewer = diagnostics_of(many_links(n - 1));
  const Diagnostic* joints = find(fewer, {"[[joint]]"});
  ASSERT_NE(joints, nullptr);
  EXPECT_EQ(joints->where.line, 1);
}

TEST(Limits, ATableLawOfMoreThanTenThousandRowsIsRefused) {
  std::string rows;
  for (int k = 0; k <= 10000; ++k) rows += fmt::format("{}[{}, {}]", k ? ", " : "", k * 1e-4, k);
  const std::string text = replaced(four_bar(), "speed = 10\nspeed_unit = \"rad/s\"",
                                    "table = [" + rows + "]\nduration = 1");
  const Place at = place_of(text, "table =");
  expect_diagnostic(text, {at.line, at.column + 8}, {"10001 rows: the limit is 10000"});
}

TEST(Limits, APolynomialOfMoreThanTwentyCoefficientsIsRefused) {
  std::string coefficients = "1";
  for (int k = 1; k < 21; ++k) coefficients += ", 0";
  const std::string text = replaced(four_bar(), "speed = 10\nspeed_unit = \"rad/s\"",
                                    "polynomial = [" + coefficients + "]\nduration = 1");
  const Place at = place_of(text, "polynomial =");
  expect_diagnostic(text, {at.line, at.column + 13}, {"21 coefficients: the limit is 20"});
}

TEST(Limits, ACoordinateBeyondAThousandKilometresIsRefusedInFileUnits) {
  // 2e9 mm is 2000 km; the limit, 1e6 m, is 1e9 mm.
  std::string text = replaced(four_bar(), "length = \"m\"", "length = \"mm\"");
  text = replaced(text, "D = [0.10, 0]", "D = [2e9, 0]");
  expect_diagnostic(
      text, place_of(text, "2e9"),
      {"point 'D' of link 'ground' = 2000000000 mm is too large", "limit is 1e+09 mm"});
}

TEST(Limits, ADrawnAngleBeyondTenThousandRadiansIsRefused) {
  // 1e7 degrees (1.7e5 rad) took 47 s to fail to close; the limit, 1e4 rad, is 572958 degrees.
  const std::string text = replaced(four_bar(), "pose = [0, 0, 60]", "pose = [0, 0, 1e7]");
  expect_diagnostic(text, place_of(text, "1e7"),
                    {"pose of link 'crank'", "too large: the limit is 572958 deg"});
  const std::string start = replaced(four_bar(), "start = 60", "start = 1e7");
  expect_diagnostic(start, place_of(start, "1e7"), {"'start' in [driver]", "too large"});
  // A range may reach further: the budget counts the steps to get there (test_budget).
  EXPECT_NO_THROW(parse_mechanism(
      replaced(four_bar(), "speed = 10", "speed = 10\nrange = [0, 1e7]"), "good.toml"));
}

TEST(Limits, ASpeedTooSlowForACycleIsRefused) {
  // 1e-320 rad/s (subnormal) makes one turn last 6e320 s, an infinite time.
  const std::string text = replaced(four_bar(), "speed = 10", "speed = 1e-320");
  expect_diagnostic(text, place_of(text, "1e-320"),
                    {"'speed' in [driver] = ", "rad/s is too small", "limit is 1e-09 rad/s"});
}

TEST(Limits, ASpeedThatUnderflowsToRestIsRefused) {
  // 5e-324 rpm (the smallest double) times 2 pi / 60 is 0 rad/s: the driver became "at rest".
  // The limit, 1e-9 rad/s, is 1e-9 * 60 / (2 pi) = 9.54930e-9 rpm.
  std::string text = replaced(four_bar(), "speed = 10", "speed = 5e-324");
  text = replaced(text, "speed_unit = \"rad/s\"", "speed_unit = \"rpm\"");
  expect_diagnostic(text, place_of(text, "5e-324"),
                    {"'speed' in [driver] = ", "rpm is too small", "limit is 9.5493e-09 rpm"});
  // A coordinate that underflows is refused too, at the smallest normal double (2.2e-308 m in
  // mm: 2.2e-305 mm).
  std::string tiny = replaced(four_bar(), "length = \"m\"", "length = \"mm\"");
  tiny = replaced(tiny, "D = [0.10, 0]", "D = [100, 1e-320]");
  expect_diagnostic(tiny, place_of(tiny, "1e-320"), {"is too small", "limit is 2.22507e-305 mm"});
}

TEST(Limits, ASpeedBeyondTheLimitIsRefusedInItsOwnUnit) {
  // 1e300 rev/s; the limit 1e9 rad/s is 1e9 / (2 pi) = 1.59155e8 rev/s.
  std::string text = replaced(four_bar(), "speed = 10", "speed = 1e300");
  text = replaced(text, "speed_unit = \"rad/s\"", "speed_unit = \"rev/s\"");
  expect_diagnostic(text, place_of(text, "1e300"), {"too large", "1.59155e+08 rev/s"});
}

TEST(Limits, TableTimesCloserThanANanosecondAreRefused) {
  const std::string text = replaced(four_bar(), "speed = 10\nspeed_unit = \"rad/s\"",
                                    "table = [[0, 60], [1e-12, 61], [1, 62]]\nduration = 1");
  expect_diagnostic(text, place_of(text, "[1e-12"), {"closer than the limit of 1e-09 s"});
}

TEST(Limits, APolynomialLawThatRunsAwayIsRefusedAtItsKey) {
  // 60 deg + 1e10 deg/s * t passes 1e8 rad = 5.72958e9 deg before t = 1 s; its rate, 1.7e8
  // rad/s, is within the 1e9 rad/s limit, so the value is the fault.
  const std::string text = replaced(four_bar(), "speed = 10\nspeed_unit = \"rad/s\"",
                                    "polynomial = [1e10]\nduration = 1");
  const Place at = place_of(text, "polynomial =");
  expect_diagnostic(text, {at.line, at.column + 13},
                    {"[driver] 'polynomial' reaches", "the limit is 5.72958e+09 deg"});
}

TEST(Limits, AReferenceValueBeyondTheLimitIsRefused) {
  const std::string text = four_bar() + R"(
[[reference]]
quantity = "omega.coupler"
at = 60
value = 1e300
source = "test"
)";
  expect_diagnostic(text, place_of(text, "1e300"), {"'value' in [[reference]]", "too large"});
}

TEST(Limits, AMechanismSmallerThanAMicrometreIsRefused) {
  // The base four-bar's ground in nanometres instead of metres: its points 0.1 nm apart, and
  // every other link's at most 0.12 nm from its origin, all drawn near the world's origin.
  std::string text = replaced(four_bar(), "length = \"m\"", "length = \"mm\"");
  text = replaced(text, "D = [0.10, 0]", "D = [1e-7, 0]");
  text = replaced(text, "B = [0.04, 0]", "B = [4e-8, 0]");
  text = replaced(text, "C = [0.12, 0]", "C = [1.2e-7, 0]");
  text = replaced(text, "C = [0.08, 0]", "C = [8e-8, 0]");
  text = replaced(text, "pose = [0.02, 0.034641, 18.38]", "pose = [2e-8, 3.4641e-8, 18.38]");
  text = replaced(text, "pose = [0.10, 0, 64.94]", "pose = [1e-7, 0, 64.94]");
  expect_diagnostic(text, place_of(text, "[[link]]"), {"the mechanism's size", "1e-06 m"});
}

}  // namespace
}  // namespace crosslink

namespace crosslink {
namespace {

// Physics keys (docs/mechanism-format.md): mass, com, inertia; gravity; [[load]]; [[spring]];
// mass and force units.
std::string with_physics(const std::string& crank_keys, const std::string& tail = "") {
  return replaced(four_bar(), "pose = [0, 0, 60]\n", "pose = [0, 0, 60]\n" + crank_keys) + tail;
}

TEST(ValidationPhysics, UnitsAndValuesAreReadInSi) {
  // 40 g, 2 kg cm^2 = 2e-3 * 1e-4 kg m^2 in a cm file; gravity 981 cm/s^2; a 0.5 kN force,
  // a 2 kN cm torque, a spring of 3 kN/cm.
  std::string text =
      replaced(four_bar(), "length = \"m\"", "length = \"cm\"\nmass = \"g\"\nforce = \"kN\"");
  text = replaced(text, "D = [0.10, 0] }", "D = [10, 0] }");
  text = replaced(text, "B = [0.04, 0] }\npose = [0, 0, 60]",
                  "B = [4, 0] }\npose = [0, 0, 60]\nmass = 40\ncom = [2, 0]\ninertia = 2000");
  text = replaced(text, "C = [0.12, 0] }\npose = [0.02, 0.034641, 18.38]",
                  "C = [12, 0] }\npose = [2, 3.4641, 18.38]");
  text = replaced(text, "C = [0.08, 0] }\npose = [0.10, 0, 64.94]",
                  "C = [8, 0] }\npose = [10, 0, 64.94]");
  text += R"(
gravity = [0, -981]
[[load]]
link = "coupler"
point = "C"
force = [0.5, 0]
[[load]]
link = "rocker"
torque = 2
[[spring]]
links = ["ground", "rocker"]
points = ["A", "C"]
stiffness = 3
free_length = 5
)";
  // Top-level keys after tables belong to the last table in TOML: put gravity first.
  text = replaced(text, "\ngravity = [0, -981]\n", "\n");
  text = "gravity = [0, -981]\n" + text;
  const Mechanism m = parse_mechanism(text, "good.toml");
  const Link& crank = m.links[static_cast<size_t>(m.find_link("crank"))];
  EXPECT_FALSE(crank.mass.assumed);
  EXPECT_DOUBLE_EQ(crank.mass.mass, 0.040);
  EXPECT_DOUBLE_EQ(crank.mass.com.x(), 0.02);
  EXPECT_NEAR(crank.mass.inertia, 2000 * 1e-3 * 1e-4, 1e-18);
  EXPECT_TRUE(m.links[static_cast<size_t>(m.find_link("coupler"))].mass.assumed);
  EXPECT_DOUBLE_EQ(m.gravity.y(), -9.81);
  ASSERT_EQ(m.loads.size(), 2u);
  EXPECT_DOUBLE_EQ(m.loads[0].force_at(0.0).x(), 500.0);
  EXPECT_DOUBLE_EQ(m.loads[1].force_at(0.0).x(), 2000.0 * 0.01);
  ASSERT_EQ(m.springs.size(), 1u);
  EXPECT_DOUBLE_EQ(m.springs[0].stiffness, 3000.0 / 0.01);
  EXPECT_DOUBLE_EQ(m.springs[0].free_length, 0.05);
}

TEST(ValidationPhysics, NegativeMass) {
  const std::string text = with_physics("mass = -1\ncom = \"A\"\ninertia = 0\n");
  expect_diagnostic(text, place_of(text, "-1"), {"'mass' must not be negative", "crank"});
}

// A subnormal mass (1e-320 kg, fuzz-timeout-3615... of issue 24) is refused at its key: the
// smallest normal double, 2.22507e-308 kg, is the limit.
TEST(ValidationPhysics, AMassThatUnderflowsIsRefused) {
  const std::string text = with_physics("mass = 1e-320\ncom = \"A\"\ninertia = 0\n");
  expect_diagnostic(
      text, place_of(text, "1e-320"),
      {"'mass' of link 'crank' = 1e-320 kg is too small", "limit is 2.22507e-308 kg"});
}

TEST(ValidationPhysics, ZeroMassWithInertia) {
  const std::string text = with_physics("mass = 0\ncom = \"A\"\ninertia = 0.5\n");
  expect_diagnostic(text, place_of(text, "0\ncom"), {"zero mass cannot have inertia"});
}

TEST(ValidationPhysics, NegativeInertia) {
  const std::string text = with_physics("mass = 1\ncom = \"A\"\ninertia = -0.5\n");
  expect_diagnostic(text, place_of(text, "-0.5"), {"'inertia' must not be negative"});
}

TEST(ValidationPhysics, MassWithoutInertia) {
  const std::string text = with_physics("mass = 1\ncom = \"A\"\n");
  expect_diagnostic(text, place_of(text, "1\ncom"), {"gives 'mass' but no 'inertia'"});
}

TEST(ValidationPhysics, CentreOfMassAtAMissingPoint) {
  const std::string text = with_physics("mass = 1\ncom = \"Q\"\ninertia = 0\n");
  expect_diagnostic(text, place_of(text, "\"Q\""), {"'com' names point 'Q'", "its points: A, B"});
}

TEST(ValidationPhysics, LoadOnAMissingPoint) {
  const std::string text =
      with_physics("", "\n[[load]]\nlink = \"coupler\"\npoint = \"Z\"\nforce = [1, 0]\n");
  expect_diagnostic(text, place_of(text, "\"Z\""), {"point 'Z' is not on link 'coupler'"});
}

TEST(ValidationPhysics, LoadWithoutAValue) {
  const std::string text = with_physics("", "\n[[load]]\nlink = \"coupler\"\npoint = \"C\"\n");
  expect_diagnostic(text, place_of(text, "[[load]]"), {"load #1 needs exactly one of 'force'"});
}

TEST(ValidationPhysics, TorqueAtAPoint) {
  const std::string text =
      with_physics("", "\n[[load]]\nlink = \"coupler\"\npoint = \"C\"\ntorque = 1\n");
  expect_diagnostic(text, place_of(text, "\"C\"\ntorque"), {"a torque acts on the whole link"});
}

TEST(ValidationPhysics, LoadTableDriverValuesMustIncrease) {
  const std::string text = with_physics(
      "", "\n[[load]]\nlink = \"rocker\"\ntorque_table = [[0, 1], [90, 2], [45, 3]]\n");
  expect_diagnostic(text, place_of(text, "[45, 3]"), {"must increase strictly"});
}

TEST(ValidationPhysics, SpringBetweenTwoPointsOfOneLink) {
  const std::string text =
      with_physics("",
                   "\n[[spring]]\nlinks = [\"rocker\", \"rocker\"]\npoints = [\"D\", \"C\"]\n"
                   "stiffness = 10\nfree_length = 0.05\n");
  expect_diagnostic(text, place_of(text, "[\"rocker\", \"rocker\"]"),
                    {"joins two points of one link ('rocker')"});
}

TEST(ValidationPhysics, SpringStiffnessNeedsAFreeLength) {
  const std::string text =
      with_physics("",
                   "\n[[spring]]\nlinks = [\"ground\", \"rocker\"]\npoints = [\"A\", \"C\"]\n"
                   "stiffness = 17\n");
  expect_diagnostic(text, place_of(text, "17\n"), {"'stiffness' needs 'free_length'"});
}

TEST(ValidationPhysics, NegativeDamping) {
  const std::string text =
      with_physics("",
                   "\n[[spring]]\nlinks = [\"ground\", \"rocker\"]\npoints = [\"A\", \"C\"]\n"
                   "damping = -2\n");
  expect_diagnostic(text, place_of(text, "-2"), {"'damping' must not be negative"});
}

// A spring's values have the physics limits (analytic/model/limits.h): 1e308 N s/cm was 1e310 N
// s/m, infinite, and `check` printed `damping inf` as ok.
TEST(ValidationPhysics, SpringValuesBeyondTheLimitsAreRefusedAtTheirKeys) {
  const std::string spring =
      "\n[[spring]]\nlinks = [\"ground\", \"rocker\"]\npoints = [\"A\", \"C\"]\n";
  std::string cm = replaced(four_bar(), "length = \"m\"", "length = \"cm\"");
  cm = replaced(cm, "D = [0.10, 0]", "D = [10, 0]");  // a drawing's scale does not matter here
  const std::string damping = cm + spring + "damping = 1e308\n";
  // 1e12 N s/m is 1e10 N s/cm.
  expect_diagnostic(
      damping, place_of(damping, "1e308"),
      {"'damping' in spring #1 = 1e+308 N s/cm is too large", "the limit is 1e+10 N s/cm"});
  const std::string stiffness = with_physics("", spring + "stiffness = 2e15\nfree_length = 0.1\n");
  expect_diagnostic(
      stiffness, place_of(stiffness, "2e15"),
      {"'stiffness' in spring #1 = 2000000000000000 N/m is too large", "the limit is 1e+15 N/m"});
  const std::string length = with_physics("", spring + "stiffness = 2\nfree_length = 2e6\n");
  expect_diagnostic(length, place_of(length, "2e6"), {"'free_length'", "too large"});
}

TEST(ValidationPhysics, UnknownMassUnit) {
  const std::string text =
      replaced(four_bar(), "angle = \"deg\"", "angle = \"deg\"\nmass = \"lb\"");
  expect_diagnostic(text, place_of(text, "\"lb\""), {"unknown unit 'lb' for 'mass'", "kg, g"});
}

TEST(ValidationPhysics, UnknownForceUnit) {
  const std::string text =
      replaced(four_bar(), "angle = \"deg\"", "angle = \"deg\"\nforce = \"lbf\"");
  expect_diagnostic(text, place_of(text, "\"lbf\""), {"unknown unit 'lbf' for 'force'", "N, kN"});
}

TEST(ValidationPhysics, GravityIsTwoNumbers) {
  const std::string text = "gravity = [0, -9.81, 0]\n" + four_bar();
  expect_diagnostic(text, place_of(text, "[0, -9.81, 0]"), {"'gravity'", "2 numbers"});
}

}  // namespace
}  // namespace crosslink

namespace crosslink {
namespace {

// Issue 13: arithmetic in numbers. Expected values are the arithmetic worked by hand.
constexpr double kPi = std::numbers::pi;

const Link& link_named(const Mechanism& m, const std::string& name) {
  return m.links[static_cast<size_t>(m.find_link(name))];
}
const Eigen::Vector2d& local(const Mechanism& m, const std::string& link, const std::string& p) {
  const Link& l = link_named(m, link);
  return l.points[static_cast<size_t>(l.find_point(p))].local;
}

TEST(Expressions, AreEvaluatedInTheFilesUnits) {
  // In degrees: acos(0.5) is 60 (deg), cos(60) is cos(60 deg) = 0.5.
  std::string text = replaced(four_bar(), "start = 60", "start = \"acos(0.5)\"");
  text = replaced(text, "B = [0.04, 0]", "B = [\"0.08*cos(60)\", 0]");
  text = replaced(text, "D = [0.10, 0]", "D = [\"2^3^2 / 5120\", \"-2^2 + 4\"]");
  text = replaced(text, "speed = 10", "speed = \"2 * (3 + 2)\"");
  const Mechanism deg = parse_mechanism(text, "good.toml");
  EXPECT_NEAR(deg.drivers[0].start, kPi / 3, 1e-15);
  EXPECT_NEAR(local(deg, "crank", "B").x(), 0.04, 1e-17);
  EXPECT_EQ(local(deg, "ground", "D"), Eigen::Vector2d(0.10, 0.0));  // 512 / 5120, 0
  EXPECT_EQ(deg.drivers[0].law.speed, 10.0);

  // In radians the same values are written with pi: the same mechanism.
  text = replaced(text, "angle = \"deg\"", "angle = \"rad\"");
  text = replaced(text, "B = [\"0.08*cos(60)\", 0]", "B = [\"0.08*cos(pi/3)\", 0]");
  text = replaced(text, "pose = [0, 0, 60]", "pose = [0, 0, \"pi/3\"]");
  text = replaced(text, "18.38]", "\"18.38 * pi/180\"]");
  text = replaced(text, "64.94]", "\"64.94 * pi/180\"]");
  const Mechanism rad = parse_mechanism(text, "good.toml");
  EXPECT_NEAR(rad.drivers[0].start, kPi / 3, 1e-15);  // acos(0.5) in radians
  EXPECT_NEAR(local(rad, "crank", "B").x(), 0.04, 1e-17);
  EXPECT_NEAR((*link_named(rad, "coupler").pose)(2), (*link_named(deg, "coupler").pose)(2), 1e-15);
}

TEST(Expressions, ScaleToSiLikeALiteral) {
  // In cm and g: 4 cm, 2 + 2 = 4 cm; inertia 1000 * 2 g cm^2. A string `com` is a point's name,
  // never an expression.
  std::string text = replaced(four_bar(), "length = \"m\"", "length = \"cm\"\nmass = \"g\"");
  text = replaced(text, "D = [0.10, 0]", "D = [\"5 * 2\", 0]");
  text = replaced(text, "B = [0.04, 0] }\npose = [0, 0, 60]",
                  "B = [\"2 + 2\", 0] }\npose = [0, 0, 60]\nmass = \"40\"\ncom = \"B\"\n"
                  "inertia = \"1000 * 2\"");
  text = replaced(text, "C = [0.12, 0] }\npose = [0.02, 0.034641, 18.38]",
                  "C = [12, 0] }\npose = [2, 3.4641, 18.38]");
  text = replaced(text, "C = [0.08, 0] }\npose = [0.10, 0, 64.94]",
                  "C = [8, 0] }\npose = [10, 0, 64.94]");
  const Mechanism m = parse_mechanism(text, "good.toml");
  EXPECT_DOUBLE_EQ(local(m, "ground", "D").x(), 0.10);
  EXPECT_DOUBLE_EQ(local(m, "crank", "B").x(), 0.04);
  const Link& crank = link_named(m, "crank");
  EXPECT_DOUBLE_EQ(crank.mass.mass, 0.040);
  EXPECT_DOUBLE_EQ(crank.mass.com.x(), 0.04);
  EXPECT_NEAR(crank.mass.inertia, 2000 * 1e-3 * 1e-4, 1e-18);
}

TEST(Expressions, AReferenceKeepsItsExpressionAsPrinted) {
  const std::string text = four_bar() + R"(
[[reference]]
quantity = "omega.coupler"
at = "50 + 10"
value = "-12 - 1/3"
source = "as printed"
)";
  const Mechanism m = parse_mechanism(text, "good.toml");
  ASSERT_EQ(m.references.size(), 1u);
  EXPECT_NEAR(m.references[0].driver_value, kPi / 3, 1e-15);
  EXPECT_EQ(m.references[0].value, -12.0 - 1.0 / 3.0);
  EXPECT_EQ(m.references[0].printed, "-12 - 1/3");
  EXPECT_EQ(m.references[0].precision, 0.0);  // no last printed digit: give `precision`
}

// An error inside an expression is at its character: the string's column, 1 for the quote, and
// the characters before it.
TEST(Expressions, ASyntaxErrorIsAtItsCharacter) {
  const std::string text = replaced(four_bar(), "B = [0.04, 0]", "B = [\"0.04 * * 2\", 0]");
  expect_diagnostic(text, place_of(text, "* 2"),
                    {"point 'B' of link 'crank' = \"0.04 * * 2\": expected a number, a name or "
                     "'(', found '*'"});
}

TEST(Expressions, AnUnknownFunctionIsAtItsName) {
  const std::string text = replaced(four_bar(), "start = 60", "start = \"sqr(3600)\"");
  expect_diagnostic(text, place_of(text, "sqr("),
                    {"'start' in [driver] = \"sqr(3600)\": unknown function 'sqr'",
                     "functions: sqrt, abs, sin, cos, tan, asin, acos, atan, atan2"});
}

TEST(Expressions, DivisionByZeroIsAtTheDivision) {
  const std::string text = replaced(four_bar(), "D = [0.10, 0]", "D = [\"0.1/0\", 0]");
  expect_diagnostic(text, place_of(text, "/0\""),
                    {"point 'D' of link 'ground'", "division by zero"});
}

TEST(Expressions, UnbalancedParentheses) {
  const std::string open = replaced(four_bar(), "start = 60", "start = \"2 * (30\"");
  expect_diagnostic(open, place_of(open, "(30"), {"'(' is never closed"});
  const std::string close = replaced(four_bar(), "start = 60", "start = \"2 * 30)\"");
  expect_diagnostic(close, place_of(close, ")\""), {"')' without a matching '('"});
}

TEST(Expressions, ANonFiniteValueIsAnError) {
  const std::string text =
      replaced(four_bar(), "pose = [0, 0, 60]", "pose = [0, 0, \"60 + sqrt(-1)\"]");
  expect_diagnostic(text, place_of(text, "sqrt(-1)"),
                    {"pose of link 'crank'", "sqrt(-1) is not a real number"});
}

// An expression's value passes the checks of a literal, reported at the string.
TEST(Expressions, AValueBeyondTheLimitIsRefusedAtTheString) {
  const std::string text = replaced(four_bar(), "D = [0.10, 0]", "D = [\"2 * 1e6\", 0]");
  expect_diagnostic(text, place_of(text, "\"2 * 1e6\""),
                    {"point 'D' of link 'ground' = 2000000 m is too large", "limit is 1e+06 m"});
}

// A string written with escapes does not read as its value: the error is at the string.
TEST(Expressions, AnEscapedStringIsReportedAtTheString) {
  const std::string text = replaced(four_bar(), "start = 60", "start = \"1/\\u0030\"");
  expect_diagnostic(text, place_of(text, "\"1/"), {"'start' in [driver]", "division by zero"});
}

// toml++ counts columns in characters: after an 'é' (two bytes) on the line, one less than the
// byte's place.
TEST(Expressions, ColumnsCountCharactersNotBytes) {
  const std::string text =
      replaced(four_bar(), "D = [0.10, 0] }\n",
               "D = [0.10, 0] }\nlines = { \"é\" = { through = \"A\", angle = \"1/0\" } }\n");
  const Place byte = place_of(text, "/0\"");
  expect_diagnostic(text, {byte.line, byte.column - 1}, {"line 'é'", "division by zero"});
}

TEST(Expressions, ABooleanIsNeitherANumberNorAnExpression) {
  const std::string text = replaced(four_bar(), "start = 60", "start = true");
  const Place key = place_of(text, "start = true");
  expect_diagnostic(text, {key.line, key.column + 8},
                    {"'start' in [driver] must be a number, or an expression in quotes"});
}

// Issue 13: polar points. The coupler BC (B at its origin, C at 0.12 on its x axis) carries
//   P = 0.05 from B at 30 deg from the x axis:          (0.025 sqrt(3), 0.025)
//   Q = 0.03 from C at -45 deg from the direction C -> B (180 deg): at 135 deg,
//       (0.12 - 0.015 sqrt(2), 0.015 sqrt(2))
//   S = 0.02 from P along the x axis, R = 0.01 from S at 90 deg: S = P + (0.02, 0),
//       R = S + (0, 0.01); R refers to S, listed after it, and S to P, itself polar.
const std::string kCoupler = "points = { B = [0, 0], C = [0.12, 0] }";
// (TOML 1.0 keeps an inline table on one line.)
const std::string kPolarCoupler =
    "points = { B = [0, 0], C = [0.12, 0], "
    "P = { from = \"B\", length = 0.05, angle = 30 }, "
    "Q = { from = \"C\", toward = \"B\", length = 0.03, angle = -45 }, "
    "R = { from = \"S\", length = \"0.02 / 2\", angle = \"180 / 2\" }, "
    "S = { from = \"P\", length = 0.02, angle = 0 } }";

std::string with_coupler(const std::string& points) {
  return replaced(four_bar(), kCoupler, points);
}

TEST(PolarPoints, EqualTheirCartesianPoints) {
  const Mechanism m = parse_mechanism(with_coupler(kPolarCoupler), "good.toml");
  const Eigen::Vector2d p(0.025 * std::sqrt(3.0), 0.025);
  const Eigen::Vector2d q(0.12 - 0.015 * std::sqrt(2.0), 0.015 * std::sqrt(2.0));
  const Eigen::Vector2d s = p + Eigen::Vector2d(0.02, 0.0);
  const Eigen::Vector2d r = s + Eigen::Vector2d(0.0, 0.01);
  for (const auto& [name, expected] : {std::pair{"P", p}, {"Q", q}, {"R", r}, {"S", s}}) {
    EXPECT_NEAR(local(m, "coupler", name).x(), expected.x(), 1e-15) << name;
    EXPECT_NEAR(local(m, "coupler", name).y(), expected.y(), 1e-15) << name;
  }
  // In the table's order, as [x, y] points are; each located at its own table.
  const Link& coupler = link_named(m, "coupler");
  ASSERT_EQ(coupler.points.size(), 6u);
  for (size_t k = 0; k < 6; ++k) EXPECT_EQ(coupler.points[k].name, std::string(1, "BCPQRS"[k]));
  const std::string text = with_coupler(kPolarCoupler);
  EXPECT_EQ(coupler.points[3].where.line, place_of(text, "Q = {").line);
  EXPECT_EQ(coupler.points[3].where.column, place_of(text, "Q = {").column + 4);
}

// An inclined ground as textbooks give it: a pivot E 0.05 from D at 180 - 27.3 deg, and a guide
// through it at -27.3 deg.
TEST(PolarPoints, AnInclinedGroundThroughAPolarPoint) {
  const std::string text =
      replaced(four_bar(), "D = [0.10, 0] }\n",
               "D = [0.10, 0], E = { from = \"D\", length = 0.05, angle = \"180 - 27.3\" } }\n"
               "lines = { incline = { through = \"E\", angle = -27.3 } }\n");
  const Mechanism m = parse_mechanism(text, "good.toml");
  const double a = (180 - 27.3) * kPi / 180;
  const Eigen::Vector2d e(0.10 + 0.05 * std::cos(a), 0.05 * std::sin(a));
  EXPECT_NEAR(local(m, "ground", "E").x(), e.x(), 1e-15);
  EXPECT_NEAR(local(m, "ground", "E").y(), e.y(), 1e-15);
  const Line& incline = link_named(m, "ground").lines.at(0);
  EXPECT_EQ(incline.origin, local(m, "ground", "E"));
  EXPECT_NEAR(incline.direction.x(), std::cos(-27.3 * kPi / 180), 1e-15);
  EXPECT_NEAR(incline.direction.y(), std::sin(-27.3 * kPi / 180), 1e-15);
}

TEST(PolarPoints, ACircleIsReportedOnceNamingThePoints) {
  const std::string text = with_coupler(
      "points = { B = [0, 0], C = [0.12, 0], "
      "P = { from = \"Q\", length = 0.05, angle = 30 }, "
      "Q = { from = \"B\", toward = \"P\", length = 0.03, angle = 10 }, "
      "R = { from = \"P\", length = 0.01, angle = 0 } }");
  const std::vector<Diagnostic> found = diagnostics_of(text);
  ASSERT_EQ(found.size(), 1u);  // R only refers to the circle
  const Place from = place_of(text, "\"Q\", length");
  expect_diagnostic(text, from,
                    {"points of link 'coupler' are measured from one another in a circle: "
                     "P -> Q -> P",
                     "its points: B, C, P, Q, R"});
}

TEST(PolarPoints, APointMeasuredFromItself) {
  const std::string text = with_coupler(
      "points = { B = [0, 0], C = [0.12, 0], P = { from = \"P\", length = 1, "
      "angle = 0 } }");
  expect_diagnostic(text, place_of(text, "\"P\", length"), {"in a circle: P -> P"});
}

TEST(PolarPoints, AnUnknownPointListsTheLinksPoints) {
  const std::string text = with_coupler(
      "points = { B = [0, 0], C = [0.12, 0], P = { from = \"X\", length = 1, angle = 0 } }");
  expect_diagnostic(text, place_of(text, "\"X\""),
                    {"point 'P' of link 'coupler': 'from' names point 'X', which is not on link "
                     "'coupler' (its points: B, C, P)"});
  const std::string toward = with_coupler(
      "points = { B = [0, 0], C = [0.12, 0], P = { from = \"B\", toward = \"D\", length = 1, "
      "angle = 0 } }");
  expect_diagnostic(toward, place_of(toward, "\"D\""),
                    {"'toward' names point 'D', which is not on link 'coupler'"});
}

TEST(PolarPoints, TowardMustNotBeFrom) {
  const std::string text = with_coupler(
      "points = { B = [0, 0], C = [0.12, 0], P = { from = \"B\", toward = \"B\", "
      "length = 1, angle = 0 } }");
  const Place key = place_of(text, "toward = \"B\"");
  expect_diagnostic(text, {key.line, key.column + 9},
                    {"point 'P'", "'from' and 'toward' are both 'B'"});
}

TEST(PolarPoints, TowardAtTheSamePlaceAsFrom) {
  const std::string text = with_coupler(
      "points = { B = [0, 0], C = [0.12, 0], E = [0, 0], P = { from = \"B\", "
      "toward = \"E\", length = 1, angle = 0 } }");
  expect_diagnostic(text, place_of(text, "\"E\", length"),
                    {"point 'P' of link 'coupler'", "direction 'B' -> 'E'", "the same place"});
}

TEST(PolarPoints, TheLengthMustBePositive) {
  for (const std::string length : {"0", "-0.05", "\"1 - 1\""}) {
    const std::string text = with_coupler(
        "points = { B = [0, 0], C = [0.12, 0], P = { from = \"B\", length = " + length +
        ", angle = 30 } }");
    expect_diagnostic(text, place_of(text, length + ", angle"),
                      {"point 'P' of link 'coupler': 'length' must be positive"});
  }
}

TEST(PolarPoints, KeysAreChecked) {
  const std::string missing =
      with_coupler("points = { B = [0, 0], C = [0.12, 0], P = { from = \"B\", length = 0.05 } }");
  expect_diagnostic(missing, place_of(missing, "{ from"), {"point 'P'", "needs 'angle'"});
  const std::string unknown = with_coupler(
      "points = { B = [0, 0], C = [0.12, 0], P = { from = \"B\", distance = 0.05, angle = 0 } "
      "}");
  expect_diagnostic(unknown, place_of(unknown, "distance"),
                    {"unknown key 'distance'", "valid keys: from, toward, length, angle"});
  const std::string neither = with_coupler("points = { B = [0, 0], C = [0.12, 0], P = \"B + 1\" }");
  expect_diagnostic(neither, place_of(neither, "\"B + 1\""),
                    {"point 'P' of link 'coupler' must be [x, y] or { from = \"P\""});
}

// A dynamics case: the four-bar's crank free from 60 deg at 10 rad/s under gravity for 1 s.
std::string dynamics_case(const std::string& table = "duration = 1\ninterval = 0.01\nrate = 10\n") {
  return "gravity = [0, -9.81]\n" +
         replaced(four_bar(), "speed = 10\nspeed_unit = \"rad/s\"\n", "") + "\n[dynamics]\n" +
         table;
}

TEST(ValidationDynamics, TheCaseIsValid) {
  const Mechanism m = parse_mechanism(dynamics_case(), "good.toml");
  ASSERT_TRUE(m.dynamics.has_value());
  EXPECT_DOUBLE_EQ(m.dynamics->rate, 10.0);
  EXPECT_DOUBLE_EQ(m.dynamics->duration, 1.0);
}

TEST(ValidationDynamics, DurationMustBePositive) {
  for (const std::string duration : {"0", "-2"}) {
    const std::string text = dynamics_case("duration = " + duration + "\ninterval = 0.01\n");
    expect_diagnostic(text, place_of(text, duration + "\ninterval"),
                      {"[dynamics] 'duration' must be positive"});
  }
}

TEST(ValidationDynamics, IntervalWithinTheDuration) {
  for (const std::string interval : {"0", "2"}) {
    const std::string text = dynamics_case("duration = 1\ninterval = " + interval + "\n");
    Place at = place_of(text, "interval = " + interval);
    at.column += 11;  // at the value
    expect_diagnostic(text, at, {"[dynamics] 'interval'", "at most 'duration'"});
  }
}

// The initial rate is the kinematic view's driver speed, with its limits: 1e300 rev/s made every
// sample singular with no event; a rate that underflows is refused like a speed.
TEST(ValidationDynamics, RateAndEffortBeyondTheLimitsAreRefusedAtTheirKeys) {
  const std::string fast =
      dynamics_case("duration = 1\ninterval = 0.01\nrate = 1e300\nrate_unit = \"rev/s\"\n");
  // 1e9 rad/s is 1e9 / (2 pi) = 1.59155e8 rev/s.
  expect_diagnostic(
      fast, place_of(fast, "1e300"),
      {"'rate' in [dynamics] = 1e+300 rev/s is too large", "the limit is 1.59155e+08 rev/s"});
  const std::string slow = dynamics_case("duration = 1\ninterval = 0.01\nrate = 1e-12\n");
  expect_diagnostic(slow, place_of(slow, "1e-12"),
                    {"'rate' in [dynamics] = 1e-12 rad/s is too small", "limit is 1e-09 rad/s"});
  // A torque on the crank beyond 1e12 N m, constant or in a table.
  const std::string effort = dynamics_case("duration = 1\ninterval = 0.01\neffort = 1e13\n");
  expect_diagnostic(effort, place_of(effort, "1e13"), {"'effort' in [dynamics]", "too large"});
  const std::string table =
      dynamics_case("duration = 1\ninterval = 0.01\neffort_table = [[0, 0], [1, -5e12]]\n");
  expect_diagnostic(table, place_of(table, "-5e12"), {"'effort_table' row", "too large"});
}

TEST(ValidationDynamics, OneEffortOnly) {
  const std::string text =
      dynamics_case("duration = 1\ninterval = 0.01\neffort = 1\neffort_table = [[0, 0], [1, 1]]\n");
  expect_diagnostic(text, place_of(text, "[[0, 0]"), {"'effort' (constant) or 'effort_table'"});
}

TEST(ValidationDynamics, EffortTableTimesIncrease) {
  const std::string text =
      dynamics_case("duration = 1\ninterval = 0.01\neffort_table = [[0, 0], [0.5, 1], [0.5, 2]]\n");
  expect_diagnostic(text, place_of(text, "[0.5, 2]"), {"'effort_table' times must increase"});
}

TEST(ValidationDynamics, NoMotionLawBesideIt) {
  const std::string text = replaced(dynamics_case(), "start = 60\n", "start = 60\nspeed = 3\n");
  Place at = place_of(text, "speed = 3");
  at.column += 8;  // at the value
  expect_diagnostic(text, at, {"takes no motion law", "remove 'speed'"});
}

// Inconsistent initial velocities: the slider-crank driven from its slider, started at its outer
// toggle (s = sqrt((r + l)^2 - e^2), where the slider cannot move whatever the crank does), has
// no slider rate that the crank and rod can follow: refused at its [dynamics] table, never
// integrated.
TEST(ValidationDynamics, AStartAtASingularPositionHasNoConsistentVelocity) {
  std::string text = test::source_text("mechanisms/singular/slider_crank_from_slider.toml");
  text = replaced(text, "start = 60\nspeed = 100", "start = 79.372539331937716\n# speed");
  text = text.substr(0, text.find("[expect]")) +
         "[dynamics]\nduration = 0.1\ninterval = 0.01\nrate = 100\n";
  const Mechanism m = parse_mechanism(text, "toggle.toml");
  try {
    simulate(m);
    ADD_FAILURE() << "a start at the toggle was integrated";
  } catch (const DefinitionError& e) {
    ASSERT_EQ(e.diagnostics().size(), 1u);
    EXPECT_EQ(e.diagnostics()[0].where.line, m.dynamics->where.line);
    EXPECT_NE(e.diagnostics()[0].message.find("is a singular position of the coordinate"),
              std::string::npos)
        << e.what();
  }
  // A step away, the same rate is followed.
  text = replaced(text, "start = 79.372539331937716", "start = 70");
  EXPECT_TRUE(simulate(parse_mechanism(text, "away.toml")).ok);
}

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  size_t from = 0;
  for (size_t at = text.find('\n'); at != std::string::npos; at = text.find('\n', from)) {
    lines.push_back(text.substr(from, at - from));
    from = at + 1;
  }
  if (from < text.size()) lines.push_back(text.substr(from));
  return lines;
}

// Issue 35, item 8: the mechanism's size came from the drawing's absolute coordinates, so one
// link drawn 9e5 m from where it assembles (inside the coordinate limit) made it 9e5 m, and with
// it the self-check's thresholds, the default masses (1.05e13 kg mm^2) and the engines' scales.
// It comes from the linkage: the crank-rocker's coupler drawn far away (its pose, or its points
// in its own frame) leaves the size and every default mass as they are drawn in place.
TEST(Validation, ALinkDrawnFarAwayDoesNotMakeTheMechanismsSize) {
  // Without its masses: every link gets the default model, which the size scales.
  std::string base;
  for (const std::string& line :
       lines_of(test::source_text("mechanisms/fourbar_crank_rocker.toml")))
    if (!line.starts_with("mass =") && !line.starts_with("com =") && !line.starts_with("inertia ="))
      base += line + "\n";
  const Mechanism near = parse_mechanism(base, "near.toml");
  for (const Link& link : near.links) EXPECT_TRUE(link.ground || link.mass.assumed) << link.name;
  // In place: the drawn extent, A to C here (ground 0.10, crank 0.04 at 0 degrees, rocker 0.08
  // at 62.72 degrees): |C| = |(0.10 + 0.08 cos 62.72, 0.08 sin 62.72)|.
  const double c = 62.720 * std::numbers::pi / 180.0;
  EXPECT_NEAR(near.size(), std::hypot(0.10 + 0.08 * std::cos(c), 0.08 * std::sin(c)), 1e-12);
  const std::string posed =
      replaced(base, "pose = [0.04, 0, 36.336]", "pose = [900000.04, 0, 36.336]");
  const std::string shifted = replaced(base, "points = { B = [0, 0], C = [0.12, 0] }",
                                       "points = { B = [900000, 0], C = [900000.12, 0] }");
  for (const std::string& text : {posed, shifted}) {
    const Mechanism far = parse_mechanism(text, "far.toml");
    EXPECT_DOUBLE_EQ(far.size(), near.size());
    for (size_t l = 0; l < far.links.size(); ++l) {
      if (far.links[l].ground) continue;
      // (The shifted coupler's length, 900000.12 - 900000 m, is 0.12 to the 1.2e-10 m spacing
      // of doubles there, so its own bar differs by that much.)
      const MassProperties &a = far.links[l].mass, &b = near.links[l].mass;
      EXPECT_NEAR(a.mass, b.mass, 1e-8 * b.mass) << far.links[l].name;
      EXPECT_NEAR(a.inertia, b.inertia, 1e-8 * b.inertia) << far.links[l].name;
    }
  }
  // A link that is long is long wherever it is drawn: a point 9e5 m along the coupler is part of
  // the linkage, and makes its size.
  const std::string long_coupler = replaced(base, "points = { B = [0, 0], C = [0.12, 0] }",
                                            "points = { B = [0, 0], C = [0.12, 0], P = [9e5, 0] }");
  EXPECT_GE(parse_mechanism(long_coupler, "long.toml").size(), 9e5);
}

}  // namespace
}  // namespace crosslink
