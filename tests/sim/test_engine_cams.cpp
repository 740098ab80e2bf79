// The engines' cams (docs/cams.md, "The engines' contact"): MuJoCo, ODE and Simbody hold a roller
// or a flat face on an eccentric cam by contact (two spheres; a sphere and a box or a half-space),
// Bullet the roller, against the exact motion and contact force of
// mechanisms/cams/eccentric_roller_spring.toml (the offset slider-crank's) and
// eccentric_flat_faced.toml (simple harmonic motion), both checked against their closed forms in
// tests/analytic/test_cam_joints.cpp, and each engine's jump speed read from its own contact force
// against the exact one; an engine refuses what it cannot hold, naming the joint.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "analytic/model/loader.h"
#include "analytic/physics/dynamics.h"
#include "analytic/reference/sweep.h"
#include "methods/engines.h"
#include "sim/settings.h"
#include "tests/common/changed.h"

namespace crosslink::sim {
namespace {

Mechanism cam_mechanism(const std::string& name) {
  return load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/cams/" + name + ".toml");
}

EngineRun run_engine(const std::string& name, const Mechanism& m, const Trajectory& exact) {
  const auto engine = methods::find_engine(name)->make();
  std::string why;
  EXPECT_TRUE(engine->supports(m, &why)) << why;
  EngineRun run = engine->run(m, exact, {});
  EXPECT_TRUE(run.ok) << run.message;
  return run;
}

// The largest |engine - exact| of a channel over the samples both solve, over the exact peak.
double worst(const Trajectory& exact, const Trajectory& engine, const std::string& channel) {
  const Eigen::VectorXd e = *exact.channel(channel), g = *engine.channel(channel);
  double peak = 0.0, off = 0.0;
  for (int i = 0; i < exact.samples(); ++i) {
    if (!usable(exact.status[static_cast<size_t>(i)])) continue;
    peak = std::max(peak, std::abs(e(i)));
    if (usable(engine.status[static_cast<size_t>(i)])) off = std::max(off, std::abs(g(i) - e(i)));
  }
  return off / peak;
}

// The definitions an engine holds by contact: the disc under a roller and under a flat face, each
// below its jump speed (the exact summary's, at the pose of sample `jump_sample`).
struct HeldCam {
  const char* name;
  int jump_sample;    // the sample at (or nearest) the jump's pose
  double slow, fast;  // two speeds below the jump [rpm]
  double jump;        // the exact jump speed there [rpm]
};
const HeldCam kHeld[] = {
    // The jump at 0.2177 deg, 276.374 rpm (0 deg: the force is least there to 1e-3 of the speed).
    {"eccentric_roller_spring", 0, 200, 240, 276.374},
    // The jump at 180 deg, the closed form sqrt(7500) rad/s = 827.0 rpm (docs/cams.md,
    // "Eccentric cams").
    {"eccentric_flat_faced", 180, 500, 600, 827.0},
};
// Per engine and definition (kHeld's order), bounds on the worst errors of the follower's travel,
// its acceleration and the contact force, of peak, at the engine's defaults: a few times the
// measured (MuJoCo 1.6e-6, 6.4e-6, 5.3e-6 and 1.35e-6, 1.0e-6, 2.1e-6; ODE, at its coarser
// default step, 1.3e-5, 5.3e-5, 4.1e-5 and 7.6e-6, 3.2e-5, 4.7e-6; Simbody, whose Hertz contact of
// steel sinks the follower half a micrometre, 4.3e-6, 1.3e-5, 1.55e-5 and 8.4e-6, 4.25e-5,
// 2.0e-5; Bullet ODE's to the digits shown: both solve the same velocity-level LCP at the same
// steps).
struct Bounds {
  const char* engine;
  double travel[2], acceleration[2], force[2];
};
const Bounds kBounds[] = {
    {"mujoco", {1e-5, 5e-6}, {2e-5, 5e-6}, {2e-5, 1e-5}},
    {"ode", {5e-5, 3e-5}, {2e-4, 1e-4}, {2e-4, 2e-5}},
    {"simbody", {1.5e-5, 3e-5}, {5e-5, 1.5e-4}, {5e-5, 6e-5}},
    {"bullet", {5e-5, 3e-5}, {2e-4, 1e-4}, {2e-4, 2e-5}},
};

// Below its jump speed the follower stays on the disc: the engine's contact holds it (MuJoCo's soft
// contact settles at a steady penetration; ODE's speculative contact closes each gap in its step),
// every joint's gap, the contact's penetration among them, under a fifth of the gap threshold of
// 1e-4 of the size (measured: MuJoCo 2.7e-7 and 7.1e-8 m, ODE 1.5e-6 and 3.8e-7 m, Simbody 6.6e-7
// and 4.2e-7 m), and the
// follower's travel, acceleration and the contact force follow the exact ones.
TEST(EngineCams, EachEngineHoldsTheFollowerOnTheDiscAsTheExactMotion) {
  for (const Bounds& bounds : kBounds)
    for (size_t k = 0; k < std::size(kHeld); ++k) {
      const HeldCam& held = kHeld[k];
      if (bounds.travel[k] == 0.0) continue;  // refused (EachEngineRefuses...)
      SCOPED_TRACE(std::string(bounds.engine) + " on " + held.name);
      const Mechanism m = cam_mechanism(held.name);
      const Trajectory exact = sweep(m);
      const EngineRun run = run_engine(bounds.engine, m, exact);
      for (int i = 0; i < exact.samples(); ++i)
        EXPECT_EQ(run.trajectory.status[static_cast<size_t>(i)], PoseStatus::ok) << "sample " << i;
      const Trajectory& t = run.trajectory;
      const double gap = t.loop_gap.maxCoeff();
      fmt::print(
          "{} on {}: gap {:.3g} m; of peak: s {:.3g}, sddot {:.3g}, contact force "
          "{:.3g}, driver torque {:.3g}\n",
          bounds.engine, held.name, gap, worst(exact, t, "s.follower"),
          worst(exact, t, "sddot.follower"), worst(exact, t, "f.contact"),
          worst(exact, t, "torque.driver"));
      EXPECT_LT(gap, 0.2 * 1e-4 * m.size());
      EXPECT_LT(worst(exact, t, "s.follower"), bounds.travel[k]);
      EXPECT_LT(worst(exact, t, "sddot.follower"), bounds.acceleration[k]);
      EXPECT_LT(worst(exact, t, "f.contact"), bounds.force[k]);
    }
}

// At a fixed pose the contact force a spring-held follower needs is N = a - b w^2 (the spring's
// pull less the follower's inertia, both at that pose), so two speeds below the jump give the
// speed at which it reaches zero there: the jump speed, at the pose the exact summary locates.
// Each engine's own contact force gives the speed the exact force gives, to 1e-5 (MuJoCo) and
// 1e-4 (ODE, at its coarser step; Simbody, its follower sunk into the disc; measured 1.5e-5 and
// 7.7e-6).
TEST(EngineCams, EachEnginesJumpSpeedFromItsContactForceIsTheExactOne) {
  const double rpm = std::numbers::pi / 30.0;
  const auto zero_force_speed = [](double w1, double n1, double w2, double n2) {
    const double b = (n1 - n2) / (w2 * w2 - w1 * w1), a = n1 + b * w1 * w1;
    return std::sqrt(a / b);
  };
  for (const auto& [engine, within] :
       {std::pair{"mujoco", 1e-5}, {"ode", 1e-4}, {"simbody", 1e-4}, {"bullet", 1e-4}})
    for (const HeldCam& held : kHeld) {
      SCOPED_TRACE(std::string(engine) + " on " + held.name);
      Mechanism m = cam_mechanism(held.name);
      double exact_n[2], engine_n[2];
      const double speeds[2] = {held.slow * rpm, held.fast * rpm};
      for (int k = 0; k < 2; ++k) {
        m.drivers[0].law.speed = speeds[k];
        const Trajectory exact = sweep(m);
        exact_n[k] = *exact.sample("f.contact", held.jump_sample);
        engine_n[k] =
            *run_engine(engine, m, exact).trajectory.sample("f.contact", held.jump_sample);
      }
      const double exact_jump = zero_force_speed(speeds[0], exact_n[0], speeds[1], exact_n[1]);
      const double engine_jump = zero_force_speed(speeds[0], engine_n[0], speeds[1], engine_n[1]);
      fmt::print("{} on {}: jump speed at sample {}: exact {:.6f} rpm, engine {:.6f} rpm\n", engine,
                 held.name, held.jump_sample, exact_jump / rpm, engine_jump / rpm);
      EXPECT_NEAR(exact_jump / rpm, held.jump, 1e-3 * held.jump);
      EXPECT_NEAR(engine_jump / exact_jump, 1.0, within);
    }
}

// Past its jump speed (500 rpm, 1.8 times it) the exact motion needs a pull over part of the turn
// and flags those samples contact_lost; run through them (the sweep started at 180 deg, so they
// are inside it), every engine's follower leaves the disc there and flies on past them, off its
// cam by more than the gap threshold at samples the exact motion keeps on, which each engine
// flags contact_lost itself and notes. The four engines, each by its own contact, agree on where
// the flight shows and for how long (measured: 116 samples from 425 deg in all four).
TEST(EngineCams, PastItsJumpSpeedEachEnginesFollowerFliesOffTheDisc) {
  Mechanism m = cam_mechanism("eccentric_roller_spring");
  m.drivers[0].law.speed = 500 * std::numbers::pi / 30.0;
  m.drivers[0].start = std::numbers::pi;
  const Trajectory exact = sweep(m);
  int flagged = 0;
  for (PoseStatus s : exact.status) flagged += s == PoseStatus::contact_lost;
  EXPECT_GT(flagged, 0);
  std::vector<std::pair<int, int>> flights;  // per engine: its first own flag, and their count
  for (const methods::EngineEntry& e : methods::engine_table()) {
    SCOPED_TRACE(e.name);
    const EngineRun run = run_engine(e.name, m, exact);
    int first = -1, count = 0;
    for (int i = 0; i < exact.samples(); ++i)
      if (run.trajectory.status[static_cast<size_t>(i)] == PoseStatus::contact_lost &&
          usable(exact.status[static_cast<size_t>(i)]) && count++ == 0)
        first = i;
    fmt::print("{}: off its cam at {} samples from sample {}\n", e.name, count, first);
    EXPECT_GT(count, 0);
    EXPECT_NE(run.message.find("the follower is off its cam at"), std::string::npos) << run.message;
    flights.emplace_back(first, count);
  }
  for (const auto& [first, count] : flights) {
    EXPECT_EQ(first, flights.front().first);
    EXPECT_NEAR(count, flights.front().second, 2);
  }
}

// A pin in a curved slot in each engine (docs/cams.md, "Curved slots in the engines"): MuJoCo's
// spatial tendon, ODE's double ball and Simbody's rod hold the pin's distance from the arc's
// centre as one row; Bullet, which has no such constraint, an arm of auxiliary_mass() hinged at
// both. Each run of the two bundled curved slots (the crank-rocker's coupler as a slot, and the
// eccentric cam's roller, each exact to round-off against its four-bar and slider-crank in
// tests/analytic/test_curved_slots.cpp) follows the exact motion and the slot's force, to bounds
// a few times the measured (printed): the output's angle or travel, its acceleration, the slot's
// force and the driver's torque (measured: MuJoCo 2.4e-6, 2.8e-5, 3.2e-5, 2.9e-5 on the rocker;
// ODE and Bullet, at their coarser step, 2.9e-5, 3.4e-4, 4.5e-4, 4.5e-4; Simbody, whose kinematic
// run solves the rod exactly, 1.4e-12 and 6.0e-12 in angle and force).
struct SlotBounds {
  const char* engine;
  double output[2], acceleration[2], force[2], torque[2];
};
const SlotBounds kSlotBounds[] = {
    {"mujoco", {1e-5, 5e-6}, {1e-4, 2e-5}, {1e-4, 2e-5}, {1e-4, 2e-5}},
    {"ode", {1e-4, 5e-5}, {1e-3, 2e-4}, {1.5e-3, 2e-4}, {1.5e-3, 3e-4}},
    {"simbody", {1e-11, 1e-12}, {2e-5, 3e-6}, {3e-11, 1e-12}, {3e-11, 1e-12}},
    {"bullet", {1e-4, 5e-5}, {1e-3, 2e-4}, {1.5e-3, 2e-4}, {1.5e-3, 3e-4}},
};
struct Slotted {
  const char* name;
  const char *output, *acceleration, *force;
};
const Slotted kSlotted[] = {
    {"curved_slot_rocker", "angle.rocker", "alpha.rocker", "f.slot"},
    {"eccentric_cam_roller", "s.follower", "sddot.follower", "f.roller"},
};

TEST(EngineCurvedSlots, EachEngineHoldsThePinOnItsArcAsTheExactMotionAndForce) {
  for (const SlotBounds& bounds : kSlotBounds)
    for (size_t k = 0; k < std::size(kSlotted); ++k) {
      const Slotted& slotted = kSlotted[k];
      SCOPED_TRACE(std::string(bounds.engine) + " on " + slotted.name);
      const Mechanism m = cam_mechanism(slotted.name);
      const Trajectory exact = sweep(m);
      const EngineRun run = run_engine(bounds.engine, m, exact);
      const Trajectory& t = run.trajectory;
      int flagged = 0;
      for (PoseStatus status : t.status) flagged += !usable(status);
      const double output = worst(exact, t, slotted.output),
                   acceleration = worst(exact, t, slotted.acceleration),
                   force = worst(exact, t, slotted.force),
                   torque = worst(exact, t, "torque.driver");
      fmt::print(
          "{} on {}: {} samples flagged; of peak: {} {:.3g}, {} {:.3g}, {} {:.3g}, torque.driver "
          "{:.3g}\n",
          bounds.engine, slotted.name, flagged, slotted.output, output, slotted.acceleration,
          acceleration, slotted.force, force, torque);
      EXPECT_EQ(flagged, 0);
      EXPECT_LT(output, bounds.output[k]);
      EXPECT_LT(acceleration, bounds.acceleration[k]);
      EXPECT_LT(force, bounds.force[k]);
      EXPECT_LT(torque, bounds.torque[k]);
    }
}

// Forward dynamics through a curved slot: curved_slot_rocker falling from rest under gravity (its
// crank free), each engine against the exact simulation. An arm as light as auxiliary_mass() made
// ODE's step fail here ("!bSafeNormalize4Fault"); its double ball runs.
TEST(EngineCurvedSlots, EachEngineLetsTheSlottedLinkageFallAsTheExactSimulation) {
  const Mechanism m = test::changed(
      "mechanisms/cams/curved_slot_rocker.toml",
      {{"[units]", "gravity = [0, -9.81]\n\n[units]"},
       {"speed = 240               # 8 pi rad/s, as the four-bar\nspeed_unit = \"rpm\"\n",
        "\n[dynamics]\nduration = 0.3\ninterval = 0.002\nrate = 0\neffort = 0\n"}});
  const Simulation exact = simulate(m);
  ASSERT_TRUE(exact.ok) << exact.message;
  for (const methods::EngineEntry& e : methods::engine_table()) {
    SCOPED_TRACE(e.name);
    const EngineRun run = run_engine(e.name, m, exact.trajectory);
    const Trajectory& t = run.trajectory;
    const double angle = worst(exact.trajectory, t, "angle.rocker"),
                 force = worst(exact.trajectory, t, "f.slot");
    fmt::print("{}: of peak: angle.rocker {:.3g}, f.slot {:.3g}\n", e.name, angle, force);
    for (PoseStatus status : t.status) EXPECT_TRUE(usable(status));
    EXPECT_LT(angle, 2e-5);  // measured 3.7e-6 (MuJoCo, ODE), 5.3e-10 (Simbody)
    EXPECT_LT(force, 1e-4);  // measured 2.6e-5 (ODE), 2.1e-9 (Simbody)
  }
}

// A follower held on its cam both ways (a groove): the exact contact force `channel` along the
// follower's line changes side and no sample loses contact; each engine follows the travel and
// that force within its bounds (travel, force; of peak), printed as `what`.
using HeldBounds = std::vector<std::pair<const char*, std::pair<double, double>>>;
void expect_held_both_ways(const Mechanism& m, const std::string& channel, const std::string& what,
                           const HeldBounds& bounds) {
  const Trajectory exact = sweep(m);
  for (PoseStatus status : exact.status) ASSERT_EQ(status, PoseStatus::ok);
  const Eigen::VectorXd push = *exact.channel(channel);
  EXPECT_LT(push.minCoeff() * push.maxCoeff(), 0.0);  // the groove pulls over part of the turn
  for (const auto& [engine, bound] : bounds) {
    SCOPED_TRACE(engine);
    const EngineRun run = run_engine(engine, m, exact);
    const Trajectory& t = run.trajectory;
    for (PoseStatus status : t.status) EXPECT_EQ(status, PoseStatus::ok);
    const double travel = worst(exact, t, "s.follower"), force = worst(exact, t, channel);
    fmt::print("{} on {}: of peak: s {:.3g}, {} {:.3g}\n", engine, what, travel, channel, force);
    EXPECT_LT(travel, bound.first);
    EXPECT_LT(force, bound.second);
  }
}

// A groove round the disc holds the roller both ways (form closure): the roller's centre stays
// R + r from the disc's, a point on a circle, which each engine holds as it holds a curved slot
// (MuJoCo's tendon, ODE's double ball, Simbody's rod, Bullet's arm), not by contact. Run at 500
// rpm, past the spring-held follower's jump speed (276 rpm), the exact contact force along the
// follower's line changes side and no sample loses contact; each engine follows the motion and
// that force to bounds a few times the measured (printed: MuJoCo 1.0e-6 and 5.4e-6 of peak, ODE
// and Bullet 1.3e-5 and 6.6e-5, Simbody 3.8e-14 and 2.2e-14 in travel and force).
TEST(EngineCams, AGroovedDiscHoldsItsFollowerPastTheJumpSpeedAsACurvedSlot) {
  const Mechanism m = test::changed(
      "mechanisms/cams/eccentric_roller_spring.toml",
      {{"point = \"C\"\n\n[joint.profile]", "point = \"C\"\nclosure = \"form\"\n\n[joint.profile]"},
       {"speed = 240", "speed = 500"}});
  expect_held_both_ways(m, "fx.contact", "the grooved disc at 500 rpm",
                        {{"mujoco", {5e-6, 3e-5}},
                         {"ode", {5e-5, 3e-4}},
                         {"simbody", {1e-12, 1e-12}},
                         {"bullet", {5e-5, 3e-4}}});
}

// A flat face in a groove round its disc (a yoke, closure = "form") is held both ways: every
// engine makes it two contacts of the one joint, the face and a far face the disc's diameter
// across it (SceneContact::far). eccentric_flat_faced.toml so
// grooved and run at 1000 rpm, past the spring-held face's jump speed (827 rpm): the exact contact
// force along the follower's line changes side (at 127 and 234 deg), no sample loses contact, and
// each engine follows the travel and that force to bounds a few times the measured (printed: MuJoCo
// 1.0e-6 and 1.8e-3 of peak, ODE 7.6e-6 and 1.9e-5, Simbody 1.4e-5 and 9.9e-3, Bullet 7.6e-6 and
// 4.7e-2). MuJoCo's and Simbody's worst force is at the crossing at 234 deg, where the load passes
// from one face to the other through their compliance (a Hertz contact is softest at no load);
// ODE's speculative contact has none. Bullet's travel is ODE's, but its force, read from the
// manifold points of the two faces between the same two bodies, is noisy by about 0.5 % of peak
// throughout and 4.7 % at the first sample: why is not found (ODE solves the same LCP).
TEST(EngineCams, AYokeHoldsItsFlatFaceBothWaysAsTwoFaces) {
  const Mechanism m = test::changed("mechanisms/cams/eccentric_flat_faced.toml",
                                    {{"face = \"face\"\n", "face = \"face\"\nclosure = \"form\"\n"},
                                     {"speed = 600", "speed = 1000"}});
  expect_held_both_ways(m, "fy.contact", "the yoke at 1000 rpm",
                        {{"mujoco", {5e-6, 5e-3}},
                         {"ode", {3e-5, 1e-4}},
                         {"simbody", {5e-5, 3e-2}},
                         {"bullet", {3e-5, 0.1}}});
}

// translating_roller_345.toml (a 3-4-5 rise and a 4-5-6-7 return, offset roller) without its
// groove, held on by a spring from S = (0.01, -0.1), 200 N/m, free length 0.1 m, at its 300 rpm:
// below its jump speed (check: 703.7 rpm). Its profile is cut from the motion law, not a disc.
// With `knife`, its roller taken off: a knife edge on the same pitch curve.
Mechanism spring_held_345(bool knife = false) {
  return test::changed(
      "mechanisms/cams/translating_roller_345.toml",
      {{"closure = \"form\"          # a groove holds the follower both ways: no spring keeps it "
        "on\n",
        ""},
       {"roller_radius = 0.01\n", knife ? "" : "roller_radius = 0.01\n"},
       {"D = [0.01, 0] }", "D = [0.01, 0], S = [0.01, -0.1] }"},
       {"[driver]",
        "[[spring]]\nname = \"return_spring\"\nlinks = [\"ground\", \"follower\"]\n"
        "points = [\"S\", \"C\"]\nstiffness = 200\nfree_length = 0.1\n\n[driver]"}});
}

// A profile that is not a disc is, in MuJoCo, a prism over a convex polygon of `cam_facets`
// vertices on the profile, whose hull MuJoCo collides with the roller by MPR (docs/cams.md, "The
// engines' contact"). The chords between the vertices lie inside the profile, so the roller sinks
// past the exact profile by their sagitta besides MuJoCo's own penetration: the run's largest
// gap, which falls at each doubling from 90 to 360 facets by more than 2.5 (measured 3.1 and 2.7;
// the sagitta alone by 4), and at the default 1440 facets no sample is flagged and the travel is
// within 1e-4 of peak (measured 4.1e-5), as is a knife edge's. Its acceleration and the contact
// force do not follow: the facets' corners and MPR's contact on a float mesh kick the follower from
// step to step (printed; docs/engines.md, "Cams", measures them against the facets, the step and
// the contact).
TEST(EngineCams, MuJoCoHoldsAFollowerOnAMeshOfAProfileThatIsNotADisc) {
  const Mechanism m = spring_held_345();
  const Trajectory exact = sweep(m);
  for (PoseStatus status : exact.status) ASSERT_EQ(status, PoseStatus::ok);
  const auto engine = methods::find_engine("mujoco")->make();
  std::string why;
  ASSERT_TRUE(engine->supports(m, &why)) << why;
  std::vector<double> gap;
  for (const int facets : {90, 180, 360, kDefaultCamFacets}) {
    const EngineRun run = engine->run(m, exact, {{"cam_facets", std::to_string(facets)}});
    ASSERT_TRUE(run.ok) << run.message;
    const Trajectory& t = run.trajectory;
    gap.push_back(t.loop_gap.maxCoeff());
    fmt::print(
        "mujoco, {} facets: gap {:.3g} m; of peak: s {:.3g}, sddot {:.3g}, contact force {:.3g}\n",
        facets, gap.back(), worst(exact, t, "s.follower"), worst(exact, t, "sddot.follower"),
        worst(exact, t, "f.contact"));
    if (facets != kDefaultCamFacets) continue;
    for (PoseStatus status : t.status) EXPECT_EQ(status, PoseStatus::ok);
    EXPECT_LT(worst(exact, t, "s.follower"), 1e-4);
  }
  for (size_t k = 1; k < 3; ++k) EXPECT_GT(gap[k - 1] / gap[k], 2.5) << k;
  // A knife edge: a sphere of half the least radius of curvature on the profile moved in by as
  // much (measured 3.9e-5 of peak in travel).
  const Mechanism knife = spring_held_345(true);
  const Trajectory knife_exact = sweep(knife);
  const EngineRun run = engine->run(knife, knife_exact, {});
  ASSERT_TRUE(run.ok) << run.message;
  for (PoseStatus status : run.trajectory.status) EXPECT_EQ(status, PoseStatus::ok);
  fmt::print("mujoco, knife edge: of peak: s {:.3g}\n",
             worst(knife_exact, run.trajectory, "s.follower"));
  EXPECT_LT(worst(knife_exact, run.trajectory, "s.follower"), 1e-4);
}

// Every engine holds the disc's roller; Bullet refuses its flat face, and each engine a cam it has
// no contact shape for, naming the joint and why: ODE, Simbody and Bullet any profile that is not a
// disc; MuJoCo, which meshes one, a groove round it (its outer wall is concave) and a concave
// profile (its mesh would be the hull).
TEST(EngineCams, EachEngineRefusesACamItCannotHoldNamingTheJointAndWhy) {
  const Mechanism disc = cam_mechanism("eccentric_roller_spring");
  for (const methods::EngineEntry& e : methods::engine_table()) {
    std::string why;
    const bool supported = e.make()->supports(disc, &why);
    EXPECT_TRUE(supported) << e.name << ": " << why;
    if (!supported) {
      EXPECT_NE(why.find("joint 'contact'"), std::string::npos) << why;
      EXPECT_NE(why.find("contact, which it does not model"), std::string::npos) << why;
    }
  }
  std::string why;
  for (const char* holding : {"ode", "simbody", "bullet"}) {
    const auto engine = methods::find_engine(holding)->make();
    for (const char* name : {"spring_cam_jump", "tangent_cam_roller", "oscillating_roller"}) {
      std::string why;
      EXPECT_FALSE(engine->supports(cam_mechanism(name), &why)) << name;
      EXPECT_NE(why.find("joint 'contact': this engine holds a follower on a cam by contact with "
                         "a disc (an eccentric cam) only"),
                std::string::npos)
          << name << ": " << why;
    }
  }
  const auto mujoco = methods::find_engine("mujoco")->make();
  EXPECT_TRUE(mujoco->supports(cam_mechanism("spring_cam_jump"), &why)) << why;
  for (const char* grooved : {"tangent_cam_roller", "oscillating_roller"}) {
    EXPECT_FALSE(mujoco->supports(cam_mechanism(grooved), &why)) << grooved;
    EXPECT_NE(why.find("joint 'contact': a groove round a profile that is not a disc"),
              std::string::npos)
        << why;
  }
  // A rise of 40 mm in 60 deg bends the pitch curve the other way at its start (its radius of
  // curvature negative: s'' > Rp + s + 2 s'^2 / (Rp + s) there), a hollow the roller follows.
  const Mechanism hollow = test::changed(
      "mechanisms/cams/translating_roller_345.toml",
      {
          {"closure = \"form\"          # a groove holds the follower both ways: no spring keeps "
           "it "
           "on\n",
           ""},
          {"{ law = \"polynomial_345\", span = 100, to = 0.02 },\n  { law = \"dwell\", span = 80 }",
           "{ law = \"polynomial_345\", span = 60, to = 0.04 },\n  { law = \"dwell\", span = 120 "
           "}"},
      });
  EXPECT_FALSE(mujoco->supports(hollow, &why));
  EXPECT_NE(why.find("joint 'contact': the profile is concave at"), std::string::npos) << why;
}

}  // namespace
}  // namespace crosslink::sim
