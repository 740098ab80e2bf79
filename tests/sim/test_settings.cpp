// The settings schema's readers (sim/settings.h): what a run prints is the schema's entries for
// its kind of run, in the schema's order, and a reported value cannot be set.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "sim/settings.h"

namespace crosslink::sim {
namespace {

// A setting for both runs, a value only kinematic runs report, a setting of dynamics runs.
const SettingSchema& schema() {
  static const SettingSchema s = {
      {.name = "dt", .kind = SettingKind::number, .default_value = "1", .range = kPositive},
      {.name = "derivatives", .applies_to = AppliesTo::kinematic, .reported = true},
      {.name = "start",
       .kind = SettingKind::choice,
       .default_value = "exact",
       .words = {"exact", "staggered"},
       .applies_to = AppliesTo::dynamics},
  };
  return s;
}

TEST(PrintedSettings, AreTheEntriesOfTheRunsKindInTheSchemasOrder) {
  EXPECT_EQ(
      printed_settings(schema(), RunKind::kinematic, {{"derivatives", "central"}, {"dt", "2"}}),
      (RunSettings{{"dt", "2"}, {"derivatives", "central"}}));
  EXPECT_EQ(printed_settings(schema(), RunKind::dynamics, {{"start", "exact"}, {"dt", "2"}}),
            (RunSettings{{"dt", "2"}, {"start", "exact"}}));
}

TEST(PrintedSettings, RefuseAValueMissingTwiceOrNotDeclaredForTheRun) {
  // A declared entry without its value.
  EXPECT_THROW(printed_settings(schema(), RunKind::kinematic, {{"dt", "2"}}), std::logic_error);
  // A name the schema does not declare.
  EXPECT_THROW(printed_settings(schema(), RunKind::dynamics,
                                {{"dt", "2"}, {"start", "exact"}, {"energy_scale", "1 J"}}),
               std::logic_error);
  // A name declared for the other kind of run.
  EXPECT_THROW(printed_settings(schema(), RunKind::dynamics,
                                {{"dt", "2"}, {"start", "exact"}, {"derivatives", "central"}}),
               std::logic_error);
  EXPECT_THROW(printed_settings(schema(), RunKind::kinematic,
                                {{"dt", "2"}, {"derivatives", "central"}, {"dt", "3"}}),
               std::logic_error);
}

TEST(SettingValues, RefuseAReportedValueAsInput) {
  try {
    (void)SettingValues(schema(), "Test", {{"derivatives", "central"}});
    ADD_FAILURE() << "a reported value was set";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "Test setting \"derivatives\" is reported by the run, not set");
  }
  try {
    (void)SettingValues(schema(), "Test", {{"dtt", "1"}});
    ADD_FAILURE() << "an unknown name was set";
  } catch (const std::invalid_argument& e) {
    // The names it knows are the ones a user sets.
    EXPECT_EQ(std::string(e.what()), "unknown Test setting \"dtt\" (known: dt, start)");
  }
  EXPECT_EQ(allowed_values(schema()[1]), "reported by the run, not set");
}

}  // namespace
}  // namespace crosslink::sim
