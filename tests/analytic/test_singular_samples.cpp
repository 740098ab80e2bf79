// A sample on or beside a singular position is either the exact limit along the branch the sweep
// follows, or flagged: never a number from a singular solve marked ok (issue 24, item 1).
//
// Independent references:
//   - closed forms, differentiated exactly (a second-order Taylor jet in the driver), for a
//     parallelogram (theta4 = theta2, theta3 = 0: omega4 = omega2, alpha 0 at constant speed;
//     the driver torque is 0, the kinetic energy being constant), a kite (C the mirror image of
//     A in BD) and an in-line slider-crank driven from its slider (toggles at s = l +- r);
//   - for every bundled kinematic definition, the limit of samples approached from both sides of
//     each change point (a polynomial through well-conditioned samples on either side), and at
//     a toggle no finite rate at all (the rates grow as 1 / sqrt of the distance to it).
// Each is swept by every exact method (Newton's traced sweep, and the dyads where the chain
// decomposes) at output steps from 0.5 to 90 degrees, and from starts on and next to each
// singular position.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "analytic/kinematics/dyads.h"
#include "analytic/model/loader.h"
#include "analytic/reference/dyad_sweep.h"
#include "analytic/reference/sweep.h"
#include "tests/common/exact.h"
#include "tests/common/jet.h"
#include "tests/common/mechanisms.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;
// A sample marked ok agrees with the exact value to this fraction of its channel's scale: far
// above the solvers' round-off amplified by the Jacobian's condition a grid step from a singular
// position (about 1e-11 measured), far below a value from a singular solve (the parallelogram's
// omega of -4.19 rad/s for +6.28: O(1)).
constexpr double kRoundOff = 1e-9;

using test::Jet;  // a value and its derivatives with respect to the driver

struct Vec {
  Jet x, y;
};
Vec operator+(Vec a, Vec b) {
  return {a.x + b.x, a.y + b.y};
}
Vec operator-(Vec a, Vec b) {
  return {a.x - b.x, a.y - b.y};
}
Vec operator*(Jet k, Vec a) {
  return {k * a.x, k * a.y};
}
Jet dot(Vec a, Vec b) {
  return a.x * b.x + a.y * b.y;
}
Jet angle_of(Vec a) {
  return atan2(a.y, a.x);
}

// The pose (origin, angle) of every moving link at a driver value, on the branch followed.
struct LinkPose {
  std::string link;
  Vec origin;
  Jet angle;
};
using ClosedForm = std::function<std::vector<LinkPose>(Jet driver)>;

double length(const Mechanism& m, const char* link, const char* p, const char* q) {
  const Link& l = m.links[static_cast<size_t>(m.find_link(link))];
  return (l.points[static_cast<size_t>(l.find_point(p))].local -
          l.points[static_cast<size_t>(l.find_point(q))].local)
      .norm();
}
Vec ground_point(const Mechanism& m, const char* point) {
  const Link& g = m.links[static_cast<size_t>(m.ground())];
  const Eigen::Vector2d p = g.points[static_cast<size_t>(g.find_point(point))].local;
  return {Jet(p.x()), Jet(p.y())};
}
Vec polar(Jet r, Jet theta) {
  return {r * cos(theta), r * sin(theta)};
}

// Parallelogram branch: C = B + (D - A), so the rocker turns with the crank, the coupler stays.
ClosedForm parallelogram(const Mechanism& m) {
  const double a = length(m, "crank", "A", "B");
  const Vec A = ground_point(m, "A"), D = ground_point(m, "D");
  return [=](Jet theta) {
    const Vec B = A + polar(a, theta);
    return std::vector<LinkPose>{{"crank", A, theta}, {"coupler", B, Jet(0)}, {"rocker", D, theta}};
  };
}

// Kite branch: C is the mirror image of A in the line BD.
ClosedForm kite(const Mechanism& m) {
  const double a = length(m, "crank", "A", "B");
  const Vec A = ground_point(m, "A"), D = ground_point(m, "D");
  return [=](Jet theta) {
    const Vec B = A + polar(a, theta);
    const Vec bd = D - B;
    const Vec u = (Jet(1) / sqrt(dot(bd, bd))) * bd;
    const Vec foot = B + dot(A - B, u) * u;
    const Vec C = Jet(2) * foot - A;
    return std::vector<LinkPose>{
        {"crank", A, theta}, {"coupler", B, angle_of(C - B)}, {"rocker", D, angle_of(C - D)}};
  };
}

