// [[derived]] quantities (analytic/derived/derived.h) against closed forms: an offset
// slider-crank's stroke and dead points, a Whitworth and a crank-shaper quick return's time ratio,
// a crank-rocker's extreme transmission angles, a Chebyshev linkage's straightness; every bundled
// [expect.derived]; values that do not exist; the definition's errors.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <numbers>
#include <tuple>

#include "analytic/derived/derived.h"
#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "tests/common/crank_rocker.h"
#include "tests/common/diagnostics.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kDeg = kPi / 180.0;

// The values of the quantities the definition declares (the design summary's aside: its tests
// are test_summary.cpp).
std::vector<DerivedValue> declared(std::vector<DerivedValue> values) {
  std::erase_if(values, [](const DerivedValue& v) { return v.spec->summary; });
  return values;
}
std::vector<DerivedValue> exact_of(const Mechanism& m, const Trajectory& t) {
  return declared(derived_exact(m, t));
}
std::vector<DerivedValue> sampled_of(const Mechanism& m, const Trajectory& t) {
  return declared(derived_sampled(m, t));
}

double field(const std::vector<DerivedValue>& values, std::string_view quantity) {
  const std::optional<double> v = derived_value(values, quantity);
  EXPECT_TRUE(v.has_value()) << quantity;
  return v.value_or(NAN);
}

// A driver value within [0, 2 pi).
double turn(double v) {
  return std::fmod(std::fmod(v, 2 * kPi) + 2 * kPi, 2 * kPi);
}

// Offset slider-crank (mechanisms/slider_crank_offset.toml: crank r = 0.04, rod l = 0.12,
// offset e = 0.01 m): stroke sqrt((l+r)^2-e^2) - sqrt((l-r)^2-e^2); the dead points where crank
// and rod are collinear, extended at asin(e/(l+r)) and folded at pi + asin(e/(l-r)).
TEST(Derived, OffsetSliderCrankStrokeAndDeadPointsAreTheClosedForms) {
  const std::string text = test::source_text("mechanisms/slider_crank_offset.toml") +
                           "\n[[derived]]\nname = \"S\"\nquantity = \"stroke\"\n"
                           "channel = \"s.slider\"\n"
                           "\n[[derived]]\nname = \"dead\"\nquantity = \"dead_points\"\n"
                           "channel = \"s.slider\"\n"
                           // An interval across the cycle's start, read modulo a turn.
                           "\n[[derived]]\nname = \"across\"\nquantity = \"stroke\"\n"
                           "channel = \"s.slider\"\nrange = [-100, 200]\n";
  const Mechanism m = parse_mechanism(text, "slider_crank_offset.toml");
  const Trajectory t = sweep(m);
  const std::vector<DerivedValue> v = exact_of(m, t);
  const double r = 0.04, l = 0.12, e = 0.01;
  const double far = std::sqrt((l + r) * (l + r) - e * e),
               near = std::sqrt((l - r) * (l - r) - e * e);
  EXPECT_NEAR(field(v, "S"), far - near, 1e-12);
  EXPECT_NEAR(field(v, "S.max"), far, 1e-12);
  EXPECT_NEAR(field(v, "S.min"), near, 1e-12);
  EXPECT_NEAR(turn(field(v, "S.at_max")), std::asin(e / (l + r)), 1e-9);
  EXPECT_NEAR(turn(field(v, "S.at_min")), kPi + std::asin(e / (l - r)), 1e-9);
  EXPECT_NEAR(turn(field(v, "dead")), kPi + std::asin(e / (l - r)), 1e-9);
  EXPECT_NEAR(turn(field(v, "dead.at_max")), std::asin(e / (l + r)), 1e-9);
  EXPECT_NEAR(field(v, "across"), far - near, 1e-12);
  EXPECT_NEAR(field(v, "across.at_max"), std::asin(e / (l + r)), 1e-9);
  EXPECT_NEAR(field(v, "across.at_min"), kPi + std::asin(e / (l - r)), 1e-9);

  // From the samples alone (1 degree): the parabola's vertex, its value off by O(h^3), its
  // driver value by O(h^2) of the channel's curvature.
  const std::vector<DerivedValue> s = sampled_of(m, t);
  EXPECT_NEAR(field(s, "S"), far - near, 1e-8);
  EXPECT_GT(std::abs(field(s, "S") - (far - near)), 1e-15);  // an estimate, not the exact value
  EXPECT_NEAR(turn(field(s, "S.at_max")), std::asin(e / (l + r)), 1e-3);
}

