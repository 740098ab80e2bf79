// Exact kinetostatics (analytic/physics/kinetostatics.h) against independent expected values:
//   - the two methods, Lagrange multipliers and the power balance, agree on the driver's effort
//     at every sample of every bundled file (as defined, and loaded with gravity, a spring, a
//     damper, a force and a torque) to 1e-9 of its peak (with joint friction, the balance takes
//     the dissipated power at method 1's friction: tests/analytic/test_friction.cpp checks the
//     friction itself by an independent solve);
//   - Newton-Euler on every link: the extracted joint reactions, the driver's effort, gravity,
//     loads and springs sum to m a_c and, about the centre of mass, to I alpha, to 1e-9 (a gear
//     pair's mesh force at its pitch point, as the teeth push: mechanisms/gears too);
//   - the shaking force and moment equal the negated sum of the forces the ground's joints exert;
//   - quasi-statics: under gravity alone at a crawl, the driver's effort is dV/d(driver), V the
//     potential energy, by central differences of exact positions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/model/planar.h"
#include "analytic/physics/kinetostatics.h"
#include "analytic/reference/sweep.h"
#include "tests/common/mechanisms.h"

namespace crosslink {
namespace {

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// Calls f(state, report) at every usable sample of the exact sweep, with the state solved there
// (position from the sweep's pose polished by Newton, velocity and acceleration).
template <typename F>
void at_every_sample(const Mechanism& m, const NewtonSolver& solver, F f) {
  const Trajectory t = sweep(m);
  KinematicState state(m);
  for (int k = 0; k < t.samples(); ++k) {
    if (!usable(t.status[static_cast<size_t>(k)])) continue;
    state.q = coordinates_at(m, t, k);
    if (m.axis().timed()) {
      state.drive_at(m, t.time(k));  // the sweep runs in time: every driver by its law
    } else {
      DriverState d = m.drivers[0].at_time(t.time(k));
      d.value = t.along(k);
      if (m.drivers[0].law.kind == MotionLaw::Kind::constant_speed) d.rate = m.drivers[0].law.speed;
      state.swept() = d;
    }
    const SolveReport r = solver.solve(state);
    ASSERT_EQ(r.status, PoseStatus::ok) << m.file << " at " << state.swept().value;
    f(state, r);
  }
}

// The forces are the motion's: ok, or a force-closed cam's follower that leaves the cam there
// (mechanisms/cams/spring_cam_jump.toml), whose forces are the ones that would hold it on (the
// contact pulling), which balance as any others.
bool held(const ForceSample& forces) {
  return forces.status == PoseStatus::ok || forces.status == PoseStatus::contact_lost;
}

class EveryMechanism : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryMechanism, MultipliersAndPowerBalanceGiveTheSameDriverEffort) {
  const Mechanism file = load_mechanism(GetParam());
  for (const Mechanism& m : {file, test::loaded(file)}) {
    const NewtonSolver solver(m);
    const Kinetostatics kinetostatics(solver);
    ForceSample forces = kinetostatics.make_sample();
    std::vector<std::pair<double, double>> efforts;
    // The effort's scale: its peak, or the largest reaction (times the size for a torque) where
    // the effort is zero by design (a parallelogram's, at constant speed without gravity).
    double scale = 0.0;
    const double arm = m.drivers[0].angular() ? m.size() : 1.0;
    at_every_sample(m, solver, [&](KinematicState& state, const SolveReport&) {
      kinetostatics.solve(state, forces);
      ASSERT_TRUE(held(forces)) << forces.why(m);
      for (const Eigen::Vector2d& f : forces.joint_force) scale = std::max(scale, arm * f.norm());
      // With joint friction, the power it dissipates at method 1's magnitudes.
      const std::optional<double> power = kinetostatics.power_balance(state, &forces);
      ASSERT_TRUE(power.has_value());
      efforts.emplace_back(forces.effort(0), *power);
    });
    ASSERT_FALSE(efforts.empty());
    for (const auto& [a, b] : efforts) scale = std::max(scale, std::abs(a));
    ASSERT_GT(scale, 0.0) << m.file;
    for (const auto& [a, b] : efforts) EXPECT_NEAR(a, b, 1e-9 * scale) << m.file;
  }
}

// Several drivers (and the gear trains): the drivers' power from their multipliers, the sum of
// effort x rate, is the power balance's (input_power, with the friction's dissipation at method
// 1's magnitudes) at every sample, to 1e-9 of the largest term of either side over the sweep.
class SeveralDrivers : public ::testing::TestWithParam<std::string> {};

TEST_P(SeveralDrivers, TheirEffortsTimesRatesBalanceThePower) {
  const Mechanism file = load_mechanism(GetParam());
  for (const Mechanism& m : {file, test::loaded(file)}) {
    const NewtonSolver solver(m);
    const Kinetostatics kinetostatics(solver);
    ForceSample forces = kinetostatics.make_sample();
    std::vector<std::pair<double, double>> powers;
    double scale = 0.0;
    at_every_sample(m, solver, [&](KinematicState& state, const SolveReport&) {
      kinetostatics.solve(state, forces);
      double power = 0.0;
      for (int d = 0; d < state.driver_count(); ++d) {
        const double term = forces.effort(d) * state.drivers[static_cast<size_t>(d)].rate;
        power += term;
        scale = std::max(scale, std::abs(term));
      }
      const double balance = kinetostatics.input_power(state, &forces);
      // The balance's own terms, each link's rates of kinetic and potential energy, and the
      // reactions' power at the fastest link's speed: a chain without power (Ryan's rack at
      // constant speed) balances the multipliers' round-off against them.
      double terms = std::abs(balance), speed = 0.0;
      for (size_t l = 0; l < m.links.size(); ++l) {
        const int k = m.moving_index(static_cast<int>(l));
        if (k < 0) continue;
        const BodyMotion b = BodyMotion::of(k, state.q, &state.qdot, &state.qddot);
        const MassProperties& mp = m.links[l].mass;
        terms += std::abs(mp.mass * b.velocity(mp.com).dot(b.acceleration(mp.com))) +
                 std::abs(mp.inertia * b.omega * b.alpha) +
                 std::abs(mp.mass * m.gravity.dot(b.velocity(mp.com)));
        speed = std::max(speed, b.v.norm() + std::abs(b.omega) * m.size());
      }
      for (const Eigen::Vector2d& f : forces.joint_force) terms = std::max(terms, f.norm() * speed);
      scale = std::max(scale, terms);

      powers.emplace_back(power, balance);
    });
    ASSERT_FALSE(powers.empty()) << m.file;
    ASSERT_GT(scale, 0.0) << m.file;
    for (const auto& [a, b] : powers) EXPECT_NEAR(a, b, 1e-9 * scale) << m.file;
  }
}

// mechanisms/drivers/*.toml, the gear trains and the friction files with several drivers.
std::vector<std::string> driver_and_gear_files() {
  std::vector<std::string> files = test::files_in("drivers");
  for (std::string& f : test::gear_files()) files.push_back(std::move(f));
  for (std::string& f : test::friction_files())
    if (test::several_drivers(f)) files.push_back(std::move(f));
  return files;
}

INSTANTIATE_TEST_SUITE_P(Mechanisms, SeveralDrivers, ::testing::ValuesIn(driver_and_gear_files()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return std::filesystem::path(info.param).stem().string();
                         });

// Newton-Euler on every moving link from the extracted reactions: the force and moment sums
// against m a_c and I alpha, to 1e-9 of the largest force (and force times size).
TEST_P(EveryMechanism, ReactionsBalanceEveryLink) {
  const Mechanism m = test::loaded(load_mechanism(GetParam()));
  const NewtonSolver solver(m);
  const Kinetostatics kinetostatics(solver);
  ForceSample forces = kinetostatics.make_sample();
  const std::vector<int> slides = m.slide_joints();
  const Driver& d = m.drivers[0];
  at_every_sample(m, solver, [&](KinematicState& state, const SolveReport&) {
    kinetostatics.solve(state, forces);
    ASSERT_TRUE(held(forces)) << forces.why(m);
    const auto body = [&](int link) {
      return BodyMotion::of(m.moving_index(link), state.q, &state.qdot, &state.qddot);
    };
    std::vector<Eigen::Vector2d> force(m.links.size(), Eigen::Vector2d::Zero());
    std::vector<double> moment(m.links.size(), 0.0);  // about the centre of mass
    auto apply = [&](int link, const Eigen::Vector2d& at, const Eigen::Vector2d& f, double c) {
      const BodyMotion b = body(link);
      force[static_cast<size_t>(link)] += f;
      moment[static_cast<size_t>(link)] +=
          cross(at - b.position(m.links[static_cast<size_t>(link)].mass.com), f) + c;
    };
    double scale = 0.0;
    for (size_t j = 0; j < m.joints.size(); ++j) {
      const Joint& joint = m.joints[j];
      // A gear pair's force acts at its pitch point, fixed on its carrier; a cam's at the contact.
      const Eigen::Vector2d at =
          joint.is_gearing() ? body(joint.carrier).position(pitch_point(m, joint))
          : joint.type == JointType::cam
              ? cam_contact(m, joint, body(joint.link_a), body(joint.link_b)).point
              : body(joint.link_b)
                    .position(m.links[static_cast<size_t>(joint.link_b)]
                                  .points[static_cast<size_t>(joint.point_b)]
                                  .local);
      double couple = 0.0;
      const auto s = std::find(slides.begin(), slides.end(), static_cast<int>(j));
      if (s != slides.end()) couple = forces.moment[static_cast<size_t>(s - slides.begin())];
      apply(joint.link_b, at, forces.joint_force[j], couple);
      apply(joint.link_a, at, -forces.joint_force[j], -couple);
      scale = std::max(scale, forces.joint_force[j].norm());
    }
    // A pin's friction moment (a slide's friction force is in its joint force).
    const std::vector<int> friction = m.friction_joints();
    for (size_t f = 0; f < friction.size(); ++f) {
      const Joint& joint = m.joints[static_cast<size_t>(friction[f])];
      if (joint.is_slide()) continue;
      apply(joint.link_b, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), forces.friction[f]);
      apply(joint.link_a, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), -forces.friction[f]);
    }
    // The driver's effort on its driven link, and its reaction.
    if (d.type == DriverType::slider) {
      const Joint& joint = m.joints[static_cast<size_t>(d.joint)];
      const Eigen::Vector2d along = body(joint.link_a)
                                        .turn(m.links[static_cast<size_t>(joint.link_a)]
                                                  .lines[static_cast<size_t>(joint.line)]
                                                  .direction);
      const Eigen::Vector2d at = body(joint.link_b)
                                     .position(m.links[static_cast<size_t>(joint.link_b)]
                                                   .points[static_cast<size_t>(joint.point_b)]
                                                   .local);
      apply(joint.link_b, at, forces.effort(0) * along, 0.0);
      apply(joint.link_a, at, -forces.effort(0) * along, 0.0);
    } else {
      apply(d.link, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), forces.effort(0));
      // Its reaction: on the joint's other link, or for a link's absolute angle on the ground.
      apply(d.type == DriverType::joint_angle ? m.joints[static_cast<size_t>(d.joint)].link_a
                                              : m.ground(),
            Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), -forces.effort(0));
    }
    for (const Load& load : m.loads) {
      const Eigen::Vector2d v = load_value(load, state);
      if (load.kind == Load::Kind::torque)
        apply(load.link, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), v.x());
      else
        apply(load.link, body(load.link).position(load.local), v, 0.0);
    }
    for (const Spring& s : m.springs) {
      const BodyMotion a = body(s.link_a), b = body(s.link_b);
      const Eigen::Vector2d pa = a.position(s.local_a), pb = b.position(s.local_b);
      const Eigen::Vector2d u = (pa - pb).normalized();
      const double rate = u.dot(a.velocity(s.local_a) - b.velocity(s.local_b));
      const double pull = s.stiffness * ((pa - pb).norm() - s.free_length) + s.damping * rate;
      apply(s.link_b, pb, pull * u, 0.0);
      apply(s.link_a, pa, -pull * u, 0.0);
    }
    for (size_t l = 0; l < m.links.size(); ++l) {
      const Link& link = m.links[l];
      if (link.ground) continue;
      const BodyMotion b = body(static_cast<int>(l));
      const Eigen::Vector2d expected = link.mass.mass * b.acceleration(link.mass.com);
      const Eigen::Vector2d total = force[l] + link.mass.mass * m.gravity;
      const double tolerance = 1e-9 * std::max(scale, 1.0);
      EXPECT_NEAR(total.x(), expected.x(), tolerance) << link.name << " at " << state.swept().value;
      EXPECT_NEAR(total.y(), expected.y(), tolerance) << link.name << " at " << state.swept().value;
      EXPECT_NEAR(moment[l], link.mass.inertia * b.alpha, tolerance * m.size())
          << link.name << " at " << state.swept().value;
    }
    // The ground: what its joints and the driver's reaction take, with the springs anchored on
    // it, is the shaking force and moment.
    const int g = m.ground();
    const Eigen::Vector2d ground_force = force[static_cast<size_t>(g)];
    // Moments were summed about the ground's (unused) centre of mass: move them to the origin.
    const Eigen::Vector2d c = m.links[static_cast<size_t>(g)].mass.com;
    const double ground_moment = moment[static_cast<size_t>(g)] + cross(c, ground_force);
    const double tolerance = 1e-9 * std::max(scale, 1.0);
    EXPECT_NEAR(forces.shaking.x(), ground_force.x(), tolerance);
    EXPECT_NEAR(forces.shaking.y(), ground_force.y(), tolerance);
    EXPECT_NEAR(forces.shaking.z(), ground_moment, tolerance * m.size());
  });
}