// In-line slider-crank driven by s, B above the line: cos(theta2) = (s^2 + r^2 - l^2) / (2 s r).
ClosedForm slider_crank(const Mechanism& m) {
  const double r = length(m, "crank", "A", "B"), l = length(m, "rod", "B", "C");
  const Vec A = ground_point(m, "A");
  return [=](Jet s) {
    const Jet theta = acos((s * s + Jet(r * r - l * l)) / (Jet(2 * r) * s));
    const Vec B = A + polar(r, theta);
    const Vec C = A + Vec{s, Jet(0)};
    return std::vector<LinkPose>{
        {"crank", A, theta}, {"rod", B, angle_of(C - B)}, {"slider", C, Jet(0)}};
  };
}

// The definition drawn at `start` by the closed form (poses to full precision).
Mechanism drawn_at(Mechanism m, const ClosedForm& exact, double start) {
  m.drivers[0].start = start;
  for (const LinkPose& p : exact(Jet(start))) {
    Link& link = m.links[static_cast<size_t>(m.find_link(p.link))];
    link.pose = Eigen::Vector3d(p.origin.x.v, p.origin.y.v, p.angle.v);
  }
  return m;
}

// The exact value of every kinematic channel at a driver value, at constant speed `rate`.
std::map<std::string, double> exact_channels(const Mechanism& m, const ClosedForm& exact,
                                             double driver, double rate) {
  std::map<std::string, double> out;
  const Jet at(driver, 1.0, 0.0);
  for (const LinkPose& p : exact(at)) {
    out["angle." + p.link] = p.angle.v;
    out["omega." + p.link] = p.angle.d * rate;
    out["alpha." + p.link] = p.angle.dd * rate * rate;
    const Link& link = m.links[static_cast<size_t>(m.find_link(p.link))];
    for (const Point& point : link.points) {
      const Vec w =
          p.origin + Vec{cos(p.angle) * Jet(point.local.x()) - sin(p.angle) * Jet(point.local.y()),
                         sin(p.angle) * Jet(point.local.x()) + cos(p.angle) * Jet(point.local.y())};
      out["x." + point.name] = w.x.v;
      out["y." + point.name] = w.y.v;
      out["vx." + point.name] = w.x.d * rate;
      out["vy." + point.name] = w.y.d * rate;
      out["ax." + point.name] = w.x.dd * rate * rate;
      out["ay." + point.name] = w.y.dd * rate * rate;
    }
  }
  return out;
}

// Every sample marked ok against the closed form; returns how many ok samples were checked.
// `torque_scale` > 0: the driver torque is 0 exactly (constant kinetic energy), to that scale.
int expect_ok_samples_exact(const Mechanism& m, const ClosedForm& exact, const Trajectory& t,
                            const std::string& what, double torque_scale = 0.0) {
  const double rate = m.drivers[0].law.speed;
  const double size = m.size();
  const double unit = m.drivers[0].angular() ? 1.0 : size;
  // Scales: the size, 1 rad, and the rates at unit driver rate times the speed (its square).
  std::map<Quantity, double> scale{{Quantity::position, size},
                                   {Quantity::angle, 1.0},
                                   {Quantity::velocity, std::abs(rate) / unit * size},
                                   {Quantity::acceleration, rate * rate / (unit * unit) * size}};
  int checked = 0;
  for (int k = 0; k < t.samples(); ++k) {
    if (t.status[static_cast<size_t>(k)] != PoseStatus::ok) continue;
    ++checked;
    const std::map<std::string, double> expected = exact_channels(m, exact, t.along(k), rate);
    for (const auto& [name, value] : expected) {
      const std::optional<Eigen::VectorXd> column = t.channel(name);
      if (!column) {
        ADD_FAILURE() << "no channel " << name;
        continue;
      }
      const std::string kind = name.substr(0, name.find('.'));
      double s = scale.at(Trajectory::quantity_of(name));
      if (kind == "omega") s = std::abs(rate) / unit;
      if (kind == "alpha") s = rate * rate / (unit * unit);
      double error = (*column)(k)-value;
      if (kind == "angle") error = std::remainder(error, 2 * kPi);
      // A non-finite exact value (a rate at a toggle) makes any number marked ok wrong.
      EXPECT_TRUE(std::abs(error) <= kRoundOff * s)
          << what << ": " << name << " at driver " << fmt::format("{:.17g}", t.along(k))
          << " is ok with " << (*column)(k) << ", exact " << value;
    }
    if (torque_scale > 0 && t.has_forces) {
      EXPECT_LE(std::abs(t.effort(k, 0)), kRoundOff * torque_scale)
          << what << ": torque.driver at driver " << fmt::format("{:.17g}", t.along(k));
    }
  }
  return checked;
}