// Whitworth (mechanisms/published/whitworth_quick_return.toml, crank CA = 150, centres CD = 100
// mm, lever DP = 75): the return takes beta = 2 acos(CD/CA) of the crank's turn, the ratio is
// (2 pi - beta) / beta, the stroke 2 DP.
TEST(Derived, WhitworthTimeRatioAndStrokeAreTheClosedForms) {
  const Mechanism m = load_mechanism(std::string(CROSSLINK_SOURCE_DIR) +
                                     "/mechanisms/published/whitworth_quick_return.toml");
  const Trajectory t = sweep(m);
  const std::vector<DerivedValue> v = exact_of(m, t);
  const double beta = 2.0 * std::acos(100.0 / 150.0);
  EXPECT_NEAR(field(v, "Q"), (2 * kPi - beta) / beta, 1e-10);
  EXPECT_NEAR(field(v, "Q.increasing"), beta, 1e-10);  // the ram's return is the short arc
  EXPECT_NEAR(field(v, "ram_stroke"), 0.150, 1e-12);
  EXPECT_NEAR(turn(field(v, "ram_stroke.at_max")),
              std::atan2(100.0, -std::sqrt(150.0 * 150.0 - 1e4)), 1e-9);
  // The printed 2.735 is the exact ratio rounded (2.73524), though the source's own rounded
  // beta = 96.4 deg gives 2.7344.
  EXPECT_LT(std::abs(field(v, "Q") - 2.735), 0.0005);
}

// The crank-shaper of mechanisms/quick_return.toml: AB = 0.10, AC = 0.20, the rocker's extremes
// where the slot is tangent to the crank circle, sin(beta / 2) = AB / AC: 240 and 120 degrees.
TEST(Derived, CrankShaperTimeRatioIsTwo) {
  const std::string text = test::source_text("mechanisms/quick_return.toml") +
                           "\n[[derived]]\nname = \"Q\"\nquantity = \"time_ratio\"\n"
                           "channel = \"s.ram\"\n";
  const Mechanism m = parse_mechanism(text, "quick_return.toml");
  const std::vector<DerivedValue> v = exact_of(m, sweep(m));
  const double half = std::asin(0.10 / 0.20);
  EXPECT_NEAR(field(v, "Q"), (kPi + 2 * half) / (kPi - 2 * half), 1e-10);
}

// Crank-rocker a = 0.04, b = 0.12, c = 0.08, d = 0.10: cos mu = (b^2 + c^2 - a^2 - d^2 + 2 a d
// cos theta) / (2 b c), extreme at theta = 0 (least) and pi (most).
TEST(Derived, CrankRockerTransmissionExtremesAreTheClosedForm) {
  // Drawn at 60.37 degrees, so that no sample lies on an extreme (the parabola through three
  // samples is exact on a symmetric extreme at a sample).
  const std::string text = test::crank_rocker(60.37).text() +
                           "\n[[derived]]\nname = \"tr\"\nquantity = \"transmission\"\n";
  const Mechanism m = parse_mechanism(text, "four_bar.toml");
  const std::vector<DerivedValue> v = exact_of(m, sweep(m));
  const double a = 0.04, b = 0.12, c = 0.08, d = 0.10;
  auto mu = [&](double theta) {
    return std::acos((b * b + c * c - a * a - d * d + 2 * a * d * std::cos(theta)) / (2 * b * c));
  };
  EXPECT_NEAR(field(v, "tr"), mu(0.0), 1e-12);
  EXPECT_NEAR(field(v, "tr.max"), mu(kPi), 1e-12);
  // A flat extreme: located to sqrt(eps), on either side of the turn's start.
  EXPECT_NEAR(std::remainder(field(v, "tr.at_min"), 2 * kPi), 0.0, 1e-6);
  EXPECT_NEAR(field(v, "tr.at_max"), kPi, 1e-6);
}

