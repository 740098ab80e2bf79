#include "analytic/model/loader.h"

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
#include "analytic/model/trajectory.h"
#include "analytic/model/units_text.h"

namespace crosslink {
namespace {

// [[driver]] tables: each is a row of the Jacobian and a column of every sample.
constexpr size_t kMostDrivers = 64;

std::string join(const std::vector<std::string>& names) {
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
    const std::string unit = scale.unit.empty() ? "" : " " + std::string(scale.unit);
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
constexpr UnitChoice kLengthUnits[] = {
    {"mm", 1e-3}, {"cm", 1e-2}, {"m", 1.0}, {"in", 0.0254}, {"ft", 0.3048}};
constexpr UnitChoice kAngleUnits[] = {{"deg", std::numbers::pi / 180.0}, {"rad", 1.0}};
constexpr UnitChoice kMassUnits[] = {{"kg", 1.0}, {"g", 1e-3}};
constexpr UnitChoice kForceUnits[] = {{"N", 1.0}, {"kN", 1e3}};
constexpr UnitChoice kAngularSpeedUnits[] = {{"rad/s", 1.0},
                                             {"deg/s", std::numbers::pi / 180.0},
                                             {"rpm", 2.0 * std::numbers::pi / 60.0},
                                             {"rev/s", 2.0 * std::numbers::pi}};
constexpr UnitChoice kAngularAccelerationUnits[] = {{"rad/s^2", 1.0},
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

Scale length_scale(const Units& units) {
  return {units.length, units.length_name, limits::kLength};
}
Scale angle_scale(const Units& units) {
  return {units.angle, units.angle_name, limits::kAngle};
}
// The driver's start (as drawn), and the values it is swept or solved to: angles, or lengths
// for a slider.
Scale start_scale(const Mechanism& m, const Driver& d) {
  return d.angular() ? angle_scale(m.units) : length_scale(m.units);
}
Scale driver_scale(const Mechanism& m, const Driver& d) {
  if (!d.angular()) return length_scale(m.units);
  return {m.units.angle, m.units.angle_name, limits::kDriverValue};
}

std::vector<std::string> point_names(const Link& link) {
  std::vector<std::string> names;
  for (const Point& p : link.points) names.push_back(p.name);
  return names;
}

// A link's `mass`, `com` and `inertia`: all three or none (then the default model, filled in
// once the mechanism's size is known).
void read_mass(Reader& r, const toml::table& t, const Units& units, Link& link) {
  const std::string what = fmt::format("link '{}'", link.name);
  const toml::node* mass = t.get("mass");
  const toml::node* com = t.get("com");
  const toml::node* inertia = t.get("inertia");
  if (!mass) {
    if (com || inertia)
      r.error(r.at(com ? com : inertia),
              fmt::format("{} gives '{}' but no 'mass': give mass, com and inertia together, or "
                          "none for the default model",
                          what, com ? "com" : "inertia"));
    return;
  }
  if (!com || !inertia) {
    r.error(r.at(*mass),
            fmt::format("{} gives 'mass' but no '{}': give mass, com (a point name or [x, y]) "
                        "and inertia (about the centre of mass; 0 for a point mass) together",
                        what, com ? "inertia" : "com"));
    return;
  }
  const std::optional<double> m = r.number(*mass, fmt::format("'mass' of {}", what),
                                           Scale{units.mass, units.mass_name, limits::kMass});
  const std::optional<double> i =
      r.number(*inertia, fmt::format("'inertia' of {}", what),
               Scale{units.mass * units.length * units.length, "", limits::kInertia});
  if (m && *m < 0.0) r.error(r.at(*mass), fmt::format("{}: 'mass' must not be negative", what));
  if (i && *i < 0.0)
    r.error(r.at(*inertia), fmt::format("{}: 'inertia' must not be negative", what));
  if (m && i && *m == 0.0 && *i > 0.0)
    r.error(r.at(*mass), fmt::format("{}: a link of zero mass cannot have inertia {}", what, *i));
  std::optional<Eigen::Vector2d> centre;
  if (const auto* name = com->as_string()) {
    const int p = link.find_point(name->get());
    if (p < 0)
      r.error(r.at(*com), fmt::format("{}: 'com' names point '{}', which is not on it (its "
                                      "points: {})",
                                      what, name->get(), join(point_names(link))));
    else
      centre = link.points[static_cast<size_t>(p)].local;
  } else if (const auto xy =
                 r.numbers(*com, fmt::format("'com' of {} (a point name or [x, y])", what),
                           {length_scale(units), length_scale(units)})) {
    centre = Eigen::Vector2d((*xy)[0], (*xy)[1]);
  }
  if (!m || !i || !centre || *m < 0.0 || *i < 0.0) return;
  link.mass.mass = *m;
  link.mass.inertia = *i;
  link.mass.com = *centre;
  link.mass.assumed = false;
}

// A polar point: `length` from point `from` of the same link, at `angle` counter-clockwise
// from the link's x axis, or from the direction from -> `toward` when that is given.
struct PolarPoint {
  std::string from;
  std::optional<std::string> toward;  // none: the x axis
  const toml::node* from_node = nullptr;
  const toml::node* toward_node = nullptr;
  double length = 0.0, angle = 0.0;  // SI
};

// Reads `{ from = "P", length = l, angle = a [, toward = "Q"] }`, with `names` the points of
// its link; nullopt after its errors.
std::optional<PolarPoint> read_polar(Reader& r, const toml::table& t, const std::string& what,
                                     const std::string& link, const std::vector<std::string>& names,
                                     const Units& units) {
  r.known_keys(t, what, {"from", "toward", "length", "angle"});
  const std::optional<std::string> from = r.string(t, "from", what, true);
  const std::optional<std::string> toward = r.string(t, "toward", what, false);
  const std::optional<double> length = r.number(t, "length", what, true, length_scale(units));
  const std::optional<double> angle = r.number(t, "angle", what, true, angle_scale(units));
  bool good = from && length && angle && (toward || !t.get("toward"));
  for (const auto& [key, name] : {std::pair{"from", from}, std::pair{"toward", toward}})
    if (name && std::find(names.begin(), names.end(), *name) == names.end()) {
      r.error(r.at(t.get(key)), fmt::format("{}: '{}' names point '{}', which is not on link '{}' "
                                            "(its points: {})",
                                            what, key, *name, link, join(names)));
      good = false;
    }
  if (from && toward && *from == *toward) {
    r.error(r.at(t.get("toward")),
            fmt::format("{}: 'from' and 'toward' are both '{}': the angle is measured from the "
                        "direction from -> toward, which needs two points",
                        what, *toward));
    good = false;
  }
  // A point at distance 0 would have no use for its angle; a negative distance is an angle
  // a half turn off.
  if (length && *length <= 0.0) {
    r.error(r.at(t.get("length")),
            fmt::format("{}: 'length' must be positive (the distance from '{}')", what,
                        from.value_or("from")));
    good = false;
  }
  if (!good) return std::nullopt;
  return PolarPoint{*from, toward, t.get("from"), t.get("toward"), *length, *angle};
}

// A link's points, [x, y] or polar (read_polar) in the link's frame, kept in the table's order.
// A polar point may refer to points listed after it, or polar themselves: each is placed once
// the points it refers to are, and a circle of references is reported once.
void read_points(Reader& r, const toml::table& points, const Units& units, Link& link) {
  std::vector<std::string> names;
  for (auto&& [key, node] : points) names.emplace_back(key.str());
  std::map<std::string, Eigen::Vector2d> placed;
  std::map<std::string, PolarPoint> waiting;
  std::set<std::string> failed;  // reported; what refers to them is not placed, silently
  for (auto&& [key, node] : points) {
    const std::string name(key.str());
    const std::string what = fmt::format("point '{}' of link '{}'", name, link.name);
    std::optional<PolarPoint> polar;
    std::optional<std::vector<double>> xy;
    if (const toml::table* t = node.as_table())
      polar = read_polar(r, *t, what, link.name, names, units);
    else if (node.is_array())
      xy = r.numbers(node, what, {length_scale(units), length_scale(units)});
    else
      r.error(r.at(node), fmt::format("{} must be [x, y] or {{ from = \"P\", length = ..., "
                                      "angle = ... }}",
                                      what));
    if (polar)
      waiting.emplace(name, *polar);
    else if (xy)
      placed.emplace(name, Eigen::Vector2d((*xy)[0], (*xy)[1]));
    else
      failed.insert(name);
  }

  // Where a polar point is, once the points it refers to are placed or have failed; nullopt
  // when one failed (reported) or they are one place.
  auto place = [&](const std::string& name, const PolarPoint& p) -> std::optional<Eigen::Vector2d> {
    if (failed.count(p.from) || (p.toward && failed.count(*p.toward))) return std::nullopt;
    const Eigen::Vector2d& from = placed.at(p.from);
    double zero = 0.0;  // the angle's zero: the x axis, or the direction from -> toward
    if (p.toward) {
      const Eigen::Vector2d d = placed.at(*p.toward) - from;
      if (d.norm() < 1e-12) {
        r.error(r.at(p.toward_node),
                fmt::format("point '{}' of link '{}' is measured from the direction '{}' -> '{}', "
                            "but they are the same place",
                            name, link.name, p.from, *p.toward));
        return std::nullopt;
      }
      zero = std::atan2(d.y(), d.x());
    }
    return from + p.length * Eigen::Vector2d(std::cos(zero + p.angle), std::sin(zero + p.angle));
  };
  // Place what can be placed until nothing more can; what waits then is on a circle or
  // refers to one.
  auto done = [&](const std::string& name) { return placed.count(name) || failed.count(name); };
  for (bool progress = true; progress;) {
    progress = false;
    for (auto it = waiting.begin(); it != waiting.end();) {
      const PolarPoint& p = it->second;
      if (!done(p.from) || (p.toward && !done(*p.toward))) {
        ++it;
        continue;
      }
      if (const std::optional<Eigen::Vector2d> xy = place(it->first, p))
        placed.emplace(it->first, *xy);
      else
        failed.insert(it->first);
      it = waiting.erase(it);
      progress = true;
    }
  }
  std::set<std::string> reported;
  for (const auto& entry : waiting) {
    // Follow the references that wait until one repeats: the circle. via[k] is the key by
    // which path[k] refers to path[k + 1].
    std::vector<std::string> path{entry.first};
    std::vector<const toml::node*> via;
    size_t start = 0;
    for (;;) {
      const PolarPoint& q = waiting.at(path.back());
      const bool by_from = waiting.count(q.from) > 0;
      via.push_back(by_from ? q.from_node : q.toward_node);
      path.push_back(by_from ? q.from : *q.toward);
      start = static_cast<size_t>(std::find(path.begin(), path.end(), path.back()) - path.begin());
      if (start + 1 < path.size()) break;
    }
    if (reported.count(path[start])) continue;
    std::string circle;
    for (size_t k = start; k < path.size(); ++k) circle += (k == start ? "" : " -> ") + path[k];
    reported.insert(path.begin() + static_cast<std::ptrdiff_t>(start), path.end());
    r.error(r.at(via[start]),
            fmt::format("points of link '{}' are measured from one another in a circle: {} "
                        "(give one of them as [x, y]; its points: {})",
                        link.name, circle, join(names)));
  }

  for (auto&& [key, node] : points)
    if (const auto p = placed.find(std::string(key.str())); p != placed.end())
      link.points.push_back({p->first, p->second, r.at(node)});
}

// Reads one [[link]] entry.
Link read_link(Reader& r, const toml::table& t, const Units& units, int index) {
  Link link;
  const std::string what = fmt::format("link #{}", index + 1);
  r.known_keys(
      t, what,
      {"name", "ground", "points", "lines", "pose", "description", "mass", "com", "inertia"});
  link.where = r.at(t);
  link.name = r.string(t, "name", what, true).value_or(fmt::format("link{}", index + 1));
  if (const toml::node* g = t.get("ground")) {
    if (const auto* b = g->as_boolean())
      link.ground = b->get();
    else
      r.error(r.at(*g), "'ground' must be true or false");
  }

  const toml::table* points = r.table(t, "points", fmt::format("link '{}'", link.name), true);
  if (points && points->size() > limits::kPoints) {
    r.error(r.at(*points), fmt::format("link '{}' has {} points: the limit is {} in all links",
                                       link.name, points->size(), limits::kPoints));
  } else if (points) {
    if (points->empty()) r.error(r.at(*points), fmt::format("link '{}' has no points", link.name));
    read_points(r, *points, units, link);
  }

  const toml::table* lines = r.table(t, "lines", what, false);
  if (lines && lines->size() > limits::kLines) {
    r.error(r.at(*lines), fmt::format("link '{}' has {} lines: the limit is {} in all links",
                                      link.name, lines->size(), limits::kLines));
  } else if (lines) {
    for (auto&& [key, node] : *lines) {
      const std::string line_what = fmt::format("line '{}' of link '{}'", key.str(), link.name);
      const auto* lt = node.as_table();
      if (!lt) {
        r.error(r.at(node), fmt::format("{} must be a table {{ through = \"P\", angle = ... }} or "
                                        "{{ through = \"P\", toward = \"Q\" }}",
                                        line_what));
        continue;
      }
      r.known_keys(*lt, line_what, {"through", "toward", "angle"});
      Line line;
      line.name = std::string(key.str());
      line.where = r.at(node);
      const std::optional<std::string> through = r.string(*lt, "through", line_what, true);
      const int from = through ? link.find_point(*through) : -1;
      if (through && from < 0) {
        std::vector<std::string> names;
        for (const Point& p : link.points) names.push_back(p.name);
        r.error(r.at(lt->get("through")),
                fmt::format("{}: point '{}' is not on link '{}' (its points: {})", line_what,
                            *through, link.name, join(names)));
        continue;
      }
      if (from < 0) continue;
      line.origin = link.points[from].local;
      const std::optional<std::string> toward = r.string(*lt, "toward", line_what, false);
      if ((lt->get("toward") != nullptr) == (lt->get("angle") != nullptr)) {
        r.error(line.where,
                fmt::format("{} needs exactly one of 'toward' (a point) or 'angle'", line_what));
        continue;
      }
      const std::optional<double> angle =
          r.number(*lt, "angle", line_what, false, angle_scale(units));
      if (!toward && !angle) continue;  // reported
      if (toward) {
        const int to = link.find_point(*toward);
        if (to < 0) {
          r.error(r.at(lt->get("toward")),
                  fmt::format("{}: point '{}' is not on link '{}'", line_what, *toward, link.name));
          continue;
        }
        const Eigen::Vector2d d = link.points[to].local - line.origin;
        if (d.norm() < 1e-12) {
          r.error(r.at(lt->get("toward")),
                  fmt::format("{} is degenerate: '{}' and '{}' are the same place", line_what,
                              *through, *toward));
          continue;
        }
        line.direction = d.normalized();
      } else {
        line.direction = Eigen::Vector2d(std::cos(*angle), std::sin(*angle));
      }
      if (link.find_line(line.name) >= 0)
        r.error(line.where, fmt::format("duplicate line name '{}'", line.name));
      link.lines.push_back(line);
    }
  }

  if (const toml::node* pose = t.get("pose")) {
    link.pose_where = r.at(*pose);
    if (const auto p = r.numbers(*pose, fmt::format("pose of link '{}' ([x, y, angle])", link.name),
                                 {length_scale(units), length_scale(units), angle_scale(units)}))
      link.pose = Eigen::Vector3d((*p)[0], (*p)[1], (*p)[2]);
  }
  read_mass(r, t, units, link);
  return link;
}

std::vector<std::string> link_names(const Mechanism& m) {
  std::vector<std::string> names;
  for (const Link& l : m.links) names.push_back(l.name);
  return names;
}

// Resolves a link name from key `key` of `t`; reports an unknown name with the valid ones.
int resolve_link(Reader& r, const Mechanism& m, const toml::table& t, std::string_view key,
                 std::string_view what) {
  const std::optional<std::string> name = r.string(t, key, what, true);
  if (!name) return -1;
  const int index = m.find_link(*name);
  if (index < 0)
    r.error(r.at(t.get(key)), fmt::format("{}: unknown link '{}' (valid links: {})", what, *name,
                                          join(link_names(m))));
  return index;
}

int resolve_point(Reader& r, const Mechanism& m, int link, const toml::node* node,
                  const std::string& name, std::string_view what) {
  const int index = m.links[link].find_point(name);
  if (index < 0)
    r.error(r.at(node), fmt::format("{}: point '{}' is not on link '{}' (its points: {})", what,
                                    name, m.links[link].name, join(point_names(m.links[link]))));
  return index;
}

// A link's frame in the world as drawn (the origin where no pose is given).
Eigen::Vector3d drawn_pose(const Link& link) {
  return link.pose.value_or(Eigen::Vector3d::Zero());
}

Joint read_joint(Reader& r, const Mechanism& m, const toml::table& t, int index) {
  Joint joint;
  joint.where = r.at(t);
  const std::string what = fmt::format("joint #{}", index + 1);
  const std::string type = r.string(t, "type", what, true).value_or("");
  if (type == "revolute") {
    r.known_keys(t, what + " (revolute)", {"type", "name", "links", "point"});
    joint.type = JointType::revolute;
    const toml::node* links = t.get("links");
    const auto* array = links ? links->as_array() : nullptr;
    if (!array || array->size() != 2 || !(*array)[0].is_string() || !(*array)[1].is_string()) {
      r.error(links ? r.at(*links) : joint.where,
              fmt::format("{} needs 'links' = [\"first\", \"second\"] (two link names)", what));
      return joint;
    }
    const std::optional<std::string> point = r.string(t, "point", what, true);
    joint.name = r.string(t, "name", what, false).value_or(point.value_or(""));
    int* ends[2] = {&joint.link_a, &joint.link_b};
    int* pts[2] = {&joint.point_a, &joint.point_b};
    for (int e = 0; e < 2; ++e) {
      const std::string name = *(*array)[static_cast<size_t>(e)].value<std::string>();
      *ends[e] = m.find_link(name);
      if (*ends[e] < 0) {
        r.error(r.at((*array)[static_cast<size_t>(e)]),
                fmt::format("{}: unknown link '{}' (valid links: {})", what, name,
                            join(link_names(m))));
        continue;
      }
      if (point) *pts[e] = resolve_point(r, m, *ends[e], t.get("point"), *point, what);
    }
    if (joint.link_a >= 0 && joint.link_a == joint.link_b)
      r.error(r.at(*links),
              fmt::format("{} joins link '{}' to itself", what, m.links[joint.link_a].name));
    return joint;
  }
  if (type == "prismatic" || type == "pin_in_slot") {
    joint.type = type == "prismatic" ? JointType::prismatic : JointType::pin_in_slot;
    const std::string twhat = fmt::format("{} ({})", what, type);
    std::vector<std::string> keys = {"type", "name", "guide", "line", "slider", "point"};
    if (joint.type == JointType::prismatic) keys.push_back("angle");
    r.known_keys(t, twhat, keys);
    joint.link_a = resolve_link(r, m, t, "guide", twhat);
    joint.link_b = resolve_link(r, m, t, "slider", twhat);
    const std::optional<std::string> line = r.string(t, "line", twhat, true);
    const std::optional<std::string> point = r.string(t, "point", twhat, true);
    if (joint.link_a >= 0 && line) {
      joint.line = m.links[joint.link_a].find_line(*line);
      if (joint.line < 0) {
        std::vector<std::string> names;
        for (const Line& l : m.links[joint.link_a].lines) names.push_back(l.name);
        r.error(r.at(t.get("line")),
                fmt::format("{}: line '{}' is not on link '{}' (its lines: {})", twhat, *line,
                            m.links[joint.link_a].name, join(names)));
      }
    }
    if (joint.link_b >= 0 && point)
      joint.point_b = resolve_point(r, m, joint.link_b, t.get("point"), *point, twhat);
    if (joint.link_a >= 0 && joint.link_a == joint.link_b)
      r.error(joint.where, fmt::format("{}: guide and slider are the same link", twhat));
    const std::string default_name =
        (joint.link_b >= 0 ? m.links[joint.link_b].name : std::string("?")) + "/" +
        line.value_or("?");
    joint.name = r.string(t, "name", twhat, false).value_or(default_name);
    if (joint.type == JointType::prismatic) {
      if (const auto angle = r.number(t, "angle", twhat, false, angle_scale(m.units))) {
        joint.relative_angle = *angle;
      } else if (joint.link_a >= 0 && joint.link_b >= 0) {
        // The slider keeps the relative angle it is drawn at (0 where a pose is not given).
        joint.relative_angle =
            drawn_pose(m.links[joint.link_b])(2) - drawn_pose(m.links[joint.link_a])(2);
      }
    }
    return joint;
  }
  if (type == "gear" || type == "rack_pinion") {  // completed by read_gearing
    joint.type = type == "gear" ? JointType::gear : JointType::rack_pinion;
    return joint;
  }
  r.error(t.get("type") ? r.at(t.get("type")) : joint.where,
          fmt::format("{}: unknown joint type '{}' (valid types: revolute, prismatic, "
                      "pin_in_slot, gear, rack_pinion)",
                      what, type));
  return joint;
}

Eigen::Vector2d drawn_point(const Link& link, const Eigen::Vector2d& local) {
  const Eigen::Vector3d p = drawn_pose(link);
  return p.head<2>() + Eigen::Rotation2Dd(p(2)) * local;
}

// The point of the carrier that gear `gear` turns about: the one point name the two links share
// (one name is one place, joined by revolutes: check_structure). -1, reported, when there is none
// or more than one.
int gear_centre(Reader& r, const Mechanism& m, int gear, int carrier, const toml::node* at,
                std::string_view what) {
  std::vector<int> shared;
  for (const Point& p : m.links[gear].points)
    if (const int c = m.links[carrier].find_point(p.name); c >= 0) shared.push_back(c);
  if (shared.size() == 1) return shared.front();
  std::vector<std::string> names;
  for (int c : shared) names.push_back(m.links[carrier].points[c].name);
  r.error(r.at(at),
          shared.empty()
              ? fmt::format("{}: '{}' turns about no point of its carrier '{}' (a gear turns "
                            "about a point of the link both centres are fixed on: give the two "
                            "links that point's name, joined by a revolute)",
                            what, m.links[gear].name, m.links[carrier].name)
              : fmt::format("{}: '{}' shares {} points with its carrier '{}' ({}): a gear turns "
                            "about one",
                            what, m.links[gear].name, shared.size(), m.links[carrier].name,
                            join(names)));
  return -1;
}

// A gear pair's or a rack and pinion's links, centres, pitch radii, ratio and phase
// (docs/mechanism-format.md, "Gear pairs"), once every joint is read: a rack names its slide.
void read_gearing(Reader& r, Mechanism& m, const toml::table& t, int index) {
  Joint& joint = m.joints[static_cast<size_t>(index)];
  const bool gear = joint.type == JointType::gear;
  const std::string what = fmt::format("joint #{} ({})", index + 1, to_string(joint.type));
  const Scale length = length_scale(m.units), angle = angle_scale(m.units);
  joint.pressure_angle = 20.0 * std::numbers::pi / 180.0;  // ISO 53's standard involute
  if (const auto p = r.number(t, "pressure_angle", what, false, angle)) {
    if (!(*p >= 0.0 && *p < 0.5 * std::numbers::pi))
      r.error(r.at(t.get("pressure_angle")),
              fmt::format("{}: 'pressure_angle' must be from 0 to less than 90 degrees", what));
    joint.pressure_angle = *p;
  }
  const std::optional<double> phase = r.number(t, "phase", what, false, gear ? angle : length);
  if (gear) {
    r.known_keys(
        t, what,
        {"type", "name", "gears", "carrier", "teeth", "radii", "mesh", "phase", "pressure_angle"});
    const toml::node* gears = t.get("gears");
    const auto* array = gears ? gears->as_array() : nullptr;
    if (!array || array->size() != 2 || !(*array)[0].is_string() || !(*array)[1].is_string()) {
      r.error(gears ? r.at(*gears) : joint.where,
              fmt::format("{} needs 'gears' = [\"first\", \"second\"] (the two gear links)", what));
      return;
    }
    int* ends[2] = {&joint.link_a, &joint.link_b};
    for (size_t e = 0; e < 2; ++e) {
      const std::string name = *(*array)[e].value<std::string>();
      *ends[e] = m.find_link(name);
      if (*ends[e] < 0)
        r.error(r.at((*array)[e]), fmt::format("{}: unknown link '{}' (valid links: {})", what,
                                               name, join(link_names(m))));
    }
    joint.carrier = t.get("carrier") ? resolve_link(r, m, t, "carrier", what) : m.ground();
    if (joint.link_a < 0 || joint.link_b < 0 || joint.carrier < 0) return;
    joint.name = r.string(t, "name", what, false)
                     .value_or(m.links[joint.link_a].name + "/" + m.links[joint.link_b].name);
    if (joint.link_a == joint.link_b || joint.link_a == joint.carrier ||
        joint.link_b == joint.carrier) {
      r.error(r.at(*gears), fmt::format("{}: the two gears and the carrier ('{}') must be three "
                                        "different links",
                                        what, m.links[joint.carrier].name));
      return;
    }
    const std::optional<std::string> mesh = r.string(t, "mesh", what, false);
    if (mesh && *mesh != "external" && *mesh != "internal")
      r.error(r.at(t.get("mesh")),
              fmt::format("{}: 'mesh' is \"external\" or \"internal\", not '{}'", what, *mesh));
    const bool internal = mesh.value_or("external") == "internal";
    joint.centre_a = gear_centre(r, m, joint.link_a, joint.carrier, gears, what);
    joint.centre_b = gear_centre(r, m, joint.link_b, joint.carrier, gears, what);
    if (joint.centre_a < 0 || joint.centre_b < 0) return;
    const Link& carrier = m.links[joint.carrier];
    const double d =
        (carrier.points[joint.centre_b].local - carrier.points[joint.centre_a].local).norm();
    const toml::node* teeth = t.get("teeth");
    const toml::node* radii = t.get("radii");
    if ((teeth != nullptr) == (radii != nullptr)) {
      r.error(teeth ? r.at(*teeth) : joint.where,
              fmt::format("{} needs exactly one of 'teeth' = [z1, z2] or 'radii' = [r1, r2] (the "
                          "pitch radii)",
                          what));
      return;
    }
    if (teeth) {
      const auto z = r.numbers(*teeth, fmt::format("'teeth' in {}", what),
                               {Scale{1.0, "", 1e6}, Scale{1.0, "", 1e6}});
      if (!z) return;
      if (!((*z)[0] >= 1 && (*z)[1] >= 1 && std::floor((*z)[0]) == (*z)[0] &&
            std::floor((*z)[1]) == (*z)[1])) {
        r.error(r.at(*teeth), fmt::format("{}: 'teeth' are two whole numbers of at least 1", what));
        return;
      }
      // The pitch circles roll on each other: their radii are in the teeth's ratio and add up
      // to the centre distance (external), or differ by it (internal).
      const double sum = internal ? std::abs((*z)[1] - (*z)[0]) : (*z)[0] + (*z)[1];
      if (sum == 0.0 || d == 0.0) {
        r.error(r.at(*teeth),
                fmt::format("{}: an internal pair needs a ring with more teeth than its pinion "
                            "and centres apart",
                            what));
        return;
      }
      joint.radius_a = d * (*z)[0] / sum;
      joint.radius_b = d * (*z)[1] / sum;
    } else {
      const auto rr = r.numbers(*radii, fmt::format("'radii' in {}", what), {length, length});
      if (!rr) return;
      joint.radius_a = (*rr)[0];
      joint.radius_b = (*rr)[1];
      const double need =
          internal ? std::abs(joint.radius_b - joint.radius_a) : joint.radius_a + joint.radius_b;
      if (!(joint.radius_a > 0.0 && joint.radius_b > 0.0) ||
          std::abs(need - d) > 1e-9 * std::max(d, need)) {
        r.error(
            r.at(*radii),
            fmt::format("{}: pitch circles of radii {:g} and {:g} {} mesh {} {:g} {} apart; "
                        "the centres '{}' and '{}' on '{}' are {:g} {} apart",
                        what, joint.radius_a / m.units.length, joint.radius_b / m.units.length,
                        m.units.length_name, internal ? "internally" : "externally",
                        need / m.units.length, m.units.length_name,
                        carrier.points[joint.centre_a].name, carrier.points[joint.centre_b].name,
                        carrier.name, d / m.units.length, m.units.length_name));
        return;
      }
    }
    joint.ratio = (internal ? -1.0 : 1.0) * joint.radius_b / joint.radius_a;
    // The gears mesh as drawn (0 where no pose is given), as a prismatic keeps its drawn angle.
    auto turned = [&](int l) { return drawn_pose(m.links[l])(2) - drawn_pose(carrier)(2); };
    joint.phase = phase.value_or(turned(joint.link_a) + joint.ratio * turned(joint.link_b));
    return;
  }

  r.known_keys(t, what, {"type", "name", "pinion", "rack", "radius", "phase", "pressure_angle"});
  joint.link_a = resolve_link(r, m, t, "pinion", what);
  const std::optional<std::string> rack = r.string(t, "rack", what, true);
  const std::optional<double> radius = r.number(t, "radius", what, true, length);
  if (joint.link_a < 0 || !rack || !radius) return;
  joint.slide = m.find_joint(*rack);
  if (joint.slide < 0 || m.joints[joint.slide].type != JointType::prismatic) {
    std::vector<std::string> names;
    for (const Joint& j : m.joints)
      if (j.type == JointType::prismatic) names.push_back(j.name);
    r.error(r.at(t.get("rack")),
            fmt::format("{}: 'rack' names the prismatic joint that carries the rack; '{}' is {} "
                        "(prismatic joints: {})",
                        what, *rack, joint.slide < 0 ? "no joint" : "not prismatic", join(names)));
    joint.slide = -1;
    return;
  }
  const Joint& slide = m.joints[joint.slide];
  // A rack whose own joint is refused (its line or point unknown) is not read further: its
  // fault is already said at the prismatic.
  if (slide.link_a < 0 || slide.link_b < 0 || slide.line < 0 || slide.point_b < 0) {
    joint.slide = -1;
    return;
  }
  joint.carrier = slide.link_a;
  joint.link_b = slide.link_b;
  joint.name = r.string(t, "name", what, false)
                   .value_or(m.links[joint.link_a].name + "/" + m.links[joint.link_b].name);
  if (joint.link_a == m.ground()) {
    r.error(r.at(t.get("pinion")),
            fmt::format("{}: the pinion turns on the rack's guide; the ground cannot be it", what));
    return;
  }
  if (joint.link_a == joint.carrier || joint.link_a == joint.link_b) {
    r.error(
        r.at(t.get("pinion")),
        fmt::format("{}: the pinion must be another link than the rack's guide and slider", what));
    return;
  }
  if (!(*radius > 0.0)) {
    r.error(r.at(t.get("radius")),
            fmt::format("{}: 'radius' (the pitch radius) must be positive", what));
    return;
  }
  joint.radius_a = *radius;
  joint.centre_a = gear_centre(r, m, joint.link_a, joint.carrier, t.get("pinion"), what);
  if (joint.centre_a < 0) return;
  const Link& guide = m.links[joint.carrier];
  const Line& line = guide.lines[static_cast<size_t>(slide.line)];
  const double side = perp(line.direction).dot(guide.points[joint.centre_a].local - line.origin);
  if (std::abs(side) <= 1e-9 * m.size()) {
    r.error(r.at(t.get("pinion")),
            fmt::format("{}: the pinion's centre '{}' is on the rack's line '{}': the pinion "
                        "rolls on one side of it",
                        what, guide.points[joint.centre_a].name, line.name));
    return;
  }
  // Rolling without slip: the rack moves with the pinion's point on the side of the line,
  // s' = r (theta_p - theta_guide)' when the centre is on the line's left.
  joint.ratio = side > 0.0 ? *radius : -*radius;
  const Link& rack_link = m.links[joint.link_b];
  const Eigen::Vector2d origin = drawn_point(guide, line.origin);
  const Eigen::Vector2d u = Eigen::Rotation2Dd(drawn_pose(guide)(2)) * line.direction;
  const double s = u.dot(drawn_point(rack_link, rack_link.points[slide.point_b].local) - origin);
  joint.phase = phase.value_or(
      s - joint.ratio * (drawn_pose(m.links[joint.link_a])(2) - drawn_pose(guide)(2)));
}

// A polynomial or table law must stay within the magnitudes of a driver, its rates and
// accelerations too, at every time the solvers evaluate it: the sweep's 361 samples and the
// 3601-point grid `solve --at` searches (both equal divisions of the duration).
void check_law(Reader& r, const Driver& d, const Scale& value_scale) {
  const int n = 3600;
  for (int k = 0; k <= n; ++k) {
    const double time = d.law.duration * k / n;
    const DriverState s = d.at_time(time);
    const std::string_view unit = value_scale.unit;
    std::string fault;
    if (!(std::abs(s.value) <= value_scale.largest))
      fault = fmt::format("reaches {:g} {} (the limit is {:g} {})", s.value / value_scale.si, unit,
                          value_scale.largest / value_scale.si, unit);
    else if (!(std::abs(s.rate) <= limits::kRate))
      fault = fmt::format("moves at {:g} {}/s (the limit is {:g} in SI)", s.rate / value_scale.si,
                          unit, limits::kRate);
    else if (!(std::abs(s.accel) <= limits::kAcceleration))
      fault = fmt::format("accelerates at {:g} {}/s^2 (the limit is {:g} in SI)",
                          s.accel / value_scale.si, unit, limits::kAcceleration);
    if (!fault.empty()) {
      r.error(d.law.where,
              fmt::format("[driver] '{}' {} at t = {:g} s", to_string(d.law.kind), fault, time));
      return;
    }
  }
}

// Constant acceleration from the start speed: value = start + speed t + acceleration t^2 / 2.
// Without a duration an angular driver's cycle is the time it takes to turn once.
void read_acceleration(Reader& r, const Mechanism& m, Driver& d, const toml::table& t,
                       const Scale& value_scale, bool duration_given) {
  d.law.kind = MotionLaw::Kind::constant_acceleration;
  d.law.where = r.at(t.get("acceleration"));
  Scale scale{value_scale.si, "", limits::kAcceleration};
  std::string unit_name = m.units.length_name + "/s^2";
  if (d.angular()) {
    unit_name = "rad/s^2";
    if (const auto f = unit_factor(r, t, "[driver]", "acceleration_unit", kAngularAccelerationUnits,
                                   "rad/s^2", &unit_name))
      scale.si = *f;
  } else if (t.get("acceleration_unit")) {
    r.error(r.at(t.get("acceleration_unit")),
            fmt::format("[driver]: a slider's acceleration is in the file's length unit per "
                        "second squared ({}/s^2); remove 'acceleration_unit'",
                        m.units.length_name));
  }
  scale.unit = unit_name;
  d.law.acceleration_unit = {unit_name, scale.si};
  const std::optional<double> acceleration = r.number(t, "acceleration", "[driver]", true, scale);
  if (!acceleration || !r.diagnostics().empty()) return;
  d.law.acceleration = *acceleration;
  if (!duration_given) {
    const auto shown = [&] {
      return fmt::format("speed {:g} {}, acceleration {:g} {}", d.law.speed / d.law.speed_unit.si,
                         d.law.speed_unit.name, *acceleration / scale.si, unit_name);
    };
    if (!d.angular()) {
      r.error(d.law.where, fmt::format("[driver] a slider at constant acceleration ({}) needs "
                                       "'duration' (seconds): it has no turn to complete",
                                       shown()));
      return;
    }
    // The first t > 0 with |speed t + acceleration t^2 / 2| = 2 pi, in the direction of motion.
    const double direction =
        d.law.speed != 0.0 ? std::copysign(1.0, d.law.speed) : std::copysign(1.0, *acceleration);
    const double w = direction * d.law.speed, a = direction * *acceleration;
    const double turn = 2.0 * std::numbers::pi;
    const double discriminant = w * w + 2.0 * a * turn;
    if ((w == 0.0 && a == 0.0) || discriminant < 0.0) {
      r.error(d.law.where,
              fmt::format("[driver] at {} the driver {} before it turns once: give 'duration' "
                          "(seconds)",
                          shown(), w == 0.0 && a == 0.0 ? "does not move" : "stops"));
      return;
    }
    d.law.duration = 2.0 * turn / (w + std::sqrt(discriminant));
  }
  check_law(r, d, value_scale);
}

// One driver's table: [driver], or one of [[driver]] (`named`: it takes a 'name', read before).
void read_driver(Reader& r, const Mechanism& m, Driver& d, const toml::table* t,
                 const toml::table& root, bool named) {
  d.where = r.at(*t);
  std::vector<std::string> keys = {
      "type",       "joint", "link",       "from",         "to",
      "start",      "speed", "speed_unit", "acceleration", "acceleration_unit",
      "polynomial", "table", "duration",   "range"};
  if (named) keys.push_back("name");
  r.known_keys(*t, "[driver]", keys);
  const std::string type = r.string(*t, "type", "[driver]", true).value_or("");
  if (type == "joint_angle") {
    d.type = DriverType::joint_angle;
    const std::optional<std::string> joint = r.string(*t, "joint", "[driver]", true);
    if (joint) {
      d.joint = m.find_joint(*joint);
      if (d.joint < 0) {
        std::vector<std::string> names;
        for (const Joint& j : m.joints)
          if (j.type == JointType::revolute) names.push_back(j.name);
        r.error(
            r.at(t->get("joint")),
            fmt::format("[driver]: unknown joint '{}' (revolute joints: {})", *joint, join(names)));
      } else if (m.joints[d.joint].type != JointType::revolute) {
        r.error(r.at(t->get("joint")),
                fmt::format("[driver]: joint_angle needs a revolute joint; '{}' is {}", *joint,
                            to_string(m.joints[d.joint].type)));
        d.joint = -1;
      }
    }
    if (d.joint >= 0) {
      const Joint& j = m.joints[d.joint];
      d.link = j.link_b;
      d.from = j.point_b;
      if (const auto to = r.string(*t, "to", "[driver] (joint_angle)", true))
        d.to = resolve_point(r, m, d.link, t->get("to"), *to, "[driver] 'to'");
      if (d.to >= 0 && d.to == d.from)
        r.error(r.at(t->get("to")), "[driver]: 'to' must differ from the joint's point");
    }
  } else if (type == "link_angle") {
    d.type = DriverType::link_angle;
    d.link = resolve_link(r, m, *t, "link", "[driver]");
    if (d.link >= 0) {
      const auto from = r.string(*t, "from", "[driver] (link_angle)", true);
      const auto to = r.string(*t, "to", "[driver] (link_angle)", true);
      if (from) d.from = resolve_point(r, m, d.link, t->get("from"), *from, "[driver] 'from'");
      if (to) d.to = resolve_point(r, m, d.link, t->get("to"), *to, "[driver] 'to'");
      if (d.from >= 0 && d.to >= 0 &&
          (m.links[d.link].points[d.to].local - m.links[d.link].points[d.from].local).norm() <
              1e-12)
        r.error(r.at(t->get("to")), "[driver]: 'from' and 'to' are the same place");
      if (m.links[d.link].ground)
        r.error(r.at(t->get("link")), "[driver]: the ground cannot be driven");
    }
  } else if (type == "slider") {
    d.type = DriverType::slider;
    const std::optional<std::string> joint = r.string(*t, "joint", "[driver]", true);
    if (joint) {
      d.joint = m.find_joint(*joint);
      if (d.joint < 0 || !m.joints[d.joint].is_slide()) {
        std::vector<std::string> names;
        for (const Joint& j : m.joints)
          if (j.is_slide()) names.push_back(j.name);
        r.error(r.at(t->get("joint")),
                fmt::format("[driver]: '{}' is not a prismatic or pin_in_slot joint (those: {})",
                            *joint, join(names)));
        d.joint = -1;
      } else {
        d.link = m.joints[d.joint].link_b;
      }
    }
  } else {
    r.error(t->get("type") ? r.at(t->get("type")) : d.where,
            fmt::format("[driver]: unknown type '{}' (valid types: joint_angle, link_angle, "
                        "slider)",
                        type));
  }

  // Driver values are in the file's angle unit, or its length unit for a slider.
  const Scale value_scale = driver_scale(m, d);
  d.start = r.number(*t, "start", "[driver]", true, start_scale(m, d)).value_or(0.0);
  if (const toml::node* range = t->get("range")) {
    d.range_where = r.at(*range);
    if (const auto lr =
            r.numbers(*range, "[driver] 'range' ([low, high])", {value_scale, value_scale})) {
      if ((*lr)[0] >= (*lr)[1])
        r.error(r.at(*range), "[driver] 'range' must be [low, high] with low < high");
      else
        d.range = std::make_pair((*lr)[0], (*lr)[1]);
    }
  }

  // The motion law: exactly one of speed, polynomial, table; none for a dynamics case.
  const int laws =
      (t->get("speed") ? 1 : 0) + (t->get("polynomial") ? 1 : 0) + (t->get("table") ? 1 : 0);
  if (root.get("dynamics")) {
    for (const char* key : {"speed", "acceleration", "polynomial", "table"})
      if (const toml::node* law = t->get(key)) {
        r.error(r.at(law), fmt::format("[driver] of a dynamics case ([dynamics]) takes no motion "
                                       "law: the coordinate moves freely; remove '{}'",
                                       key));
        break;
      }
    return;
  }
  if (t->get("acceleration") && !t->get("speed")) {
    r.error(r.at(t->get("acceleration")),
            "[driver] 'acceleration' needs 'speed', the speed at t = 0 (speed = 0 from rest)");
    return;
  }
  if (laws != 1) {
    r.error(d.where,
            "[driver] needs exactly one motion law: 'speed' (constant, or with 'acceleration' "
            "from that speed), 'polynomial' or 'table'");
    return;
  }
  const Scale time_scale{1.0, "s", limits::kDuration, limits::kShortestDuration};
  // A polynomial's or a table's cycle; optional with a speed (for an acceleration law).
  const std::optional<double> duration =
      r.number(*t, "duration", "[driver]", !t->get("speed"), time_scale);
  if (duration && *duration <= 0.0)
    r.error(r.at(t->get("duration")), "[driver] 'duration' must be positive (seconds)");
  d.law.duration = duration.value_or(0.0);
  if (t->get("speed")) {
    d.law.kind = MotionLaw::Kind::constant_speed;
    d.law.where = r.at(t->get("speed"));
    Scale speed_scale{value_scale.si, "", limits::kRate, limits::kSlowestSpeed};
    std::string unit_name = m.units.length_name + "/s";
    if (d.angular()) {
      unit_name = "rad/s";
      if (const auto f =
              unit_factor(r, *t, "[driver]", "speed_unit", kAngularSpeedUnits, "rad/s", &unit_name))
        speed_scale.si = *f;
    } else if (t->get("speed_unit")) {
      r.error(r.at(t->get("speed_unit")),
              fmt::format("[driver]: a slider's speed is in the file's length unit per second "
                          "({}/s); remove 'speed_unit'",
                          m.units.length_name));
    }
    speed_scale.unit = unit_name;
    d.law.speed_unit = {unit_name, speed_scale.si};
    const std::optional<double> speed = r.number(*t, "speed", "[driver]", true, speed_scale);
    d.law.speed = speed.value_or(0.0);
    if (t->get("acceleration")) read_acceleration(r, m, d, *t, value_scale, duration.has_value());
    return;
  }
  if (const toml::node* poly = t->get("polynomial")) {
    d.law.kind = MotionLaw::Kind::polynomial;
    d.law.where = r.at(*poly);
    const auto* array = poly->as_array();
    if (!array || array->empty()) {
      r.error(r.at(*poly),
              "[driver] 'polynomial' must be [c1, c2, ...]: value = start + c1 t + "
              "c2 t^2 + ... (file units, seconds)");
      return;
    }
    if (array->size() > limits::kPolynomialTerms) {
      r.error(r.at(*poly), fmt::format("[driver] 'polynomial' has {} coefficients: the limit is {}",
                                       array->size(), limits::kPolynomialTerms));
      return;
    }
    // Each coefficient is finite; what the law reaches is checked below.
    for (const toml::node& c : *array)
      d.law.coefficients.push_back(
          r.number(c, "a polynomial coefficient", {value_scale.si, value_scale.unit})
              .value_or(0.0));
  } else {
    d.law.kind = MotionLaw::Kind::table;
    const toml::node* table = t->get("table");
    d.law.where = r.at(*table);
    const auto* rows = table->as_array();
    if (!rows || rows->size() < 3) {
      r.error(r.at(*table), "[driver] 'table' must list at least 3 rows [[t, value], ...]");
      return;
    }
    if (rows->size() > limits::kTableRows) {
      r.error(r.at(*table), fmt::format("[driver] 'table' has {} rows: the limit is {}",
                                        rows->size(), limits::kTableRows));
      return;
    }
    const Scale row_time{1.0, "s", limits::kDuration};
    for (const toml::node& row : *rows) {
      const auto tv = r.numbers(row, "a [driver] table row ([t, value])", {row_time, value_scale});
      if (!tv) return;
      if (!d.law.table_time.empty() && (*tv)[0] <= d.law.table_time.back()) {
        r.error(r.at(row), "[driver] table times must increase strictly");
        return;
      }
      // A shorter step makes the spline's rates overflow.
      if (!d.law.table_time.empty() && (*tv)[0] - d.law.table_time.back() < time_scale.smallest) {
        r.error(r.at(row), fmt::format("[driver] table times {:g} s and {:g} s are closer than "
                                       "the limit of {:g} s",
                                       d.law.table_time.back(), (*tv)[0], time_scale.smallest));
        return;
      }
      d.law.table_time.push_back((*tv)[0]);
      d.law.table_value.push_back((*tv)[1]);
    }
    // The value at t = 0: knots may start before it (the spline's end condition kept off the
    // cycle); at a first knot at 0 this is its value exactly.
    d.start = d.at_time(0.0).value;
  }
  if (duration && r.diagnostics().empty()) check_law(r, d, value_scale);
}

// What a driver drives, for two drivers on one thing: a joint's coordinate, or a link's absolute
// angle (a link_angle driver's, or a joint_angle driver's on a joint to the ground).
std::string driven_thing(const Mechanism& m, const Driver& d) {
  if (d.type == DriverType::link_angle ||
      (d.type == DriverType::joint_angle && d.joint >= 0 &&
       m.links[static_cast<size_t>(m.joints[static_cast<size_t>(d.joint)].link_a)].ground))
    return d.link >= 0 ? fmt::format("the angle of link '{}'", m.links[d.link].name) : "";
  return d.joint >= 0 ? fmt::format("joint '{}'", m.joints[d.joint].name) : "";
}

// [driver], or [[driver]] tables: several drivers, each named (docs/mechanism-format.md,
// "Several drivers").
void read_drivers(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::node* node = root.get("driver");
  const toml::array* array = node ? node->as_array() : nullptr;
  if (!array) {  // the one-driver form
    if (const toml::table* t = r.table(root, "driver", "a mechanism", true))
      read_driver(r, m, m.drivers.front(), t, root, false);
    return;
  }
  if (!array->is_array_of_tables() || array->empty()) {
    r.error(r.at(*node), "'driver' must be a table ([driver]) or tables ([[driver]])");
    return;
  }
  if (array->size() > kMostDrivers) {
    r.error(r.at((*array)[kMostDrivers]),
            fmt::format("{} [[driver]] tables: the limit is {}", array->size(), kMostDrivers));
    return;
  }
  const bool several = array->size() > 1;
  m.drivers.assign(array->size(), Driver{});
  std::vector<std::string> taken;  // names a driver's channels would share
  for (const Link& l : m.links) taken.push_back(l.name);
  for (const Joint& j : m.joints) taken.push_back(j.name);
  for (const Mechanism::NamedPoint& p : m.named_points()) taken.push_back(p.name);
  for (size_t i = 0; i < array->size(); ++i) {
    const toml::table* t = (*array)[i].as_table();
    Driver& d = m.drivers[i];
    const toml::node* name = t->get("name");
    if (name) {
      d.name = r.string(*t, "name", "[[driver]]", true).value_or("");
      if (name->is_string() && d.name.empty())
        r.error(r.at(*name), "[[driver]] 'name' must not be empty");
    } else if (several) {
      r.error(r.at(*t), fmt::format("[[driver]] needs a 'name' when there are several drivers "
                                    "({} here): its channels are named after it "
                                    "(torque.<name>, angle.<name>)",
                                    array->size()));
    }
    const size_t first = r.diagnostics().size();
    read_driver(r, m, d, t, root, true);
    r.relabel(first, "[driver]",
              d.name.empty() ? std::string("[[driver]]") : fmt::format("[[driver]] '{}'", d.name));
    if (!several || d.name.empty()) continue;
    if (std::find(taken.begin(), taken.end(), d.name) != taken.end())
      r.error(r.at(*name), fmt::format("[[driver]] name '{0}' is already a link's, joint's or "
                                       "point's name: its channels (angle.{0}, torque.{0}) "
                                       "would be ambiguous; choose another",
                                       d.name));
    for (size_t k = 0; k < i; ++k)
      if (m.drivers[k].name == d.name)
        r.error(r.at(*name), fmt::format("duplicate driver name '{}' (first at line {}); driver "
                                         "names must be unique",
                                         d.name, m.drivers[k].where.line));
  }
  if (!several) return;
  for (size_t i = 0; i < m.drivers.size(); ++i) {
    const Driver& d = m.drivers[i];
    const toml::table& t = *(*array)[i].as_table();
    const std::string thing = driven_thing(m, d);
    for (size_t k = 0; k < i && !thing.empty(); ++k)
      if (driven_thing(m, m.drivers[k]) == thing) {
        r.error(r.at(t.get("joint")  ? t.get("joint")
                     : t.get("link") ? t.get("link")
                                     : &t),
                fmt::format("drivers '{}' and '{}' both drive {}: one coordinate takes one "
                            "driver (drive another joint or link)",
                            m.drivers[k].name, d.name, thing));
        break;
      }
    if (d.range)
      r.error(d.range_where,
              fmt::format("[[driver]] '{}': 'range' sweeps one driver's values; with several "
                          "drivers the sweep runs in time over the longest cycle (remove "
                          "'range', or give 'duration')",
                          d.name));
    if (!root.get("dynamics") && d.law.kind == MotionLaw::Kind::constant_speed && !d.at_rest() &&
        d.cycle() == 0.0)
      r.error(d.law.where,
              fmt::format("[[driver]] '{}': a slider at constant speed has no turn to set the "
                          "sweep's time: give 'duration' (seconds)",
                          d.name));
  }
}

// With several drivers the sweep runs in time: what reads a sweep over one driver's values is
// refused at its key.
// The first driver whose row of the constraint Jacobian at q is a combination of the joints'
// rows and the drivers' before it (the joints then hold its coordinate still, to first order),
// or -1. Each link turns about the centroid of its points here, not its frame's origin (the
// chain rule: d/dtheta less d/dr times A'(theta) c), so that points drawn far from that origin
// do not make its columns nearly parallel; then every column and row has unit length.
int first_locked_driver(const Mechanism& m, const ConstraintLayout& layout,
                        const Eigen::VectorXd& q) {
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(layout.rows(), q.size());
  layout.jacobian(LinkFrames{q}, jac);
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0 || m.links[l].points.empty()) continue;
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const Point& p : m.links[l].points) c += p.local;
    c /= static_cast<double>(m.links[l].points.size());
    const double th = q(3 * k + 2), cs = std::cos(th), sn = std::sin(th);
    const Eigen::Vector2d turned(-sn * c.x() - cs * c.y(), cs * c.x() - sn * c.y());  // A'(th) c
    jac.col(3 * k + 2) -= jac.col(3 * k) * turned.x() + jac.col(3 * k + 1) * turned.y();
  }
  for (Eigen::Index c = 0; c < jac.cols(); ++c)
    if (const double norm = jac.col(c).norm(); norm > 0.0) jac.col(c) /= norm;
  for (int row = 0; row < layout.rows(); ++row)
    if (const double norm = jac.row(row).norm(); norm > 0.0) jac.row(row) /= norm;
  // Cheap first (a dense QR of IFToMM A02 at N = 160 took 7 s): a square Jacobian whose sparse
  // LU solves two fixed right-hand sides with bounded solutions is far from singular, so no
  // row depends on the others.
  if (jac.rows() == jac.cols()) {
    const Eigen::SparseMatrix<double> sparse = jac.sparseView();
    Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
    lu.compute(sparse);
    if (lu.info() == Eigen::Success) {
      bool bounded = true;
      for (const double phase : {1.0, 2.0}) {
        Eigen::VectorXd b(jac.rows());
        for (Eigen::Index i = 0; i < b.size(); ++i) b(i) = std::sin(phase + 1.618034 * i);
        const Eigen::VectorXd x = lu.solve(b);
        bounded =
            bounded && lu.info() == Eigen::Success && x.allFinite() && x.norm() <= 1e8 * b.norm();
      }
      if (bounded) return -1;
    }
  }
  auto rank = [&](int rows) {
    if (rows == 0) return Eigen::Index{0};
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(jac.topRows(rows));
    qr.setThreshold(1e-9);
    return qr.rank();
  };
  Eigen::Index before = rank(layout.joint_row_count());
  for (int d = 0; d < layout.driver_count(); ++d) {
    const Eigen::Index with = rank(layout.driver_row(d) + 1);
    if (with == before) return d;
    before = with;
  }
  return -1;
}

// A chain that Grübler–Kutzbach counts as mobile can still be locked: a planetary train whose
// sun mesh is moved onto the ground meshes the planet with two fixed gears that disagree, which
// holds the arm (the driver) still and leaves the sun free; the count sees 1 and the sweep
// wrote thousands of samples all at t = 0. Locked means the driver's row of the constraint
// Jacobian depends on the joints' rows, tested at the drawn pose and at a perturbation of it: a
// structural lock (gear rows are constant, a rigid sub-chain is rigid everywhere) holds at both;
// a drawing that happens to sit at a dead point or a limit of the assembling range does not.
void check_locked(Reader& r, const Mechanism& m) {
  if (!r.diagnostics().empty() || m.ground() < 0 || m.moving_count() == 0) return;
  const ConstraintLayout layout(m);
  const int n = 3 * m.moving_count();
  Eigen::VectorXd drawn = Eigen::VectorXd::Zero(n);
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k >= 0 && m.links[l].pose) drawn.segment<3>(3 * k) = *m.links[l].pose;
  }
  const int locked = first_locked_driver(m, layout, drawn);
  if (locked < 0) return;
  // A fixed, irregular perturbation: a tenth of the size and of a radian at most.
  Eigen::VectorXd moved = drawn;
  for (int i = 0; i < n; ++i)
    moved(i) += (i % 3 == 2 ? 0.1 : 0.1 * m.size()) * std::sin(1.0 + 2.399963 * i);
  if (first_locked_driver(m, layout, moved) != locked) return;
  const Driver& d = m.drivers[static_cast<size_t>(locked)];
  r.error(d.where,
          fmt::format("the chain is locked: its joints hold the driven coordinate{} still, "
                      "though Grübler–Kutzbach counts a mobility of {} (its count cannot see "
                      "constraints that repeat or contradict each other, such as two gear meshes "
                      "fixing one gear's turn). The driver's row of the constraint Jacobian is a "
                      "combination of the joints' rows at the drawn pose and near it; free the "
                      "chain (a gear on the wrong link, a joint too many) or drive a coordinate "
                      "that moves",
                      d.name.empty() ? "" : " '" + d.name + "'", mobility(m).mobility));
}

