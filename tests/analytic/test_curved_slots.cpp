// A pin in a curved slot (pin_in_slot with `arc`: issue 37, slice 2), against the linkages it is
// equivalent to. A pin held on a circle of radius R about a point C of another link is a binary
// link of length R from the pin to C; so the eccentric cam with a roller follower is the offset
// slider-crank with crank e and rod R + r, and the crank pin in the rocker's circular slot is the
// crank-rocker four-bar. With the equivalent link massless, the two definitions have the same
// motion and the same forces, solved from different constraint rows (the arc's distance row
// against two revolutes' four): each channel is held to 1e-9 of its peak, the bound
// for an independent check.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "tests/common/changed.h"
#include "tests/common/cli.h"
#include "tests/common/diagnostics.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

struct Channel {
  std::string in_a, in_b;  // its name in each sweep
  double sign = 1.0;       // b's value times sign is a's
};

// The exact sweeps of a and b: every channel of the pairs equal at every sample, to 1e-9 of its
// peak; prints the worst.
void expect_equivalent(const Mechanism& ma, const Mechanism& mb,
                       const std::vector<Channel>& channels) {
  const Trajectory a = sweep(ma), b = sweep(mb);
  ASSERT_TRUE(a.has_forces && b.has_forces);
  EXPECT_EQ(a.samples(), b.samples());
  double worst = 0.0;
  for (const Channel& c : channels) {
    double peak = 0.0, apart = 0.0;
    for (int k = 0; k < std::min(a.samples(), b.samples()); ++k) {
      EXPECT_EQ(a.status[static_cast<size_t>(k)], PoseStatus::ok) << k;
      const std::optional<double> va = a.sample(c.in_a, k), vb = b.sample(c.in_b, k);
      ASSERT_TRUE(va && vb) << "no channel " << c.in_a << " or " << c.in_b;
      peak = std::max(peak, std::abs(*va));
      apart = std::max(apart, std::abs(*va - c.sign * *vb));
    }
    EXPECT_GT(peak, 0.0) << c.in_a;
    EXPECT_LE(apart, 1e-9 * peak) << c.in_a << " against " << c.in_b << ": " << apart
                                  << " apart, peak " << peak;
    if (peak > 0.0) worst = std::max(worst, apart / peak);
  }
  std::printf("[ %s ] within %.2e of peak of %s over %d samples\n", ma.file.c_str(), worst,
              mb.file.c_str(), a.samples());
}

// The roller's centre C keeps R + r = 0.12 m from the disc's centre B: the offset slider-crank's
// rod BC (a = e = 0.04, b = 0.12, offset 0.01), here massless, with the disc's mass on the crank.
TEST(CurvedSlots, EccentricCamIsTheOffsetSliderCrank) {
  const Mechanism cam = load_mechanism("mechanisms/cams/eccentric_cam_roller.toml");
  const Mechanism slider_crank =
      test::changed("mechanisms/slider_crank_offset.toml",
                    {{"mass = 0.0157\ncom = [0.02, 0]\ninertia = 2.22417e-06",
                      "mass = 1.99758\ncom = \"B\"\ninertia = 8.09021e-03"},
                     {"mass = 0.0471\ncom = [0.06, 0]\ninertia = 5.69125e-05",
                      "mass = 0\ncom = [0.06, 0]\ninertia = 0"}});
  expect_equivalent(
      cam, slider_crank,
      {{"angle.cam", "angle.crank"},
       {"x.C", "x.C"},
       {"y.C", "y.C"},
       {"vx.C", "vx.C"},
       {"ax.C", "ax.C"},
       {"s.follower", "s.slider"},
       {"sdot.follower", "sdot.slider"},
       {"sddot.follower", "sddot.slider"},
       {"x.B", "x.B"},
       {"torque.driver", "torque.driver"},
       // The cam's force on the roller is the rod's on the slider; the ground's on each.
       {"fx.roller", "fx.C"},
       {"fy.roller", "fy.C"},
       {"fy.follower", "fy.slider"},
       {"fx.A", "fx.A"},
       {"fy.A", "fy.A"}});
}