// Chebyshev's straight-line linkage: ground AD = 2, cranks AB = DC = 2.5, coupler BC = 1, P its
// middle, crossed. Over AB from atan(3/4) (DC upright, P = (2, 2)) to 90 deg (AB upright,
// P = (0, 2)) the path is symmetric about x = 1, so the minimum-zone line is horizontal and the
// deviation is half the range of P's height, computed here from the closed-form position.
TEST(Derived, ChebyshevStraightnessIsTheClosedFormPathsFlatness) {
  const std::string text = R"toml(name = "Chebyshev"
[units]
length = "m"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { A = [0, 0], D = [2, 0] }
[[link]]
name = "crank"
points = { A = [0, 0], B = [2.5, 0] }
pose = [0, 0, 90]
[[link]]
name = "coupler"
points = { B = [0, 0], C = [1, 0], P = [0.5, 0] }
pose = [0, 2.5, -90]
[[link]]
name = "rocker"
points = { D = [0, 0], C = [2.5, 0] }
pose = [2, 0, 143.1301]
[[joint]]
type = "revolute"
links = ["ground", "crank"]
point = "A"
[[joint]]
type = "revolute"
links = ["crank", "coupler"]
point = "B"
[[joint]]
type = "revolute"
links = ["coupler", "rocker"]
point = "C"
[[joint]]
type = "revolute"
links = ["ground", "rocker"]
point = "D"
[driver]
type = "joint_angle"
joint = "A"
to = "B"
start = 90
speed = 1
[[derived]]
name = "flat"
quantity = "straightness"
point = "P"
range = ["atan(0.75)", 90]
)toml";
  const Mechanism m = parse_mechanism(text, "chebyshev.toml");
  const std::vector<DerivedValue> v = exact_of(m, sweep(m));
  // Closed form: C on the circles about B (1) and D (2.5), on the crossed branch.
  auto p = [](double theta) {
    const Eigen::Vector2d B(2.5 * std::cos(theta), 2.5 * std::sin(theta)), D(2.0, 0.0);
    const double dist = (D - B).norm(), along = (1.0 - 6.25 + dist * dist) / (2 * dist);
    const Eigen::Vector2d u = (D - B) / dist, normal(-u.y(), u.x());
    const Eigen::Vector2d C = B + along * u - std::sqrt(1.0 - along * along) * normal;
    return Eigen::Vector2d(0.5 * (B + C));
  };
  // Its extremes of height and of x over the interval: dense, then golden section.
  auto extreme = [&](int coordinate, double sign) {
    const double lo = std::atan(0.75), hi = kPi / 2;
    const int n = 20000;
    int best = 0;
    for (int k = 0; k <= n; ++k)
      if (sign * p(lo + (hi - lo) * k / n)(coordinate) >
          sign * p(lo + (hi - lo) * best / n)(coordinate))
        best = k;
    double a = lo + (hi - lo) * std::max(0, best - 1) / n,
           b = lo + (hi - lo) * std::min(n, best + 1) / n;
    for (int i = 0; i < 100; ++i) {
      const double c = a + (b - a) * 0.382, d = a + (b - a) * 0.618;
      if (sign * p(c)(coordinate) > sign * p(d)(coordinate))
        b = d;
      else
        a = c;
    }
    return p(0.5 * (a + b))(coordinate);
  };
  const double deviation = 0.5 * (extreme(1, 1.0) - extreme(1, -1.0));
  EXPECT_GT(deviation, 1e-4);  // not a straight line: a measurable deviation
  EXPECT_NEAR(field(v, "flat"), deviation, 1e-10);
  // P runs from (2, 2) to (0, 2): at the interval's ends (the lower one a toggle, DC and the
  // coupler in line), x monotone between.
  EXPECT_NEAR(p(std::atan(0.75)).x() - p(kPi / 2).x(), 2.0, 1e-12);
  EXPECT_NEAR(field(v, "flat.extent"), 2.0, 1e-10);
  EXPECT_NEAR(std::sin(field(v, "flat.direction")), 0.0, 1e-6);  // horizontal
}