// Every bundled definition, the gear trains, the curved slots and the definitions with joint
// friction.
std::vector<std::string> with_gears() {
  std::vector<std::string> files = test::bundled_files(true);
  for (std::string& f : test::gear_files()) files.push_back(std::move(f));
  for (std::string& f : test::files_in("cams")) files.push_back(std::move(f));
  for (std::string& f : test::friction_files())
    if (!test::several_drivers(f)) files.push_back(std::move(f));  // those: SeveralDrivers
  return files;
}

INSTANTIATE_TEST_SUITE_P(Mechanisms, EveryMechanism, ::testing::ValuesIn(with_gears()),
                         [](const ::testing::TestParamInfo<std::string>& info) {
                           return std::filesystem::path(info.param).stem().string();
                         });

// Under gravity alone, driven at a crawl, the driver holds the mechanism against its weight:
// effort = dV/d(driver) with V = -sum m g . r_c, by central differences of exact poses.
TEST(QuasiStatics, DriverEffortIsTheDerivativeOfPotentialEnergy) {
  for (const char* name : {"fourbar_crank_rocker.toml", "sewing_machine.toml",
                           "singular/slider_crank_from_slider.toml", "watt_sixbar.toml"}) {
    Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + name);
    m.gravity = Eigen::Vector2d(0.0, -9.81);
    m.drivers[0].law.speed = std::copysign(1e-7, m.drivers[0].law.speed);
    const NewtonSolver solver(m);
    const Kinetostatics kinetostatics(solver);
    ForceSample forces = kinetostatics.make_sample();
    const double h = m.drivers[0].angular() ? 1e-5 : 1e-5 * m.size();
    auto potential = [&](const Eigen::VectorXd& q) {
      double v = 0.0;
      for (size_t l = 0; l < m.links.size(); ++l) {
        if (m.links[l].ground) continue;
        const BodyMotion b =
            BodyMotion::of(m.moving_index(static_cast<int>(l)), q, nullptr, nullptr);
        v -= m.links[l].mass.mass * m.gravity.dot(b.position(m.links[l].mass.com));
      }
      return v;
    };
    std::vector<std::pair<double, double>> pairs;
    int visited = 0;
    at_every_sample(m, solver, [&](KinematicState& state, const SolveReport& report) {
      // Every tenth sample, away from toggles (where dV/d(driver) grows without bound and the
      // differences' truncation error with it).
      if (visited++ % 10 != 0 || report.rcond < 1e-2) return;
      kinetostatics.solve(state, forces);
      KinematicState shifted = state;
      double v[2];
      for (int side = 0; side < 2; ++side) {
        shifted.q = state.q;
        shifted.swept().value = state.swept().value + (side == 0 ? h : -h);
        ASSERT_EQ(solver.solve_position(shifted).status, PoseStatus::ok);
        v[side] = potential(shifted.q);
      }
      pairs.emplace_back(forces.effort(0), (v[0] - v[1]) / (2.0 * h));
    });
    double peak = 0.0;
    for (const auto& [a, b] : pairs) peak = std::max(peak, std::abs(b));
    ASSERT_GT(peak, 0.0) << name;
    for (const auto& [a, b] : pairs) EXPECT_NEAR(a, b, 1e-7 * peak) << name;
  }
}

}  // namespace
}  // namespace crosslink