// A table read over one driver's value, in a definition whose sweep runs in time (several
// drivers): refused where it is written, its values not read (docs/mechanism-format.md,
// "Several drivers"). `message` has one {}: "N drivers".
bool refused_in_time(Reader& r, const Mechanism& m, const SourceLocation& where,
                     std::string_view message) {
  if (!m.axis().timed()) return false;
  r.error(where, fmt::format(fmt::runtime(message), fmt::format("{} drivers", m.drivers.size())));
  return true;
}
// Each of an array's tables, so refused.
bool refused_in_time(Reader& r, const Mechanism& m, const toml::array& tables,
                     std::string_view message) {
  if (!m.axis().timed()) return false;
  for (const toml::node& entry : tables) refused_in_time(r, m, r.at(*entry.as_table()), message);
  return true;
}

// "Q", "Q.field": the [[derived]] quantities and their fields, for a message.
std::string derived_names(const Mechanism& m) {
  std::string out;
  for (const DerivedSpec& d : m.derived) {
    const std::vector<std::string> fields = derived_fields(d.kind);
    out += fmt::format("{}{} (fields {})", out.empty() ? ": " : "; ", d.name, join(fields));
  }
  return out;
}

// SI factor for a [[reference]] value, from its channel's kind (see docs/mechanism-format.md).
std::optional<double> reference_factor(const Mechanism& m, std::string_view quantity) {
  const std::string_view kind = quantity.substr(0, quantity.find('.'));
  if (kind == "angle") return m.units.angle;
  if (kind == "omega" || kind == "alpha") return 1.0;
  static const std::vector<std::string_view> lengths = {"x",  "y", "vx", "vy",   "v",    "ax",
                                                        "ay", "a", "s",  "sdot", "sddot"};
  if (std::find(lengths.begin(), lengths.end(), kind) != lengths.end()) return m.units.length;
  static const std::vector<std::string_view> forces = {"fx",         "fy",         "f",    "fn",
                                                       "shaking_fx", "shaking_fy", "force"};
  if (std::find(forces.begin(), forces.end(), kind) != forces.end()) return m.units.force;
  if (kind == "torque" || kind == "moment" || kind == "shaking_moment")
    return m.units.force * m.units.length;
  return std::nullopt;
}

