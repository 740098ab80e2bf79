// Closed-form dyads against Newton–Raphson on the full constraint equations: two independent
// position methods (and two velocity and acceleration solves) on every bundled mechanism.
//
// Agreement, at every sample that both methods solve (status ok):
//   positions      |x_dyads - x_newton| <= 1e-10 * size        (size: Mechanism::size())
//   angles         |theta_dyads - theta_newton| <= 1e-10 rad
//   rates          |v_dyads - v_newton| <= 1e-10 * scale
// per channel (velocities and accelerations alike). The scale is physical, never round-off: the
// mechanism's own rate of that kind (see `characteristic` below), or the largest peak over the
// cycle of the channels of the same kind when that is larger.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include "analytic/kinematics/dyads.h"
#include "analytic/model/loader.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/sweep.h"

namespace crosslink {
namespace {

constexpr double kAgreement = 1e-10;

std::vector<std::string> bundled_mechanisms(const std::string& folder = "") {
  std::vector<std::string> files;
  const std::filesystem::path dir =
      std::filesystem::path(CROSSLINK_SOURCE_DIR) / "mechanisms" / folder;
  for (const auto& entry : std::filesystem::directory_iterator(dir))
    if (entry.path().extension() == ".toml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

std::string stem(const std::string& path) {
  return std::filesystem::path(path).stem().string();
}

// The seed notes say these cannot be solved one dyad at a time (seed-mechanisms.md 2, 3; the
// Wanzer needle bar's inversion 1 is the same chain with the pins exchanged between the slots).
bool expected_not_to_decompose(const std::string& name) {
  return name == "polycentric_hinge" || name == "wanzer_needle_bar" ||
         name == "wanzer_needle_bar_inversion1";
}

class Bundled : public ::testing::TestWithParam<std::string> {};

TEST_P(Bundled, DyadsAgreeWithNewton) {
  const Mechanism m = load_mechanism(GetParam());
  const Decomposition decomposition = decompose(m);
  if (expected_not_to_decompose(stem(GetParam()))) {
    EXPECT_FALSE(decomposition.complete) << "expected a class-III chain or floating driver";
    EXPECT_FALSE(decomposition.reason.empty());
    std::printf("[ not decomposable ] %s: %s\n", stem(GetParam()).c_str(),
                decomposition.reason.c_str());
    return;
  }
  if (!decomposition.complete) {
    // A mechanism added later that does not decompose must say why; Newton still solves it.
    EXPECT_FALSE(decomposition.reason.empty());
    std::printf("[ not decomposable ] %s: %s\n", stem(GetParam()).c_str(),
                decomposition.reason.c_str());
    GTEST_SKIP() << decomposition.reason;
  }
  for (const AssurGroup& g : decomposition.groups) std::printf("  group: %s\n", g.name.c_str());

  const Trajectory newton = sweep(m);
  const Trajectory dyads = dyad_sweep(m, newton);
  ASSERT_EQ(dyads.samples(), newton.samples());
  EXPECT_EQ(dyads.method, "dyads");

  // Every sample Newton solves, the dyads solve too (they may also solve a few more). The
  // agreement is checked away from singular positions: beside one (one degree from the
  // parallelogram's change points) the closed form's circle intersection meets a double root and
  // both methods carry round-off amplified by the condition, as the comparator allows for.
  std::vector<int> rows;
  int newton_ok = 0, both_ok = 0;
  for (int r = 0; r < newton.samples(); ++r) {
    const bool ok = usable(newton.status[static_cast<size_t>(r)]);
    newton_ok += ok;
    if (!ok || !usable(dyads.status[static_cast<size_t>(r)])) continue;
    ++both_ok;
    if (!newton.beside_singular(r)) rows.push_back(r);
  }
  EXPECT_EQ(both_ok, newton_ok);
  ASSERT_GT(rows.size(), 10u);

  // The scale of a rate channel. A channel can be zero by design: vy of a horizontal slider, or
  // every angular acceleration of the parallelogram (fourbar_change_point), whose links all turn
  // at the crank's constant rate. Its peak over the cycle, and even the largest peak of its kind,
  // is then round-off (~1e-9 rad/s^2 there) and cannot measure an error: scaled by it, a 7.6e-13
  // rad/s of the coupler at the 180 deg change point read as 1.2e-10. So the scale is a
  // characteristic rate of the mechanism itself: with the driver's largest rate Omega over the
  // cycle (rad/s; a slider's m/s divided by the size) and the size L,
  //   angular velocity Omega, angular acceleration Omega^2, velocity Omega L, acceleration
  //   Omega^2 L,
  // or the largest peak of the channels of the same kind when that is larger (a driver with a
  // non-constant law, a link turning faster than the crank).
  auto peak = [&](const std::string& name) {
    double p = 0.0;
    for (int r : rows) p = std::max(p, std::abs((*newton.channel(name))(r)));
    return p;
  };
  auto kind = [](const std::string& name) {
    const bool angular = name.rfind("omega.", 0) == 0 || name.rfind("alpha.", 0) == 0;
    return std::string(to_string(Trajectory::quantity_of(name))) + (angular ? "/angular" : "");
  };
  std::map<std::string, double> largest;
  for (const std::string& name : newton.channel_names())
    largest[kind(name)] = std::max(largest[kind(name)], peak(name));

  const double size = m.size();
  double omega = 0.0;  // the driver's largest rate over the cycle [rad/s]
  for (int r = 0; r < newton.samples(); ++r)
    omega = std::max(omega, std::abs(m.drivers[0].at_time(newton.time(r)).rate));
  if (!m.drivers[0].angular()) omega /= size;
  auto characteristic = [&](const std::string& name) {
    const bool angular = kind(name).ends_with("/angular");
    const Quantity q = Trajectory::quantity_of(name);
    const double rate = q == Quantity::velocity ? omega : omega * omega;
    return angular ? rate : rate * size;
  };
  double worst = 0.0;
  std::string worst_channel;
  for (const std::string& name : newton.channel_names()) {
    // Forces are the multipliers at each method's poses: the positions' agreement covers them.
    const Quantity q = Trajectory::quantity_of(name);
    if (q == Quantity::force || q == Quantity::torque) continue;
    const Eigen::VectorXd a = *newton.channel(name), b = *dyads.channel(name);
    double scale = 1.0;  // angles: radians
    if (q == Quantity::position) scale = size;
    if (q == Quantity::velocity || q == Quantity::acceleration)
      scale = std::max(characteristic(name), largest[kind(name)]);
    for (int r : rows) {
      const double error = std::abs(a(r) - b(r)) / scale;
      if (error > worst) worst = error, worst_channel = name;
      ASSERT_LE(error, kAgreement)
          << name << " at driver " << newton.along(r) << ": newton " << a(r) << ", dyads " << b(r);
    }
  }
  std::printf("[ agreement ] %s: %zu samples, largest relative difference %.2e (%s)\n",
              stem(GetParam()).c_str(), rows.size(), worst, worst_channel.c_str());
}

INSTANTIATE_TEST_SUITE_P(Mechanisms, Bundled, ::testing::ValuesIn(bundled_mechanisms()),
                         [](const auto& info) { return stem(info.param); });
// Gear pairs (issue 20 item 3): a gear whose mate and carrier are placed has its angle, so the
// geared five-bars and the epicyclic trains decompose; a rack and pinion places its pinion from
// the placed rack's travel, or its rack from the placed pinion's turn.
INSTANTIATE_TEST_SUITE_P(Gears, Bundled, ::testing::ValuesIn(bundled_mechanisms("gears")),
                         [](const auto& info) { return stem(info.param); });

// The geared five-bar becomes one RRR dyad once the gear fixes the second crank: the driven
// crank, then the geared crank (its pivot and the gear's angle), then the couplers.
TEST(Dyads, AGearPairPlacesTheSecondCrankOfAGearedFiveBar) {
  for (const std::string name : {"geared_fivebar", "constans_dyer_geared_fivebar"}) {
    const Mechanism m =
        load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/" + name + ".toml");
    const Decomposition d = decompose(m);
    ASSERT_TRUE(d.complete) << name << ": " << d.reason;
    ASSERT_EQ(d.groups.size(), 3u) << name;
    EXPECT_EQ(d.groups[0].kind, AssurGroup::Kind::input) << d.groups[0].name;
    EXPECT_EQ(d.groups[1].kind, AssurGroup::Kind::input) << d.groups[1].name;
    EXPECT_NE(d.groups[1].name.find("gear angle from"), std::string::npos) << d.groups[1].name;
    EXPECT_EQ(d.groups[2].kind, AssurGroup::Kind::dyad) << d.groups[2].name;
    EXPECT_EQ(d.groups[2].name.rfind("RRR dyad", 0), 0u) << d.groups[2].name;
  }
}

// A rack and pinion places one side from the other (the rack's guide placed): the slider-crank's
// RRP dyad places the rack, whose travel then turns the pinion about its pivot (an input link);
// Ryan's driven pinion moves the rack along its guide (an input link, its point at the travel).
TEST(Dyads, ARackAndPinionPlacesThePinionFromTheRackOrTheRackFromThePinion) {
  const std::string dir = std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/gears/";
  const Decomposition crank = decompose(load_mechanism(dir + "rack_pinion_slider_crank.toml"));
  ASSERT_TRUE(crank.complete) << crank.reason;
  ASSERT_EQ(crank.groups.size(), 3u);
  EXPECT_EQ(crank.groups[0].kind, AssurGroup::Kind::input) << crank.groups[0].name;
  EXPECT_EQ(crank.groups[1].kind, AssurGroup::Kind::dyad) << crank.groups[1].name;
  EXPECT_EQ(crank.groups[1].name.rfind("RRP dyad rod + rack", 0), 0u) << crank.groups[1].name;
  EXPECT_EQ(crank.groups[2].kind, AssurGroup::Kind::input) << crank.groups[2].name;
  EXPECT_EQ(crank.groups[2].link[0],
            load_mechanism(dir + "rack_pinion_slider_crank.toml").find_link("pinion"));
  EXPECT_NE(crank.groups[2].name.find("pinion angle from the travel of rack rack"),
            std::string::npos)
      << crank.groups[2].name;

  const Mechanism ryan = load_mechanism(dir + "ryan_rack_and_pinion.toml");
  const Decomposition driven = decompose(ryan);
  ASSERT_TRUE(driven.complete) << driven.reason;
  ASSERT_EQ(driven.groups.size(), 2u);
  EXPECT_EQ(driven.groups[0].link[0], ryan.find_link("pinion")) << driven.groups[0].name;
  EXPECT_EQ(driven.groups[1].kind, AssurGroup::Kind::input) << driven.groups[1].name;
  EXPECT_EQ(driven.groups[1].link[0], ryan.find_link("rack")) << driven.groups[1].name;
  EXPECT_NE(driven.groups[1].name.find("pin on ground at the travel from pinion pinion"),
            std::string::npos)
      << driven.groups[1].name;
}

// A gear pair is no inner joint of a dyad: it takes one freedom, not a revolute's or a slide's
// two. A crank-rocker (crank 15, coupler 60, rocker 40 mm, pivots 50 mm apart) whose rocker is a
// gear meshing with a second gear on the ground, the gear pair listed before the rocker's
// joints: once the crank is placed both gears are held by their pivots alone, and the pair was
// taken as the inner joint of an "RPR dyad g1 + g2" (read as a slide it has no line). The RRR
// dyad places the coupler and the rocker, then the gear pair the second gear, as Newton does.
TEST(Dyads, AGearPairIsNoInnerJointOfADyad) {
  const Mechanism m = parse_mechanism(R"(name = "crank-rocker turning a gear train"
[units]
length = "mm"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { A = [0, 0], D = [50, 0], E = [50, -50] }
[[link]]
name = "crank"
points = { A = [0, 0], B = [15, 0] }
[[link]]
name = "coupler"
points = { B = [0, 0], C = [60, 0] }
pose = [15, 0, 39.84]
[[link]]
name = "g1"
points = { D = [0, 0], C = [40, 0] }
pose = [50, 0, 73.9]
[[link]]
name = "g2"
points = { E = [0, 0], Q = [30, 0] }
pose = [50, -50, 0]
[[joint]]
type = "revolute"
links = ["ground", "crank"]
point = "A"
[[joint]]
type = "revolute"
links = ["crank", "coupler"]
point = "B"
[[joint]]
type = "gear"
gears = ["g1", "g2"]
radii = [20, 30]
[[joint]]
type = "revolute"
links = ["coupler", "g1"]
point = "C"
[[joint]]
type = "revolute"
links = ["ground", "g1"]
point = "D"
[[joint]]
type = "revolute"
links = ["ground", "g2"]
point = "E"
[driver]
type = "joint_angle"
joint = "A"
to = "B"
start = 0
speed = 60
speed_unit = "rpm"
)",
                                      "geared_rocker.toml");
  const Decomposition d = decompose(m);
  ASSERT_TRUE(d.complete) << d.reason;
  ASSERT_EQ(d.groups.size(), 3u);
  EXPECT_EQ(d.groups[1].name.rfind("RRR dyad coupler + g1", 0), 0u) << d.groups[1].name;
  EXPECT_EQ(d.groups[2].link[0], m.find_link("g2")) << d.groups[2].name;
  EXPECT_NE(d.groups[2].name.find("gear angle from g1"), std::string::npos) << d.groups[2].name;
  const Trajectory newton = sweep(m);
  const Trajectory dyads = dyad_sweep(m, newton);
  const int g2 = m.moving_index(m.find_link("g2"));
  ASSERT_GT(newton.samples(), 300);
  for (int k = 0; k < newton.samples(); ++k) {
    ASSERT_EQ(dyads.status[static_cast<size_t>(k)], PoseStatus::ok) << k;
    EXPECT_NEAR(dyads.angle(k, g2), newton.angle(k, g2), 1e-10) << k;
    EXPECT_NEAR(dyads.omega(k, g2), newton.omega(k, g2), 1e-10 * 2.0 * std::numbers::pi) << k;
  }
}

// A rack reached with neither side placed: the pinion turns on an arm swinging about O, the rack
// slides along the arm and is held by a rod to the ground, and the driver turns the pinion on
// the arm. No link has three equations to placed links, so the chain is left to Newton, and
// the reason names the rack and pinion and why it places neither side.
TEST(Dyads, ARackAndPinionOnAnUnplacedGuideIsNamedInTheReason) {
  const Mechanism m = parse_mechanism(R"(name = "rack on a swinging arm"
[units]
length = "mm"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { O = [0, 0], F = [100, -50] }
[[link]]
name = "arm"
points = { O = [0, 0], D = [50, 20] }
lines = { guide = { through = "O", angle = 0 } }
[[link]]
name = "pinion"
points = { D = [0, 0], T = [20, 0] }
pose = [50, 20, 0]
[[link]]
name = "rack"
points = { C = [0, 0] }
pose = [100, 0, 0]
[[link]]
name = "rod"
points = { C = [0, 0], F = [0, -50] }
pose = [100, 0, 0]
[[joint]]
type = "revolute"
links = ["ground", "arm"]
point = "O"
[[joint]]
type = "revolute"
links = ["arm", "pinion"]
point = "D"
[[joint]]
type = "prismatic"
name = "rack_slide"
guide = "arm"
line = "guide"
slider = "rack"
point = "C"
[[joint]]
type = "revolute"
links = ["rack", "rod"]
point = "C"
[[joint]]
type = "revolute"
links = ["rod", "ground"]
point = "F"
[[joint]]
type = "rack_pinion"
name = "mesh"
pinion = "pinion"
rack = "rack_slide"
radius = 20
[driver]
type = "joint_angle"
joint = "D"
to = "T"
start = 0
speed = 10
)",
                                      "arm.toml");
  const Decomposition d = decompose(m);
  EXPECT_FALSE(d.complete);
  EXPECT_NE(d.reason.find("rack and pinion 'mesh' places neither its pinion 'pinion' nor its "
                          "rack 'rack' (their guide 'arm' is not placed"),
            std::string::npos)
      << d.reason;
  EXPECT_NE(d.reason.find("left to Newton"), std::string::npos) << d.reason;
  // Newton solves it; the dyads method says why it does not.
  const Trajectory newton = sweep(m);
  EXPECT_GT(std::count_if(newton.status.begin(), newton.status.end(), usable), 10)
      << newton.samples() << " samples";
  const Trajectory dyads = dyad_sweep(m, newton);
  ASSERT_FALSE(dyads.events.empty());
  EXPECT_NE(dyads.events[0].message.find("rack and pinion 'mesh'"), std::string::npos)
      << dyads.events[0].message;
}

// A rack and pinion that places neither side is a redundant coupling, named as the gear pair's
// is: Ryan's rack and pinion with its rack driven too (a slider driver on its slide, built here:
// the loader refuses a second driver for one freedom), so the pinion and the rack are each an
// input link of their own driver and the mesh is left over.
TEST(Dyads, ARackAndPinionPlacingNeitherSideIsNamedAsRedundant) {
  Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                               "/mechanisms/gears/ryan_rack_and_pinion.toml");
  Driver slide;
  slide.name = "rack";
  slide.type = DriverType::slider;
  slide.joint = m.find_joint("rack_slide");
  slide.link = m.find_link("rack");
  m.drivers.push_back(slide);
  const Decomposition d = decompose(m);
  EXPECT_FALSE(d.complete);
  EXPECT_EQ(d.groups.size(), 2u);
  EXPECT_NE(d.reason.find("rack and pinion 'mesh' places neither its pinion 'pinion' nor its "
                          "rack 'rack' (each placed before it by other joints): a redundant "
                          "coupling, left to Newton"),
            std::string::npos)
      << d.reason;
}

// The dyad method must be able to fail: on the other assembly mode the crank-rocker's coupler
// and rocker are the mirror image about BD, and no longer agree with Newton on the drawn one.
TEST(Dyads, OtherAssemblyModeDisagrees) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/fourbar_crank_rocker.toml");
  const DyadSolver solver(m, decompose(m));
  const NewtonSolver newton(m);
  KinematicState assembled(m);
  ASSERT_EQ(newton.assemble(assembled).status, PoseStatus::ok);
  DyadState state(m);
  solver.set_modes(assembled, state);
  state.kinematics.swept() = assembled.swept();
  ASSERT_EQ(solver.solve(state).status, PoseStatus::ok);
  EXPECT_LT((state.kinematics.q - assembled.q).lpNorm<Eigen::Infinity>(), 1e-12);
  for (int& mode : state.assembly_mode) mode = -mode;
  state.history = 0;
  ASSERT_EQ(solver.solve(state).status, PoseStatus::ok);
  EXPECT_GT((state.kinematics.q - assembled.q).lpNorm<Eigen::Infinity>(), 1e-3);
}

// Hand-checkable four-bar: theta2 = 0 puts B on AD, so C is the apex of triangle B C D with
// BC = 0.12, CD = 0.08, BD = 0.06; the rocker angle follows from the law of cosines.
TEST(Dyads, CrankRockerAtZeroByLawOfCosines) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/fourbar_crank_rocker.toml");
  const DyadSolver solver(m, decompose(m));
  const NewtonSolver newton(m);
  KinematicState assembled(m);
  ASSERT_EQ(newton.assemble(assembled).status, PoseStatus::ok);
  DyadState state(m);
  solver.set_modes(assembled, state);
  state.kinematics.swept() = m.drivers[0].at_time(0.0);
  ASSERT_EQ(solver.solve(state).status, PoseStatus::ok);
  const double b = 0.12, c = 0.08, bd = 0.06;
  const double angle_d = std::acos((c * c + bd * bd - b * b) / (2 * c * bd));  // at D, from DB
  const double theta4 = std::numbers::pi - angle_d;                            // DB points along -x
  const int rocker = m.moving_index(m.find_link("rocker"));
  EXPECT_NEAR(state.kinematics.q(3 * rocker + 2), theta4, 1e-12);
}

}  // namespace
}  // namespace crosslink