// B stays 0.12 m from the rocker's point C: the crank-rocker four-bar with its coupler massless.
TEST(CurvedSlots, CurvedSlotRockerIsTheCrankRocker) {
  const Mechanism slot = load_mechanism("mechanisms/cams/curved_slot_rocker.toml");
  const Mechanism fourbar = test::changed("mechanisms/fourbar_crank_rocker.toml",
                                          {{"mass = 0.0471\ncom = [0.06, 0]\ninertia = 5.69125e-05",
                                            "mass = 0\ncom = [0.06, 0]\ninertia = 0"}});
  expect_equivalent(
      slot, fourbar,
      {{"angle.rocker", "angle.rocker"},
       {"omega.rocker", "omega.rocker"},
       {"alpha.rocker", "alpha.rocker"},
       {"x.C", "x.C"},
       {"ay.C", "ay.C"},
       {"torque.driver", "torque.driver"},
       // The rocker's force on the crank's pin is the massless coupler's, minus the crank's on it.
       {"fx.slot", "fx.B", -1.0},
       {"fy.slot", "fy.B", -1.0},
       {"fx.D", "fx.D"},
       {"fy.D", "fy.D"}});
}

// A slot's text changed to `to`, refused at the line of `key`, saying `says`.
struct Fault {
  std::string to, key, says;
};
void expect_faults_at_keys(const std::string& base, const std::string& slot,
                           const std::vector<Fault>& faults) {
  for (const Fault& c : faults) {
    const std::string text = test::replaced(base, slot, c.to);
    const std::string error = test::error_of(text, "slot.toml");
    EXPECT_NE(error.find(c.says), std::string::npos) << c.to << "\n" << error;
    EXPECT_NE(error.find("slot.toml:" + std::to_string(test::line_of(text, c.key)) + ":"),
              std::string::npos)
        << c.to << "\n"
        << error;
  }
}

// Each fault of an arc is refused at its key.
TEST(CurvedSlots, EachFaultIsLocatedAtItsKey) {
  const std::string base = test::source_text("mechanisms/cams/curved_slot_rocker.toml");
  const std::string arc = "arc = { centre = \"C\", radius = 0.12 }";
  const std::vector<Fault> cases = {
      {"arc = 0.12", "arc = 0.12", "'arc' in joint #3 (pin_in_slot) must be a table"},
      {"arc = { centre = \"C\", radius = -0.12 }", "arc =", "'radius' in the arc of joint #3"},
      {"arc = { centre = \"C\", radius = 0 }", "arc =", "must be positive"},
      {"arc = { centre = \"Q\", radius = 0.12 }", "arc =", "'Q'"},
      {"arc = { radius = 0.12 }", "arc =", "needs 'centre'"},
      {"arc = { centre = \"C\" }", "arc =", "needs 'radius'"},
      {"arc = { centre = \"C\", radius = 0.12, turn = 1 }", "arc =", "unknown key 'turn'"},
      {arc + "\nline = \"x\"", "arc =", "gives more than one of 'line', 'arc' and 'spline'"},
      {arc + "\nfriction = { coefficient = 0.1 }", "friction",
       "friction on a pin in a slot is not modelled"},
  };
  expect_faults_at_keys(base, arc, cases);
}

// Grübler–Kutzbach counts the pin in its slot as a half joint; the dyads have no closed form for
// it and say so (the engines run it: tests/sim/test_engine_cams.cpp, EngineCurvedSlots.*).
TEST(CurvedSlots, CheckCountsItsMobilityAndSaysTheDyadsHaveNoClosedForm) {
  const test::CommandRun check = test::crosslink("check mechanisms/cams/curved_slot_rocker.toml");
  EXPECT_EQ(check.exit_code, 0) << check.err;
  EXPECT_NE(check.out.find("M = 3(n-1) - 2 j1 - j2 = 3(3-1) - 2*2 - 1 = 1"), std::string::npos)
      << check.out;
  EXPECT_NE(check.out.find("no closed form for pin 'slot' in its arc"), std::string::npos)
      << check.out;
  EXPECT_NE(check.out.find("crank in an arc of rocker (point B, radius 0.12 m about C)"),
            std::string::npos)
      << check.out;
}