// The output steps of the requirement: 0.5 to 90 degrees.
const std::vector<double> kStepsDeg = {0.5, 1, 2, 3, 5, 7, 10, 15, 20, 30, 45, 60, 90};

struct Fixture {
  const char* file;
  ClosedForm (*closed_form)(const Mechanism&);
  std::vector<double> singular;  // the singular driver values (change points or toggles)
};

// Starts on each singular position, within round-off of it, next to it and away from it.
std::vector<double> starts_around(const std::vector<double>& singular, double unit) {
  std::vector<double> starts;
  for (const double p : singular)
    for (const double beside : {0.0, 1e-15, -1e-15, 1e-10, -1e-10, 1e-7, -1e-7, 1e-4, -1e-4})
      starts.push_back(p + beside * unit);
  return starts;
}

double torque_scale(const Mechanism& m) {
  // Inertial forces at the size times the size: sum of m (size omega^2) size + I omega^2.
  const double w = m.drivers[0].law.speed / (m.drivers[0].angular() ? 1.0 : m.size());
  double s = 0;
  for (const Link& l : m.links)
    if (!l.ground) s += (l.mass.mass * m.size() * m.size() + l.mass.inertia) * w * w;
  return s;
}

// One fixture: its drawn start at every step, and starts around its singular positions at a
// few steps (all of them under `slow`).
void sweep_fixture(const Fixture& f, const std::vector<double>& steps, bool all_starts) {
  const Mechanism drawn = load_mechanism(f.file);
  const ClosedForm exact = f.closed_form(drawn);
  const double unit = drawn.drivers[0].angular() ? kDeg : drawn.units.length;
  const double torque =
      std::string(f.file).find("parallelogram") != std::string::npos ? torque_scale(drawn) : 0.0;
  std::vector<double> starts = {drawn.drivers[0].start};
  const std::vector<double> around = starts_around(f.singular, unit);
  starts.insert(starts.end(), around.begin(), around.end());
  for (const double start : starts) {
    Mechanism m = drawn_at(drawn, exact, start);
    const bool drawn_start = start == drawn.drivers[0].start;
    for (const double step : steps) {
      if (!drawn_start && !all_starts && step != 1.0 && step != 45.0) continue;
      std::map<std::string, Trajectory> methods;
      try {
        methods = test::exact_sweeps(m, step * unit);
      } catch (const DefinitionError&) {
        continue;  // a start the sweep refuses (drawn at a change point) has no sample to check
      }
      for (const auto& [method, t] : methods) {
        const std::string what =
            fmt::format("{} {} from {:.17g} at {:g} step", f.file, method, start / unit, step);
        const int checked = expect_ok_samples_exact(m, exact, t, what, torque);
        if (drawn_start) {
          EXPECT_GT(checked, 0) << what;
        }
      }
    }
  }
}

const Fixture kParallelogram{
    "tests/analytic/singular/parallelogram.toml", parallelogram, {0.0, 180 * kDeg, 360 * kDeg}};
const Fixture kKite{"tests/analytic/singular/kite.toml", kite, {0.0, 180 * kDeg, 360 * kDeg}};
const Fixture kSliderCrank{
    "tests/analytic/singular/slider_crank_from_slider.toml", slider_crank, {40e-3, 80e-3}};

// The case: the parallelogram drawn at 45 deg, a 1-degree sweep landing on the change
// point at 360 deg.
TEST(SingularSamples, ParallelogramFrom45DegreesLandingOnTheChangePoint) {
  const Mechanism m = load_mechanism(kParallelogram.file);
  const ClosedForm exact = parallelogram(m);
  for (const auto& [method, t] : test::exact_sweeps(m, kDeg)) {
    bool landed = false;
    for (int k = 0; k < t.samples(); ++k) landed |= std::abs(t.along(k) - 2 * kPi) < 1e-12;
    EXPECT_TRUE(landed) << method;
    EXPECT_GT(expect_ok_samples_exact(m, exact, t, method, torque_scale(m)), 300) << method;
  }
}

TEST(SingularSamples, ParallelogramEveryStepAndStart) {
  sweep_fixture(kParallelogram, {1, 45}, false);
}
TEST(SingularSamples, KiteEveryStepAndStart) {
  sweep_fixture(kKite, {1, 45}, false);
}
// Slider steps in mm (0.5 to 20 mm: the stroke ends 40 and 80 mm lie on every grid from 60 mm).
TEST(SingularSamples, SliderCrankStrokeEndsOnTheGrid) {
  sweep_fixture(kSliderCrank, {0.5, 1, 2, 5, 10, 20}, false);
}