namespace crosslink {
namespace {

// A published dynamic force analysis: Marghitu & Dupac, Advanced Dynamics (Springer 2012), ch. 6,
// Example 6.1, bundled with its printed results as [[reference]] rows. Forces and the motor moment
// are printed to three decimals: the exact values must lie within half a unit of the last digit
// (and a little for the printed value's own rounding of the inputs, none here: the inputs are
// exact). Kinematic rows are printed to three significant digits and are checked by test_seeds'
// rules elsewhere.
TEST(PublishedExamples, MarghituSixBarForcesToThePrintedDigits) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/rrtr_rrt_sixbar_forces.toml");
  int checked = 0;
  for (const Reference& r : m.references) {
    const Quantity q = Trajectory::quantity_of(r.quantity);
    if (q != Quantity::force && q != Quantity::torque) continue;
    const Trajectory exact = solve_at(m, r.driver_value);
    ASSERT_EQ(exact.status[0], PoseStatus::ok);
    const std::optional<Eigen::VectorXd> value = exact.channel(r.quantity);
    ASSERT_TRUE(value.has_value()) << r.quantity;
    EXPECT_NEAR((*value)(0), r.value, 0.5e-3) << r.quantity << " (" << r.source << ")";
    ++checked;
  }
  EXPECT_EQ(checked, 14);  // Mmot and the x, y of F01, F12, F32, F03, F34, F54, and F05's y
}

}  // namespace
}  // namespace crosslink