// A point of the crank-rocker's rocker (C, and E off its line) moves on a circle about the
// ground pivot D = (0.10, 0): the minimum zone is that circle, its deviation round-off. The
// rocker swings between the crank's two collinear positions with the coupler (AC = b + a and
// b - a): the angle at D of the triangle A D C, cos = (d^2 + c^2 - AC^2) / (2 d c), gives the
// path's extent about D.
TEST(Derived, ARockersPointTracesItsCircleAboutThePivot) {
  test::CrankRockerText text = test::crank_rocker(60.37);
  text.moving.replace(text.moving.find("C = [0.08, 0]"), 13, "C = [0.08, 0], E = [0.05, 0.02]");
  const Mechanism m = parse_mechanism(
      text.text() +
          "\n[[derived]]\nname = \"C\"\nquantity = \"circularity\"\npoint = \"C\"\n"
          "\n[[derived]]\nname = \"E\"\nquantity = \"circularity\"\npoint = \"E\"\n",
      "four_bar.toml");
  const Trajectory t = sweep(m);
  const double a = 0.04, b = 0.12, c = 0.08, d = 0.10;
  const double swing = std::acos((d * d + c * c - (b + a) * (b + a)) / (2 * d * c)) -
                       std::acos((d * d + c * c - (b - a) * (b - a)) / (2 * d * c));
  // Exact: E, read off the rocker alone, to round-off; C, read off the coupler's pose, to the
  // chain's closure (Newton's residual, about 1e-13 m here). From the samples alone (their
  // parabolas' vertices, O(h^3) off the path): within 1e-7 m.
  const std::vector<DerivedValue> v = exact_of(m, t), sampled = sampled_of(m, t);
  for (const auto& [values, on_c, on_e] :
       {std::tuple{&v, 1e-12, 1e-15}, std::tuple{&sampled, 1e-7, 1e-7}}) {
    for (const DerivedValue& value : *values) EXPECT_EQ(value.reason, "") << on_c;
    EXPECT_LE(field(*values, "C"), on_c);
    EXPECT_NEAR(field(*values, "C.radius"), c, on_c);
    EXPECT_NEAR(field(*values, "C.centre_x"), d, 10 * on_c);
    EXPECT_NEAR(field(*values, "C.centre_y"), 0.0, 10 * on_c);
    EXPECT_LE(field(*values, "E"), on_e);
    EXPECT_NEAR(field(*values, "E.radius"), std::hypot(0.05, 0.02), on_e);
    EXPECT_NEAR(field(*values, "E.centre_x"), d, 10 * on_e);
    EXPECT_NEAR(field(*values, "E.centre_y"), 0.0, 10 * on_e);
  }
  // The swing is located on the exact path; the samples' parabola is off by O(h^3).
  EXPECT_NEAR(field(v, "C.extent"), swing, 1e-11);
  EXPECT_NEAR(field(v, "E.extent"), swing, 1e-11);
  EXPECT_GT(std::abs(field(sampled, "C.extent") - swing), 1e-11);
}