// The names a reference channel may end in: the mechanism's outputs.
std::vector<std::string> reference_objects(const Mechanism& m) {
  std::vector<std::string> objects;
  for (const Link& l : m.links)
    if (!l.ground) objects.push_back(l.name);
  for (const auto& p : m.named_points()) objects.push_back(p.name);
  for (const Joint& j : m.joints)
    if (std::find(objects.begin(), objects.end(), j.name) == objects.end())
      objects.push_back(j.name);
  objects.push_back("driver");
  // Without a ground link (an error said already) there is no ground's name.
  if (const int ground = m.ground(); ground >= 0)
    objects.push_back(m.links[static_cast<size_t>(ground)].name);
  return objects;
}

bool names_object(const std::vector<std::string>& objects, std::string_view quantity) {
  const size_t dot = quantity.find('.');
  if (dot == std::string_view::npos) return false;
  return std::find(objects.begin(), objects.end(), quantity.substr(dot + 1)) != objects.end();
}

// The unit of the last digit of a number as written: "57.3" 0.1, "-12.00" 0.01, "240" 1,
// "1.5e3" 100; 0 when it is not a plain decimal literal.
double last_digit(std::string_view literal) {
  const size_t exponent = literal.find_first_of("eE");
  const std::string_view mantissa = literal.substr(0, exponent);
  if (mantissa.empty() || mantissa.find_first_not_of("+-0123456789._") != std::string_view::npos)
    return 0.0;
  const size_t point = mantissa.find('.');
  int decimals = 0;
  if (point != std::string_view::npos)
    for (const char c : mantissa.substr(point + 1)) decimals += c >= '0' && c <= '9';
  int power = 0;
  if (exponent != std::string_view::npos) {
    const std::string e(literal.substr(exponent + 1));
    char* end = nullptr;
    const long p = std::strtol(e.c_str(), &end, 10);
    if (end == e.c_str() || *end != '\0' || std::abs(p) > 300) return 0.0;
    power = static_cast<int>(p);
  }
  return std::pow(10.0, power - decimals);
}

