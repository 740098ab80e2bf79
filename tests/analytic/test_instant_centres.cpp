// Instantaneous centres (Kennedy–Aronhold) against the exact velocity solution and against the
// course notes' printed values.
//
//   Wanzer needle bar, inversion 2, disk at 0 (notes 002), numbered as the notes:
//   1 ground, 2 disk, 3 triangle EFG, 4 block E (slot B, x = 10 in the disk), 5 block F (slot C,
//   y = 10 in the disk), 6 needle G (slot D, x = 0 fixed).
//
//            E +------ slot B (x = 10, on the disk)          I(2,3) = (x_F, y_E): the slot
//              |\                                            normals at E and F (notes: "2,5
//   ---- A ----+-F--- slot C (y = 10, on the disk)           and 3,5 intersect 2,3 ...")
//        |     |/                                            I(2,6) = on y = 0 (I(1,2)-I(1,6))
//        |     /                                             and on I(2,3)-G (I(3,6))
//        G needle, slot D (x = 0)                            V_G = omega2 * AP, AP = |I(2,6)|
//
// Agreement with the exact solution: |V_ic - V_exact| <= 1e-9 |V_exact|. The notes' values
// are a Working Model run (365 mm/s) and a ruler construction (AP = 14.7 mm, 370 mm/s); the
// percentage differences are printed (the exact V_G = 382.1 mm/s, AP = 15.20 mm).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <numbers>
#include <string>
#include <vector>

#include "analytic/kinematics/instant_centres.h"
#include "analytic/model/loader.h"
#include "analytic/model/planar.h"
#include "analytic/reference/sweep.h"
#include "tests/common/mechanisms.h"