#if CROSSLINK_SLOW_TESTS
TEST(SingularSamplesSlow, ParallelogramEveryStepAndStart) {
  sweep_fixture(kParallelogram, kStepsDeg, true);
}
TEST(SingularSamplesSlow, KiteEveryStepAndStart) {
  sweep_fixture(kKite, kStepsDeg, true);
}
TEST(SingularSamplesSlow, SliderCrankStrokeEndsOnTheGrid) {
  sweep_fixture(kSliderCrank, {0.5, 1, 2, 4, 5, 10, 20, 40}, true);
}
#endif

// An explicit `range` is swept by driver-parametrised continuation, not the traced curve: the
// same rule at its samples, at ranges ending on a change point and beside it. (Across one, the
// continuation does not keep to the smooth branch: docs/singular-positions.md, not covered.)
TEST(SingularSamples, RangesEndingOnAndBesideChangePoints) {
  for (const Fixture* f : {&kParallelogram, &kKite}) {
    const Mechanism drawn = load_mechanism(f->file);
    const ClosedForm exact = f->closed_form(drawn);
    for (const double end : {180.0, 180 + 1e-7, 180 - 1e-7, 180 + 1e-10, 180 - 1e-10, 179.75})
      for (const double step : {0.25, 1.0, 7.0}) {
        Mechanism m = drawn;
        m.drivers[0].range = std::make_pair(m.drivers[0].start, end * kDeg);
        for (const auto& [method, t] : test::exact_sweeps(m, step * kDeg)) {
          const std::string what =
              fmt::format("{} {} over a range to {:.12g} deg at {:g}", f->file, method, end, step);
          EXPECT_GT(expect_ok_samples_exact(m, exact, t, what), 0) << what;
        }
      }
  }
}

// Every bundled kinematic definition (mechanisms/, published/, singular/) that the dyads solve:
// grids landing on each singular position of its first pass, and 1e-7 and 1e-10 of the driver
// beside it, at steps from about 0.5 to 90 degrees. The second exact method is the independent
// reference: every sample both mark ok agrees to round-off of its channel's scale, and neither
// marks ok a sample the other cannot solve well. Returns how many samples were compared.
int compare_methods_around_singular_positions(const std::string& file, bool all_steps) {
  const Mechanism m = load_mechanism(file);
  if (!decompose(m).complete || m.drivers[0].law.kind != MotionLaw::Kind::constant_speed) return 0;
  std::vector<SingularPosition> singular;
  sweep(m, {}, singular);
  const double unit = m.drivers[0].angular() ? 1.0 : m.size();
  const double reach = m.drivers[0].angular() ? 2 * kPi : 1e9;
  const double rate = std::abs(m.drivers[0].law.speed) / unit;
  const std::map<Quantity, double> scale{{Quantity::position, m.size()},
                                         {Quantity::angle, 1.0},
                                         {Quantity::velocity, rate * m.size()},
                                         {Quantity::acceleration, rate * rate * m.size()}};
  int compared = 0;
  for (const SingularPosition& p : singular) {
    const double gap = p.driver - m.drivers[0].start;
    if (p.kind == SingularKind::branch_jump || std::abs(gap) < 1e-3 * unit || std::abs(gap) > reach)
      continue;
    const double coarse = std::max(1.0, std::ceil(std::abs(gap) / (90 * kDeg * unit)));
    const double fine = std::ceil(std::abs(gap) / (0.5 * kDeg * unit));
    std::vector<double> divisions = {coarse, std::ceil(std::abs(gap) / (7 * kDeg * unit))};
    if (all_steps) divisions.push_back(fine);
    for (const double n : divisions)
      for (const double beside : {0.0, 1e-7, -1e-7, 1e-10, -1e-10}) {
        const double step = std::abs(gap + beside * unit) / n;
        const std::map<std::string, Trajectory> t = test::exact_sweeps(m, step);
        const Trajectory& newton = t.at("newton");
        const Trajectory& dyads = t.at("dyads");
        for (int k = 0; k < newton.samples(); ++k) {
          const PoseStatus a = newton.status[static_cast<size_t>(k)];
          const PoseStatus b = dyads.status[static_cast<size_t>(k)];
          const std::string what = fmt::format("{}: step {:.17g} beside {:g}, driver {:.17g}", file,
                                               step, beside, newton.along(k));
          EXPECT_EQ(to_string(a), to_string(b)) << what;
          if (a != PoseStatus::ok || b != PoseStatus::ok) continue;
          ++compared;
          for (const std::string& name : newton.channel_names()) {
            const Quantity q = Trajectory::quantity_of(name);
            if (!scale.count(q)) continue;
            double error = (*newton.channel(name))(k) - (*dyads.channel(name))(k);
            if (q == Quantity::angle) error = std::remainder(error, 2 * kPi);
            // A link's rates are angular: rad/s and rad/s^2 at the driver's rate.
            const std::string kind = name.substr(0, name.find('.'));
            const double s = kind == "omega" ? rate : kind == "alpha" ? rate * rate : scale.at(q);
            EXPECT_LE(std::abs(error), kRoundOff * s) << what << ": " << name;
          }
        }
      }
  }
  return compared;
}