// The rocker of curved_slot_rocker.toml with its slot a spline through `points` (its frame).
Mechanism spline_rocker(const std::vector<Eigen::Vector2d>& points,
                        const std::string& pose = "[0.10, 0, 62.720]",
                        const std::string& speed = "240") {
  std::string named, through;
  for (size_t i = 0; i < points.size(); ++i) {
    named += fmt::format(", S{} = [{:.17g}, {:.17g}]", i + 1, points[i].x(), points[i].y());
    through += fmt::format("{}\"S{}\"", i ? ", " : "", i + 1);
  }
  return test::changed(
      "mechanisms/cams/curved_slot_rocker.toml",
      {{"C = [0.08, 0] }", "C = [0.08, 0]" + named + " }"},
       {"pose = [0.10, 0, 62.720]", "pose = " + pose},
       {"speed = 240 ", "speed = " + speed + " "},
       {"arc = { centre = \"C\", radius = 0.12 }", "spline = { through = [" + through + "] }"}});
}

// Points of the slot's arc (radius 0.12 about C = (0.08, 0) on the rocker), n of them evenly from
// `from` to `to` degrees.
std::vector<Eigen::Vector2d> arc_points(int n, double from, double to) {
  std::vector<Eigen::Vector2d> out;
  for (int i = 0; i < n; ++i) {
    const double a = (from + (to - from) * i / (n - 1)) * std::numbers::pi / 180.0;
    out.emplace_back(0.08 + 0.12 * std::cos(a), 0.12 * std::sin(a));
  }
  return out;
}

// A spline through points of a line is the line: the slot of the rocker along its own x axis
// through D (an inverted slider-crank), as a straight slot and as a spline through four of its
// points, solved to the same motion and forces to round-off.
TEST(SplineSlots, ThroughPointsOfALineItIsTheStraightSlot) {
  const std::vector<std::pair<std::string, std::string>> straight = {
      {"C = [0.08, 0] }", "C = [0.08, 0] }\nlines = { along = { through = \"D\", angle = 0 } }"},
      {"pose = [0.10, 0, 62.720]", "pose = [0.10, 0, 180]"},
      {"arc = { centre = \"C\", radius = 0.12 }", "line = \"along\""}};
  const Mechanism line = test::changed("mechanisms/cams/curved_slot_rocker.toml", straight);
  const Mechanism spline =
      spline_rocker({{0.0, 0.0}, {0.05, 0.0}, {0.12, 0.0}, {0.2, 0.0}}, "[0.10, 0, 180]");
  expect_equivalent(spline, line,
                    {{"angle.rocker", "angle.rocker"},
                     {"omega.rocker", "omega.rocker"},
                     {"alpha.rocker", "alpha.rocker"},
                     {"ax.B", "ax.B"},
                     {"torque.driver", "torque.driver"},
                     {"fx.slot", "fx.slot"},
                     {"fy.slot", "fy.slot"},
                     {"fx.D", "fx.D"}});
}

// Through points of the arc, the spline comes to the arc as they grow denser: the rocker's angle
// against curved_slot_rocker.toml's, its largest error over the sweep falling with the fourth
// power of the spacing (each halving divides it by 16, here within [12, 20]). The slot runs from
// 60 to 175 degrees of the arc; the pin, between 93.6 and 153.6.
TEST(SplineSlots, ThroughPointsOfTheArcItComesToTheArc) {
  const Trajectory arc = sweep(load_mechanism("mechanisms/cams/curved_slot_rocker.toml"));
  double before = 0.0;
  for (int n : {33, 65, 129}) {
    const Trajectory t = sweep(spline_rocker(arc_points(n, 60, 175)));
    ASSERT_EQ(t.samples(), arc.samples());
    double error = 0.0;
    for (int k = 0; k < t.samples(); ++k) {
      ASSERT_EQ(t.status[static_cast<size_t>(k)], PoseStatus::ok) << n << " " << k;
      error = std::max(error, std::abs(t.angle(k, 1) - arc.angle(k, 1)));
    }
    std::printf("  %2d points: the rocker within %.3e rad of the arc's%s\n", n, error,
                before > 0.0 ? fmt::format(", {:.2f} times nearer", before / error).c_str() : "");
    if (before > 0.0) {
      EXPECT_GT(before / error, 12.0) << n;
      EXPECT_LT(before / error, 20.0) << n;
    }
    before = error;
  }
  EXPECT_LT(before, 1e-7);
}

