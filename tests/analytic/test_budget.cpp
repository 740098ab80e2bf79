// The work a command asks of the exact solver is counted before it starts
// (analytic/reference/budget.h): each case states the count it expects from the definition's own
// numbers, and checks that the refusal names the input at fault, the count and the limit, and that
// raising the limit lets the same request through.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>

#include "analytic/model/loader.h"
#include "analytic/reference/budget.h"
#include "tests/common/crank_rocker.h"
#include "tests/common/mechanisms.h"
#include "tests/common/text.h"

namespace crosslink {
namespace {

constexpr double kDeg = std::numbers::pi / 180.0;

// The shared crank-rocker (tests/common/crank_rocker.h), drawn at 60 degrees; the crank turns
// fully. `law` is its [driver] table's last lines.
std::string four_bar(const std::string& law = "speed = 10\n") {
  return test::crank_rocker(60.0, law).text();
}

// The line of four_bar() that holds the first of `law`.
const int kDriverLine = test::line_of(four_bar(), "start = 60") + 1;

WorkLimits limit(long samples) {
  return {samples};
}

// The message of the DefinitionError `check` throws, which must be located at `line`.
std::string refusal_at(int line, const std::function<void()>& check) {
  try {
    check();
  } catch (const DefinitionError& e) {
    EXPECT_EQ(e.diagnostics().size(), 1u);
    EXPECT_EQ(e.diagnostics()[0].where.line, line) << e.what();
    return e.diagnostics()[0].message;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not located: " << e.what();
    return e.what();
  }
  ADD_FAILURE() << "accepted";
  return "";
}

// The message of the std::invalid_argument `check` throws for an option.
std::string option_refusal(const std::function<void()>& check) {
  try {
    check();
  } catch (const std::invalid_argument& e) {
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not an option's error: " << e.what();
    return e.what();
  }
  ADD_FAILURE() << "accepted";
  return "";
}

void expect_has(const std::string& message, const std::string& phrase) {
  EXPECT_NE(message.find(phrase), std::string::npos) << "'" << phrase << "' not in: " << message;
}

TEST(Budget, TheIssuesRangeTypoIsRefusedAtTheRange) {
  // range = [-30, 1e9] degrees at 1 degree: 1e9 + 30 steps, so 1,000,000,031 samples.
  const Mechanism m = parse_mechanism(four_bar("speed = 10\nrange = [-30, 1e9]\n"), "typo.toml");
  const std::string message =
      refusal_at(kDriverLine + 1, [&] { check_sweep_work(m, {}, WorkLimits{}); });
  expect_has(message, "driver.range = [-30, 1e+09] deg at a step of 1 deg");
  expect_has(message, "asks for 1000000031 samples: the limit is 100000");
  expect_has(message, "--max-samples N");
  // Then the continuation: from 60 back to -30, and across the range, 1e9 + 120 steps.
  expect_has(refusal_at(kDriverLine + 1, [&] { check_sweep_work(m, {}, limit(1'000'000'031)); }),
             "asks for 1000000120 continuation steps of at most 1 deg");
  EXPECT_NO_THROW(check_sweep_work(m, {}, limit(1'000'000'120)));
}

TEST(Budget, AFullTurnAtTheDefaultStepIs361Samples) {
  const Mechanism m = parse_mechanism(four_bar(), "good.toml");
  EXPECT_NO_THROW(check_sweep_work(m, {}, limit(361)));
  expect_has(option_refusal([&] { check_sweep_work(m, {}, limit(360)); }),
             "the default step of 1 degree asks for 361 samples: the limit is 360");
}

TEST(Budget, AFineStepIsRefusedNamingTheOption) {
  // 360 degrees at 0.001 degree: 360,000 steps, 360,001 samples.
  const Mechanism m = parse_mechanism(four_bar(), "good.toml");
  SweepOptions options;
  options.step = 0.001 * kDeg;
  expect_has(option_refusal([&] { check_sweep_work(m, options, WorkLimits{}); }),
             "--step 0.001 deg asks for 360001 samples: the limit is 100000");
  EXPECT_NO_THROW(check_sweep_work(m, options, limit(360'001)));
  // Following the loop back (at_limit = reverse) is taken as two turns.
  options.at_limit = SweepOptions::AtLimit::reverse;
  EXPECT_THROW(check_sweep_work(m, options, limit(360'001)), std::invalid_argument);
  EXPECT_NO_THROW(check_sweep_work(m, options, limit(720'002)));
}

TEST(Budget, AStepThatIsNotAPositiveNumberIsRefused) {
  const Mechanism m = parse_mechanism(four_bar(), "good.toml");
  for (const double step :
       {-1.0, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()}) {
    SweepOptions options;
    options.step = step;
    expect_has(option_refusal([&] { check_sweep_work(m, options, WorkLimits{}); }),
               "--step must be a positive number");
  }
}

TEST(Budget, ContinuationAcrossAWideRangeCountsEvenAtACoarseStep) {
  // [0, 1e6] degrees at 1000 degrees: 1001 samples, but the solver continues in steps of at
  // most 1 degree from 60 down to 0 and across: 60 + 1e6 steps.
  const Mechanism m = parse_mechanism(four_bar("speed = 10\nrange = [0, 1e6]\n"), "wide.toml");
  SweepOptions options;
  options.step = 1000 * kDeg;
  const std::string message =
      refusal_at(kDriverLine + 1, [&] { check_sweep_work(m, options, WorkLimits{}); });
  expect_has(message, "at --step 1000 deg asks for 1000060 continuation steps of at most 1 deg");
  EXPECT_NO_THROW(check_sweep_work(m, options, limit(1'000'060)));
}

TEST(Budget, AMotionLawIsMeasuredByTheDriverTravelItAsksFor) {
  // 60 + 1e6 t degrees over 100 s: 1e8 degrees of travel in steps of at most 1 degree.
  const Mechanism m = parse_mechanism(four_bar("polynomial = [1e6]\nduration = 100\n"), "law.toml");
  const std::string message = refusal_at(kDriverLine, [&] { check_sweep_work(m, {}, {}); });
  expect_has(message, "driver.polynomial asks for 100000000 continuation steps");
  // (The travel is summed over 360 intervals: within round-off of 1e8.)
  EXPECT_NO_THROW(check_sweep_work(m, {}, limit(100'000'001)));
  EXPECT_THROW(check_sweep_work(m, {}, limit(99'999'999)), DefinitionError);
}

TEST(Budget, ASolveAtAFarValueCountsItsContinuation) {
  // From 60 to 1e7 degrees: 27,777 whole turns and 220 degrees. The crank turns fully, so
  // solve_at skips the turns: the budget counts the 220 degrees and the turn that shows the chain
  // back at its pose, 580 steps of at most 1 degree (9,999,940 without the skip).
  const Mechanism m = parse_mechanism(four_bar(), "good.toml");
  expect_has(option_refusal([&] { check_solve_at_work(m, 1e7 * kDeg, {}, limit(579)); }),
             "--at 1e+07 deg asks for 580 continuation steps of at most 1 deg");
  EXPECT_NO_THROW(check_solve_at_work(m, 1e7 * kDeg, {}, limit(581)));
  EXPECT_NO_THROW(check_solve_at_work(m, 135 * kDeg, {}, limit(75)));
}

TEST(Budget, ASolveAtAValueThatIsNoDriverValueIsRefused) {
  // A NaN target was never reached: the continuation toward it ran for ever.
  const Mechanism m = parse_mechanism(four_bar(), "good.toml");
  for (const double at : {std::numeric_limits<double>::quiet_NaN(), 1e9})
    expect_has(option_refusal([&] { check_solve_at_work(m, at, {}, WorkLimits{}); }),
               "is not a driver value: the limit is 5.72958e+09 deg");
}

TEST(Budget, AStepLostInRoundOffIsRefused) {
  // Near 1e4 rad a double resolves 1.8e-12 rad; the budget asks for steps of at least 1e-12 of
  // the values (1e-8 rad), so 1e-9 rad steps over a 1e-5 rad range (10,001 samples) are refused.
  std::string text = four_bar("speed = 10\nrange = [1e4, 10000.00001]\n");
  text.replace(text.find("angle = \"deg\""), 13, "angle = \"rad\"");
  text.replace(text.find("start = 60"), 10, "start = 1e4");
  const Mechanism m = parse_mechanism(text, "far.toml");
  SweepOptions options;
  options.step = 1e-9;
  const std::string message =
      refusal_at(kDriverLine + 1, [&] { check_sweep_work(m, options, WorkLimits{}); });
  expect_has(message, "lost in round-off");
}

TEST(Budget, ASliderAtAnExplicitStepIsMeasuredOverItsAssemblingRange) {
  // mechanisms/singular: the slider runs between sqrt(1500) and sqrt(6300) mm, 40.6427 mm, so
  // 0.001 mm steps give 40,642 steps and 40,643 samples.
  const Mechanism m = load_mechanism("mechanisms/singular/slider_crank_from_slider.toml");
  SweepOptions options;
  options.step = 0.001e-3;
  EXPECT_NO_THROW(check_sweep_work(m, options, limit(40'643)));
  expect_has(option_refusal([&] { check_sweep_work(m, options, limit(40'642)); }),
             "--step 0.001 mm asks for 40643 samples");
  // At its default step (1/360 of the range) it needs no measuring: 361 samples.
  EXPECT_NO_THROW(check_sweep_work(m, {}, limit(361)));
  EXPECT_THROW(check_sweep_work(m, {}, limit(360)), std::invalid_argument);
}

// Issue 35, item 8: the geared five-bar with a gear of 1e6 teeth against 1 (inside the limits)
// turns its second crank 1e6 times as far as the driver; the continuation halves its steps
// until that crank turns about a degree a step, so one pose at 30 degrees took 75 s of steps no
// budget counted. They are counted: 30 degrees over steps of 1e-6 degree is 3e7 steps.
TEST(Budget, AGearThatTurnsALinkAMillionTimesTheDriverCountsItsSteps) {
  std::string text = test::source_text("mechanisms/gears/geared_fivebar.toml");
  const size_t at = text.find("teeth = [30, 30]");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 16, "teeth = [1000000, 1]");
  const Mechanism m = parse_mechanism(text, "gear.toml");
  const std::string one_pose =
      option_refusal([&] { check_solve_at_work(m, 30 * kDeg, {}, limit(100000)); });
  expect_has(one_pose, "--at 30 deg asks for 30000000 continuation steps");
  expect_has(one_pose,
             "continuation steps of at most 1e-06 deg (its gears turn a link up to "
             "1e+06 times as far as the driver): the limit is 100000 (raise it with "
             "--max-samples N)");
  const std::string cycle = option_refusal([&] { check_sweep_work(m, {}, limit(100000)); });
  expect_has(cycle, "the default step of 1 degree asks for 360000000 continuation steps");
  expect_has(cycle, "(raise it with --max-samples N)");
  // Within a raised limit the same requests pass.
  EXPECT_NO_THROW(check_solve_at_work(m, 30 * kDeg, {}, limit(30'000'001)));
  EXPECT_NO_THROW(check_sweep_work(m, {}, limit(360'000'001)));
  // Every bundled gear train is within the default limits.
  for (const char* file :
       {"geared_fivebar", "planetary_fixed_ring", "epicyclic_ring72_sun32",
        "constans_dyer_geared_fivebar", "rack_pinion_slider_crank", "ryan_rack_and_pinion"}) {
    const Mechanism bundled =
        parse_mechanism(test::source_text(std::string("mechanisms/gears/") + file + ".toml"), file);
    EXPECT_NO_THROW(check_sweep_work(bundled, {}, {})) << file;
    EXPECT_NO_THROW(check_reference_work(bundled, {})) << file;
  }
}

}  // namespace
}  // namespace crosslink
