// The loader's parts (internal to analytic/model/): the Reader that collects every problem of a
// definition at its place, the units a number is read in, and what one part of the loader asks
// of another. loader.cpp reads the top level and calls the others: loader_links.cpp (links,
// joints, gears; loader_cams.cpp for a cam joint), loader_drivers.cpp (drivers, [dynamics]),
// loader_loads.cpp (loads, springs), loader_outputs.cpp ([[derived]], the summary, [[reference]],
// [tolerance], [expect]).
#pragma once

#include <fmt/format.h>
#include <toml++/toml.h>
#include <Eigen/QR>
#include <Eigen/SparseLU>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <numbers>
#include <numeric>
#include <set>
#include "analytic/model/constraints.h"
#include "analytic/model/derived_spec.h"
#include "analytic/model/expression.h"
#include "analytic/model/fourbar.h"
#include "analytic/model/limits.h"
#include "analytic/model/loader.h"
#include "analytic/model/trajectory.h"
#include "analytic/model/units_text.h"

namespace crosslink::loading {

// [[driver]] tables: each is a row of the Jacobian and a column of every sample.
inline constexpr size_t kMostDrivers = 64;

inline std::string join(const std::vector<std::string>& names) {
  if (names.empty()) return "(none)";
  std::string text;
  for (const std::string& n : names) text += (text.empty() ? "" : ", ") + n;
  return text;
}

// How a number is read: SI per file unit, the unit's name for messages, and the magnitudes (SI)
// it may have (limits.h).
struct Scale {
  double si = 1.0;
  std::string_view unit;
  double largest = std::numeric_limits<double>::max();
  double smallest = 0.0;  // nonzero values below it are refused
};

// Collects every problem in a definition, each located by its TOML node.
class Reader {
 public:
  Reader(std::string file, std::string_view text) : file_(std::move(file)), text_(text) {}

  // The text of a node as written in the file (a value's literal), or "" if it spans lines.
  std::string literal(const toml::node& node) const {
    const toml::source_region& region = node.source();
    if (region.begin.line != region.end.line) return "";
    size_t start = 0;
    for (toml::source_index line = 1; line < region.begin.line; ++line) {
      start = text_.find('\n', start);
      if (start == std::string_view::npos) return "";
      ++start;
    }
    // toml++ counts columns in characters, not bytes.
    auto byte_of = [&](toml::source_index column) {
      size_t i = start;
      for (toml::source_index c = 1; c < column && i < text_.size(); ++c) {
        ++i;
        while (i < text_.size() && starts_nothing(text_[i])) ++i;  // the rest of a character
      }
      return i;
    };
    const size_t from = byte_of(region.begin.column), to = byte_of(region.end.column);
    return to <= text_.size() && from < to ? std::string(text_.substr(from, to - from)) : "";
  }

  SourceLocation at(const toml::source_region& region) const {
    return {file_, static_cast<int>(region.begin.line), static_cast<int>(region.begin.column)};
  }
  SourceLocation at(const toml::node& node) const { return at(node.source()); }
  SourceLocation at(const toml::node* node) const { return node ? at(*node) : file(); }
  // Byte `offset` of a string's value: that character when the string is written as it reads
  // (on one line, without escapes), else the string.
  SourceLocation at(const toml::value<std::string>& node, size_t offset) const {
    SourceLocation where = at(node);
    const std::string& value = node.get();
    const std::string written = literal(node);
    if (written.size() != value.size() + 2 || written.compare(1, value.size(), value) != 0)
      return where;
    const auto before = value.begin() + static_cast<std::ptrdiff_t>(std::min(offset, value.size()));
    where.column += 1 + static_cast<int>(std::count_if(value.begin(), before,
                                                       [](char c) { return !starts_nothing(c); }));
    return where;
  }
  // The nearest place for what has none of its own (a missing top-level table): the file's
  // first line, so every diagnostic reads file:line:column.
  SourceLocation file() const { return {file_, 1, 1}; }
  // Where something missing from `table` belongs: the table's header, or the file for the root.
  SourceLocation inside(const toml::table& table) const {
    return &table == root_ ? file() : at(table);
  }
  void set_root(const toml::table& root) { root_ = &root; }
  // Radians per angle unit of the file, for the trigonometric functions of expressions: [units]
  // is read before any number.
  void set_angle_unit(double radians) { angle_unit_ = radians; }