// A slot shorter than the pin's travel: from 100 to 160 degrees of the arc, where the pin runs
// from 93.6 to 153.6. Past its end S1 the pose does not exist: those samples are flagged
// cannot_assemble, with an event where the pin leaves the slot and one where it comes back, and
// the rest are solved; `check` prints the driver's values between as the slot's. A slot from 100
// to 150 does not hold the drawing (the pin at 153.6 degrees at the start): `check` refuses it
// there.
TEST(SplineSlots, PastAnEndThePinStopsAndTheSampleIsFlagged) {
  const Trajectory arc = sweep(load_mechanism("mechanisms/cams/curved_slot_rocker.toml"));
  const Trajectory t = sweep(spline_rocker(arc_points(13, 100, 160)));
  ASSERT_EQ(t.samples(), arc.samples());
  int flagged = 0;
  for (int k = 0; k < t.samples(); ++k) {
    // Where the arc's pin is, in degrees about C in the rocker's frame.
    const double theta = arc.angle(k, 1);
    const Eigen::Vector2d c(0.10 + 0.08 * std::cos(theta), 0.08 * std::sin(theta));
    const Eigen::Vector2d b = Eigen::Vector2d(*arc.sample("x.B", k), *arc.sample("y.B", k)) - c;
    const double at = std::atan2(b.y(), b.x()) - theta;
    const double deg = std::remainder(at, 2 * std::numbers::pi) * 180 / std::numbers::pi;
    const PoseStatus s = t.status[static_cast<size_t>(k)];
    if (deg < 99) EXPECT_EQ(s, PoseStatus::cannot_assemble) << k << " " << deg;
    if (deg > 101) EXPECT_EQ(s, PoseStatus::ok) << k << " " << deg;
    flagged += s == PoseStatus::cannot_assemble;
  }
  EXPECT_GT(flagged, 0);
  std::vector<const Trajectory::Event*> ends;
  for (const Trajectory::Event& e : t.events)
    if (e.kind == PoseStatus::cannot_assemble) ends.push_back(&e);
  ASSERT_EQ(ends.size(), 2u);
  EXPECT_NE(ends[0]->message.find("the pin B is past the end S1 of spline slot 'slot'"),
            std::string::npos)
      << ends[0]->message;
  EXPECT_NE(
      ends[1]->message.find("the pin B comes back from past the end S1 of spline slot 'slot'"),
      std::string::npos)
      << ends[1]->message;
  // Each event is placed where the pin reaches S1, between the sample that holds it and its
  // neighbour past it (after it where the pin leaves, before it where it comes back): there the
  // pin is on S1, 100 degrees round the arc.
  const Mechanism m = spline_rocker(arc_points(13, 100, 160));
  for (const Trajectory::Event* e : ends) {
    const bool back = e == ends[1];
    int k = 0;
    while (t.along(k) < e->driver) ++k;
    EXPECT_EQ(t.status[static_cast<size_t>(k)],
              back ? PoseStatus::ok : PoseStatus::cannot_assemble);
    EXPECT_EQ(t.status[static_cast<size_t>(k - 1)],
              back ? PoseStatus::cannot_assemble : PoseStatus::ok);
    // On the held side of it (the bisection's bracket is a few round-offs wide), the pin is held,
    // and within the ends' tolerance of S1: 1e-9 of the mechanism's size along the chord, which
    // the slot leaves S1 at 30 degrees to.
    const Trajectory at = solve_at(m, e->driver + (back ? 1e-12 : -1e-12));
    ASSERT_EQ(at.status[0], PoseStatus::ok);
    const double theta = at.angle(0, 1);
    const Eigen::Vector2d s1 =
        Eigen::Vector2d(0.10, 0.0) + Eigen::Rotation2Dd(theta) * arc_points(13, 100, 160).front();
    EXPECT_LT((Eigen::Vector2d(*at.sample("x.B", 0), *at.sample("y.B", 0)) - s1).norm(),
              1e-9 * m.size() / std::cos(30 * std::numbers::pi / 180) + 1e-15)
        << e->message;
    std::printf("  the pin reaches S1 at %.9f deg: %s\n", e->driver * 180 / std::numbers::pi,
                e->message.c_str());
  }
  // `check` prints the driver's values past the end, from one event to the other.
  const test::CommandRun checked = test::crosslink("check " + m.file);
  EXPECT_EQ(checked.exit_code, 0) << checked.err;
  EXPECT_NE(
      checked.out.find(fmt::format(
          "spline slot 'slot': its ends stop the pin: no pose from {:.9g} deg to {:.9g} deg\n",
          ends[0]->driver / m.units.angle, ends[1]->driver / m.units.angle)),
      std::string::npos)
      << checked.out;
  // The bundled slot, from 80 to 170 degrees, holds the pin over its whole travel.
  const test::CommandRun bundled = test::crosslink("check mechanisms/cams/spline_slot_rocker.toml");
  EXPECT_NE(bundled.out.find("  spline slot 'slot': holds its pin over the sweep\n"),
            std::string::npos)
      << bundled.out;

  // Swept the other way, the crank meets the same two places in turn, a turn below: the pin
  // leaves where it came back and comes back where it left, and the events keep the sweep's
  // order.
  const Trajectory reversed =
      sweep(spline_rocker(arc_points(13, 100, 160), "[0.10, 0, 62.720]", "-240"));
  std::vector<const Trajectory::Event*> back_ends;
  for (const Trajectory::Event& e : reversed.events)
    if (e.kind == PoseStatus::cannot_assemble) back_ends.push_back(&e);
  ASSERT_EQ(back_ends.size(), 2u);
  EXPECT_NE(back_ends[0]->message.find(" is past the end S1"), std::string::npos);
  EXPECT_NE(back_ends[1]->message.find(" comes back from past the end S1"), std::string::npos);
  EXPECT_NEAR(back_ends[0]->driver, ends[1]->driver - 2 * std::numbers::pi, 1e-12);
  EXPECT_NEAR(back_ends[1]->driver, ends[0]->driver - 2 * std::numbers::pi, 1e-12);

  const Mechanism short_slot = spline_rocker(arc_points(11, 100, 150));
  const test::CommandRun check = test::crosslink("check " + short_slot.file);
  EXPECT_EQ(check.exit_code, 2);
  EXPECT_NE(check.err.find("error: cannot assemble at driver = 0 deg: the pin B is past the end "
                           "S11 of spline slot 'slot'"),
            std::string::npos)
      << check.err;
}

