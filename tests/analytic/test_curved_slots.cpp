// A pin in a curved slot (pin_in_slot with `arc`: issue 37, slice 2), against the linkages it is
// equivalent to. A pin held on a circle of radius R about a point C of another link is a binary
// link of length R from the pin to C; so the eccentric cam with a roller follower is the offset
// slider-crank with crank e and rod R + r, and the crank pin in the rocker's circular slot is the
// crank-rocker four-bar. With the equivalent link massless, the two definitions have the same
// motion and the same forces, solved from different constraint rows (the arc's distance row
// against two revolutes' four): each channel is held to 1e-9 of its peak, the bound
// for an independent check.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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

// Each fault of an arc is refused at its key.
TEST(CurvedSlots, EachFaultIsLocatedAtItsKey) {
  const std::string base = test::source_text("mechanisms/cams/curved_slot_rocker.toml");
  const std::string arc = "arc = { centre = \"C\", radius = 0.12 }";
  struct Case {
    std::string to, key, says;
  };
  const std::vector<Case> cases = {
      {"arc = 0.12", "arc = 0.12", "'arc' in joint #3 (pin_in_slot) must be a table"},
      {"arc = { centre = \"C\", radius = -0.12 }", "arc =", "'radius' in the arc of joint #3"},
      {"arc = { centre = \"C\", radius = 0 }", "arc =", "must be positive"},
      {"arc = { centre = \"Q\", radius = 0.12 }", "arc =", "'Q'"},
      {"arc = { radius = 0.12 }", "arc =", "needs 'centre'"},
      {"arc = { centre = \"C\" }", "arc =", "needs 'radius'"},
      {"arc = { centre = \"C\", radius = 0.12, turn = 1 }", "arc =", "unknown key 'turn'"},
      {arc + "\nline = \"x\"", "arc =", "gives both 'line' and 'arc'"},
      {arc + "\nfriction = { coefficient = 0.1 }", "friction",
       "friction on a pin in a slot is not modelled"},
  };
  for (const Case& c : cases) {
    const std::string text = test::replaced(base, arc, c.to);
    const std::string error = test::error_of(text, "slot.toml");
    EXPECT_NE(error.find(c.says), std::string::npos) << c.to << "\n" << error;
    EXPECT_NE(error.find("slot.toml:" + std::to_string(test::line_of(text, c.key)) + ":"),
              std::string::npos)
        << c.to << "\n"
        << error;
  }
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

}  // namespace
}  // namespace crosslink
