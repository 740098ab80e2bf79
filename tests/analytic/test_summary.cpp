// The design summary (docs/mechanism-format.md, "Design summary"): what a designer reads about
// the output, added to every one-driver definition without being declared, checked against the
// closed forms of the slider-crank, the crank-rocker and the Whitworth quick return (law of
// cosines on the linkage's dead-point triangles).
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cmath>
#include <numbers>
#include <regex>

#include "analytic/derived/derived.h"
#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "tests/common/diagnostics.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

constexpr double kPi = std::numbers::pi;

// The summary's values (their specs point into `m`, which must outlive them).
std::vector<DerivedValue> summary_of(const Mechanism& m) {
  std::vector<DerivedValue> v = derived_exact(m, sweep(m));
  std::erase_if(v, [](const DerivedValue& d) { return !d.spec->summary; });
  return v;
}

double field(const std::vector<DerivedValue>& values, std::string_view quantity) {
  const std::optional<double> v = derived_value(values, quantity);
  EXPECT_TRUE(v.has_value()) << quantity;
  return v.value_or(NAN);
}

const DerivedValue* find(const std::vector<DerivedValue>& values, std::string_view name) {
  for (const DerivedValue& v : values)
    if (v.spec->name == name) return &v;
  return nullptr;
}

double turn(double a) {
  return std::fmod(std::fmod(a, 2 * kPi) + 2 * kPi, 2 * kPi);
}

// The offset slider-crank (crank a = 0.04, rod b = 0.12, guide offset e = 0.01 m, crank at
// +240 rpm): its output is the slider. The slider is furthest when crank and rod lie in line,
// |AC| = a + b, and nearest folded, |AC| = b - a: x = sqrt(AC^2 - e^2), the crank along AC
// (extended) or against it (folded).
TEST(Summary, TheSliderCranksStrokeTimeRatioAndDeadPoints) {
  const Mechanism m = load_mechanism("mechanisms/slider_crank_offset.toml");
  const std::vector<DerivedValue> v = summary_of(m);
  const double a = 0.04, b = 0.12, e = 0.01;
  const double far = std::sqrt((a + b) * (a + b) - e * e),
               near = std::sqrt((b - a) * (b - a) - e * e);
  const double at_far = std::atan2(e, far), at_near = std::atan2(e, near) + kPi;
  ASSERT_NE(find(v, "output_stroke"), nullptr);
  EXPECT_EQ(find(v, "output_stroke")->spec->channel, "s.slider");
  EXPECT_NEAR(field(v, "output_stroke"), far - near, 1e-12);
  EXPECT_NEAR(field(v, "output_dead_points.at_max"), at_far, 1e-9);
  EXPECT_NEAR(field(v, "output_dead_points.at_min"), at_near, 1e-9);
  const double rising = turn(at_far - at_near);  // from the nearest to the furthest, crank ccw
  EXPECT_NEAR(field(v, "output_time_ratio"), (2 * kPi - rising) / rising, 1e-9);
  EXPECT_NEAR(field(v, "output_time_ratio.increasing"), rising, 1e-9);
  // No toggle: the crank turns fully; not a four-bar: no transmission angle of its own.
  EXPECT_FALSE(derived_value(v, "toggles").has_value());
  EXPECT_EQ(find(v, "transmission"), nullptr);
}

// The Grashof crank-rocker A B C D (a = 0.04, b = 0.12, c = 0.08, ground d = 0.10 m): the rocker
// swings between |AC| = a + b and b - a. At each, the rocker's angle is 180 deg less the angle at
// D, and the crank's the angle at A (plus 180 deg folded), of the triangle A D C; the
// transmission angle's extremes are at crank 0 and 180 deg, cos mu = (b^2 + c^2 - a^2 - d^2 +-
// 2ad) / (2bc).
TEST(Summary, TheCrankRockersSwingTimeRatioAndTransmission) {
  const Mechanism m = load_mechanism("mechanisms/fourbar_crank_rocker.toml");
  const std::vector<DerivedValue> v = summary_of(m);
  const double a = 0.04, b = 0.12, c = 0.08, d = 0.10;
  const auto at_d = [&](double ac) { return std::acos((d * d + c * c - ac * ac) / (2 * d * c)); };
  const auto at_a = [&](double ac) { return std::acos((d * d + ac * ac - c * c) / (2 * d * ac)); };
  const double low = kPi - at_d(a + b), high = kPi - at_d(b - a);
  ASSERT_NE(find(v, "output_stroke"), nullptr);
  EXPECT_EQ(find(v, "output_stroke")->spec->channel, "angle.rocker");
  EXPECT_NEAR(field(v, "output_stroke"), high - low, 1e-9);
  EXPECT_NEAR(field(v, "output_stroke.min"), low, 1e-9);
  EXPECT_NEAR(field(v, "output_stroke.max"), high, 1e-9);
  const double at_low = at_a(a + b), at_high = at_a(b - a) + kPi;
  EXPECT_NEAR(field(v, "output_dead_points.at_min"), at_low, 1e-9);
  EXPECT_NEAR(field(v, "output_dead_points.at_max"), at_high, 1e-9);
  const double rising = turn(at_high - at_low);
  EXPECT_NEAR(field(v, "output_time_ratio"), rising / (2 * kPi - rising), 1e-9);
  const auto mu = [&](double sign) {
    return std::acos((b * b + c * c - a * a - d * d + sign * 2 * a * d) / (2 * b * c));
  };
  EXPECT_NEAR(field(v, "transmission.min"), mu(1), 1e-9);
  EXPECT_NEAR(field(v, "transmission.max"), mu(-1), 1e-9);
}