// Each fault of a spline slot is refused at its key; the engines refuse it, saying why.
TEST(SplineSlots, EachFaultIsLocatedAtItsKeyAndTheEnginesRefuseIt) {
  const std::string base = test::source_text("mechanisms/cams/spline_slot_rocker.toml");
  const std::string spline =
      "spline = { through = [\"S1\", \"S2\", \"S3\", \"S4\", \"S5\", "
      "\"S6\", \"S7\"] }";
  const std::vector<Fault> cases = {
      {"spline = { through = [\"S1\", \"S7\"] }", "spline =", "needs at least three points"},
      {"spline = { through = [\"S1\", \"S3\", \"S2\", \"S7\"] }",
       "spline =", "point 'S2' is not further along the chord"},
      {"spline = { through = [\"S1\", \"S4\", \"S1\"] }", "spline =", "ends where it starts"},
      {"spline = { through = [\"S1\", \"Q\", \"S7\"] }", "spline =", "point 'Q' is not on"},
      {"spline = [\"S1\", \"S4\", \"S7\"]", "spline =", "'spline' in joint #3 (pin_in_slot) must"},
      {"spline = { through = [\"S1\", \"S4\", \"S7\"], degree = 3 }",
       "spline =", "unknown key 'degree'"},
      {spline + "\narc = { centre = \"C\", radius = 0.12 }",
       "arc =", "gives more than one of 'line', 'arc' and 'spline'"},
      {spline + "\nfriction = { coefficient = 0.1 }", "friction",
       "friction on a pin in a slot is not modelled"},
  };
  expect_faults_at_keys(base, spline, cases);
  const test::CommandRun compare =
      test::crosslink("compare mechanisms/cams/spline_slot_rocker.toml");
  EXPECT_EQ(compare.exit_code, 0) << compare.err;
  for (const char* engine : {"mujoco", "bullet", "ode", "simbody"})
    EXPECT_NE(compare.out.find(fmt::format("{:<9} not run: cannot realise this mechanism: joint "
                                           "'slot': a pin in a spline slot is not built",
                                           engine)),
              std::string::npos)
        << engine << "\n"
        << compare.out;
}

}  // namespace
}  // namespace crosslink