std::vector<std::string> channels_of(const Reader& r, const Mechanism& m);

// The channel that is the driver's own coordinate (up to a constant), or "": over the driver's
// values it only moves one way, so it has no reversal, no stroke between reversals, no dead point.
std::string driven_channel(const Mechanism& m) {
  const Driver& d = m.swept();
  const int g = m.ground();
  if (d.type == DriverType::slider && d.joint >= 0)
    return "s." + m.joints[static_cast<size_t>(d.joint)].name;
  if (d.type == DriverType::link_angle && d.link >= 0)
    return "angle." + m.links[static_cast<size_t>(d.link)].name;
  if (d.type == DriverType::joint_angle && d.joint >= 0) {
    // Measured in the ground's frame (or the ground's direction in the link's): a link's angle.
    const Joint& j = m.joints[static_cast<size_t>(d.joint)];
    if (j.link_a == g && j.link_b >= 0)
      return "angle." + m.links[static_cast<size_t>(j.link_b)].name;
    if (j.link_b == g && j.link_a >= 0)
      return "angle." + m.links[static_cast<size_t>(j.link_a)].name;
  }
  return "";
}

// [[derived]]: a quantity read off the sweep (analytic/derived/derived.h), named for [[reference]]
// and [expect.derived].
void read_derived(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "derived", limits::kReferences);
  if (!array) return;
  if (refused_in_time(r, m, *array,
                      "[[derived]] quantities are read over one driver's sweep; this definition "
                      "has {}"))
    return;
  const std::vector<std::string> objects = reference_objects(m);
  // The channels a sweep has (none when an earlier error leaves no linkage to lay them out).
  const std::vector<std::string> channels = channels_of(r, m);
  using K = DerivedSpec::Kind;
  const std::vector<K> kinds = {K::extremes, K::stroke,       K::time_ratio,   K::dead_points,
                                K::toggles,  K::transmission, K::straightness, K::circularity};
  std::vector<std::string> kind_names;
  for (const K k : kinds) kind_names.emplace_back(to_string(k));
  const Driver& d = m.swept();
  for (const toml::node& entry : *array) {
    const toml::table& t = *entry.as_table();
    r.known_keys(t, "[[derived]]", {"name", "quantity", "channel", "point", "range"});
    DerivedSpec spec;
    spec.where = r.at(t);
    spec.name = r.string(t, "name", "[[derived]]", true).value_or("");
    const std::string quantity = r.string(t, "quantity", "[[derived]]", true).value_or("");
    bool ok = !spec.name.empty() && !quantity.empty();
    if (!spec.name.empty()) {
      if (spec.name.find_first_of(". ") != std::string::npos ||
          reference_factor(m, spec.name + ".") || spec.name == "mu") {
        r.error(r.at(t.get("name")),
                fmt::format("[[derived]] name '{}' must be a word without '.' or spaces, not a "
                            "channel kind (it is written \"{}\" or \"{}.<field>\" in "
                            "[[reference]] and [expect.derived])",
                            spec.name, spec.name, spec.name));
        ok = false;
      }
      for (const DerivedSpec& other : m.derived)
        if (other.name == spec.name) {
          r.error(r.at(t.get("name")),
                  fmt::format("[[derived]] name '{}' is already used at line {}", spec.name,
                              other.where.line));
          ok = false;
        }
    }
    if (!quantity.empty()) {
      const auto k = std::find(kind_names.begin(), kind_names.end(), quantity);
      if (k == kind_names.end()) {
        r.error(r.at(t.get("quantity")),
                fmt::format("[[derived]]: unknown quantity '{}' (valid: {})", quantity,
                            join(kind_names)));
        ok = false;
      } else {
        spec.kind = kinds[static_cast<size_t>(k - kind_names.begin())];
      }
    }
    if (!ok) continue;
    const bool reads_channel = spec.kind == K::extremes || spec.kind == K::stroke ||
                               spec.kind == K::time_ratio || spec.kind == K::dead_points;
    const bool reads_point = spec.kind == K::straightness || spec.kind == K::circularity;
    const std::string valid_keys = reads_point ? "point" : reads_channel ? "channel" : "range";
    for (const char* key : {"channel", "point"})
      if (const toml::node* n = t.get(key); n && valid_keys != key) {
        r.error(r.at(n), fmt::format("[[derived]] quantity '{}' takes no '{}'", quantity, key));
        ok = false;
      }
    if (reads_channel) {
      spec.channel = r.string(t, "channel", "[[derived]]", true).value_or("");
      const Quantity q = Trajectory::quantity_of(spec.channel);
      if (spec.channel.empty()) {
        ok = false;
      } else if (!reference_factor(m, spec.channel) || !names_object(objects, spec.channel) ||
                 q == Quantity::force || q == Quantity::torque) {
        r.error(r.at(t.get("channel")),
                fmt::format("[[derived]]: '{}' is not a kinematic channel of this linkage "
                            "(kind.name, kind one of angle, omega, alpha, x, y, vx, vy, v, ax, "
                            "ay, a, s, sdot, sddot; names: {})",
                            spec.channel, join(objects)));
        ok = false;
      } else if (!channels.empty() &&
                 std::find(channels.begin(), channels.end(), spec.channel) == channels.end()) {
        // A kind its object does not have ("angle.B" of a point B) has no values to read.
        const std::string object = spec.channel.substr(spec.channel.find('.') + 1);
        std::vector<std::string> its;
        for (const std::string& c : channels)
          if (c.substr(c.find('.') + 1) == object &&
              Trajectory::quantity_of(c) != Quantity::force &&
              Trajectory::quantity_of(c) != Quantity::torque)
            its.push_back(c);
        r.error(r.at(t.get("channel")),
                fmt::format("[[derived]]: '{}' is no channel of this linkage ({})", spec.channel,
                            its.empty() ? fmt::format("'{}' has no kinematic channel", object)
                                        : fmt::format("those of '{}': {}", object, join(its))));
        ok = false;
      } else if (spec.kind != K::extremes && spec.channel == driven_channel(m)) {
        r.error(
            r.at(t.get("channel")),
            fmt::format("[[derived]] '{}': '{}' is the driver's own coordinate, which moves "
                        "one way over the sweep and never turns back, so it has no {} (read "
                        "the 'extremes' of it, or the {} of a channel that reverses)",
                        quantity, spec.channel,
                        spec.kind == K::dead_points ? "dead points" : "stroke between reversals",
                        quantity));
        ok = false;
      } else if (q != Quantity::position && q != Quantity::angle &&
                 d.law.kind != MotionLaw::Kind::constant_speed) {
        r.error(r.at(t.get("channel")),
                fmt::format("[[derived]]: '{}' is a rate: its extremes over the driver need a "
                            "driver at constant speed (the law here is '{}')",
                            spec.channel, to_string(d.law.kind)));
        ok = false;
      }
    }
    if (reads_point) {
      spec.point = r.string(t, "point", "[[derived]]", true).value_or("");
      const auto points = m.named_points();
      if (!spec.point.empty() &&
          std::none_of(points.begin(), points.end(),
                       [&](const Mechanism::NamedPoint& p) { return p.name == spec.point; })) {
        std::vector<std::string> names;
        for (const auto& p : points) names.push_back(p.name);
        r.error(r.at(t.get("point")),
                fmt::format("[[derived]]: no point '{}' (points: {})", spec.point, join(names)));
      }
      if (spec.point.empty()) ok = false;
    }
    if (spec.kind == K::transmission) {
      if (const auto fb = four_bar(m)) {
        spec.channel = "mu." + fb->c;
      } else {
        r.error(r.at(t.get("quantity")),
                "[[derived]] 'transmission': the transmission angle is defined here for a "
                "four-bar (between its coupler and rocker at C); this linkage is not one");
        ok = false;
      }
    }
    if (const toml::node* range = t.get("range")) {
      const Scale scale = driver_scale(m, m.swept());
      if (const auto v = r.numbers(*range, "[[derived]] 'range' ([lower, upper] driver values)",
                                   {scale, scale})) {
        const double unit = driver_unit_of(d, m.units).scale;
        const double turn = 2.0 * std::numbers::pi;
        // A sweep over its own [driver] range holds no other driver values (a whole turn's
        // or more is read modulo a turn).
        const bool outside =
            d.range && !(d.angular() && d.range->second - d.range->first >= turn) &&
            ((*v)[0] < d.range->first - 1e-12 * unit || (*v)[1] > d.range->second + 1e-12 * unit);
        if (!((*v)[0] < (*v)[1]))
          r.error(r.at(*range), "[[derived]] 'range' must be [lower, upper] with lower < upper");
        else if (outside)
          r.error(r.at(*range),
                  fmt::format("[[derived]] 'range' [{:g}, {:g}] is outside the sweep, the "
                              "[driver] range [{:g}, {:g}]",
                              (*v)[0] / unit, (*v)[1] / unit, d.range->first / unit,
                              d.range->second / unit));
        else
          spec.range = std::make_pair((*v)[0], (*v)[1]);
      }
    }
    if (ok) m.derived.push_back(spec);
  }
}