// An elliptic trammel: a rod AB of length 2 with A on the x axis and B on the y axis; its point
// P, 0.75 from A, runs on the ellipse x = 1.25 cos u, y = 0.75 sin u (a = 1.25, b = 0.75) once
// per turn of the rod. The minimum-zone annulus is centred on the ellipse's centre, with outer
// radius a and inner b: its contacts alternate outer (+-a, 0), inner (0, +-b), outer, inner around
// the centre, four alternating extremes for the three parameters (centre, radius) of the fit, which
// is Chebyshev's alternation criterion for the best (minimax) fit. So the deviation is
// (a - b) / 2, the radius (a + b) / 2, and the path goes once around the centre. (With a < 3 b
// the annulus, a - b wide, is narrower than the ellipse's narrowest strip, 2 b wide.)
TEST(Derived, AnEllipsesMinimumZoneIsCentredWithHalfWidthHalfTheAxesDifference) {
  const std::string text = R"toml(name = "Elliptic trammel"
[units]
length = "m"
angle = "deg"
[[link]]
name = "ground"
ground = true
points = { O = [0, 0] }
lines = { x_axis = { through = "O", angle = 0 }, y_axis = { through = "O", angle = 90 } }
[[link]]
name = "rod"
points = { A = [0, 0], B = [2, 0], P = [0.75, 0] }
pose = ["2*cos(59.63)", 0, 120.37]
[[link]]
name = "a_block"
points = { A = [0, 0] }
pose = ["2*cos(59.63)", 0, 0]
[[link]]
name = "b_block"
points = { B = [0, 0] }
pose = [0, "2*sin(59.63)", 0]
[[joint]]
type = "revolute"
links = ["a_block", "rod"]
point = "A"
[[joint]]
type = "revolute"
links = ["b_block", "rod"]
point = "B"
[[joint]]
type = "prismatic"
name = "a_slide"
guide = "ground"
line = "x_axis"
slider = "a_block"
point = "A"
[[joint]]
type = "prismatic"
name = "b_slide"
guide = "ground"
line = "y_axis"
slider = "b_block"
point = "B"
[driver]
type = "joint_angle"
joint = "A"
to = "B"
start = 120.37
speed = 1
[[derived]]
name = "P"
quantity = "circularity"
point = "P"
)toml";
  const Mechanism m = parse_mechanism(text, "trammel.toml");
  const Trajectory t = sweep(m);
  const std::vector<DerivedValue> v = exact_of(m, t);
  const double a = 1.25, b = 0.75;
  EXPECT_NEAR(field(v, "P"), 0.5 * (a - b), 1e-12);
  EXPECT_NEAR(field(v, "P.radius"), 0.5 * (a + b), 1e-12);
  EXPECT_NEAR(field(v, "P.centre_x"), 0.0, 1e-12);
  EXPECT_NEAR(field(v, "P.centre_y"), 0.0, 1e-12);
  EXPECT_NEAR(field(v, "P.extent"), 2 * kPi, 1e-12);
  // From the samples alone (1 degree, none on a contact): close, but an estimate.
  const std::vector<DerivedValue> s = sampled_of(m, t);
  EXPECT_NEAR(field(s, "P"), 0.5 * (a - b), 1e-5);
  EXPECT_GT(std::abs(field(s, "P") - 0.5 * (a - b)), 1e-14);
}

// A straight path (the slider's point) has no best-fit circle: no value, with the reason.
TEST(Derived, AStraightPathsCircleIsNoneWithItsReason) {
  const std::string text = test::source_text("mechanisms/slider_crank_offset.toml") +
                           "\n[[derived]]\nname = \"C\"\nquantity = \"circularity\"\n"
                           "point = \"C\"\n";
  const Mechanism m = parse_mechanism(text, "slider_crank_offset.toml");
  const Trajectory t = sweep(m);
  for (const std::vector<DerivedValue>& values : {exact_of(m, t), sampled_of(m, t)}) {
    ASSERT_EQ(values.size(), 1u);
    EXPECT_NE(values[0].reason.find("no finite radius"), std::string::npos) << values[0].reason;
    for (const DerivedField& f : values[0].fields) EXPECT_FALSE(f.value.has_value()) << f.name;
  }
}

// The crank-rocker's rocker angle (a = 0.04, b = 0.12, c = 0.08, d = 0.10): its extremes where
// crank and coupler lie in line, psi = 180 deg - angle ADC with cos ADC = (d^2 + c^2 - AC^2) /
// (2 d c), AC = b + a (least) and b - a (most); the crank then points at C (extended) or away
// from it (folded).
TEST(Derived, CrankRockerRockerExtremesAreTheClosedForm) {
  const std::string text =
      test::crank_rocker(60.37).text() +
      "\n[[derived]]\nname = \"rock\"\nquantity = \"extremes\"\nchannel = \"angle.rocker\"\n";
  const Mechanism m = parse_mechanism(text, "four_bar.toml");
  const std::vector<DerivedValue> v = exact_of(m, sweep(m));
  const double a = 0.04, b = 0.12, c = 0.08, d = 0.10;
  auto rocker = [&](double ac) { return kPi - std::acos((d * d + c * c - ac * ac) / (2 * d * c)); };
  auto crank_at = [&](double psi) { return std::atan2(c * std::sin(psi), d + c * std::cos(psi)); };
  EXPECT_NEAR(field(v, "rock.min"), rocker(a + b), 1e-12);
  EXPECT_NEAR(field(v, "rock.max"), rocker(b - a), 1e-12);
  EXPECT_NEAR(turn(field(v, "rock.at_min")), turn(crank_at(rocker(a + b))), 1e-9);
  EXPECT_NEAR(turn(field(v, "rock.at_max")), turn(crank_at(rocker(b - a)) + kPi), 1e-9);
}