  void error(SourceLocation where, std::string message) {
    diagnostics_.push_back({std::move(where), std::move(message)});
  }
  const std::vector<Diagnostic>& diagnostics() const { return diagnostics_; }
  // Rewrites `from` as `to` in the messages said from diagnostic `first` on: one [[driver]]'s
  // faults name it as the one-driver form's name [driver].
  void relabel(size_t first, std::string_view from, const std::string& to) {
    for (size_t i = first; i < diagnostics_.size(); ++i) {
      std::string& text = diagnostics_[i].message;
      for (size_t at = text.find(from); at != std::string::npos;
           at = text.find(from, at + to.size()))
        text.replace(at, from.size(), to);
    }
  }
  void throw_if_any() const {
    if (!diagnostics_.empty()) throw DefinitionError(diagnostics_);
  }

  // Every key of `table` must be one of `allowed`.
  void known_keys(const toml::table& table, std::string_view what,
                  const std::vector<std::string>& allowed) {
    for (auto&& [key, node] : table) {
      if (std::find(allowed.begin(), allowed.end(), key.str()) == allowed.end())
        error(at(key.source()), fmt::format("unknown key '{}' in {} (valid keys: {})", key.str(),
                                            what, join(allowed)));
    }
  }

  std::optional<std::string> string(const toml::table& table, std::string_view key,
                                    std::string_view what, bool required) {
    const toml::node* node = table.get(key);
    if (!node) {
      if (required) error(inside(table), fmt::format("{} needs '{}' (a string)", what, key));
      return std::nullopt;
    }
    if (const auto* value = node->as_string()) return value->get();
    error(at(*node), fmt::format("'{}' in {} must be a string", key, what));
    return std::nullopt;
  }

  // A number converted to SI by `scale`, refused when it is not finite or is outside the
  // scale's magnitudes (so that no product or quotient of it overflows). A string is an
  // expression (analytic/model/expression.h) in the file's units, whose value is checked the same
  // way.
  std::optional<double> number(const toml::node& node, std::string_view what,
                               const Scale& scale = {}) {
    std::optional<double> value;
    if (const auto* f = node.as_floating_point()) value = f->get();
    if (const auto* i = node.as_integer()) value = static_cast<double>(i->get());
    if (const auto* s = node.as_string()) {
      const Evaluation e = evaluate(s->get(), angle_unit_);
      if (!e.ok()) {
        error(at(*s, e.offset), fmt::format("{} = \"{}\": {}", what, shortened(s->get()), e.error));
        return std::nullopt;
      }
      value = e.value;
    }
    if (!value) {
      error(at(node),
            fmt::format("{} must be a number, or an expression in quotes (\"2.5 + 1/3\")", what));
      return std::nullopt;
    }
    if (!std::isfinite(*value)) {
      error(at(node), fmt::format("{} must be finite", what));
      return std::nullopt;
    }
    const double si = *value * scale.si;
    // (fmt, not " " + string: GCC 12 warns -Wrestrict, a false positive, on the inlined +)
    const std::string unit = scale.unit.empty() ? "" : fmt::format(" {}", scale.unit);
    if (!(std::abs(si) <= scale.largest)) {
      error(at(node), fmt::format("{} = {}{} is too large: the limit is {:g}{}", what, *value, unit,
                                  scale.largest / scale.si, unit));
      return std::nullopt;
    }
    // A nonzero value that underflows (5e-324 rpm is 0 rad/s) is no more usable than one below
    // the key's own floor: it would silently become 0.
    const double smallest = std::max(scale.smallest, std::numeric_limits<double>::min());
    if (*value != 0.0 && !(std::abs(si) >= smallest)) {
      error(at(node), fmt::format("{} = {}{} is too small: the limit is {:g}{}", what, *value, unit,
                                  smallest / scale.si, unit));
      return std::nullopt;
    }
    return si;
  }

