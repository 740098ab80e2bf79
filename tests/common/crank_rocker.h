// The crank-rocker four-bar that tests and benchmarks write as text (mechanisms/
// fourbar_crank_rocker.toml without its masses): crank AB a = 0.04, coupler BC b = 0.12, rocker
// DC c = 0.08, ground AD d = 0.10 m (Grashof: a + b <= c + d), A at the origin, D on +x, drawn on
// the open assembly (C above AD). In parts, so that a test can leave one out or swap it.
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <string>

namespace crosslink::test {

struct CrankRockerText {
  std::string header, ground, moving, joints, driver;
  std::string text() const { return header + ground + moving + joints + driver; }
};

// Drawn at crank angle `crank_deg`, the coupler's and rocker's poses from the closed form (C on
// the circles about B and D, to 1e-2 degree: the loader assembles from them); `law` is the
// [driver] table's lines after its start (speed, range, ...).
inline CrankRockerText crank_rocker(
    double crank_deg = 60.0, const std::string& law = "speed = 10\nspeed_unit = \"rad/s\"\n") {
  constexpr double a = 0.04, b = 0.12, c = 0.08, d = 0.10, deg = std::numbers::pi / 180.0;
  const double bx = a * std::cos(crank_deg * deg), by = a * std::sin(crank_deg * deg);
  const double f = std::hypot(d - bx, by);
  const double coupler = std::atan2(-by, d - bx) + std::acos((b * b + f * f - c * c) / (2 * b * f));
  const double cx = bx + b * std::cos(coupler), cy = by + b * std::sin(coupler);
  const double rocker = std::atan2(cy, cx - d);
  return {
      .header = "name = \"four-bar\"\n[units]\nlength = \"m\"\nangle = \"deg\"\n",
      .ground =
          "\n[[link]]\nname = \"ground\"\nground = true\npoints = { A = [0, 0], D = [0.10, 0] }\n",
      .moving =
          fmt::format("\n[[link]]\nname = \"crank\"\npoints = {{ A = [0, 0], B = [0.04, 0] }}\n"
                      "pose = [0, 0, {:g}]\n"
                      "\n[[link]]\nname = \"coupler\"\npoints = {{ B = [0, 0], C = [0.12, 0] }}\n"
                      "pose = [{:.6g}, {:.6g}, {:.2f}]\n"
                      "\n[[link]]\nname = \"rocker\"\npoints = {{ D = [0, 0], C = [0.08, 0] }}\n"
                      "pose = [0.10, 0, {:.2f}]\n",
                      crank_deg, bx, std::abs(by) < 1e-15 ? 0.0 : by, coupler / deg, rocker / deg),
      .joints =
          "\n[[joint]]\ntype = \"revolute\"\nlinks = [\"ground\", \"crank\"]\npoint = \"A\"\n"
          "\n[[joint]]\ntype = \"revolute\"\nlinks = [\"crank\", \"coupler\"]\npoint = \"B\"\n"
          "\n[[joint]]\ntype = \"revolute\"\nlinks = [\"coupler\", \"rocker\"]\npoint = \"C\"\n"
          "\n[[joint]]\ntype = \"revolute\"\nlinks = [\"ground\", \"rocker\"]\npoint = \"D\"\n",
      .driver = fmt::format(
          "\n[driver]\ntype = \"joint_angle\"\njoint = \"A\"\nto = \"B\"\nstart = {:g}\n{}",
          crank_deg, law)};
}

}  // namespace crosslink::test