namespace crosslink {
namespace {

// Khurmi & Gupta, Theory of Machines (14th ed.), Example 15.7: a slider-crank with massless crank
// and rod, a 250 kg piston and a 68.72 kN gas load at 60 degrees from inner dead centre. The book
// prints the thrust in the connecting rod, 50.62 kN, and the turning moment, 14.484 kN m; exact:
// 50.641 kN and 14.4895 kN m (0.04 %), because the book rounds omega to 26.2 rad/s and the
// obliquity to 12.5 degrees on the way (with those, its method gives the printed digits).
TEST(PublishedExamples, KhurmiSliderCrankWithinTheBooksRounding) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/published/khurmi_slider_crank_gas_force.toml");
  ASSERT_EQ(m.references.size(), 2u);
  for (const Reference& r : m.references) {
    const Trajectory exact = solve_at(m, r.driver_value);
    ASSERT_EQ(exact.status[0], PoseStatus::ok);
    const double value = (*exact.channel(r.quantity))(0);
    EXPECT_NEAR(value, r.value, 5e-4 * std::abs(r.value)) << r.quantity;
    EXPECT_GT(std::abs(value - r.value), 1e-4 * std::abs(r.value))
        << r.quantity << ": the printed value carries the book's rounding";
  }
}

}  // namespace
}  // namespace crosslink