// The design summary: what a designer reads about the output, as [[derived]] quantities the file
// need not declare (docs/mechanism-format.md, "Design summary"). The output is `[summary]
// output` (a moving link or a slider joint), else the last slider on the ground, else the last
// moving link; the driven coordinate is never the output. Its stroke (a rocker's swing), time
// ratio and dead points; the toggles; a four-bar's transmission angle; and the path of each
// coupler point (a named point on a link with no ground joint that no joint uses): its extent
// and straightness. None for several drivers, a dynamics case or a driver at rest; one the file
// declares already (the same kind of the same channel or point, or the same name) is not added.
void add_design_summary(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::table* t = r.table(root, "summary", "a mechanism", false);
  std::string output;
  if (t) {
    r.known_keys(*t, "[summary]", {"output"});
    output = r.string(*t, "output", "[summary]", false).value_or("");
  }
  // A definition with errors so far may be incomplete (no ground): each was reported already.
  if (!r.diagnostics().empty() || m.ground() < 0) return;
  if (m.axis().timed() || m.dynamics || m.swept().at_rest()) return;
  const int g = m.ground();
  const std::string driven = driven_channel(m);
  std::vector<std::string> outputs;  // the candidates' channels, in order
  for (size_t l = 0; l < m.links.size(); ++l)
    if (static_cast<int>(l) != g) outputs.push_back("angle." + m.links[l].name);
  for (const Joint& j : m.joints)
    if (j.type == JointType::prismatic && (j.link_a == g || j.link_b == g))
      outputs.push_back("s." + j.name);
  std::erase(outputs, driven);
  std::string channel;
  if (!output.empty()) {
    for (const std::string& c : outputs)
      if (c.substr(c.find('.') + 1) == output) channel = c;
    if (channel.empty()) {
      std::vector<std::string> names;
      for (const std::string& c : outputs) names.push_back(c.substr(c.find('.') + 1));
      r.error(r.at(t->get("output")),
              fmt::format("[summary] 'output': '{}' is no moving link or slider on the ground "
                          "but the driven one (valid: {})",
                          output, join(names)));
      return;
    }
  } else if (!outputs.empty()) {
    // outputs lists the links first, then the sliders: the last slider, else the last link
    const auto slider = std::find_if(outputs.rbegin(), outputs.rend(),
                                     [](const std::string& c) { return c.starts_with("s."); });
    channel = slider != outputs.rend() ? *slider : outputs.back();
  }
  using K = DerivedSpec::Kind;
  const auto add = [&](std::string name, K kind, std::string on, std::string point) {
    for (const DerivedSpec& d : m.derived)
      if (d.name == name || (d.kind == kind && d.channel == on && d.point == point && !d.range))
        return;
    DerivedSpec spec;
    spec.name = std::move(name);
    spec.kind = kind;
    spec.channel = std::move(on);
    spec.point = std::move(point);
    spec.summary = true;
    spec.where = t ? r.at(*t) : r.file();
    m.derived.push_back(std::move(spec));
  };
  if (!channel.empty()) {
    add("output_stroke", K::stroke, channel, "");
    add("output_time_ratio", K::time_ratio, channel, "");
    add("output_dead_points", K::dead_points, channel, "");
  }
  add("toggles", K::toggles, "", "");
  if (const auto fb = four_bar(m)) add("transmission", K::transmission, "mu." + fb->c, "");
  // The links a joint holds to the ground (the ground among them): no coupler's.
  std::vector<bool> grounded(m.links.size(), false);
  grounded[static_cast<size_t>(g)] = true;
  for (const Joint& j : m.joints)
    if (j.link_a == g || j.link_b == g)
      for (const int l : {j.link_a, j.link_b})
        if (l >= 0) grounded[static_cast<size_t>(l)] = true;
  for (const Mechanism::NamedPoint& p : m.named_points()) {
    const auto joins = [&](const Joint& j) {
      return (j.link_a == p.link && j.point_a == p.point) ||
             (j.link_b == p.link && j.point_b == p.point);
    };
    if (grounded[static_cast<size_t>(p.link)] ||
        std::any_of(m.joints.begin(), m.joints.end(), joins))
      continue;
    add("path_" + p.name, K::straightness, "", p.name);
  }
}

