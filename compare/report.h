// Reports of a Comparison: console table, JSON (the machine interface, docs/json.md), CSV (per
// sample) and a self-contained HTML page with charts (docs/report.md).
#pragma once

#include <cstdio>
#include <map>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/kinematics/instant_centres.h"
#include "compare/comparison.h"

namespace crosslink::compare {

// How a channel is shown in the definition's units: file value = SI value / scale.
struct DisplayUnit {
  double scale = 1.0;
  std::string name;  // "cm/s", "deg", "rad/s^2"
};
DisplayUnit display_unit(const Mechanism& mechanism, std::string_view channel);
// The unit of a position along the sweep: the swept driver's, or s for a sweep in time.
DisplayUnit driver_unit(const Mechanism& mechanism);
// Whether the samples are in time, the abscissa of the tables and charts: a forward-dynamics
// case, or several drivers (each at its law's value at t).
bool samples_in_time(const Mechanism& mechanism);
// A driver value [SI] as the console tables show it, in the file's units: an angle past one turn
// (|value| > 360 deg) within its turn, with the whole turns it is past counted (548.37 deg is
// 188.37 deg, turns +1; 720 deg is 360 deg, turns +1; -400 deg is -40 deg, turns -1). JSON and
// CSV keep the value as swept (docs/json.md).
struct DriverTurns {
  double within = 0.0;  // file units
  long turns = 0;
};
DriverTurns driver_turns(const Mechanism& mechanism, double value);
// "188.37 deg +1 turn", "45.00 deg", "12.50 mm" with `decimals`.
std::string driver_text(const Mechanism& mechanism, double value, int decimals);

// A [[reference]] row's verdict as the tables show it: "pass (2 %)", "FAIL (rounding)"; a row not
// judged: "within rounding" or "".
std::string reference_note(const ReferenceRow& row);
// Why a judged row does not hold, with its place in the file: "[[reference]] omega.coupler at
// driver = 30.00 deg (m.toml:12:1): printed 365, exact 370.1: 1.38 % from it > its tolerance 1 %".
std::string reference_failure_text(const Mechanism& mechanism, const ReferenceRow& row);

struct ConsoleOptions {
  bool all = false;     // every channel x method row instead of the summary
  int worst_rows = 12;  // channels listed in the summary besides the failing ones
};
void print_console(const Comparison& comparison, std::FILE* out, const ConsoleOptions& options);

// The `compare` JSON document (docs/json.md, section compare). SI units throughout.
nlohmann::json to_json(const Comparison& comparison);

// One row per (method, channel, sample), SI units.
void write_csv(const Comparison& comparison, std::ostream& out);
// A number of a CSV file: the shortest text that reads back as the same double (fmt's "{}"), or
// an empty field for a value that does not exist (NaN, infinite).
std::string csv_number(double value);
// A text field of a CSV file (RFC 4180): as it is, or in double quotes with each quote doubled
// when it holds a comma, a quote or a line break (a link named "arm, left" stays one column).
// Every CSV writer of crosslink writes its names through it.
std::string csv_field(std::string_view text);

// The pose a report draws and its instantaneous centres, solved by the exact methods before the
// page is written (methods::drawing).
struct Drawing {
  double at = 0.0;     // the driver value [rad or m]; with several drivers a time [s]
  bool asked = false;  // `at` was asked for (--at), not the default start
  Trajectory pose;     // one sample: the exact pose there (its status says whether it exists)
  std::optional<InstantCentres> centres;  // where the pose is usable
};

struct HtmlOptions {
  Drawing drawing;  // required: the page draws it
  // Folders to look for vega.min.js, vega-lite.min.js, vega-embed.min.js in (flat, or as an npm
  // node_modules tree), before $CROSSLINK_REPORT_ASSETS and the compiled-in source tree.
  std::vector<std::string> asset_dirs;
  // What the command line set, so that the page tells it from the defaults ("Settings in force").
  std::optional<double> step;           // --step [rad or m]; nullopt: the default
  std::vector<std::string> tolerances;  // --tolerance as given: "velocity=0.5", "dyads:angle=1"
  std::vector<std::string> settings;    // --set as given: "dt=1e-4", "mujoco:dt=1e-4"
  std::optional<double> accuracy;       // --accuracy [%]: the engines' tolerance, chosen dt
  // Each method's line in the charts (methods::method_styles); a method without one is drawn
  // plain.
  std::map<std::string, LineStyle> styles;
};
// The folder the chart scripts were found in, or nullopt (the message says where it looked).
std::optional<std::string> find_report_assets(const std::vector<std::string>& extra_dirs,
                                              std::string* searched = nullptr);
// Writes the page; throws std::runtime_error when the chart scripts cannot be found.
void write_html(const Comparison& comparison, const HtmlOptions& options, std::ostream& out);

// The page frame every crosslink HTML report shares (compare, sweep): the head with the shared
// style plus `extra_style` and the three chart scripts inlined, and at the end the REPORT data
// object and the page's own script. Throws std::runtime_error when the chart scripts cannot be
// found (the message says where it looked).
void write_page_head(std::string_view title, std::string_view extra_style,
                     const std::vector<std::string>& asset_dirs, std::ostream& out);
void write_page_tail(std::string_view report_json, std::string_view page_script, std::ostream& out);
// Text escaped for HTML element content and attribute values.
std::string html_escape(std::string_view text);

}  // namespace crosslink::compare
