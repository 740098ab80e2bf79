// The edges, as a property over every bundled one-driver definition (issue 35): each swept with a
// `range` equal to its assembling range and to each limit from inside, and from starts 1e-9, 1e-7
// and 1e-5 degrees on either side of each singular position (drawn there: every link's pose taken
// from the regular sweep's curve), at the steps 0.7, 15 and 90 degrees (and 1, 5, 45 under
// `slow`), with Newton and the closed-form dyads. Every sample with a pose must lie on the drawn
// branch (the regular sweep's curve from the original drawing, which the closed forms hold in the
// middle of the range) to 1e-9 of the size and 1e-9 rad, and no sample may repeat or run
// backwards.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "analytic/kinematics/dyads.h"
#include "analytic/model/loader.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/sweep.h"
#include "tests/common/mechanisms.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// The drawn branch: the regular sweep of the original drawing at 0.1 degree (for a chain that
// turns fully, a second turn drawn where the first ends: a change point's smooth branch may take
// two turns to close), and a pose on it at any value by Newton from its nearest ok sample,
// stepping toward the value by halves (next to a fold the two assemblies are sqrt(distance)
// apart, so each step's Newton stays on the sample's assembly).
class Branch {
 public:
  explicit Branch(const Mechanism& m) : m_(m), solver_(m) {
    SweepOptions fine;
    fine.step = 0.1 * kDeg;
    curves_.push_back(sweep(m, fine));
    const Trajectory& first = curves_.front();
    const int last = first.samples() - 1;
    if (last > 0 && usable(first.status[static_cast<size_t>(last)]) &&
        std::abs(first.along(last) - first.along(0)) > 1.99 * kPi) {
      Mechanism on = m;
      on.drivers[0].start = first.along(last);
      const Eigen::VectorXd q = coordinates(first, last);
      for (size_t l = 0; l < on.links.size(); ++l)
        if (const int c = on.moving_index(static_cast<int>(l)); c >= 0)
          on.links[l].pose = q.segment<3>(3 * c);
      curves_.push_back(sweep(on, fine));
    }
  }

  // The pose on the branch at `value`, or nullopt where the curve has none near.
  std::optional<Eigen::VectorXd> at(double value) const {
    const Trajectory* curve = nullptr;
    int nearest = -1;
    for (const Trajectory& c : curves_)
      for (int k = 0; k < c.samples(); ++k)
        if (c.status[static_cast<size_t>(k)] == PoseStatus::ok &&
            (nearest < 0 ||
             std::abs(c.along(k) - value) < std::abs(curve->along(nearest) - value))) {
          curve = &c;
          nearest = k;
        }
    if (nearest < 0 || std::abs(curve->along(nearest) - value) > 1.5 * kDeg) return std::nullopt;
    KinematicState state(m_);
    state.q = coordinates(*curve, nearest);
    const double from = curve->along(nearest);
    SolveReport r;
    for (int i = 1; i <= 64; ++i) {
      state.swept().value = i == 64 ? value : from + (value - from) * (1.0 - std::ldexp(1.0, -i));
      r = solver_.solve_position(state);
      if (r.status != PoseStatus::ok && r.status != PoseStatus::singular) return std::nullopt;
    }
    r = solver_.polish(state, r);
    if (r.status != PoseStatus::ok && r.status != PoseStatus::singular) return std::nullopt;
    return state.q;
  }

  // A sample's coordinates: each moving link's angle and the position of its first point.
  Eigen::VectorXd coordinates(const Trajectory& t, int k) const {
    Eigen::VectorXd q = Eigen::VectorXd::Zero(m_.coordinate_count());
    for (size_t l = 0, i = 0; l < m_.links.size(); ++l) {
      const int c = m_.moving_index(static_cast<int>(l));
      if (c < 0) continue;
      const Point& p = m_.links[l].points.front();
      const auto named = std::find(t.point_names.begin(), t.point_names.end(), p.name);
      const auto column = static_cast<Eigen::Index>(named - t.point_names.begin());
      const double theta = t.angle(k, static_cast<Eigen::Index>(i++));
      const Eigen::Vector2d origin = Eigen::Vector2d(t.x(k, column), t.y(k, column)) -
                                     Eigen::Rotation2Dd(theta).toRotationMatrix() * p.local;
      q.segment<3>(3 * c) << origin.x(), origin.y(), theta;
    }
    return q;
  }

 private:
  const Mechanism& m_;
  NewtonSolver solver_;
  std::vector<Trajectory> curves_;
};

// Every sample with a pose on the branch; driver values strictly monotone, times increasing.
void expect_on_branch(const Mechanism& m, const Branch& branch, const Trajectory& t,
                      const std::string& what) {
  const double size = m.size();
  for (int k = 0; k < t.samples(); ++k) {
    if (k > 0) {
      EXPECT_NE(t.along(k), t.along(k - 1)) << what << ": sample " << k << " repeats";
      EXPECT_GT(t.time(k), t.time(k - 1)) << what << ": sample " << k << " runs backwards";
    }
    if (!usable(t.status[static_cast<size_t>(k)])) continue;
    const std::optional<Eigen::VectorXd> expected = branch.at(t.along(k));
    if (!expected) {
      ADD_FAILURE() << what << ": an ok sample at " << t.along(k) / kDeg
                    << " deg where the drawn branch has no pose";
      continue;
    }
    const Eigen::VectorXd q = branch.coordinates(t, k);
    for (Eigen::Index i = 0; i < q.size(); ++i) {
      const bool angle = i % 3 == 2;
      const double off =
          angle ? std::remainder(q(i) - (*expected)(i), 2 * kPi) : (q(i) - (*expected)(i)) / size;
      EXPECT_LE(std::abs(off), 1e-9)
          << what << ": sample " << k << " at " << t.along(k) / kDeg << " deg, coordinate " << i;
    }
  }
}