// The non-Grashof four-bar of mechanisms/singular/ (a = 40, b = 30, c = 35, d = 60 mm) reaches
// its toggles where coupler and rocker lie in line: cos theta = (a^2 + d^2 - (b + c)^2) / (2 a d),
// at +-theta.
TEST(Derived, NonGrashofTogglesAreTheClosedForm) {
  const std::string text = test::source_text("mechanisms/singular/fourbar_non_grashof.toml") +
                           "\n[[derived]]\nname = \"T\"\nquantity = \"toggles\"\n";
  const Mechanism m = parse_mechanism(text, "fourbar_non_grashof.toml");
  const std::vector<DerivedValue> v = exact_of(m, sweep(m));
  const double a = 40, b = 30, c = 35, d = 60;
  const double theta = std::acos((a * a + d * d - (b + c) * (b + c)) / (2 * a * d));
  const double t1 = field(v, "T.toggle1"), t2 = field(v, "T.toggle2");
  EXPECT_NEAR(std::min(t1, t2), -theta, 1e-10);
  EXPECT_NEAR(std::max(t1, t2), theta, 1e-10);
}

// Every bundled definition's [expect.derived] (each derived in closed form beside it).
TEST(Derived, BundledExpectationsHold) {
  std::vector<std::string> files = test::bundled_files(true, false);
  for (const auto& entry : std::filesystem::directory_iterator(std::string(CROSSLINK_SOURCE_DIR) +
                                                               "/mechanisms/published"))
    files.push_back(entry.path().string());
  int checked = 0;
  for (const std::string& file : files) {
    const Mechanism m = load_mechanism(file);
    if (!m.expect || m.expect->derived.empty() || m.dynamics) continue;
    const std::vector<DerivedValue> v = exact_of(m, sweep(m));
    for (const Expectations::Derived& e : m.expect->derived) {
      const std::optional<double> got = derived_value(v, e.quantity);
      ASSERT_TRUE(got.has_value()) << file << ": " << e.quantity;
      double d = *got - e.value;
      if (e.quantity.find(".at_") != std::string::npos) d = std::remainder(d, 2 * kPi);
      EXPECT_LE(std::abs(d), 1e-9 * std::max(1.0, std::abs(e.value))) << file << ": " << e.quantity;
      ++checked;
    }
  }
  EXPECT_GE(checked, 4);
}

// A value that does not exist has none, and says why: never 0.
TEST(Derived, AValueThatDoesNotExistIsNoneWithItsReason) {
  const std::string text = test::source_text("mechanisms/slider_crank_offset.toml") +
                           "\n[[derived]]\nname = \"S\"\nquantity = \"stroke\"\n"
                           "channel = \"s.slider\"\nrange = [20, 90]\n"
                           "\n[[derived]]\nname = \"Q\"\nquantity = \"time_ratio\"\n"
                           "channel = \"s.slider\"\nrange = [0, 300]\n"
                           "\n[[derived]]\nname = \"T\"\nquantity = \"toggles\"\n";
  const Mechanism m = parse_mechanism(text, "slider_crank_offset.toml");
  const Trajectory t = sweep(m);
  for (const std::vector<DerivedValue>& values : {exact_of(m, t), sampled_of(m, t)}) {
    ASSERT_EQ(values.size(), 3u);
    for (const DerivedValue& v : values) {
      EXPECT_FALSE(v.reason.empty()) << v.spec->name;
      for (const DerivedField& f : v.fields) EXPECT_FALSE(f.value.has_value()) << f.name;
    }
    EXPECT_NE(values[0].reason.find("does not turn back"), std::string::npos) << values[0].reason;
    EXPECT_NE(values[1].reason.find("whole cycle"), std::string::npos) << values[1].reason;
  }
}

std::string error_of(const std::string& text) {
  return test::error_of(text, "m.toml");
}