// The Whitworth quick return declares its ram's stroke and time ratio itself (its closed forms in
// [expect.derived]); the summary adds only what it does not: the ram's dead points, the lever
// along its slot at atan2(100, -+sqrt(150^2 - 100^2)).
TEST(Summary, TheWhitworthsDeclaredQuantitiesAreNotRepeated) {
  const Mechanism m = load_mechanism("mechanisms/published/whitworth_quick_return.toml");
  const std::vector<DerivedValue> v = summary_of(m);
  EXPECT_EQ(find(v, "output_stroke"), nullptr);
  EXPECT_EQ(find(v, "output_time_ratio"), nullptr);
  ASSERT_NE(find(v, "output_dead_points"), nullptr);
  EXPECT_EQ(find(v, "output_dead_points")->spec->channel, "s.ram");
  EXPECT_NEAR(field(v, "output_dead_points.at_max"),
              std::atan2(100, -std::sqrt(150.0 * 150 - 100 * 100)), 1e-9);
  EXPECT_NEAR(field(v, "output_dead_points.at_min"),
              std::atan2(100, std::sqrt(150.0 * 150 - 100 * 100)), 1e-9);
}

// The Watt six-bar's output swings twice a crank turn: a stroke, but no one forward and return
// stroke to time.
TEST(Summary, AnOutputThatSwingsTwiceATurnHasNoTimeRatio) {
  const Mechanism m = load_mechanism("mechanisms/watt_sixbar.toml");
  const std::vector<DerivedValue> v = summary_of(m);
  ASSERT_NE(find(v, "output_time_ratio"), nullptr);
  EXPECT_FALSE(derived_value(v, "output_time_ratio").has_value());
  EXPECT_NE(find(v, "output_time_ratio")->reason.find("turns back 4 times"), std::string::npos)
      << find(v, "output_time_ratio")->reason;
  EXPECT_TRUE(derived_value(v, "output_stroke").has_value());
}

// [summary] output names another link; a name that is no output is refused at its place; a
// coupler point off the joints gets its path.
TEST(Summary, TheOutputNamedAndACouplerPointsPath) {
  std::string text = test::source_text("mechanisms/fourbar_crank_rocker.toml");
  const Mechanism coupler = parse_mechanism(text + "\n[summary]\noutput = \"coupler\"\n", "m.toml");
  const std::vector<DerivedValue> v = summary_of(coupler);
  ASSERT_NE(find(v, "output_stroke"), nullptr);
  EXPECT_EQ(find(v, "output_stroke")->spec->channel, "angle.coupler");
  const std::string bad = text + "\n[summary]\noutput = \"crank\"\n";
  EXPECT_EQ(test::error_of(bad, "m.toml"),
            fmt::format("m.toml:{}:10: error: [summary] 'output': 'crank' is no moving link or "
                        "slider on the ground but the driven one (valid: coupler, rocker)",
                        test::line_of(bad, "output = \"crank\"")));
  const std::string with_point =
      std::regex_replace(text, std::regex("points = \\{ B = \\[0, 0\\], C = \\[0.12, 0\\] \\}"),
                         "points = { B = [0, 0], C = [0.12, 0], P = [0.06, 0.04] }");
  ASSERT_NE(with_point, text);
  const Mechanism pointed = parse_mechanism(with_point, "m.toml");
  const std::vector<DerivedValue> p = summary_of(pointed);
  ASSERT_NE(find(p, "path_P"), nullptr);
  EXPECT_GT(field(p, "path_P.extent"), 0.0);
  EXPECT_GT(field(p, "path_P"), 0.0);     // its deviation from a line: a coupler curve is no line
  EXPECT_EQ(find(p, "path_B"), nullptr);  // a joint's point: the crank's circle
}

// Issue 32 item 2, "for every bundled one-driver definition": each has a summary without declaring
// it, the output's stroke among it, and every value it gives exists or says why it does not.
TEST(Summary, EveryBundledOneDriverDefinitionHasOne) {
  std::vector<std::string> files = test::bundled_files(true, false);
  for (const std::string& gear : test::gear_files()) files.push_back(gear);
  int summarised = 0;
  for (const std::string& file : files) {
    const Mechanism m = load_mechanism(file);
    if (m.axis().timed() || m.at_rest()) continue;
    const std::vector<DerivedValue> v = summary_of(m);
    ASSERT_NE(find(v, "output_stroke"), nullptr) << file;
    for (const DerivedValue& d : v)
      for (const DerivedField& f : d.fields)
        EXPECT_TRUE(f.value.has_value() || !d.reason.empty())
            << file << ": " << d.spec->name << "." << f.name << " has neither value nor reason";
    ++summarised;
  }
  EXPECT_GE(summarised, 20);
}

}  // namespace
}  // namespace crosslink