// One-driver, constant-speed, angular definitions.
std::vector<std::string> edge_files() {
  std::vector<std::string> out;
  for (const std::string& file : test::bundled_files(true, false)) {
    const Mechanism m =
        parse_mechanism(test::source_text(file.substr(file.find("mechanisms/"))), file);
    if (m.drivers.size() != 1 || !m.drivers[0].angular() || m.drivers[0].at_rest() ||
        m.drivers[0].law.kind != MotionLaw::Kind::constant_speed || m.dynamics)
      continue;
    out.push_back(file.substr(file.find("mechanisms/")));
  }
  return out;
}

class EdgeProperties : public testing::TestWithParam<std::string> {};

#if CROSSLINK_SLOW_TESTS
const std::vector<double> kSteps = {0.7, 1, 5, 15, 45, 90};
#else
const std::vector<double> kSteps = {0.7, 15, 90};
#endif

TEST_P(EdgeProperties, EveryRangeAtTheLimitsIsOnTheDrawnBranch) {
  const Mechanism m = parse_mechanism(test::source_text(GetParam()), GetParam());
  const Branch branch(m);
  const AssemblingRange range = assembling_range(m);
  const std::vector<double>& steps = kSteps;

  // Ranges at the limits: the assembling range, and each limit from inside.
  std::vector<std::pair<double, double>> ranges;
  if (range.unknown.empty() && !range.full_cycle) {
    const double inside = 0.5 * (range.lower + range.upper);
    ranges = {{range.lower, range.upper}, {inside, range.upper}, {range.lower, inside}};
  }
  for (const auto& [lo, hi] : ranges)
    for (const double step : steps) {
      Mechanism ranged = m;
      ranged.drivers[0].range = std::make_pair(lo, hi);
      SweepOptions options;
      options.step = step * kDeg;
      const Trajectory t = sweep(ranged, options);
      const std::string what =
          fmt::format("range [{:.6f}, {:.6f}] deg, step {}", lo / kDeg, hi / kDeg, step);
      expect_on_branch(m, branch, t, what);
      if (decompose(m).complete) {
        expect_on_branch(m, branch, dyad_sweep(ranged, t), what + " dyads");
      }
    }
}

// Starts beside each singular position, drawn on the branch there: each sweeps on the drawn
// branch, or is refused at the driver's line where round-off cannot place it (a start within
// working precision of a change point, or beyond a toggle by less than the solver's tolerance).
void expect_starts_on_branch(const std::string& file) {
  const Mechanism m = parse_mechanism(test::source_text(file), file);
  const Branch branch(m);
  std::vector<SingularPosition> singular;
  sweep(m, {}, singular);
  const AssemblingRange range = assembling_range(m);
  const std::vector<double>& steps = kSteps;
  for (const SingularPosition& p : singular) {
    if (p.kind == SingularKind::branch_jump) continue;
    for (const double offset : {-1e-5, -1e-7, -1e-9, 1e-9, 1e-7, 1e-5}) {
      const double start = p.driver + offset * kDeg;
      const std::optional<Eigen::VectorXd> q = branch.at(start);
      if (!q) continue;  // beyond a limit: no pose to draw
      Mechanism drawn = m;
      drawn.drivers[0].start = start;
      for (size_t l = 0; l < drawn.links.size(); ++l)
        if (const int c = drawn.moving_index(static_cast<int>(l)); c >= 0)
          drawn.links[l].pose = q->segment<3>(3 * c);
      for (const double step : steps) {
        SweepOptions options;
        options.step = step * kDeg;
        const std::string what = fmt::format("{} at {:.9f} deg {:+g} deg, step {}",
                                             to_string(p.kind), p.driver / kDeg, offset, step);
        try {
          const Trajectory t = sweep(drawn, options);
          expect_on_branch(m, branch, t, what);
          if (decompose(m).complete) {
            expect_on_branch(m, branch, dyad_sweep(drawn, t), what + " dyads");
          }
        } catch (const DefinitionError& e) {
          // Refused at the driver's line: drawn at a change point to working precision, or
          // beyond a toggle (outside the assembling range) by less than the solver's tolerance,
          // where no pose closes exactly.
          const bool beyond = !range.full_cycle && (start < range.lower || start > range.upper);
          EXPECT_TRUE(p.kind == SingularKind::change_point || beyond) << what << ": " << e.what();
        }
      }
    }
  }
}

class EdgeStarts : public testing::TestWithParam<std::string> {};
TEST_P(EdgeStarts, EveryStartBesideASingularPositionIsOnTheDrawnBranch) {
  expect_starts_on_branch(GetParam());
}

// The test's name from a definition's file name.
std::string file_stem(const testing::TestParamInfo<std::string>& info) {
  std::string name = info.param.substr(info.param.rfind('/') + 1);
  name = name.substr(0, name.find('.'));
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
}

INSTANTIATE_TEST_SUITE_P(Bundled, EdgeStarts, testing::ValuesIn(edge_files()), file_stem);

INSTANTIATE_TEST_SUITE_P(Bundled, EdgeProperties, testing::ValuesIn(edge_files()), file_stem);

}  // namespace
}  // namespace crosslink