TEST(Derived, WrongInputIsLocated) {
  const std::string base = test::source_text("mechanisms/slider_crank_offset.toml");
  const std::string lines = base + "\n[[derived]]\nname = \"S\"\nquantity = \"strok\"\n";
  EXPECT_EQ(error_of(lines),
            fmt::format("m.toml:{}:12: error: [[derived]]: unknown quantity 'strok' (valid: "
                        "extremes, stroke, time_ratio, dead_points, toggles, transmission, "
                        "straightness, circularity, jump_speed, least_radius)",
                        test::line_of(lines, "quantity = \"strok\"")));
  const std::string channel =
      base + "\n[[derived]]\nname = \"S\"\nquantity = \"stroke\"\nchannel = \"s.nothing\"\n";
  EXPECT_NE(error_of(channel).find(fmt::format("m.toml:{}:11: error: [[derived]]: 's.nothing' is "
                                               "not a kinematic channel",
                                               test::line_of(channel, "s.nothing"))),
            std::string::npos)
      << error_of(channel);
  const std::string at = base +
                         "\n[[derived]]\nname = \"S\"\nquantity = \"stroke\"\nchannel = "
                         "\"s.slider\"\n[[reference]]\nquantity = \"S\"\nat = 30\nvalue = 1\n"
                         "source = \"x\"\n";
  EXPECT_NE(error_of(at).find(fmt::format("m.toml:{}:6: error: [[reference]]: 'S' is a "
                                          "[[derived]] quantity",
                                          test::line_of(at, "at = 30"))),
            std::string::npos)
      << error_of(at);
  const std::string transmission =
      base + "\n[[derived]]\nname = \"T\"\nquantity = \"transmission\"\n";
  EXPECT_NE(error_of(transmission).find("is not one"), std::string::npos) << error_of(transmission);
  // A circle of no point, of a point that does not exist, over an interval outside the sweep.
  const std::string no_point = base + "\n[[derived]]\nname = \"R\"\nquantity = \"circularity\"\n";
  EXPECT_NE(error_of(no_point).find(fmt::format("m.toml:{}:1: error: [[derived]]",
                                                test::line_of(no_point, "[[derived]]"))),
            std::string::npos)
      << error_of(no_point);
  EXPECT_NE(error_of(no_point).find("'point'"), std::string::npos) << error_of(no_point);
  const std::string nowhere =
      base + "\n[[derived]]\nname = \"R\"\nquantity = \"circularity\"\npoint = \"Q\"\n";
  EXPECT_NE(error_of(nowhere).find(fmt::format("m.toml:{}:9: error: [[derived]]: no point 'Q' "
                                               "(points: ",
                                               test::line_of(nowhere, "point = \"Q\""))),
            std::string::npos)
      << error_of(nowhere);
  std::string ranged = base;
  ranged.replace(ranged.find("start = 0\n"), 10, "start = 0\nrange = [0, 120]\n");
  ranged +=
      "\n[[derived]]\nname = \"R\"\nquantity = \"circularity\"\npoint = \"B\"\n"
      "range = [100, 150]\n";
  EXPECT_NE(error_of(ranged).find(fmt::format("m.toml:{}:9: error: [[derived]] 'range' [100, "
                                              "150] is outside the sweep, the [driver] range "
                                              "[0, 120]",
                                              test::line_of(ranged, "range = [100, 150]"))),
            std::string::npos)
      << error_of(ranged);
  const std::string expect = base +
                             "\n[[derived]]\nname = \"S\"\nquantity = \"stroke\"\nchannel = "
                             "\"s.slider\"\n[expect.derived]\n\"S.middle\" = 3\n";
  EXPECT_NE(error_of(expect).find(fmt::format(
                "m.toml:{}:1: error: [expect.derived]: 'S.middle' is no [[derived]] quantity",
                test::line_of(expect, "S.middle"))),
            std::string::npos)
      << error_of(expect);
}

