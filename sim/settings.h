// The settings schema every engine declares once (SettingSpec: name, kind, default, the values it
// takes, the runs it applies to, one line of doc), and the readers behind it: parsing and checking
// --set NAME=VALUE before any run (SettingValues), the record every run prints
// (printed_settings), the listing of `crosslink engines` and the table of docs/engines.md
// (tests/methods/test_engines.cpp holds the table and the runs' records to the declarations).
// Each reader of input throws std::invalid_argument naming the setting, its text and what it
// takes, so that a bad value is bad input (exit 2), never a failed run.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/run_record.h"

namespace crosslink::sim {

// The values a numeric setting takes: from `low` to `high`, either end excluded when open.
struct SettingRange {
  double low = -std::numeric_limits<double>::infinity();
  double high = std::numeric_limits<double>::infinity();
  bool low_open = false, high_open = false;
};
constexpr SettingRange kPositive{0.0, std::numeric_limits<double>::infinity(), true};
constexpr SettingRange kNonNegative{0.0, std::numeric_limits<double>::infinity()};
constexpr SettingRange kRcond{0.0, 1.0};  // a reciprocal condition number

// A solver's iterations per step: one that has not converged in a million never will (the
// defaults are 20 and 50), and the count stays an int.
constexpr int kMostIterations = 1'000'000;

// A run's time grows with its steps (its memory does not: the run loops keep the last 16 poses):
// 2 million steps are about 5 s of MuJoCo.
constexpr long kDefaultMaxSteps = 2'000'000;
// The most steps a run may be allowed (the command line's --max-steps bound).
constexpr long kMostSteps = 1'000'000'000'000'000'000;

// A cam profile that is not a disc is an engine's convex mesh of this many facets a turn
// (the shared setting "cam_facets").
constexpr int kDefaultCamFacets = 1440;

enum class SettingKind {
  number,  // a finite number in `range`, or one of `words` ("auto": the engine decides)
  count,   // a whole number from 1 to `most`, or one of `words`
  choice,  // one of `words`
  text,    // free text the engine checks itself (`allowed` says what it takes)
};

// The kind of run a setting applies to: a kinematic run follows the driver's law; a dynamics run
// integrates forward dynamics under the applied effort.
enum class RunKind { kinematic, dynamics };
enum class AppliesTo { both, kinematic, dynamics };

struct SettingSpec {
  std::string name;
  SettingKind kind = SettingKind::number;
  std::string default_value = {};  // the value a run reads when the setting is not given
  std::string doc = {};            // one line: what it does
  SettingRange range = {};         // number
  long most = std::numeric_limits<int>::max();  // count
  long least = 1;                               // count
  std::vector<std::string> words = {};          // choice: its values; number, count: besides
  std::string allowed = {};                     // text: what it takes
  AppliesTo applies_to = AppliesTo::both;       // the runs that print it
  // A value the run reports (the steps it took, its mass model), not one the user sets: --set
  // refuses it; kind, default and values are unused.
  bool reported = false;
  // Joint friction's: read and printed only in a run of a mechanism with joint friction.
  bool friction = false;
  // Cam contact's: read and printed only in a run of a mechanism with a cam joint.
  bool contact = false;
};
using SettingSchema = std::vector<SettingSpec>;

// A setting every engine declares alike, by name: "max_steps", "perturb_link",
// "divergence_energy", "friction_load" (those that model joint friction), "cam_facets" (those
// that mesh a cam), and the reported
// "mass_model", "driver", "energy_scale"; and those Bullet, ODE and Simbody declare alike:
// "gap_threshold", "divergence_gap", "driver_threshold", "singular_rcond", "branch_distance",
// "energy_threshold" (std::logic_error for another name).
SettingSpec shared_setting(std::string_view name);

// The shared "friction_load" as a run prints it: `extrapolated` (the default) or the last step's.
std::pair<std::string, std::string> friction_load_value(bool extrapolated);
// A number in force as a run prints it: six significant digits.
std::string format_number(double v);

// What a setting takes, in words: "a positive number, or auto", "Euler, RK4 or implicit"; "reported
// by the run, not set" for a reported value.
std::string allowed_values(const SettingSpec& spec);

// Whether `spec` is printed by a run of this kind.
// `friction`: of a mechanism with joint friction (else its entries, SettingSpec::friction, do not
// apply); `contact`: of one with a cam joint (SettingSpec::contact).
bool applies(const SettingSpec& spec, RunKind run, bool friction = true, bool contact = true);

// What a run prints (EngineRun::settings): every entry `schema` declares for this kind of run,
// set or reported, in the schema's order, each with its value in force from `in_force` (by name:
// auto resolved, the step the run took). Throws std::logic_error when a declared entry has no
// value, or a value is given twice or for a name not declared for this kind of run: the printed
// list is the schema's.
// Joint friction's entries (SettingSpec::friction) only for a mechanism with it (`friction`), cam
// contact's (SettingSpec::contact) only for one with a cam joint (`contact`).
RunSettings printed_settings(const SettingSchema& schema, RunKind run, const RunSettings& in_force,
                             bool friction = false, bool contact = false);

// An engine's settings read against its schema: every declared setting's text (its default
// unless given; a later override wins), each override checked by its kind before any run.
class SettingValues {
 public:
  // Throws std::invalid_argument for a name `schema` does not declare ("unknown <engine> setting
  // ..." with the names it knows), a value it reports, or a value its kind does not take.
  SettingValues(const SettingSchema& schema, std::string_view engine, const RunSettings& overrides);
  const std::string& text(std::string_view name) const;
  bool given(std::string_view name) const;  // overridden, not the default
  bool is(std::string_view name, std::string_view word) const { return text(name) == word; }
  double number(std::string_view name) const;  // a number setting that holds a number
  long count(std::string_view name) const;     // a count setting that holds a count

 private:
  const SettingSpec& spec(std::string_view name) const;  // a declared setting, not reported
  const SettingSchema& schema_;
  std::vector<std::string> text_;  // per declared setting
  std::vector<bool> given_;
};

// A finite number in `range` (any finite number by default).
double setting_number(std::string_view name, const std::string& text,
                      const SettingRange& range = {});
// Finite numbers separated by spaces ("0.02 1").
std::vector<double> setting_numbers(std::string_view name, const std::string& text);
// A whole number from `least` to `most` ("50", "5e1"; not "2.5" nor "3e9" beyond an int).
long setting_count(std::string_view name, const std::string& text,
                   long most = std::numeric_limits<int>::max(), long least = 1);

// The test hook perturb_link = "<moving link>:<positive factor>": that link's points and line
// origins scaled, so the scene is assembled for a valid but wrong linkage. "" or "none": `m` as
// it is. The link must be a moving link of `m`.
Mechanism perturbed(const Mechanism& m, const std::string& text);

}  // namespace crosslink::sim
