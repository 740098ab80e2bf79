// Definition loading and validation: every error class names the right line.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"

namespace crosslink {
namespace {

TEST(Loader, LoadsSewingMachine) {
  const Mechanism m = load_mechanism("mechanisms/sewing_machine.toml");
  EXPECT_EQ(m.links.size(), 6u);
  EXPECT_EQ(mobility(m).mobility, 1);
  EXPECT_DOUBLE_EQ(m.units.length, 0.01);
}

// Issue 13: every bundled definition cites what a user can look up (a book, a course, a paper,
// or that the dimensions were chosen here), never a path of the folders crosslink was written in.
TEST(Loader, BundledCitationsNameDocumentsNotPaths) {
  int files = 0;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(
           std::filesystem::path(CROSSLINK_SOURCE_DIR) / "mechanisms")) {
    if (entry.path().extension() != ".toml") continue;
    const Mechanism m = load_mechanism(entry.path().string());
    ++files;
    EXPECT_FALSE(m.citation.empty()) << entry.path();
    for (const char* path : {"shared/", "seeds/", "reference/", ".txt", ".md"})
      EXPECT_EQ(m.citation.find(path), std::string::npos) << entry.path() << ": " << m.citation;
  }
  EXPECT_GT(files, 20);
}

// Issue 13: bundled definitions that give points in polar form, as their sources do, against
// the same files with those points as [x, y] worked out here, to full precision: the points agree
// to 1e-15 m and every channel of the solved poses to round-off.
struct PolarPointOf {
  std::string polar;  // as the bundled file writes it
  double x, y;        // the same point, file units
};

constexpr double kDeg = std::numbers::pi / 180.0;

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

void expect_polar_file_solves_as_cartesian(const std::string& path,
                                           const std::vector<PolarPointOf>& points,
                                           const std::vector<double>& driver_values_deg) {
  std::string cartesian = file_text(path);
  for (const PolarPointOf& p : points) {
    const size_t at = cartesian.find(p.polar);
    ASSERT_NE(at, std::string::npos) << path << " no longer writes " << p.polar;
    cartesian.replace(at, p.polar.size(), fmt::format("[{:.17g}, {:.17g}]", p.x, p.y));
  }
  const Mechanism polar = load_mechanism(path);
  const Mechanism exact = parse_mechanism(cartesian, path + " (cartesian)");
  ASSERT_EQ(polar.links.size(), exact.links.size());
  for (size_t l = 0; l < polar.links.size(); ++l) {
    ASSERT_EQ(polar.links[l].points.size(), exact.links[l].points.size());
    for (size_t k = 0; k < polar.links[l].points.size(); ++k) {
      const Point &a = polar.links[l].points[k], &b = exact.links[l].points[k];
      EXPECT_EQ(a.name, b.name);
      EXPECT_NEAR(a.local.x(), b.local.x(), 1e-15) << path << " " << a.name;
      EXPECT_NEAR(a.local.y(), b.local.y(), 1e-15) << path << " " << a.name;
    }
  }
  for (const double value : driver_values_deg) {
    const Trajectory a = solve_at(polar, value * kDeg), b = solve_at(exact, value * kDeg);
    ASSERT_EQ(a.status[0], PoseStatus::ok) << path << " at " << value;
    ASSERT_EQ(b.status[0], PoseStatus::ok) << path << " at " << value;
    for (const std::string& channel : a.channel_names()) {
      const double u = (*a.channel(channel))(0), v = (*b.channel(channel))(0);
      EXPECT_NEAR(u, v, 1e-11 * (1 + std::abs(v))) << path << " " << channel << " at " << value;
    }
  }
}

// The notes' table: G 3.23 mm from A at -89.40 deg, D 24.62 mm from C = (26.00, 0) at -21.59
// deg, F 22.47 mm from H at -5.33 deg, each from its link's x axis.
TEST(PolarPoints, PolycentricHingeSolvesAsItsCartesianPoints) {
  const auto on = [](double x0, double length, double deg) {
    return std::pair{x0 + length * std::cos(deg * kDeg), length * std::sin(deg * kDeg)};
  };
  const auto [gx, gy] = on(0.0, 3.23, -89.40);
  const auto [dx, dy] = on(26.00, 24.62, -21.59);
  const auto [fx, fy] = on(0.0, 22.47, -5.33);
  expect_polar_file_solves_as_cartesian(
      "mechanisms/polycentric_hinge.toml",
      {{R"({ from = "A", length = 3.23, angle = -89.40 })", gx, gy},
       {R"({ from = "C", length = 24.62, angle = -21.59 })", dx, dy},
       {R"({ from = "H", length = 22.47, angle = -5.33 })", fx, fy}},
      {-40, 0, 99.38, 180, 240});
}

// Coupler and bell-crank points at an angle from a line of their link (the link's x axis):
// 0.10 at 30 deg from BC is (0.05 sqrt(3), 0.05); 0.06 at 150 deg from DC is (-0.03 sqrt(3),
// 0.03).
TEST(PolarPoints, SixBarsSolveAsTheirCartesianPoints) {
  const double r3 = std::sqrt(3.0);
  expect_polar_file_solves_as_cartesian(
      "mechanisms/stephenson_sixbar.toml",
      {{R"({ from = "B", toward = "C", length = 0.10, angle = 30 })", 0.05 * r3, 0.05}},
      {0, 90, 180, 270});
  expect_polar_file_solves_as_cartesian(
      "mechanisms/watt_sixbar.toml",
      {{R"({ from = "D", toward = "C", length = 0.06, angle = 150 })", -0.03 * r3, 0.03}},
      {0, 90, 180, 270});
}

}  // namespace
}  // namespace crosslink