// Issue 35, item 8: a [[derived]] entry on a channel its object does not have ("angle.B" of a
// point B) passed the loader and crashed solve, compare and sweep (SIGSEGV reading the channel);
// a stroke, time ratio or dead points of the driver's own coordinate, which never turns back,
// read the cycle's seam as a reversal (a stroke of 361 degrees, a time ratio of 359). Both are
// refused at the channel's key with what is valid.
TEST(Derived, AChannelItsObjectDoesNotHaveOrTheDriversOwnCoordinateIsRefusedAtItsKey) {
  const std::string base = test::source_text("mechanisms/fourbar_crank_rocker.toml");
  const std::string point_angle =
      base + "\n[[derived]]\nname = \"S\"\nquantity = \"extremes\"\nchannel = \"angle.B\"\n";
  EXPECT_NE(error_of(point_angle)
                .find(fmt::format("m.toml:{}:11: error: [[derived]]: 'angle.B' is no channel of "
                                  "this linkage (those of 'B': x.B, y.B, vx.B, vy.B, v.B, ax.B, "
                                  "ay.B, a.B)",
                                  test::line_of(point_angle, "channel = \"angle.B\""))),
            std::string::npos)
      << error_of(point_angle);
  const std::string link_x =
      base + "\n[[derived]]\nname = \"S\"\nquantity = \"stroke\"\nchannel = \"x.rocker\"\n";
  EXPECT_NE(error_of(link_x).find("'x.rocker' is no channel of this linkage (those of 'rocker': "
                                  "angle.rocker, omega.rocker, alpha.rocker)"),
            std::string::npos)
      << error_of(link_x);
  for (const char* quantity : {"stroke", "time_ratio", "dead_points"}) {
    const std::string own = base + fmt::format(
                                       "\n[[derived]]\nname = \"S\"\nquantity = \"{}\"\n"
                                       "channel = \"angle.crank\"\n",
                                       quantity);
    EXPECT_NE(error_of(own).find(fmt::format(
                  "m.toml:{}:11: error: [[derived]] '{}': 'angle.crank' is the driver's own "
                  "coordinate, which moves one way over the sweep and never turns back",
                  test::line_of(own, "channel = \"angle.crank\""), quantity)),
              std::string::npos)
        << error_of(own);
  }
  // Its extremes are defined (the ends of a sweep over a range).
  EXPECT_NO_THROW(parse_mechanism(
      base + "\n[[derived]]\nname = \"E\"\nquantity = \"extremes\"\nchannel = \"angle.crank\"\n",
      "m.toml"));
  // A slider driven along its line: its s is the driver's.
  const std::string slider = test::source_text("mechanisms/singular/slider_crank_from_slider.toml");
  const std::string driven = slider.substr(0, slider.find("[expect]")) +
                             "\n[[derived]]\nname = \"S\"\nquantity = \"stroke\"\nchannel = "
                             "\"s.piston\"\n";
  EXPECT_NE(error_of(driven).find("'s.piston' is the driver's own coordinate"), std::string::npos)
      << error_of(driven);
}

// A link that turns with the driver but is not driven (the geared five-bar's second crank, one
// turn back per turn of the first) has no reversal either: the cycle's seam, where its angle is a
// turn on, was read as one. Its stroke and extremes have no value and say why.
TEST(Derived, ALinkTurningWholeTurnsHasNoStrokeAtTheCyclesSeam) {
  const std::string text = test::source_text("mechanisms/gears/geared_fivebar.toml") +
                           "\n[[derived]]\nname = \"S\"\nquantity = \"stroke\"\n"
                           "channel = \"angle.crank5\"\n"
                           "\n[[derived]]\nname = \"Q\"\nquantity = \"time_ratio\"\n"
                           "channel = \"angle.crank5\"\n"
                           "\n[[derived]]\nname = \"R\"\nquantity = \"stroke\"\n"
                           "channel = \"angle.coupler3\"\n";
  const Mechanism m = parse_mechanism(text, "geared_fivebar.toml");
  const Trajectory t = sweep(m);
  for (const std::vector<DerivedValue>& values : {exact_of(m, t), sampled_of(m, t)}) {
    ASSERT_EQ(values.size(), 3u);
    for (size_t i = 0; i < 2; ++i) {
      EXPECT_NE(values[i].reason.find("turns whole turns"), std::string::npos)
          << values[i].spec->name << ": " << values[i].reason;
      for (const DerivedField& f : values[i].fields) EXPECT_FALSE(f.value.has_value()) << f.name;
    }
    // The coupler swings back and forth: its stroke exists, less than half a turn.
    ASSERT_TRUE(values[2].reason.empty()) << values[2].reason;
    const double stroke = field(values, "R");
    EXPECT_GT(stroke, 0.0);
    EXPECT_LT(stroke, kPi);
  }
}

}  // namespace
}  // namespace crosslink