std::vector<std::string> kinematic_definitions() {
  std::vector<std::string> files = test::bundled_files(true, false);
  for (const auto& entry : std::filesystem::directory_iterator(
           std::filesystem::path(CROSSLINK_SOURCE_DIR) / "mechanisms" / "published"))
    if (entry.path().extension() == ".toml" && !test::is_dynamics_case(entry.path()))
      files.push_back(entry.path().string());
  return files;
}

TEST(SingularSamples, BundledDefinitionsTwoMethodsAgreeBesideSingularPositions) {
  int files = 0;
  for (const std::string& file : kinematic_definitions())
    if (compare_methods_around_singular_positions(file, false) > 0) ++files;
  EXPECT_GE(files, 3);  // the change-point four-bars and the non-Grashof four-bar at least
}

// Item 6: every exact method names the same events at the same driver values. The change-point
// crank-rocker's change point is at 180 deg (a + d = b + c: all pivots collinear with the crank
// along AD's reverse), which the dyads used to tell at 181 deg (the end of their substep); the
// non-Grashof four-bar's toggles at +-acos((a^2 + d^2 - (b + c)^2) / (2 a d)).
TEST(SingularEvents, EveryMethodNamesTheSameEventsAtTheSameValues) {
  for (const std::string& file : kinematic_definitions()) {
    const Mechanism m = load_mechanism(file);
    if (!decompose(m).complete || m.drivers[0].law.kind != MotionLaw::Kind::constant_speed)
      continue;
    for (const double step : {1.0, 7.0}) {
      SweepOptions options;
      options.step = step * kDeg * (m.drivers[0].angular() ? 1.0 : m.size());
      std::vector<SingularPosition> located;
      const Trajectory newton = sweep(m, options, located);
      const Trajectory dyads = dyad_sweep(m, newton, true);
      std::vector<double> singular_events;
      for (const Trajectory::Event& e : dyads.events)
        if (e.kind == PoseStatus::singular) singular_events.push_back(e.driver);
      // Every located position is an event of the dyads at its value, and no other.
      for (const SingularPosition& p : located) {
        if (p.kind == SingularKind::branch_jump) continue;
        EXPECT_TRUE(std::any_of(singular_events.begin(), singular_events.end(),
                                [&](double d) { return std::abs(d - p.driver) < 1e-12; }))
            << file << ": " << to_string(p.kind) << " at " << p.driver << " step " << step;
      }
      for (const double d : singular_events)
        EXPECT_TRUE(
            std::any_of(
                located.begin(), located.end(),
                [&](const SingularPosition& p) { return std::abs(d - p.driver) < 1e-12; }) ||
            std::any_of(newton.events.begin(), newton.events.end(),
                        [&](const Trajectory::Event& e) { return std::abs(d - e.driver) < 1e-12; }))
            << file << ": a dyad event at " << d << " that the reference does not name";
      // No sample of one method is cannot_assemble where the other solved it.
      for (int k = 0; k < newton.samples(); ++k)
        EXPECT_EQ(has_position(newton.status[static_cast<size_t>(k)]),
                  has_position(dyads.status[static_cast<size_t>(k)]))
            << file << " at " << newton.along(k);
    }
  }
  const Mechanism m = load_mechanism("mechanisms/singular/fourbar_change_point_crank_rocker.toml");
  const Trajectory dyads = dyad_sweep(m, SweepOptions{});
  int at_180 = 0;
  for (const Trajectory::Event& e : dyads.events) {
    EXPECT_NEAR(e.driver, kPi, 1e-9) << e.message;
    at_180 += std::abs(e.driver - kPi) < 1e-9;
  }
  EXPECT_EQ(at_180, 1);
}

#if CROSSLINK_SLOW_TESTS
TEST(SingularSamplesSlow, BundledDefinitionsTwoMethodsAgreeBesideSingularPositions) {
  for (const std::string& file : kinematic_definitions())
    compare_methods_around_singular_positions(file, true);
}
#endif

}  // namespace
}  // namespace crosslink
