// What several test suites take from the bundled definitions: the files, and a loaded variant.
#pragma once

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "analytic/model/mechanism.h"

namespace crosslink::test {

// The text of a file of the source tree (`relative` to its root).
inline std::string source_text(const std::string& relative) {
  std::ifstream in(std::filesystem::path(CROSSLINK_SOURCE_DIR) / relative);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// A [dynamics] case is the exact simulation's (analytic/physics/dynamics.h), not a kinematic
// sweep's.
inline bool is_dynamics_case(const std::filesystem::path& file) {
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);)
    if (line.rfind("[dynamics]", 0) == 0) return true;
  return false;
}

// mechanisms/*.toml, and mechanisms/singular/*.toml with `singular`, sorted; with `dynamics`
// the dynamics cases too.
inline std::vector<std::string> bundled_files(bool singular, bool dynamics = true) {
  std::vector<std::string> files;
  const std::filesystem::path root = std::filesystem::path(CROSSLINK_SOURCE_DIR) / "mechanisms";
  std::vector<std::filesystem::path> dirs = {root};
  if (singular) dirs.push_back(root / "singular");
  for (const auto& dir : dirs)
    for (const auto& entry : std::filesystem::directory_iterator(dir))
      if (entry.path().extension() == ".toml" && (dynamics || !is_dynamics_case(entry.path())))
        files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

// mechanisms/<folder>/*.toml, sorted.
inline std::vector<std::string> files_in(const std::string& folder) {
  std::vector<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(
           std::filesystem::path(CROSSLINK_SOURCE_DIR) / "mechanisms" / folder))
    if (entry.path().extension() == ".toml") files.push_back(entry.path().string());
  std::sort(files.begin(), files.end());
  return files;
}
// mechanisms/gears/: gear pairs and racks.
inline std::vector<std::string> gear_files() {
  return files_in("gears");
}
// Whether a definition has several [[driver]]s.
inline bool several_drivers(const std::filesystem::path& file) {
  std::ifstream in(file);
  int drivers = 0;
  for (std::string line; std::getline(in, line);)
    if (line.rfind("[[driver]]", 0) == 0) ++drivers;
  return drivers > 1;
}
// mechanisms/friction/: joint friction.
inline std::vector<std::string> friction_files() {
  return files_in("friction");
}

// The bundled kinematic definitions' stems (mechanisms/*.toml without the dynamics cases).
inline std::vector<std::string> bundled_stems() {
  std::vector<std::string> stems;
  for (const std::string& f : bundled_files(false, false))
    stems.push_back(std::filesystem::path(f).stem().string());
  return stems;
}

// The same mechanism under gravity, with a spring and damper from a ground point to a point of
// the last moving link, a force at a point of the first moving link that is not the driven one
// (or of the driven one) and a torque on the last moving link.
inline Mechanism loaded(Mechanism m) {
  m.gravity = Eigen::Vector2d(0.0, -9.81);
  const int ground = m.ground();
  const int last = static_cast<int>(m.links.size()) - 1 == ground
                       ? static_cast<int>(m.links.size()) - 2
                       : static_cast<int>(m.links.size()) - 1;
  int first = 0;
  while (first == ground || (first == m.drivers[0].link && m.moving_count() > 1)) ++first;
  Spring s;
  s.link_a = ground;
  s.link_b = last;
  s.local_a = m.links[static_cast<size_t>(ground)].points.front().local;
  s.local_b = m.links[static_cast<size_t>(last)].points.back().local;
  s.stiffness = 50.0;
  s.free_length = 0.5 * m.size();
  s.damping = 0.7;
  m.springs.push_back(s);
  Load force;
  force.link = first;
  force.local = m.links[static_cast<size_t>(first)].points.back().local;
  force.rows.emplace_back(0.0, 3.0, -2.0);
  m.loads.push_back(force);
  Load torque;
  torque.kind = Load::Kind::torque;
  torque.link = last;
  torque.rows.emplace_back(0.0, 0.4, 0.0);
  m.loads.push_back(torque);
  return m;
}

}  // namespace crosslink::test