  std::optional<double> number(const toml::table& table, std::string_view key,
                               std::string_view what, bool required, const Scale& scale = {}) {
    const toml::node* node = table.get(key);
    if (!node) {
      if (required) error(inside(table), fmt::format("{} needs '{}' (a number)", what, key));
      return std::nullopt;
    }
    return number(*node, fmt::format("'{}' in {}", key, what), scale);
  }

  // A fixed-length array of numbers, e.g. [x, y] or [x, y, angle], each in SI by its scale.
  std::optional<std::vector<double>> numbers(const toml::node& node, std::string_view what,
                                             const std::vector<Scale>& scales) {
    const auto* array = node.as_array();
    if (!array || array->size() != scales.size()) {
      error(at(node), fmt::format("{} must be an array of {} numbers", what, scales.size()));
      return std::nullopt;
    }
    std::vector<double> values;
    for (size_t k = 0; k < scales.size(); ++k) {
      const std::optional<double> v = number((*array)[k], what, scales[k]);
      if (!v) return std::nullopt;
      values.push_back(*v);
    }
    return values;
  }

  const toml::table* table(const toml::table& parent, std::string_view key, std::string_view what,
                           bool required) {
    const toml::node* node = parent.get(key);
    if (!node) {
      if (required) error(inside(parent), fmt::format("{} needs a [{}] table", what, key));
      return nullptr;
    }
    if (const auto* t = node->as_table()) return t;
    error(at(*node), fmt::format("'{}' must be a table", key));
    return nullptr;
  }

  // The array of tables [[key]], or nullptr (absent, or an error said: not an array of tables,
  // or more than `limit` of them when a limit is given).
  const toml::array* tables(const toml::table& parent, std::string_view key, size_t limit = 0) {
    const toml::node* node = parent.get(key);
    if (!node) return nullptr;
    const auto* array = node->as_array();
    if (!array || !array->is_array_of_tables()) {
      error(at(*node), fmt::format("'{0}' must be an array of tables ([[{0}]])", key));
      return nullptr;
    }
    if (limit > 0 && array->size() > limit) {
      error(at(*node),
            fmt::format("{} [[{}]] entries: the limit is {}", array->size(), key, limit));
      return nullptr;
    }
    return array;
  }

 private:
  // A UTF-8 continuation byte: it starts no character.
  static bool starts_nothing(char c) { return (static_cast<unsigned char>(c) & 0xC0) == 0x80; }

  // An expression as a message quotes it: its first line, at most 60 bytes.
  static std::string shortened(std::string_view text) {
    size_t end = std::min(text.find('\n'), size_t{60});
    if (end >= text.size()) return std::string(text);
    while (end > 0 && starts_nothing(text[end])) --end;
    return std::string(text.substr(0, end)) + "...";
  }

