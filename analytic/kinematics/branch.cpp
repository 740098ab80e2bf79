#include "analytic/kinematics/branch.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <bit>

#include "analytic/kinematics/dyads.h"
#include "analytic/model/loader.h"
#include "analytic/model/planar.h"

namespace crosslink {
namespace {

Eigen::Vector2d world(const Mechanism& m, const std::pair<int, int>& point,
                      const Eigen::VectorXd& q) {
  const auto [link, index] = point;
  const BodyMotion b = BodyMotion::of(m.moving_index(link), q, nullptr, nullptr);
  return b.r + Eigen::Rotation2Dd(b.theta) *
                   m.links[static_cast<size_t>(link)].points[static_cast<size_t>(index)].local;
}

double turn(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return perp(b - a).dot(c - a);
}

bool all_hold(const Mechanism& m, const Eigen::VectorXd& q) {
  return std::all_of(m.branches.begin(), m.branches.end(),
                     [&](const BranchChoice& b) { return holds(m, b, q); });
}

[[noreturn]] void refuse(const BranchChoice& at, std::string message) {
  throw DefinitionError({Diagnostic{at.where, std::move(message)}});
}

// The revolute dyad's triangle: its first link's outer pin, the inner joint, the second's pin.
std::optional<BranchChoice> triangle_of(const Mechanism& m, const AssurGroup& g) {
  if (g.kind != AssurGroup::Kind::dyad || g.pin[0] < 0 || g.pin[1] < 0 ||
      m.joints[static_cast<size_t>(g.inner)].type != JointType::revolute)
    return std::nullopt;
  const Joint& inner = m.joints[static_cast<size_t>(g.inner)];
  BranchChoice b;
  const auto add = [&](int link, int point) {
    b.points.emplace_back(link, point);
    b.names.push_back(m.links[static_cast<size_t>(link)].points[static_cast<size_t>(point)].name);
  };
  add(g.link[0], g.ties[0][static_cast<size_t>(g.pin[0])].on_link);
  add(inner.link_a, inner.point_a);
  add(g.link[1], g.ties[1][static_cast<size_t>(g.pin[1])].on_link);
  return b;
}

}  // namespace

bool holds(const Mechanism& m, const BranchChoice& b, const Eigen::VectorXd& q) {
  return (turn(world(m, b.points[0], q), world(m, b.points[1], q), world(m, b.points[2], q)) >
          0.0) == b.counter_clockwise;
}

void apply_branches(Mechanism& m) {
  const bool drawn = m.drawn();
  if (drawn && m.branches.empty()) return;
  const NewtonSolver newton(m);
  KinematicState state(m);
  const bool assembled = has_position(newton.assemble(state).status);
  if (assembled && all_hold(m, state.q)) return;
  // Newton's assembly lacks a named mode, or there is none (nothing drawn to start from).
  const auto unmet = std::find_if(m.branches.begin(), m.branches.end(), [&](const auto& b) {
    return !assembled || !holds(m, b, state.q);
  });
  if (assembled && drawn)
    refuse(*unmet,
           fmt::format(
               "the drawn poses assemble with {}: the [[branch]] asks for the "
               "other mode; remove one of them",
               BranchChoice{unmet->names, unmet->points, !unmet->counter_clockwise, {}}.text()));
  const Decomposition d = decompose(m);
  if (!d.complete) {
    if (!assembled) return;  // the usual "cannot assemble" reports
    refuse(*unmet, fmt::format("[[branch]] needs a chain of dyads ({}); draw the links' poses "
                               "near the assembly wanted instead",
                               d.reason));
  }
  // The dyads close the chain from the driver outward without a starting guess: every
  // combination of their modes, the fewest changed from the first one first.
  const DyadSolver solver(m, d);
  DyadState dyads(m);
  solver.set_modes(state, dyads);
  const std::vector<int> first = dyads.assembly_mode;
  std::vector<size_t> two;  // the groups with two solutions
  for (size_t g = 0; g < d.groups.size(); ++g)
    if (d.groups[g].two_solutions) two.push_back(g);
  // Bounded work: the first kFlippable of them (4096 combinations); the others keep their first
  // mode.
  constexpr size_t kFlippable = 12;
  if (two.size() > kFlippable) two.resize(kFlippable);
  std::vector<unsigned> flips;
  for (unsigned f = 0; f < (1u << two.size()); ++f) flips.push_back(f);
  std::stable_sort(flips.begin(), flips.end(),
                   [](unsigned a, unsigned b) { return std::popcount(a) < std::popcount(b); });
  bool any = false;
  for (const unsigned f : flips) {
    solver.set_modes(state, dyads);
    for (size_t k = 0; k < two.size(); ++k)
      if (f >> k & 1u) dyads.assembly_mode[two[k]] = -first[two[k]];
    if (!has_position(solver.solve_position(dyads).status)) continue;
    any = true;
    if (!all_hold(m, dyads.kinematics.q)) continue;
    for (size_t l = 0; l < m.links.size(); ++l) {
      const int k = m.moving_index(static_cast<int>(l));
      if (k >= 0) m.links[l].pose = dyads.kinematics.q.segment<3>(3 * k);
    }
    // The default mass model scales with the drawn size.
    const double size = m.size();
    for (Link& link : m.links)
      if (link.mass.assumed) link.mass = default_mass_properties(link, size);
    return;
  }
  if (!any) return;  // the usual "cannot assemble" reports
  std::string asked;
  for (const BranchChoice& b : m.branches) asked += (asked.empty() ? "" : "; ") + b.text();
  refuse(*unmet, fmt::format("no assembly at the driver's start value has all of: {}", asked));
}

std::vector<GroupMode> start_modes(const Mechanism& m, const KinematicState& assembled) {
  const Decomposition d = decompose(m);
  if (!d.complete) return {};
  const DyadSolver solver(m, d);
  DyadState dyads(m);
  std::vector<GroupMode> out;
  for (size_t g = 0; g < d.groups.size(); ++g) {
    if (!d.groups[g].two_solutions) continue;
    solver.set_modes(assembled, dyads);
    const int mode = dyads.assembly_mode[g];
    GroupMode gm;
    gm.group = d.groups[g].name;
    gm.mode = solver.describe_mode(static_cast<int>(g), mode);
    if (std::optional<BranchChoice> t = triangle_of(m, d.groups[g])) {
      t->counter_clockwise = holds(m, *t, assembled.q);  // as made, true: ccw when it holds
      gm.mode = t->text();
      t->counter_clockwise = !t->counter_clockwise;
      gm.other = t;
    }
    dyads.assembly_mode[g] = -mode;
    gm.other_closes = solver.solve_position(dyads).status == PoseStatus::ok;
    out.push_back(gm);
  }
  return out;
}

// The loader reads; this step assembles (analytic/model/loader.h).
Mechanism load_mechanism(const std::string& path) {
  Mechanism m = read_definition(path);
  apply_branches(m);
  return m;
}

Mechanism parse_mechanism(std::string_view text, const std::string& file) {
  Mechanism m = parse_definition(text, file);
  apply_branches(m);
  return m;
}

}  // namespace crosslink