// Every channel a method writes for the mechanism, its forces' included; none while the definition
// has errors (the mechanism may be incomplete: each was reported already).
std::vector<std::string> channels_of(const Reader& r, const Mechanism& m) {
  if (!r.diagnostics().empty() || m.ground() < 0) return {};
  Trajectory shape;
  shape.resize(m, 0, true);
  return shape.channel_names();
}

void read_references(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "reference", limits::kReferences);
  if (!array) return;
  if (refused_in_time(r, m, *array,
                      "[[reference]] 'at' is a driver value; this definition has {} (its "
                      "sweep runs in time)"))
    return;
  const std::vector<std::string> objects = reference_objects(m);
  const std::vector<std::string> channels = channels_of(r, m);
  for (const toml::node& entry : *array) {
    const toml::table& t = *entry.as_table();
    r.known_keys(t, "[[reference]]",
                 {"quantity", "at", "value", "precision", "source", "tolerance"});
    Reference ref;
    ref.where = r.at(t);
    ref.quantity = r.string(t, "quantity", "[[reference]]", true).value_or("");
    ref.source = r.string(t, "source", "[[reference]]", true).value_or("");
    const DerivedSpec* spec = nullptr;
    const std::optional<DerivedUnit> derived = derived_unit_of(m, ref.quantity, &spec);
    ref.derived = derived.has_value();
    if (ref.derived && t.get("at"))
      r.error(r.at(t.get("at")),
              fmt::format("[[reference]]: '{}' is a [[derived]] quantity of the whole sweep: it "
                          "takes no 'at'",
                          ref.quantity));
    const std::optional<double> at =
        ref.derived ? std::optional<double>(0.0)
                    : r.number(t, "at", "[[reference]]", true, driver_scale(m, m.swept()));
    const std::optional<double> factor = ref.derived
                                             ? std::optional(derived_factor(m, *spec, *derived))
                                             : reference_factor(m, ref.quantity);
    const std::optional<double> value = r.number(
        t, "value", "[[reference]]", true, {factor.value_or(1.0), "", limits::kReferenceValue});
    if (!ref.quantity.empty() && !factor) {
      r.error(r.at(t.get("quantity")),
              fmt::format("[[reference]]: unknown quantity '{}' (expected kind.name with kind "
                          "one of angle, omega, alpha, x, y, vx, vy, v, ax, ay, a, s, sdot, "
                          "sddot, fx, fy, f, fn, moment, torque, force, shaking_fx, shaking_fy, "
                          "shaking_moment; or a [[derived]] name{})",
                          ref.quantity, derived_names(m)));
      continue;
    }
    if (factor && !ref.derived && !names_object(objects, ref.quantity)) {
      r.error(r.at(t.get("quantity")),
              fmt::format("[[reference]]: '{}' names no moving link, point, joint, slider, "
                          "driver or ground (valid names: {})",
                          ref.quantity, join(objects)));
      continue;
    }
    // A kind that the named object does not have ("sdot.A" of a point A) would compare with
    // nothing and pass: the kinds it has are listed.
    if (factor && !ref.derived && !channels.empty() &&
        std::find(channels.begin(), channels.end(), ref.quantity) == channels.end()) {
      const std::string object = ref.quantity.substr(ref.quantity.find('.') + 1);
      std::vector<std::string> its;
      for (const std::string& c : channels)
        if (c.substr(c.find('.') + 1) == object) its.push_back(c);
      r.error(r.at(t.get("quantity")),
              fmt::format("[[reference]]: '{}' is no channel of this mechanism ({})", ref.quantity,
                          its.empty() ? fmt::format("'{}' has none", object)
                                      : fmt::format("those of '{}': {}", object, join(its))));
      continue;
    }
    if (!at || !value || !factor) continue;
    ref.driver_value = *at;
    ref.value = *value;
    // An expression is kept as written, without its quotes.
    const toml::node& printed = *t.get("value");
    ref.printed = printed.is_string() ? *printed.value<std::string>() : r.literal(printed);
    if (const auto precision =
            r.number(t, "precision", "[[reference]] (the unit of the printed value's last digit)",
                     false, {*factor, "", limits::kReferenceValue})) {
      if (*precision <= 0.0)
        r.error(r.at(t.get("precision")), "[[reference]] 'precision' must be positive");
      ref.precision = *precision;
    } else {
      ref.precision = last_digit(ref.printed) * *factor;
    }
    // 'tolerance': a % of the exact value, or "rounding" (within half the last printed digit).
    if (const toml::node* tolerance = t.get("tolerance")) {
      ref.to_rounding = tolerance->value<std::string>() == "rounding";
      if (!ref.to_rounding) {
        ref.tolerance_pct = r.number(
            *tolerance, "[[reference]] 'tolerance' (a % of the exact value, or \"rounding\")",
            {1.0, "", limits::kTolerance});
        if (ref.tolerance_pct && !(*ref.tolerance_pct > 0.0))
          r.error(r.at(tolerance), "[[reference]] 'tolerance' must be positive");
      }
    }
    m.references.push_back(ref);
  }
}

// A point given as `point = "P"` (a named point of the link) or `at = [x, y]` (local, file
// units) in table `t`. Returns false (after an error) when neither or both are there.
bool read_place(Reader& r, const Mechanism& m, const toml::table& t, int link,
                std::string_view what, Eigen::Vector2d& local, std::string& name) {
  const toml::node* point = t.get("point");
  const toml::node* at = t.get("at");
  if ((point != nullptr) == (at != nullptr)) {
    r.error(r.at(point ? point
                 : at  ? at
                       : &t),
            fmt::format("{} needs exactly one of 'point' (a point of link '{}') or 'at' "
                        "([x, y] in its frame)",
                        what, m.links[static_cast<size_t>(link)].name));
    return false;
  }
  if (point) {
    const std::optional<std::string> n = r.string(t, "point", what, true);
    if (!n) return false;
    const int p = resolve_point(r, m, link, point, *n, what);
    if (p < 0) return false;
    local = m.links[static_cast<size_t>(link)].points[static_cast<size_t>(p)].local;
    name = *n;
    return true;
  }
  const auto xy = r.numbers(*at, fmt::format("'at' of {} ([x, y])", what),
                            {length_scale(m.units), length_scale(m.units)});
  if (!xy) return false;
  local = Eigen::Vector2d((*xy)[0], (*xy)[1]);
  return true;
}

// [[load]]: a force at a point of a link or a torque on a link, constant or a table over the
// driver coordinate.
void read_loads(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "load");
  if (!array) return;
  const double torque_unit = m.units.force * m.units.length;
  for (size_t index = 0; index < array->size(); ++index) {
    const toml::table& t = *(*array)[index].as_table();
    const std::string what = fmt::format("load #{}", index + 1);
    r.known_keys(t, "[[load]]",
                 {"name", "link", "point", "at", "force", "torque", "force_table", "torque_table"});
    Load load;
    load.where = r.at(t);
    load.name = r.string(t, "name", what, false).value_or(fmt::format("load{}", index + 1));
    load.link = resolve_link(r, m, t, "link", what);
    const char* kinds[] = {"force", "torque", "force_table", "torque_table"};
    std::vector<std::string> given;
    for (const char* k : kinds)
      if (t.get(k)) given.emplace_back(k);
    if (given.size() != 1) {
      r.error(load.where, fmt::format("{} needs exactly one of 'force' = [fx, fy], 'torque', "
                                      "'force_table' = [[driver, fx, fy], ...] or 'torque_table' "
                                      "= [[driver, torque], ...]{}",
                                      what, given.empty() ? "" : " (it has " + join(given) + ")"));
      continue;
    }
    if (load.link < 0) continue;
    if (m.links[static_cast<size_t>(load.link)].ground)
      r.error(r.at(t.get("link")), fmt::format("{}: a load on the ground does no work and moves "
                                               "nothing; put it on a moving link",
                                               what));
    const std::string kind = given.front();
    load.kind = kind.starts_with("force") ? Load::Kind::force : Load::Kind::torque;
    load.table = kind.ends_with("_table");
    if (load.table && refused_in_time(r, m, load.where,
                                      "a load's table is over the driver's value; with {} the "
                                      "sweep runs in time: give a constant force or torque"))
      continue;
    if (load.kind == Load::Kind::force) {
      if (!read_place(r, m, t, load.link, what, load.local, load.point)) continue;
    } else if (t.get("point") || t.get("at")) {
      r.error(r.at(t.get("point") ? t.get("point") : t.get("at")),
              fmt::format("{}: a torque acts on the whole link; remove '{}'", what,
                          t.get("point") ? "point" : "at"));
      continue;
    }
    const Scale unit = load.kind == Load::Kind::force
                           ? Scale{m.units.force, m.units.force_name, limits::kForce}
                           : Scale{torque_unit, "", limits::kTorque};
    const size_t width = load.kind == Load::Kind::force ? 2 : 1;
    const toml::node& value = *t.get(kind);
    load.over_turns = load.table && m.swept().angular();
    if (!load.table) {
      std::optional<std::vector<double>> v;
      if (width == 2)
        v = r.numbers(value, fmt::format("'force' of {} ([fx, fy])", what), {unit, unit});
      else if (const auto torque = r.number(value, fmt::format("'torque' of {}", what), unit))
        v = std::vector<double>{*torque};
      if (!v) continue;
      load.rows.emplace_back(0.0, (*v)[0], width == 2 ? (*v)[1] : 0.0);
      m.loads.push_back(load);
      continue;
    }
    const auto* rows = value.as_array();
    if (!rows || rows->size() < 2) {
      r.error(r.at(value), fmt::format("{}: '{}' must list at least 2 rows", what, kind));
      continue;
    }
    bool good = true;
    for (const toml::node& row : *rows) {
      std::vector<Scale> scales = {driver_scale(m, m.swept()), unit};
      if (width == 2) scales.push_back(unit);
      const auto v = r.numbers(row,
                               fmt::format("a row of '{}' of {} ([driver, {}])", kind, what,
                                           width == 2 ? "fx, fy" : "torque"),
                               scales);
      if (!v) {
        good = false;
        break;
      }
      const double d = (*v)[0];
      if (!load.rows.empty() && d <= load.rows.back()(0)) {
        r.error(r.at(row),
                fmt::format("{}: driver values in '{}' must increase strictly", what, kind));
        good = false;
        break;
      }
      load.rows.emplace_back(d, (*v)[1], width == 2 ? (*v)[2] : 0.0);
    }
    if (good) m.loads.push_back(load);
  }
}

// [[spring]]: a linear spring and damper between points of two links.
void read_springs(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "spring");
  if (!array) return;
  for (size_t index = 0; index < array->size(); ++index) {
    const toml::table& t = *(*array)[index].as_table();
    const std::string what = fmt::format("spring #{}", index + 1);
    r.known_keys(t, "[[spring]]",
                 {"name", "links", "points", "stiffness", "free_length", "damping"});
    Spring spring;
    spring.where = r.at(t);
    std::vector<std::string> names[2];
    for (const auto& [key, out] : {std::pair{"links", &names[0]}, std::pair{"points", &names[1]}}) {
      const toml::node* n = t.get(key);
      const auto* a = n ? n->as_array() : nullptr;
      if (!a || a->size() != 2 || !(*a)[0].is_string() || !(*a)[1].is_string()) {
        r.error(n ? r.at(*n) : spring.where,
                fmt::format("{} needs '{}' = [\"first\", \"second\"]", what, key));
        continue;
      }
      for (const toml::node& e : *a) out->push_back(*e.value<std::string>());
    }
    if (names[0].size() != 2 || names[1].size() != 2) continue;
    int* links[2] = {&spring.link_a, &spring.link_b};
    Eigen::Vector2d* locals[2] = {&spring.local_a, &spring.local_b};
    bool good = true;
    for (int e = 0; e < 2; ++e) {
      *links[e] = m.find_link(names[0][e]);
      if (*links[e] < 0) {
        r.error(r.at(t.get("links")), fmt::format("{}: unknown link '{}' (valid links: {})", what,
                                                  names[0][e], join(link_names(m))));
        good = false;
        continue;
      }
      const int p = resolve_point(r, m, *links[e], t.get("points"), names[1][e], what);
      if (p < 0) {
        good = false;
        continue;
      }
      *locals[e] = m.links[static_cast<size_t>(*links[e])].points[static_cast<size_t>(p)].local;
    }
    if (!good) continue;
    if (spring.link_a == spring.link_b) {
      r.error(r.at(t.get("links")),
              fmt::format("{} joins two points of one link ('{}'): it would never change length",
                          what, names[0][0]));
      continue;
    }
    spring.point_a = names[1][0];
    spring.point_b = names[1][1];
    spring.name = r.string(t, "name", what, false).value_or(spring.point_a + "-" + spring.point_b);
    const double per_length = m.units.force / m.units.length;
    const std::string force_per_length = m.units.force_name + "/" + m.units.length_name;
    const auto stiffness =
        r.number(t, "stiffness", what, false, {per_length, force_per_length, limits::kStiffness});
    const auto free_length = r.number(t, "free_length", what, false, length_scale(m.units));
    const auto damping =
        r.number(t, "damping", what, false,
                 {per_length, m.units.force_name + " s/" + m.units.length_name, limits::kDamping});
    // A value refused above has said so already.
    if ((t.get("stiffness") && !stiffness) || (t.get("free_length") && !free_length) ||
        (t.get("damping") && !damping))
      continue;
    if (!stiffness && !damping) {
      r.error(spring.where, fmt::format("{} needs 'stiffness' (force unit per length unit) "
                                        "and 'free_length', or 'damping', or both",
                                        what));
      continue;
    }
    if (stiffness && !free_length) {
      r.error(r.at(t.get("stiffness")),
              fmt::format("{}: 'stiffness' needs 'free_length' (length unit)", what));
      continue;
    }
    for (const auto& [key, v] :
         {std::pair{"stiffness", stiffness}, std::pair{"free_length", free_length},
          std::pair{"damping", damping}})
      if (v && *v < 0.0) {
        r.error(r.at(t.get(key)), fmt::format("{}: '{}' must not be negative", what, key));
        good = false;
      }
    if (!good) continue;
    spring.stiffness = stiffness.value_or(0.0);
    spring.free_length = free_length.value_or(0.0);
    spring.damping = damping.value_or(0.0);
    m.springs.push_back(spring);
  }
}