  std::string file_;
  std::string_view text_;
  const toml::table* root_ = nullptr;
  double angle_unit_ = 1.0;
  std::vector<Diagnostic> diagnostics_;
};

struct UnitChoice {
  std::string_view name;
  double si;
};
inline constexpr UnitChoice kLengthUnits[] = {
    {"mm", 1e-3}, {"cm", 1e-2}, {"m", 1.0}, {"in", 0.0254}, {"ft", 0.3048}};
inline constexpr UnitChoice kAngleUnits[] = {{"deg", std::numbers::pi / 180.0}, {"rad", 1.0}};
inline constexpr UnitChoice kMassUnits[] = {{"kg", 1.0}, {"g", 1e-3}};
inline constexpr UnitChoice kForceUnits[] = {{"N", 1.0}, {"kN", 1e3}};
inline constexpr UnitChoice kAngularSpeedUnits[] = {{"rad/s", 1.0},
                                                    {"deg/s", std::numbers::pi / 180.0},
                                                    {"rpm", 2.0 * std::numbers::pi / 60.0},
                                                    {"rev/s", 2.0 * std::numbers::pi}};
inline constexpr UnitChoice kAngularAccelerationUnits[] = {{"rad/s^2", 1.0},
                                                           {"deg/s^2", std::numbers::pi / 180.0},
                                                           {"rpm/s", 2.0 * std::numbers::pi / 60.0},
                                                           {"rev/s^2", 2.0 * std::numbers::pi}};

template <size_t N>
std::optional<double> unit_factor(Reader& r, const toml::table& table, std::string_view what,
                                  std::string_view key, const UnitChoice (&choices)[N],
                                  std::string_view fallback, std::string* name_out = nullptr) {
  std::vector<std::string> names;
  for (const UnitChoice& c : choices) names.emplace_back(c.name);
  const std::string name = r.string(table, key, what, false).value_or(std::string(fallback));
  for (const UnitChoice& c : choices)
    if (c.name == name) {
      if (name_out) *name_out = name;
      return c.si;
    }
  r.error(r.at(table.get(key)),
          fmt::format("unknown unit '{}' for '{}' (valid units: {})", name, key, join(names)));
  return std::nullopt;
}

inline Scale length_scale(const Units& units) {
  return {units.length, units.length_name, limits::kLength};
}
inline Scale angle_scale(const Units& units) {
  return {units.angle, units.angle_name, limits::kAngle};
}
// The driver's start (as drawn), and the values it is swept or solved to: angles, or lengths
// for a slider.
inline Scale start_scale(const Mechanism& m, const Driver& d) {
  return d.angular() ? angle_scale(m.units) : length_scale(m.units);
}
inline Scale driver_scale(const Mechanism& m, const Driver& d) {
  if (!d.angular()) return length_scale(m.units);
  return {m.units.angle, m.units.angle_name, limits::kDriverValue};
}

inline std::vector<std::string> point_names(const Link& link) {
  std::vector<std::string> names;
  for (const Point& p : link.points) names.push_back(p.name);
  return names;
}

// loader_links.cpp: links, their points and masses, joints and gear pairs.
Link read_link(Reader& r, const toml::table& t, const Units& units, int index);
std::vector<std::string> link_names(const Mechanism& m);
int resolve_link(Reader& r, const Mechanism& m, const toml::table& t, std::string_view key,
                 std::string_view what);
int resolve_point(Reader& r, const Mechanism& m, int link, const toml::node* node,
                  const std::string& name, std::string_view what);
int resolve_line(Reader& r, const Mechanism& m, int link, const toml::node* node,
                 const std::string& name, std::string_view what);
// A link's frame in the world as drawn (the origin where no pose is given), and a point of it.
Eigen::Vector3d drawn_pose(const Link& link);
Eigen::Vector2d drawn_point(const Link& link, const Eigen::Vector2d& local);
Joint read_joint(Reader& r, const Mechanism& m, const toml::table& t, int index);
// loader_cams.cpp: a cam joint and its profile.
Joint read_cam(Reader& r, const Mechanism& m, const toml::table& t, const std::string& what);
void read_gearing(Reader& r, Mechanism& m, const toml::table& t, int index);
// Joint friction the rest of the definition allows: journals that fit their links, and what is
// not modelled yet (beside gear pairs, in [dynamics]).
void check_friction(Reader& r, const Mechanism& m);

// loader_drivers.cpp: drivers, their laws, locked drivers, [dynamics] free coordinates.
void read_drivers(Reader& r, Mechanism& m, const toml::table& root);
void check_locked(Reader& r, const Mechanism& m);
void read_dynamics(Reader& r, Mechanism& m, const toml::table& root);
bool refused_in_time(Reader& r, const Mechanism& m, const SourceLocation& where,
                     std::string_view message);
bool refused_in_time(Reader& r, const Mechanism& m, const toml::array& tables,
                     std::string_view message);

// loader_outputs.cpp: [[derived]], the design summary, [[reference]], [tolerance], [expect].
void read_derived(Reader& r, Mechanism& m, const toml::table& root);
void add_design_summary(Reader& r, Mechanism& m, const toml::table& root);
void read_references(Reader& r, Mechanism& m, const toml::table& root);
void read_tolerances(Reader& r, Mechanism& m, const toml::table& root);
void read_expect(Reader& r, Mechanism& m, const toml::table& root);

// loader_loads.cpp: loads and springs.
void read_loads(Reader& r, Mechanism& m, const toml::table& root);
void read_springs(Reader& r, Mechanism& m, const toml::table& root);

}  // namespace crosslink::loading