namespace crosslink {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

Mechanism bundled(const char* name) {
  return load_mechanism(std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/" + name + ".toml");
}

double channel(const Trajectory& t, const std::string& name) {
  return (*t.channel(name))(0);
}

int point_column(const Trajectory& t, const std::string& name) {
  for (size_t i = 0; i < t.point_names.size(); ++i)
    if (t.point_names[i] == name) return static_cast<int>(i);
  return -1;
}

double percent(double value, double reference) {
  return 100.0 * (value - reference) / reference;
}

// Every pair of every bundled-like chain gets a centre, and the velocities it gives match.
void expect_all_velocities(const Mechanism& m, const Trajectory& exact) {
  const InstantCentres ic = instant_centres(m, exact, 0);
  const CentreVelocities v = centre_velocities(m, ic, exact, 0);
  ASSERT_TRUE(v.complete) << v.message;
  double peak = 0.0;
  for (int p = 0; p < static_cast<int>(exact.point_names.size()); ++p)
    peak = std::max(peak, std::hypot(exact.vx(0, p), exact.vy(0, p)));
  for (int p = 0; p < static_cast<int>(exact.point_names.size()); ++p) {
    EXPECT_NEAR(v.point[p].x(), exact.vx(0, p), 1e-9 * peak) << exact.point_names[p];
    EXPECT_NEAR(v.point[p].y(), exact.vy(0, p), 1e-9 * peak) << exact.point_names[p];
  }
}

TEST(InstantCentres, WanzerNeedleBarAtDiskAngleZero) {
  const Mechanism m = bundled("wanzer_needle_bar");
  const Trajectory exact = solve_at(m, 0.0);
  ASSERT_EQ(exact.status[0], PoseStatus::ok);
  const InstantCentres ic = instant_centres(m, exact, 0);
  const int disk = m.find_link("disk"), needle = m.find_link("needle");
  const InstantCentre& i26 = ic.at(disk, needle);
  ASSERT_EQ(i26.found, InstantCentre::Found::kennedy) << i26.how;
  ASSERT_FALSE(i26.at_infinity());

  // Independent construction of the notes: I(2,3) = (x_F, y_E), then I(2,6) where the line
  // from I(2,3) through G meets y = 0.
  const double mm = 1e-3;
  const Eigen::Vector2d e(channel(exact, "x.E"), channel(exact, "y.E"));
  const Eigen::Vector2d f(channel(exact, "x.F"), channel(exact, "y.F"));
  const Eigen::Vector2d g(channel(exact, "x.G"), channel(exact, "y.G"));
  const Eigen::Vector2d i23(f.x(), e.y());
  const double t = -g.y() / (i23.y() - g.y());
  const Eigen::Vector2d i26_by_hand = g + t * (i23 - g);
  EXPECT_NEAR(i26.position().x(), i26_by_hand.x(), 1e-12);
  EXPECT_NEAR(i26.position().y(), i26_by_hand.y(), 1e-12);
  // The notes' geometry solution (E, F, G printed to 4 decimals).
  EXPECT_NEAR(e.y() / mm, 19.9279, 1e-4);
  EXPECT_NEAR(f.x() / mm, 22.5473, 1e-4);
  EXPECT_NEAR(g.y() / mm, -41.2603, 1e-4);

  const CentreVelocities v = centre_velocities(m, ic, exact, 0);
  ASSERT_TRUE(v.complete) << v.message;
  const int gcol = point_column(exact, "G");
  const double vg_exact = exact.vy(0, gcol), vg_ic = v.point[gcol].y();
  EXPECT_NEAR(vg_ic, vg_exact, 1e-9 * std::abs(vg_exact));
  EXPECT_NEAR(v.point[gcol].x(), 0.0, 1e-9 * std::abs(vg_exact));  // the needle runs on x = 0
  const double ap = i26.position().norm();
  std::printf(
      "Wanzer at disk 0: I(2,6) = (%.4f, %.4f) mm, AP = %.4f mm (ruler 14.7: %+.2f %%)\n"
      "  V_G exact %.3f mm/s, from centres %.3f mm/s (difference %.1e)\n"
      "  Working Model 365 mm/s: exact differs by %+.2f %%; ruler IC 370 mm/s: %+.2f %%; notes "
      "370 vs 365: %+.2f %%\n",
      i26.position().x() / mm, i26.position().y() / mm, ap / mm, percent(ap / mm, 14.7),
      vg_exact / mm, vg_ic / mm, std::abs(vg_ic - vg_exact) / std::abs(vg_exact),
      percent(-vg_exact / mm, 365.0), percent(-vg_exact / mm, 370.0), percent(370.0, 365.0));
  // Downward. The notes' values lie 3 to 5 % below the exact one (AP by ruler 14.7 mm against
  // 15.20 mm from the notes' own E, F, G), more than the 1.5 % their rounding explains: the
  // difference is reported, and bounded only loosely (6 %) so a wrong mechanism still fails.
  EXPECT_LT(vg_exact, 0.0);
  EXPECT_NEAR(-vg_exact / mm, 365.0, 0.06 * 365.0);
  EXPECT_NEAR(-vg_exact / mm, 370.0, 0.06 * 370.0);
  EXPECT_NEAR(ap / mm, 14.7, 0.06 * 14.7);
  expect_all_velocities(m, exact);
}

// Notes 000 at theta2 = 135 deg: needle velocity 64.71 cm/s down (closed form), 64.72
// (graphical, i.e. instant centres drawn to scale).
TEST(InstantCentres, SewingMachineNeedle) {
  const Mechanism m = bundled("sewing_machine");
  const Trajectory exact = solve_at(m, 135 * kDeg);
  ASSERT_EQ(exact.status[0], PoseStatus::ok);
  const InstantCentres ic = instant_centres(m, exact, 0);
  EXPECT_EQ(ic.kennedy_unplaced, 0);
  const CentreVelocities v = centre_velocities(m, ic, exact, 0);
  ASSERT_TRUE(v.complete) << v.message;
  const int f = point_column(exact, "F");
  const double cm = 0.01, vf = exact.vy(0, f);
  EXPECT_NEAR(v.point[f].y(), vf, 1e-9 * std::abs(vf));
  std::printf(
      "Sewing machine at 135 deg: V_F exact %.3f cm/s, centres %.3f cm/s; notes 64.71 "
      "(closed form) %+.2f %%, 64.72 (graphical) %+.2f %%\n",
      -vf / cm, -v.point[f].y() / cm, percent(-vf / cm, 64.71), percent(-vf / cm, 64.72));
  expect_all_velocities(m, exact);
}

// Crank-rocker: I(1,3) is where lines AB (crank) and DC (rocker) cross, by two-line algebra
// written out here; omega3 = omega2 * AB / (I13 B) with signs, an independent check.
TEST(InstantCentres, CrankRockerI13AtCrossingOfCrankAndRocker) {
  const Mechanism m = bundled("fourbar_crank_rocker");
  const Trajectory exact = solve_at(m, 40 * kDeg);
  ASSERT_EQ(exact.status[0], PoseStatus::ok);
  const InstantCentres ic = instant_centres(m, exact, 0);
  auto at = [&](const char* p) {
    const int c = point_column(exact, p);
    return Eigen::Vector2d(exact.x(0, c), exact.y(0, c));
  };
  const Eigen::Vector2d a = at("A"), b = at("B"), c = at("C"), d = at("D");
  // A + s (B - A) = D + u (C - D)  ->  s by Cramer's rule.
  const Eigen::Vector2d ab = b - a, dc = c - d, ad = d - a;
  const double det = ab.x() * (-dc.y()) - ab.y() * (-dc.x());
  const double s = (ad.x() * (-dc.y()) - ad.y() * (-dc.x())) / det;
  const Eigen::Vector2d i13 = a + s * ab;
  const InstantCentre& centre = ic.at(m.find_link("ground"), m.find_link("coupler"));
  ASSERT_EQ(centre.found, InstantCentre::Found::kennedy);
  EXPECT_NEAR(centre.position().x(), i13.x(), 1e-12);
  EXPECT_NEAR(centre.position().y(), i13.y(), 1e-12);
  // B turns about A with the crank and about I13 with the coupler: omega2 perp(B - A) =
  // omega3 perp(B - I13), and B - I13 = (1 - s)(B - A).
  const double omega2 = m.drivers[0].law.speed;
  const double omega3 = omega2 / (1.0 - s);
  EXPECT_NEAR(channel(exact, "omega.coupler"), omega3, 1e-9 * std::abs(omega3));
  expect_all_velocities(m, exact);
}

// Six-bar with a slider on a moving guide at phi2 = 339 deg: the crank and link 6 both turn
// about A, so I(1,2) = I(1,6) = I(2,6) = A (the last by Kennedy, to round-off) and the ratio
// omega6 / omega2 through them is 0/0. Link 6's speed must come from a well-conditioned pair
// (through I(5,6) = F, I(4,6) or I(3,6)), not from that one.
TEST(InstantCentres, SixBarLinkSixAboutTheCrankPivot) {
  const Mechanism m = bundled("sixbar_slider_guide");
  const Trajectory exact = solve_at(m, 339 * kDeg);
  ASSERT_EQ(exact.status[0], PoseStatus::ok);
  const InstantCentres ic = instant_centres(m, exact, 0);
  EXPECT_EQ(ic.kennedy_unplaced, 0);
  const int ground = m.find_link("ground"), crank = m.find_link("crank"),
            link6 = m.find_link("link6");
  ASSERT_TRUE(ic.at(crank, link6).placed());
  EXPECT_LT((ic.at(crank, link6).position() - ic.at(ground, link6).position()).norm(), 1e-12);
  const CentreVelocities v = centre_velocities(m, ic, exact, 0);
  ASSERT_TRUE(v.complete) << v.message;
  const int k6 = m.moving_index(link6);
  const double omega6 = exact.omega(0, k6);
  EXPECT_NEAR(omega6, -2.98134, 1e-5);
  EXPECT_NEAR(v.omega[static_cast<size_t>(k6)], omega6, 1e-9 * std::abs(omega6));
  EXPECT_TRUE(v.from_geometry[static_cast<size_t>(k6)]);
}

// Quick return at theta2 = 90 deg: every centre of links 2 to 6 lies on x = 0, so Kennedy's
// lines for I(2,5) and I(2,6) coincide and those two come from the velocity solution, labelled.
// The velocities do not need them (link 5 translates: from I(1,5) at infinity and I(4,5) = D).
// A link that can only be reached through a centre from the velocities is labelled so.
TEST(InstantCentres, CentresFromTheVelocitiesAreLabelled) {
  const Mechanism m = bundled("quick_return");
  const Trajectory exact = solve_at(m, 90 * kDeg);
  ASSERT_EQ(exact.status[0], PoseStatus::ok);
  InstantCentres ic = instant_centres(m, exact, 0);
  EXPECT_EQ(ic.kennedy_unplaced, 2);
  const int ground = m.find_link("ground"), crank = m.find_link("crank"),
            link5 = m.find_link("link5"), ram = m.find_link("ram");
  EXPECT_EQ(ic.at(crank, link5).found, InstantCentre::Found::velocity);
  EXPECT_EQ(ic.at(crank, ram).found, InstantCentre::Found::velocity);
  CentreVelocities v = centre_velocities(m, ic, exact, 0);
  ASSERT_TRUE(v.complete) << v.message;
  for (bool g : v.from_geometry) EXPECT_TRUE(g);
  const auto k_ram = static_cast<size_t>(m.moving_index(ram));
  const int ram_point = point_column(exact, "E");
  EXPECT_NEAR(v.point[static_cast<size_t>(ram_point)].x(), exact.vx(0, ram_point), 1e-12);

  // Every way to the ram goes through I(1,6): were it from the velocities, the ram (only) would
  // say so.
  for (InstantCentre& c : ic.centres)
    if (c.i == std::min(ground, ram) && c.j == std::max(ground, ram))
      c.found = InstantCentre::Found::velocity;
  v = centre_velocities(m, ic, exact, 0);
  ASSERT_TRUE(v.complete) << v.message;
  for (size_t l = 0; l < v.from_geometry.size(); ++l)
    EXPECT_EQ(v.from_geometry[l], l != k_ram) << exact.link_names[l];
  EXPECT_NEAR(v.point[static_cast<size_t>(ram_point)].x(), exact.vx(0, ram_point), 1e-12);
}

// IFToMM A02 at its start: the two couplers of the double parallelogram translate together (the
// exact velocities: equal angular rates and equal velocities of one world point), so they have
// no relative motion and every point is a centre of the pair. The velocity fallback divided 0 by
// 0 and gave a NaN centre (it stopped the report's script); the pair stays unplaced, with why,
// and the velocities from the other centres are still complete.
TEST(InstantCentres, APairWithNoRelativeMotionHasNoCentre) {
  const Mechanism m = bundled("iftomm_a02_double_fourbar");
  const Trajectory exact = solve_at(m, m.drivers[0].start);
  ASSERT_TRUE(usable(exact.status[0]));
  const int c1 = m.find_link("coupler1"), c2 = m.find_link("coupler2");
  const auto k1 = static_cast<Eigen::Index>(m.moving_index(c1)),
             k2 = static_cast<Eigen::Index>(m.moving_index(c2));
  EXPECT_NEAR(exact.omega(0, k1), exact.omega(0, k2), 1e-12);
  const InstantCentres ic = instant_centres(m, exact, 0);
  const InstantCentre& pair = ic.at(c1, c2);
  EXPECT_FALSE(pair.placed());
  EXPECT_NE(pair.how.find("no relative motion"), std::string::npos) << pair.how;
  for (const InstantCentre& c : ic.centres)
    if (c.placed()) {
      EXPECT_TRUE(c.point.allFinite()) << c.i << "," << c.j;
    }
  const CentreVelocities v = centre_velocities(m, ic, exact, 0);
  ASSERT_TRUE(v.complete) << v.message;
  for (size_t l = 0; l < v.omega.size(); ++l)
    EXPECT_NEAR(v.omega[l], exact.omega(0, static_cast<Eigen::Index>(l)), 1e-9) << l;
}

// Every bundled mechanism over its whole sweep: the velocities from the centres against the
// Newton solver's (an independent method: J qdot = nu) at every usable sample, to 1e-9 of each
// channel's scale. Scales are physical: the driver's rate for angular velocities and the rate
// times the mechanism's size for linear ones (a slider driver: rate / size and rate), or the
// channel's peak over the sweep when larger. Samples where a centre had to be placed from the
// exact velocities are counted and must be labelled so (not an independent check there).
// The singular catalogue (mechanisms/singular/) is included: there a sample may lie on a change
// point, where the Jacobian's reciprocal condition falls to ~1e-8 and neither method's velocity
// is known to 1e-9 (a linear solve's forward error is ~eps / rcond); such samples (rcond below
// 1e-5; none in mechanisms/*.toml) are held to 1e-14 / rcond instead, and counted.
TEST(InstantCentres, EveryBundledMechanismOverItsSweep) {
  namespace fs = std::filesystem;
  // The kinematic definitions: a dynamics case's constant-rate sweep is not its motion (and
  // Andrews' squeezer starts with E at rest, where the centres about E coincide and Kennedy
  // cannot give body6's velocity).
  std::vector<fs::path> files;
  for (const std::string& f : test::bundled_files(true, false)) files.emplace_back(f);
  ASSERT_GE(files.size(), 10u);
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.filename().string());
    const Mechanism m = load_mechanism(file.string());
    const Trajectory exact = sweep(m);
    const int links = static_cast<int>(exact.link_names.size());
    const int points = static_cast<int>(exact.point_names.size());
    double rate = 0.0;
    for (int r = 0; r < exact.samples(); ++r)
      rate = std::max(rate, std::abs(m.drivers[0].at_time(exact.time(r)).rate));
    const double size = m.size();
    const double angular = m.drivers[0].angular() ? rate : rate / size;
    const double linear = m.drivers[0].angular() ? rate * size : rate;
    std::vector<double> omega_scale(static_cast<size_t>(links), angular);
    std::vector<double> v_scale(static_cast<size_t>(points), linear);
    int usable_samples = 0;
    for (int r = 0; r < exact.samples(); ++r) {
      if (!usable(exact.status[static_cast<size_t>(r)])) continue;
      ++usable_samples;
      for (int l = 0; l < links; ++l)
        omega_scale[l] = std::max(omega_scale[l], std::abs(exact.omega(r, l)));
      for (int p = 0; p < points; ++p)
        v_scale[p] =
            std::max(v_scale[p], std::max(std::abs(exact.vx(r, p)), std::abs(exact.vy(r, p))));
    }
    ASSERT_GT(usable_samples, 0);
    double worst_omega = 0.0, worst_v = 0.0;
    int worst_omega_row = -1, worst_v_row = -1, not_independent = 0, ill_conditioned = 0;
    for (int r = 0; r < exact.samples(); ++r) {
      if (!usable(exact.status[static_cast<size_t>(r)])) continue;
      const double tolerance =
          exact.rcond(r) >= 1e-5 ? 1e-9 : std::max(1e-9, 1e-14 / exact.rcond(r));
      if (tolerance > 1e-9) ++ill_conditioned;
      const InstantCentres ic = instant_centres(m, exact, r);
      const CentreVelocities v = centre_velocities(m, ic, exact, r);
      ASSERT_TRUE(v.complete) << "sample " << r << ": " << v.message;
      const bool all_geometric =
          std::find(v.from_geometry.begin(), v.from_geometry.end(), false) == v.from_geometry.end();
      // The label: a link is from geometry only if no centre from the velocities was placed.
      if (ic.kennedy_unplaced == 0) {
        EXPECT_TRUE(all_geometric) << "sample " << r;
      }
      if (!all_geometric) ++not_independent;
      for (int l = 0; l < links; ++l) {
        const double e = std::abs(v.omega[static_cast<size_t>(l)] - exact.omega(r, l)) /
                         omega_scale[static_cast<size_t>(l)];
        if (e > worst_omega) worst_omega = e, worst_omega_row = r;
        EXPECT_LE(e, tolerance) << "omega." << exact.link_names[l] << " at sample " << r
                                << " (driver " << exact.along(r) << "): centres "
                                << v.omega[static_cast<size_t>(l)] << ", Newton "
                                << exact.omega(r, l);
      }
      for (int p = 0; p < points; ++p) {
        const double e = std::max(std::abs(v.point[static_cast<size_t>(p)].x() - exact.vx(r, p)),
                                  std::abs(v.point[static_cast<size_t>(p)].y() - exact.vy(r, p))) /
                         v_scale[static_cast<size_t>(p)];
        if (e > worst_v) worst_v = e, worst_v_row = r;
        EXPECT_LE(e, tolerance) << "v." << exact.point_names[p] << " at sample " << r << " (driver "
                                << exact.along(r) << ")";
      }
    }
    std::printf(
        "%-40s %3d samples: max |omega_ic - omega_newton| / scale %.2e (sample %d), "
        "max |v_ic - v_newton| / scale %.2e (sample %d); %d samples use a centre from the "
        "velocities; %d ill-conditioned (rcond < 1e-5)\n",
        file.filename().string().c_str(), usable_samples, worst_omega, worst_omega_row, worst_v,
        worst_v_row, not_independent, ill_conditioned);
    if (file.parent_path().filename() == "mechanisms") {
      EXPECT_EQ(ill_conditioned, 0);
    }
    // The six-bar is placed by Kennedy alone at every sample: a fully independent check.
    if (file.filename() == "sixbar_slider_guide.toml") {
      EXPECT_EQ(not_independent, 0);
    }
  }
}

}  // namespace
}  // namespace crosslink
