// The engine table and the settings schema each engine declares (methods/engines.h,
// sim/settings.h): the command line, the docs table and every check come from one declaration.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "analytic/model/loader.h"
#include "analytic/reference/sweep.h"
#include "methods/engines.h"
#include "methods/registry.h"

namespace crosslink::methods {
namespace {

const std::string kFourbar =
    std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/fourbar_crank_rocker.toml";
// A dynamics case ([dynamics]) whose engine runs take well under a second.
const std::string kSqueezer =
    std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/andrews_squeezer.toml";

std::string read(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// docs/engines.md holds, for each engine, the table `crosslink engines --markdown` prints after
// the marker "<!-- settings: NAME -->", up to the first blank line.
TEST(EngineTable, TheDocsTableListsExactlyTheDeclaredSettings) {
  const std::string doc = read(std::string(CROSSLINK_SOURCE_DIR) + "/docs/engines.md");
  for (const EngineEntry& e : engine_table()) {
    const std::string marker = "<!-- settings: " + e.name + " -->\n";
    const size_t at = doc.find(marker);
    ASSERT_NE(at, std::string::npos) << marker;
    const size_t begin = doc.find('|', at);
    const size_t end = doc.find("\n\n", begin);
    EXPECT_EQ(doc.substr(begin, end + 1 - begin), settings_markdown(e))
        << e.name << ": regenerate with `crosslink engines --markdown`";
  }
}

// A value a setting's kind does not take is refused before any run (exit 2 on the command line);
// every declared default is a value it takes.
TEST(EngineTable, EverySettingRefusesWhatItsKindDoesNotTakeAndTakesItsDefault) {
  const Mechanism m = load_mechanism(kFourbar);
  for (const EngineEntry& e : engine_table()) {
    const auto engine = e.make();
    for (const sim::SettingSpec& s : engine->settings_schema()) {
      if (s.reported) {  // what a run reports is not input
        try {
          engine->check_settings(m, {{s.name, "1"}});
          ADD_FAILURE() << e.name << ':' << s.name << " was set";
        } catch (const std::invalid_argument& error) {
          EXPECT_NE(std::string(error.what()).find("is reported by the run, not set"),
                    std::string::npos)
              << error.what();
        }
        continue;
      }
      EXPECT_NO_THROW(engine->check_settings(m, {{s.name, s.default_value}}))
          << e.name << ':' << s.name;
      const char* bad = s.kind == sim::SettingKind::count ? "2.5" : "not-a-value";
      if (s.kind == sim::SettingKind::text) continue;  // checked by the engine (perturb_link...)
      try {
        engine->check_settings(m, {{s.name, bad}});
        ADD_FAILURE() << e.name << ':' << s.name << " took " << bad;
      } catch (const std::invalid_argument& error) {
        EXPECT_NE(std::string(error.what()).find(sim::allowed_values(s)), std::string::npos)
            << error.what();
      }
    }
    EXPECT_THROW(engine->check_settings(m, {{"no_such_setting", "1"}}), std::invalid_argument);
  }
  // The example: a solver's name is not an integrator.
  EXPECT_THROW(find_engine("mujoco")->make()->check_settings(m, {{"integrator", "CG"}}),
               std::invalid_argument);
}

// The keys every engine shares have one name and one unit, so that one bare --set reaches every
// engine that runs: each engine reports the loop-gap threshold it was given, in metres.
TEST(EngineTable, SharedKeysReachEveryEngine) {
  for (const EngineEntry& e : engine_table()) {
    const sim::SettingSchema& schema = e.make()->settings_schema();
    for (const char* key :
         {"dt", "max_steps", "gap_threshold", "driver_threshold", "singular_rcond", "perturb_link"})
      EXPECT_TRUE(std::any_of(schema.begin(), schema.end(),
                              [&](const sim::SettingSpec& s) { return s.name == key; }))
          << e.name << " does not take " << key;
  }
  const Mechanism m = load_mechanism(kFourbar);
  const MethodRun reference = run_reference(m);
  for (const EngineEntry& e : engine_table()) {
    const MethodRun run = run_method(e.name, m, reference, {{"gap_threshold", "0.5"}});
    ASSERT_TRUE(run.ok) << e.name << ": " << run.message;
    const auto row = std::find_if(run.settings.begin(), run.settings.end(),
                                  [](const auto& s) { return s.first == "gap_threshold"; });
    ASSERT_NE(row, run.settings.end()) << e.name;
    EXPECT_EQ(row->second, "0.5") << e.name;
  }
}

// What a run prints (EngineRun::settings, in every report) is its engine's schema: every entry
// declared for its kind of run, set or reported, in the declared order, and nothing else.
TEST(EngineTable, EveryRunPrintsItsSchema) {
  const std::string friction =
      std::string(CROSSLINK_SOURCE_DIR) + "/mechanisms/friction/slider_crank_friction.toml";
  for (const std::string& path : {kFourbar, kSqueezer, friction}) {
    const Mechanism m = load_mechanism(path);
    const sim::RunKind kind = m.dynamics ? sim::RunKind::dynamics : sim::RunKind::kinematic;
    const MethodRun reference = run_reference(m);
    for (const EngineEntry& e : engine_table()) {
      std::vector<std::string> declared;
      for (const sim::SettingSpec& s : e.make()->settings_schema())
        if (sim::applies(s, kind, m.has_friction(), m.has_cam())) declared.push_back(s.name);
      const MethodRun run = run_method(e.name, m, reference, {});
      if (!run.available && m.has_friction()) continue;  // an engine without joint friction
      ASSERT_TRUE(run.ok) << e.name << " on " << path << ": " << run.message;
      std::vector<std::string> printed;
      for (const auto& setting : run.settings) printed.push_back(setting.first);
      EXPECT_EQ(printed, declared) << e.name << " on " << path;
    }
  }
}

// The registry, the sweep and the tolerances read the one table.
TEST(EngineTable, EveryReaderListsEveryEngine) {
  std::vector<std::string> expected = {"analytic", "dyads", "ic"};
  for (const EngineEntry& e : engine_table()) expected.push_back(e.name);
  EXPECT_EQ(method_names(), expected);
  for (const bool dynamics : {false, true}) {
    const compare::Tolerances t(engine_tolerances(dynamics));
    for (const EngineEntry& e : engine_table()) {
      EXPECT_TRUE(t.is_engine(e.name)) << e.name;
      EXPECT_FALSE((dynamics ? e.dynamics_variants : e.variants).empty()) << e.name;
    }
    EXPECT_FALSE(t.is_engine("dyads"));
  }
}

// Every method is drawn in a style of its own, the engines' from their table rows: the compare
// page had styles for MuJoCo and Bullet only (ODE and Simbody were drawn alike) and the sweep page
// none for Simbody.
TEST(EngineTable, EveryMethodHasAStyleOfItsOwn) {
  std::vector<std::pair<std::string, std::vector<double>>> seen;
  for (const auto& [name, style] : method_styles()) {
    EXPECT_EQ(style.colour.size(), 7u) << name << ": " << style.colour;
    const std::pair<std::string, std::vector<double>> key{style.colour, style.dash};
    EXPECT_EQ(std::count(seen.begin(), seen.end(), key), 0) << name;
    seen.push_back(key);
  }
  EXPECT_EQ(seen.size(), method_names().size());
  for (const EngineEntry& e : engine_table()) EXPECT_FALSE(e.style.colour.empty()) << e.name;
}

}  // namespace
}  // namespace crosslink::methods