namespace crosslink {
namespace {

// The four-bar of "Makina Dinamiği - Ders Notları", Örnek 7 (mechanisms/published/
// fourbar_dynamic_force_example7.toml): the notes' force step, their equations (7)-(17) of
// section 3.1.3.2, written out here. Inertia loads F3 = -m3 aG3 at G3 (r3 from B along BC),
// F4 = -m4 aG4 at G4 (r4 from O4 along O4C), couples T3 = -J3 alpha3, T4 = -J4 alpha4; the crank's
// centre of mass at O2 and alpha2 = 0 (F2 = 0, T2 = 0). Link 4's and link 3's moment balances give
// F34; then F14 = -F34 - F4, F23 = F34 - F3, F12 = F23, and the crank's balance T.
struct NotesForces {
  Eigen::Vector2d f34, f14, f23;
  double torque;
};
NotesForces notes_force_step(double th2, double th3, double th4, double l2, double l3, double l4,
                             double r3, double r4, const Eigen::Vector2d& f3,
                             const Eigen::Vector2d& f4, double t3, double t4) {
  const double a11 = -l4 * std::sin(th4), a12 = l4 * std::cos(th4);
  const double a21 = l3 * std::sin(th3), a22 = -l3 * std::cos(th3);
  const double b1 = f4.x() * r4 * std::sin(th4) - f4.y() * r4 * std::cos(th4) - t4;
  const double b2 = f3.x() * r3 * std::sin(th3) - f3.y() * r3 * std::cos(th3) - t3;
  const double det = a11 * a22 - a12 * a21;
  NotesForces out;
  out.f34 = {(a22 * b1 - a12 * b2) / det, (a11 * b2 - a21 * b1) / det};
  out.f14 = -out.f34 - f4;
  out.f23 = out.f34 - f3;
  out.torque = out.f23.y() * l2 * std::cos(th2) - out.f23.x() * l2 * std::sin(th2);
  return out;
}

constexpr double kDeg = std::numbers::pi / 180.0;

// With crosslink's exact kinematics fed to it, the notes' dyad-by-dyad force step gives crosslink's
// Lagrange-multiplier forces: the two methods agree, so what separates the printed answers from
// the exact ones is the kinematics.
TEST(PublishedExamples, Example7NotesForceStepOnExactKinematicsIsOurs) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/published/fourbar_dynamic_force_example7.toml");
  const Trajectory t = solve_at(m, 120.0 * kDeg);
  ASSERT_EQ(t.status[0], PoseStatus::ok);
  const auto value = [&](const std::string& channel) { return (*t.channel(channel))(0); };
  const Eigen::Vector2d f3 = -0.5 * Eigen::Vector2d(value("ax.G3"), value("ay.G3"));
  const Eigen::Vector2d f4 = -0.4 * Eigen::Vector2d(value("ax.G4"), value("ay.G4"));
  const NotesForces notes = notes_force_step(
      120.0 * kDeg, value("angle.coupler"), value("angle.rocker"), 0.050, 0.151, 0.111, 0.0755,
      0.0555, f3, f4, -1.21e-3 * value("alpha.coupler"), -0.91e-3 * value("alpha.rocker"));
  const auto expect_force = [&](const std::string& joint, const Eigen::Vector2d& f) {
    EXPECT_NEAR(value("fx." + joint), f.x(), 1e-9 * f.norm()) << joint;
    EXPECT_NEAR(value("fy." + joint), f.y(), 1e-9 * f.norm()) << joint;
  };
  expect_force("C", notes.f34);
  expect_force("O4", notes.f14);
  expect_force("B", notes.f23);
  expect_force("O2", notes.f23);
  EXPECT_NEAR(value("torque.driver"), notes.torque, 1e-9 * std::abs(notes.torque));
}

// The notes' printed answers follow from their printed, graphical, inputs (theta3 = 26 deg and
// theta4 = 85 deg read off the drawing; F3 = 187 N at 116 deg as (-82, 168) N, F4 = 60 N at 110 deg
// as (-20.5, 56.4) N; T3 = -1211.6 N mm, T4 = 1020.6 N mm): the same step gives F34, F14 and F23
// to their printed 0.1 N, and their T = -3481.5 N mm from the rounded F23 they print (-3481.8 from
// the unrounded one). The transcription holds; the differences from exact are their kinematics'.
TEST(PublishedExamples, Example7PrintedForcesFollowFromItsGraphicalKinematics) {
  const NotesForces notes =
      notes_force_step(120.0 * kDeg, 26.0 * kDeg, 85.0 * kDeg, 50, 151, 111, 75.5, 55.5, {-82, 168},
                       {-20.5, 56.4}, -1211.6, 1020.6);
  EXPECT_NEAR(notes.f34.x(), 31.6, 0.05);
  EXPECT_NEAR(notes.f34.y(), 110.5, 0.05);
  EXPECT_NEAR(notes.f14.x(), -11.1, 0.05);
  EXPECT_NEAR(notes.f14.y(), -166.9, 0.05);
  EXPECT_NEAR(notes.f23.x(), 113.6, 0.05);
  EXPECT_NEAR(notes.f23.y(), -57.5, 0.05);
  // T from the unrounded F23, within what rounding F23 to 0.1 N moves it (0.05 N at l2 = 50 mm
  // over both components), and exactly from the rounded F23 the notes print.
  const double c2 = std::cos(120.0 * kDeg), s2 = std::sin(120.0 * kDeg);
  EXPECT_NEAR(notes.torque, -3481.5, 0.05 * 50 * (std::abs(c2) + std::abs(s2)));
  EXPECT_NEAR(-57.5 * 50 * c2 - 113.6 * 50 * s2, -3481.5, 0.05);
}

// The slider-crank of the same notes, Örnek 9 (mechanisms/published/
// slider_crank_dynamic_force_example9.toml): their force step, equations (1)-(8) of section
// 4.1.2, written out here. Inertia loads -m3 aG3 at G3 (lG from B), the couple -J3 alpha3, -m4 aG4
// on the piston and the gas force P towards the crank; the rod at phi below the line of stroke;
// the crank's centre of mass at O2 and alpha2 = 0.
struct NotesSliderForces {
  Eigen::Vector2d f34, f23;  // rod on piston, crank on rod (= ground on crank)
  double f14y, torque;
};
NotesSliderForces notes_slider_step(double theta, double phi, double r, double l, double lg,
                                    const Eigen::Vector2d& f3, double t3, double f4, double p) {
  NotesSliderForces out;
  const double f43x = -(p - f4);  // (1): F34x + (-m4 aG4) - P = 0
  const double f43y =
      -(f43x * l * std::sin(phi) + f3.x() * lg * std::sin(phi) + f3.y() * lg * std::cos(phi) + t3) /
      (l * std::cos(phi));  // (5)
  out.f34 = {-f43x, -f43y};
  out.f14y = f43y;                                                                      // (2)
  out.f23 = {-f43x - f3.x(), -f43y - f3.y()};                                           // (3), (4)
  out.torque = -out.f23.x() * r * std::sin(theta) + out.f23.y() * r * std::cos(theta);  // (8)
  return out;
}

// With crosslink's exact kinematics, the notes' force step gives crosslink's forces.
TEST(PublishedExamples, Example9NotesForceStepOnExactKinematicsIsOurs) {
  const Mechanism m =
      load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                     "/mechanisms/published/slider_crank_dynamic_force_example9.toml");
  const Trajectory t = solve_at(m, 60.0 * kDeg);
  ASSERT_EQ(t.status[0], PoseStatus::ok);
  const auto value = [&](const std::string& channel) { return (*t.channel(channel))(0); };
  const NotesSliderForces notes =
      notes_slider_step(60.0 * kDeg, -value("angle.rod"), 0.051, 0.200, 0.051,
                        -1.36 * Eigen::Vector2d(value("ax.G3"), value("ay.G3")),
                        -0.0102 * value("alpha.rod"), -0.91 * value("ax.C"), 6300.0);
  const double scale = notes.f23.norm();
  EXPECT_NEAR(value("fx.C"), notes.f34.x(), 1e-9 * scale);
  EXPECT_NEAR(value("fy.C"), notes.f34.y(), 1e-9 * scale);
  EXPECT_NEAR(value("fn.piston"), notes.f14y, 1e-9 * scale);
  for (const std::string joint : {"B", "O2"}) {
    EXPECT_NEAR(value("fx." + joint), notes.f23.x(), 1e-9 * scale) << joint;
    EXPECT_NEAR(value("fy." + joint), notes.f23.y(), 1e-9 * scale) << joint;
  }
  EXPECT_NEAR(value("torque.driver"), notes.torque, 1e-9 * std::abs(notes.torque));
}