// One driver's free coordinate in [dynamics] (the one-driver form) or [dynamics.<name>] (`what`):
// its initial rate and applied effort. The coordinate's kinematic view (check, solve, compare) is
// a constant speed equal to its initial rate, or 1 unit/s when that is 0.
FreeCoordinate read_free_coordinate(Reader& r, const Mechanism& m, Driver& d, const toml::table& t,
                                    const std::string& what) {
  FreeCoordinate c;
  double rate_unit = d.angular() ? 1.0 : m.units.length;
  std::string rate_name = d.angular() ? "rad/s" : m.units.length_name + "/s";
  if (d.angular()) {
    if (const auto f =
            unit_factor(r, t, what, "rate_unit", kAngularSpeedUnits, "rad/s", &rate_name))
      rate_unit = *f;
  } else if (t.get("rate_unit")) {
    r.error(r.at(t.get("rate_unit")),
            fmt::format("{}: a slider's rate is in the file's length unit per second "
                        "({}/s); remove 'rate_unit'",
                        what, m.units.length_name));
  }
  // The initial rate is the kinematic view's speed: the same limits as a driver's speed.
  c.rate =
      r.number(t, "rate", what, false, {rate_unit, rate_name, limits::kRate, limits::kSlowestSpeed})
          .value_or(0.0);
  const Scale effort_scale = d.angular()
                                 ? Scale{m.units.force * m.units.length, "", limits::kTorque}
                                 : Scale{m.units.force, m.units.force_name, limits::kForce};
  if (t.get("effort") && t.get("effort_table"))
    r.error(r.at(t.get("effort_table")),
            fmt::format("{} takes 'effort' (constant) or 'effort_table' ([[t, value], ...]), not "
                        "both",
                        what));
  if (const auto e = r.number(t, "effort", what, false, effort_scale))
    c.effort.emplace_back(0.0, *e);
  const toml::node* table = t.get("effort") ? nullptr : t.get("effort_table");
  if (table) {
    const auto* rows = table->as_array();
    if (!rows || rows->size() < 2)
      r.error(r.at(*table),
              fmt::format("{} 'effort_table' must list at least 2 rows [[t, value], ...]", what));
    else
      for (const toml::node& row : *rows) {
        const auto tv = r.numbers(row, "an 'effort_table' row ([t, value])",
                                  {Scale{1.0, "s", limits::kDuration}, effort_scale});
        if (!tv) break;
        if (!c.effort.empty() && (*tv)[0] <= c.effort.back().first) {
          r.error(r.at(row), fmt::format("{} 'effort_table' times must increase strictly", what));
          break;
        }
        c.effort.emplace_back((*tv)[0], (*tv)[1]);
      }
  }
  d.law.kind = MotionLaw::Kind::constant_speed;
  d.law.speed = c.rate != 0.0 ? c.rate : 1.0;
  return c;
}

// [dynamics]: a forward-dynamics case. With one driver its coordinate's keys are [dynamics]'s;
// with several, each driver's are in [dynamics.<name>] (a driver without one starts at rest and
// moves freely).
void read_dynamics(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::table* t = r.table(root, "dynamics", "a mechanism", false);
  if (!t) return;
  const std::vector<std::string> coordinate_keys = {"rate", "rate_unit", "effort", "effort_table"};
  std::vector<std::string> keys = {"duration", "interval"};
  if (m.axis().timed())
    for (const Driver& d : m.drivers) keys.push_back(d.name);
  else
    keys.insert(keys.end(), coordinate_keys.begin(), coordinate_keys.end());
  if (m.axis().timed()) {
    // A coordinate's key at the top: whose it is is not said.
    for (const std::string& key : coordinate_keys)
      if (const toml::node* node = t->get(key))
        r.error(r.at(*node),
                fmt::format("[dynamics] '{}' belongs to one driver: with {} drivers give each "
                            "driver's rate and effort in its own table [dynamics.<name>] "
                            "([dynamics.{}])",
                            key, m.drivers.size(), m.drivers.front().name));
    for (auto&& [key, node] : *t)
      if (std::find(keys.begin(), keys.end(), key.str()) == keys.end() &&
          std::find(coordinate_keys.begin(), coordinate_keys.end(), key.str()) ==
              coordinate_keys.end())
        r.error(
            r.at(key.source()),
            fmt::format("unknown key '{}' in [dynamics]: it takes 'duration', 'interval' and "
                        "one table per driver, [dynamics.<name>] (drivers: {})",
                        key.str(), join(std::vector<std::string>(keys.begin() + 2, keys.end()))));
  } else {
    r.known_keys(*t, "[dynamics]", keys);
  }
  DynamicsCase c;
  c.where = r.at(*t);
  const Scale seconds{1.0, "s", limits::kDuration, limits::kShortestDuration};
  const std::optional<double> duration = r.number(*t, "duration", "[dynamics] (s)", true, seconds);
  if (duration && *duration <= 0.0)
    r.error(r.at(t->get("duration")), "[dynamics] 'duration' must be positive (seconds)");
  c.duration = duration.value_or(0.0);
  if (const toml::node* key = t->get("duration")) c.duration_where = r.at(*key);
  const std::optional<double> interval = r.number(*t, "interval", "[dynamics] (s)", true, seconds);
  if (interval && (*interval <= 0.0 || (duration && *interval > *duration)))
    r.error(r.at(t->get("interval")),
            "[dynamics] 'interval' (s between output samples) must be positive and at most "
            "'duration'");
  c.interval = interval.value_or(0.0);
  if (!m.axis().timed()) {
    static_cast<FreeCoordinate&>(c) = read_free_coordinate(
        r, m, m.drivers[static_cast<size_t>(m.axis().driver)], *t, "[dynamics]");
    m.dynamics = c;
    return;
  }
  for (size_t i = 0; i < m.drivers.size(); ++i) {
    Driver& d = m.drivers[i];
    const std::string what = fmt::format("[dynamics.{}]", d.name);
    FreeCoordinate coordinate;
    if (const toml::table* own = r.table(*t, d.name, "[dynamics]", false)) {
      r.known_keys(*own, what, coordinate_keys);
      coordinate = read_free_coordinate(r, m, d, *own, what);
    } else {
      d.law.kind = MotionLaw::Kind::constant_speed;  // at rest: its kinematic view at 1 unit/s
      d.law.speed = 1.0;
    }
    if (i == 0)
      static_cast<FreeCoordinate&>(c) = coordinate;
    else
      c.others.push_back(coordinate);
  }
  m.dynamics = c;
}

void read_tolerances(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::table* t = r.table(root, "tolerance", "a mechanism", false);
  if (!t) return;
  r.known_keys(*t, "[tolerance]",
               {"position", "angle", "velocity", "acceleration", "force", "torque"});
  auto read = [&](std::string_view key, std::optional<double>& out) {
    if (const auto v =
            r.number(*t, key, "[tolerance] (% of peak)", false, {1.0, "%", limits::kTolerance})) {
      if (*v <= 0.0)
        r.error(r.at(t->get(key)), fmt::format("[tolerance] '{}' must be positive", key));
      else
        out = *v;
    }
  };
  read("position", m.tolerances.position);
  read("angle", m.tolerances.angle);
  read("velocity", m.tolerances.velocity);
  read("acceleration", m.tolerances.acceleration);
  read("force", m.tolerances.force);
  read("torque", m.tolerances.torque);
}

// [expect]: the singular behaviour the definition's author derived in closed form.
void read_expect(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::table* t = r.table(root, "expect", "a mechanism", false);
  if (!t) return;
  r.known_keys(*t, "[expect]",
               {"limits", "toggles", "change_points", "grashof", "derived", "tolerance"});
  Expectations e;
  e.where = r.at(*t);
  if (refused_in_time(r, m, e.where, "[expect] gives one driver's values; this definition has {}"))
    return;
  const Scale value_scale = driver_scale(m, m.swept());
  if (const toml::node* tolerance = t->get("tolerance")) {
    e.tolerance_pct = r.number(*tolerance, "[expect] 'tolerance'", {1.0, "", limits::kTolerance});
    if (e.tolerance_pct && !(*e.tolerance_pct > 0.0))
      r.error(r.at(*tolerance),
              fmt::format("[expect] 'tolerance' must be a positive percentage of the claimed value "
                          "such as 0.1, at most {:g}",
                          limits::kTolerance));
  }
  if (const toml::node* range = t->get("limits")) {
    e.limits_at = r.at(*range);
    if (const auto v =
            r.numbers(*range, "[expect] 'limits' ([lower, upper])", {value_scale, value_scale}))
      e.limits = std::make_pair((*v)[0], (*v)[1]);
  }
  for (const auto& [key, out, at] :
       {std::tuple{"toggles", &e.toggles, &e.toggles_at},
        std::tuple{"change_points", &e.change_points, &e.change_points_at}}) {
    const toml::node* node = t->get(key);
    if (!node) continue;
    *at = r.at(*node);
    const auto* array = node->as_array();
    if (!array) {
      r.error(r.at(*node), fmt::format("[expect] '{}' must be an array of driver values", key));
      continue;
    }
    if (array->size() > limits::kExpectedPositions) {
      r.error(r.at(*node), fmt::format("[expect] '{}' lists {} values: the limit is {}", key,
                                       array->size(), limits::kExpectedPositions));
      continue;
    }
    for (const toml::node& v : *array)
      if (const auto x = r.number(v, fmt::format("[expect] '{}'", key), value_scale))
        out->push_back(*x);
  }
  if (const toml::table* derived = r.table(*t, "derived", "[expect]", false))
    for (const auto& [key, node] : *derived) {
      const std::string quantity(key.str());
      const DerivedSpec* spec = nullptr;
      const std::optional<DerivedUnit> unit = derived_unit_of(m, quantity, &spec);
      if (!unit) {
        r.error(r.at(key.source()),
                fmt::format("[expect.derived]: '{}' is no [[derived]] quantity or field{}",
                            quantity, derived_names(m)));
        continue;
      }
      if (const auto x = r.number(node, fmt::format("[expect.derived] '{}'", quantity),
                                  {derived_factor(m, *spec, *unit), "", limits::kReferenceValue}))
        e.derived.push_back({quantity, *x, r.at(node)});
    }
  e.grashof = r.string(*t, "grashof", "[expect]", false).value_or("");
  if (const toml::node* grashof = t->get("grashof")) e.grashof_at = r.at(*grashof);
  if (!e.grashof.empty() && e.grashof != "Grashof" && e.grashof != "change point" &&
      e.grashof != "non-Grashof")
    r.error(r.at(t->get("grashof")),
            "[expect] 'grashof' must be \"Grashof\", \"change point\" "
            "or \"non-Grashof\"");
  m.expect = e;
}

// [[branch]]: an assembly mode by name, `points` = three named points, `turn` = "ccw" | "cw"
// (BranchChoice).
void read_branches(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "branch", limits::kJoints);
  if (!array) return;
  const std::vector<Mechanism::NamedPoint> named = m.named_points();
  std::vector<std::string> all;
  for (const auto& p : named) all.push_back(p.name);
  for (const toml::node& entry : *array) {
    const toml::table& t = *entry.as_table();
    r.known_keys(t, "[[branch]]", {"points", "turn"});
    BranchChoice b;
    b.where = r.at(t);
    const toml::node* points = t.get("points");
    const auto* list = points ? points->as_array() : nullptr;
    if (!list || list->size() != 3) {
      r.error(points ? r.at(*points) : b.where,
              "[[branch]] needs 'points': the names of three points, whose triangle's 'turn' "
              "names the assembly");
      continue;
    }
    for (const toml::node& p : *list) {
      const auto* name = p.as_string();
      const auto found = name ? std::find_if(named.begin(), named.end(),
                                             [&](const auto& n) { return n.name == name->get(); })
                              : named.end();
      if (found == named.end()) {
        r.error(r.at(p), fmt::format("[[branch]] 'points': {} is not a named point (points: {})",
                                     name ? "'" + name->get() + "'" : "a value", join(all)));
        continue;
      }
      if (std::find(b.names.begin(), b.names.end(), found->name) != b.names.end())
        r.error(r.at(p), fmt::format("[[branch]] 'points' names '{}' twice", found->name));
      b.names.push_back(found->name);
      b.points.emplace_back(found->link, found->point);
    }
    const std::optional<std::string> turn = r.string(t, "turn", "[[branch]]", true);
    if (turn && *turn != "ccw" && *turn != "cw")
      r.error(r.at(t.get("turn")), "[[branch]] 'turn' must be \"ccw\" or \"cw\"");
    if (b.names.size() != 3 || !turn) continue;
    b.counter_clockwise = *turn == "ccw";
    m.branches.push_back(b);
  }
}

