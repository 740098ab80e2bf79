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

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "analytic/instant_centres.h"
#include "analytic/loader.h"
#include "analytic/sweep.h"

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
  const double omega2 = m.driver.law.speed;
  const double omega3 = omega2 / (1.0 - s);
  EXPECT_NEAR(channel(exact, "omega.coupler"), omega3, 1e-9 * std::abs(omega3));
  expect_all_velocities(m, exact);
}

}  // namespace
}  // namespace crosslink