// On the notes' printed, graphical, inputs (phi rounded to 13 deg; -m3 aG3 = (3197.4, 4401.0) N
// from aG3 = 4000 m/s^2 at 234 deg; -J3 alpha3 = -224.4 N m; -m4 aG4 = 1710.8 N), the same step
// gives their printed forces to their 0.1 N (F23y -5301.52) and their T = -196660.3 N mm within
// what rounding F23 to 0.1 N moves it (-196660.88).
TEST(PublishedExamples, Example9PrintedForcesFollowFromItsGraphicalKinematics) {
  const NotesSliderForces notes = notes_slider_step(60.0 * kDeg, 13.0 * kDeg, 51, 200, 51,
                                                    {3197.4, 4401.0}, -224.4e3, 1710.8, 6300);
  EXPECT_NEAR(notes.f34.x(), 4589.2, 0.05);
  EXPECT_NEAR(notes.f34.y(), -900.5, 0.05);
  EXPECT_NEAR(notes.f14y, 900.5, 0.05);
  EXPECT_NEAR(notes.f23.x(), 1391.8, 0.05);
  EXPECT_NEAR(notes.f23.y(), -5301.5, 0.05);
  EXPECT_NEAR(notes.torque, -196660.3, 0.05 * 51 * (std::sin(60.0 * kDeg) + std::cos(60.0 * kDeg)));
}

}  // namespace
}  // namespace crosslink