// Structure: one ground, unique names, named points that are one place, a connected chain,
// and a mobility that one driver can drive (reported at `driver`, the [driver] table, if any).
void check_structure(Reader& r, const Mechanism& m, const toml::node* driver) {
  std::vector<int> grounds;
  for (size_t i = 0; i < m.links.size(); ++i)
    if (m.links[i].ground) grounds.push_back(static_cast<int>(i));
  if (grounds.empty())
    r.error(m.links.front().where,
            "no link has ground = true: one link must be the frame (add ground = true to it)");
  if (!grounds.empty() && m.links[grounds[0]].pose_where.line > 0)
    r.error(m.links[grounds[0]].pose_where,
            fmt::format("link '{}' is the ground: its frame is the world's, so it takes no "
                        "'pose' (its points are world coordinates)",
                        m.links[grounds[0]].name));
  for (size_t i = 1; i < grounds.size(); ++i)
    r.error(m.links[grounds[i]].where,
            fmt::format("link '{}' is a second ground (the first is '{}'): exactly one link is "
                        "the frame",
                        m.links[grounds[i]].name, m.links[grounds[0]].name));
  for (size_t i = 0; i < m.joints.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (!m.joints[i].name.empty() && m.joints[i].name == m.joints[j].name)
        r.error(m.joints[i].where,
                fmt::format("duplicate joint name '{}' (first at line {}); give one a 'name'",
                            m.joints[i].name, m.joints[j].where.line));
  if (!r.diagnostics().empty()) return;

  // Links joined through revolute joints; a named point must be one place, so every link that
  // names it must be joined to the others at that point.
  const size_t n = m.links.size();
  std::vector<size_t> parent(n);
  auto find = [&](size_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  std::map<std::string, std::vector<int>> named_on;
  for (size_t l = 0; l < n; ++l)
    for (const Point& p : m.links[l].points) named_on[p.name].push_back(static_cast<int>(l));
  for (const auto& [name, links] : named_on) {
    if (links.size() < 2) continue;
    std::iota(parent.begin(), parent.end(), 0);
    for (const Joint& j : m.joints)
      if (j.type == JointType::revolute && m.links[j.link_a].points[j.point_a].name == name)
        parent[find(static_cast<size_t>(j.link_a))] = find(static_cast<size_t>(j.link_b));
    for (int l : links)
      if (find(static_cast<size_t>(l)) != find(static_cast<size_t>(links[0]))) {
        const Point& p = m.links[l].points[m.links[l].find_point(name)];
        r.error(p.where, fmt::format("point '{}' is named on links '{}' and '{}', which no "
                                     "revolute joint at '{}' connects: one name is one place "
                                     "(rename one of them)",
                                     name, m.links[links[0]].name, m.links[l].name, name));
      }
  }

  // Every link must be connected to the ground.
  std::iota(parent.begin(), parent.end(), 0);
  for (const Joint& j : m.joints)
    parent[find(static_cast<size_t>(j.link_a))] = find(static_cast<size_t>(j.link_b));
  const int g = m.ground();
  bool connected = true;
  for (size_t l = 0; l < n; ++l)
    if (find(l) != find(static_cast<size_t>(g))) {
      connected = false;
      r.error(m.links[l].where,
              fmt::format("link '{}' is not connected to the ground by any chain of joints",
                          m.links[l].name));
    }
  if (!connected) return;  // its mobility count would only repeat the fault

  const Mobility mob = mobility(m);
  const auto* several = driver ? driver->as_array() : nullptr;
  if (several && several->is_array_of_tables() && several->size() > 1) {
    const int count = static_cast<int>(several->size());
    if (mob.mobility == count) return;
    const std::string counted = fmt::format(
        "mobility {} with {} drivers. Grübler–Kutzbach: {} ({} links, {} full "
        "joints, {} half joints)",
        mob.mobility, count, mob.explain(), mob.links, mob.full_joints, mob.half_joints);
    // Too many: at the first driver beyond the mobility; too few: at the first driver.
    if (mob.mobility < count)
      r.error(r.at((*several)[static_cast<size_t>(std::max(mob.mobility, 0))]),
              fmt::format("{}: each driver fixes one freedom, so this driver is one too many "
                          "(drive {} of the coordinates, or free a joint)",
                          counted, std::max(mob.mobility, 0)));
    else
      r.error(r.at((*several)[0]),
              fmt::format("{}: {} freedom{} left undriven (add a [[driver]] for each, or a "
                          "joint)",
                          counted, mob.mobility - count, mob.mobility - count == 1 ? "" : "s"));
    return;
  }
  if (mob.mobility != 1) {
    // Say which side of the count is off: the links' freedoms or the joints' constraints.
    const int off = std::abs(mob.mobility - 1);
    const std::string freedoms = fmt::format("freedom{}", off == 1 ? "" : "s");
    const std::string verdict =
        mob.mobility < 1
            ? fmt::format(
                  "the chain is over-constrained, {} {} too few for the one driver: a "
                  "joint too many (a revolute or prismatic takes 2, a pin_in_slot or gear pair 1), "
                  "a revolute or prismatic where a pin_in_slot belongs, or a link "
                  "missing",
                  off, freedoms)
            : fmt::format(
                  "the chain is under-constrained, {} {} more than the one driver "
                  "fixes: a joint missing (a revolute or prismatic takes 2, a "
                  "pin_in_slot or gear pair 1), a pin_in_slot where a revolute or prismatic "
                  "belongs, or a link too many",
                  off, freedoms);
    r.error(r.at(driver), fmt::format("mobility {} with 1 driver. Grübler–Kutzbach: {} ({} "
                                      "links, {} full joints, {} half joints): the joints take "
                                      "{} of the {} freedoms of the {} moving links. {}",
                                      mob.mobility, mob.explain(), mob.links, mob.full_joints,
                                      mob.half_joints, 2 * mob.full_joints + mob.half_joints,
                                      3 * (mob.links - 1), mob.links - 1, verdict));
  }
}

// Screens the text before toml++ parses it: a key with more dotted parts, or arrays and inline
// tables nested deeper, than limits.h allows is refused at its place, since the parser recurses
// once per level. A light scan: strings and comments are skipped, and every dot outside them
// counts toward the key or value it is in (a float has one), up to the next = , [ ] { } or line.
std::optional<Diagnostic> screen(std::string_view text, const std::string& file) {
  int line = 1, column = 1, depth = 0, dots = 0;
  size_t i = 0;
  auto advance = [&](size_t n) {
    for (size_t end = std::min(text.size(), i + n); i < end; ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
  };
  auto starts = [&](std::string_view token) { return text.substr(i, token.size()) == token; };
  // Past the string opening at i (quote ' or "; three of them for a multi-line string).
  auto skip_string = [&] {
    const char quote = text[i];
    const bool multi = starts(std::string(3, quote));
    advance(multi ? 3 : 1);
    while (i < text.size()) {
      if (multi ? starts(std::string(3, quote)) : text[i] == quote) {
        advance(multi ? 3 : 1);
        return;
      }
      if (!multi && text[i] == '\n') return;  // unterminated: the parser says so
      advance(quote == '"' && text[i] == '\\' ? 2 : 1);
    }
  };
  while (i < text.size()) {
    const char c = text[i];
    if (c == '"' || c == '\'') {
      skip_string();
      continue;
    }
    if (c == '#') {
      while (i < text.size() && text[i] != '\n') advance(1);
      continue;
    }
    if (c == '[' || c == '{') {
      dots = 0;
      if (++depth > limits::kNesting)
        return Diagnostic{{file, line, column},
                          fmt::format("arrays and tables nested deeper than {} levels, the limit "
                                      "of a definition",
                                      limits::kNesting)};
    } else if (c == ']' || c == '}') {
      depth = std::max(0, depth - 1);
      dots = 0;
    } else if (c == '=' || c == ',' || c == '\n') {
      dots = 0;
    } else if (c == '.' && ++dots >= limits::kKeyParts) {
      return Diagnostic{{file, line, column},
                        fmt::format("a key of more than {} dotted parts, the limit of a definition",
                                    limits::kKeyParts)};
    }
    advance(1);
  }
  return std::nullopt;
}

// Points and lines over all links within their limits (each link's were checked as read), and
// a mechanism large enough for its size to scale tolerances.
void check_counts(Reader& r, const Mechanism& m) {
  size_t points = 0, lines = 0;
  for (const Link& link : m.links) {
    points += link.points.size();
    lines += link.lines.size();
    if (points > limits::kPoints || lines > limits::kLines) {
      r.error(link.where, fmt::format("{} points and {} lines up to link '{}': the limits are {} "
                                      "points and {} lines in all links",
                                      points, lines, link.name, limits::kPoints, limits::kLines));
      return;
    }
  }
  if (r.diagnostics().empty() && m.size() < limits::kSmallestSize)
    r.error(m.links.front().where,
            fmt::format("the mechanism's size (the largest distance between its drawn points) is "
                        "{:g} m: the limit is {:g} m",
                        m.size(), limits::kSmallestSize));
}

Mechanism read(Reader& r, const toml::table& root, const std::string& file) {
  Mechanism m;
  m.file = file;
  r.set_root(root);
  r.known_keys(root, "the definition",
               {"name", "description", "citation", "units", "link", "joint", "driver", "reference",
                "derived", "tolerance", "expect", "gravity", "load", "spring", "dynamics", "branch",
                "summary"});
  m.name = r.string(root, "name", "a mechanism", true).value_or("");
  m.description = r.string(root, "description", "a mechanism", false).value_or("");
  m.citation = r.string(root, "citation", "a mechanism", false).value_or("");

  if (const toml::table* units = r.table(root, "units", "a mechanism", true)) {
    r.known_keys(*units, "[units]", {"length", "angle", "mass", "force"});
    if (!units->get("length")) r.error(r.at(*units), "[units] needs 'length' (mm, cm or m)");
    if (!units->get("angle")) r.error(r.at(*units), "[units] needs 'angle' (deg or rad)");
    m.units.length =
        unit_factor(r, *units, "[units]", "length", kLengthUnits, "m", &m.units.length_name)
            .value_or(1.0);
    m.units.angle =
        unit_factor(r, *units, "[units]", "angle", kAngleUnits, "rad", &m.units.angle_name)
            .value_or(1.0);
    r.set_angle_unit(m.units.angle);
    m.units.mass = unit_factor(r, *units, "[units]", "mass", kMassUnits, "kg", &m.units.mass_name)
                       .value_or(1.0);
    m.units.force =
        unit_factor(r, *units, "[units]", "force", kForceUnits, "N", &m.units.force_name)
            .value_or(1.0);
  }

  const toml::node* links = root.get("link");
  const auto* link_array = links ? links->as_array() : nullptr;
  if (!link_array || !link_array->is_array_of_tables() || link_array->empty()) {
    r.error(links ? r.at(*links) : r.file(), "a mechanism needs [[link]] tables");
    r.throw_if_any();
  }
  if (link_array->size() > limits::kLinks) {
    r.error(r.at((*link_array)[limits::kLinks]),
            fmt::format("{} [[link]] tables: the limit is {}", link_array->size(), limits::kLinks));
    r.throw_if_any();
  }
  for (size_t i = 0; i < link_array->size(); ++i)
    m.links.push_back(read_link(r, *(*link_array)[i].as_table(), m.units, static_cast<int>(i)));
  check_counts(r, m);
  r.throw_if_any();
  // Names must be unique before joints refer to them.
  for (size_t i = 0; i < m.links.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (m.links[i].name == m.links[j].name)
        r.error(m.links[i].where,
                fmt::format("duplicate link name '{}' (first at line {}); link names must be "
                            "unique",
                            m.links[i].name, m.links[j].where.line));
  for (const Link& link : m.links)
    for (size_t i = 0; i < link.points.size(); ++i)
      for (size_t j = 0; j < i; ++j)
        if (link.points[i].name == link.points[j].name)
          r.error(link.points[i].where,
                  fmt::format("duplicate point '{}' on link '{}'", link.points[i].name, link.name));
  r.throw_if_any();
  const double size = m.size();
  for (Link& link : m.links)
    if (link.mass.assumed) link.mass = default_mass_properties(link, size);
  if (const toml::node* g = root.get("gravity"))
    if (const auto v = r.numbers(*g, "'gravity' ([gx, gy] in the length unit per s^2)",
                                 {Scale{m.units.length, "", limits::kGravity},
                                  Scale{m.units.length, "", limits::kGravity}}))
      m.gravity = Eigen::Vector2d((*v)[0], (*v)[1]);

  const toml::node* joints = root.get("joint");
  const auto* joint_array = joints ? joints->as_array() : nullptr;
  if (!joint_array || !joint_array->is_array_of_tables()) {
    r.error(joints ? r.at(*joints) : r.file(), "a mechanism needs [[joint]] tables");
  } else if (joint_array->size() > limits::kJoints) {
    r.error(
        r.at((*joint_array)[limits::kJoints]),
        fmt::format("{} [[joint]] tables: the limit is {}", joint_array->size(), limits::kJoints));
  } else {
    for (size_t i = 0; i < joint_array->size(); ++i)
      m.joints.push_back(read_joint(r, m, *(*joint_array)[i].as_table(), static_cast<int>(i)));
    for (size_t i = 0; i < joint_array->size(); ++i)
      if (m.joints[i].is_gearing())
        read_gearing(r, m, *(*joint_array)[i].as_table(), static_cast<int>(i));
  }
  r.throw_if_any();

  check_structure(r, m, root.get("driver"));
  read_drivers(r, m, root);
  read_dynamics(r, m, root);
  read_loads(r, m, root);
  read_springs(r, m, root);
  read_tolerances(r, m, root);
  read_derived(r, m, root);
  add_design_summary(r, m, root);
  read_references(r, m, root);
  read_expect(r, m, root);
  read_branches(r, m, root);
  check_locked(r, m);
  r.throw_if_any();
  return m;
}

}  // namespace

Mechanism parse_definition(std::string_view text, const std::string& file) {
  Reader reader(file, text);
  if (text.size() > static_cast<size_t>(limits::kDefinitionBytes)) {
    reader.error(reader.file(), fmt::format("the file has more than {} bytes, the limit of a "
                                            "definition",
                                            limits::kDefinitionBytes));
    reader.throw_if_any();
  }
  if (std::optional<Diagnostic> fault = screen(text, file)) throw DefinitionError({*fault});
  toml::table root;
  try {
    root = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    reader.error(reader.at(e.source()), fmt::format("TOML syntax: {}", e.description()));
    reader.throw_if_any();
  }
  return read(reader, root, file);
}

Mechanism read_definition(const std::string& path) {
  // "-" is standard input, named <stdin> in diagnostics.
  const bool standard_input = path == "-";
  const std::string name = standard_input ? "<stdin>" : path;
  std::ifstream file;
  if (!standard_input) file.open(path, std::ios::binary);
  std::istream& in = standard_input ? std::cin : file;
  auto refuse = [&](std::string message) {
    Diagnostic problem;
    problem.where.file = name;
    problem.message = std::move(message);
    throw DefinitionError({problem});
  };
  if (!in) refuse("cannot open the file");
  // One byte over the limit is enough to refuse it (and /dev/zero is not read for ever).
  std::string text(static_cast<size_t>(limits::kDefinitionBytes) + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (!in && !in.eof()) refuse("cannot read the file");  // a directory, say
  text.resize(static_cast<size_t>(in.gcount()));
  return parse_definition(text, name);
}

}  // namespace crosslink
