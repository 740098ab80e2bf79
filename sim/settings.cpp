#include "sim/settings.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace crosslink::sim {
namespace {

[[noreturn]] void refuse(std::string_view name, const std::string& text, std::string_view what) {
  throw std::invalid_argument(fmt::format("setting {} = \"{}\": expected {}", name, text, what));
}

std::string describe(const SettingRange& r) {
  const bool below = std::isfinite(r.low), above = std::isfinite(r.high);
  if (!below && !above) return "a number";
  if (r.low == 0.0 && !above) return r.low_open ? "a positive number" : "0 or a positive number";
  return fmt::format("a number in {}{:g}, {:g}{}", r.low_open ? '(' : '[', r.low, r.high,
                     r.high_open ? ')' : ']');
}

// The text as one finite number, or nullopt.
std::optional<double> finite(const std::string& text) {
  size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (used != text.size() || !std::isfinite(value)) return std::nullopt;
  return value;
}

// The text as a finite number within `range`, or nullopt.
std::optional<double> within(const std::string& text, const SettingRange& range) {
  const std::optional<double> v = finite(text);
  if (!v || *v < range.low || (range.low_open && *v == range.low) || *v > range.high ||
      (range.high_open && *v == range.high))
    return std::nullopt;
  return v;
}

}  // namespace

double setting_number(std::string_view name, const std::string& text, const SettingRange& range) {
  const std::optional<double> v = within(text, range);
  if (!v) refuse(name, text, describe(range));
  return *v;
}

std::vector<double> setting_numbers(std::string_view name, const std::string& text) {
  std::istringstream in(text);
  std::vector<double> values;
  for (std::string word; in >> word;) {
    const std::optional<double> v = finite(word);
    if (!v) refuse(name, text, "numbers separated by spaces");
    values.push_back(*v);
  }
  return values;
}

long setting_count(std::string_view name, const std::string& text, long most, long least) {
  const std::string takes = fmt::format("a whole number from {} to {}", least, most);
  // Digits alone are read exactly (a count beyond 2^53 is not rounded); "5e1" as a number.
  if (!text.empty() && text.find_first_not_of("0123456789") == std::string::npos) {
    try {
      const long long v = std::stoll(text);
      if (v >= least && v <= most) return static_cast<long>(v);
    } catch (const std::out_of_range&) {
    }
    refuse(name, text, takes);
  }
  const std::optional<double> v = finite(text);
  if (!v || *v < static_cast<double>(least) || *v > static_cast<double>(most) ||
      *v != std::floor(*v))
    refuse(name, text, takes);
  return static_cast<long>(*v);
}

namespace {

// "a, b or c"
std::string one_of(const std::vector<std::string>& words) {
  std::string out;
  for (size_t i = 0; i < words.size(); ++i)
    out += (i == 0 ? "" : i + 1 == words.size() ? " or " : ", ") + words[i];
  return out;
}

// Numbers and counts: what they take besides ", or auto".
std::string or_words(std::string what, const std::vector<std::string>& words) {
  return words.empty() ? what : what + ", or " + one_of(words);
}

}  // namespace

std::string allowed_values(const SettingSpec& spec) {
  if (spec.reported) return "reported by the run, not set";
  switch (spec.kind) {
    case SettingKind::number:
      return or_words(describe(spec.range), spec.words);
    case SettingKind::count:
      return or_words(fmt::format("a whole number from {} to {}", spec.least, spec.most),
                      spec.words);
    case SettingKind::choice:
      return one_of(spec.words);
    case SettingKind::text:
      return spec.allowed;
  }
  return spec.allowed;
}

bool applies(const SettingSpec& spec, RunKind run, bool friction, bool contact) {
  if ((spec.friction && !friction) || (spec.contact && !contact)) return false;
  return spec.applies_to == AppliesTo::both ||
         (spec.applies_to == AppliesTo::kinematic) == (run == RunKind::kinematic);
}

RunSettings printed_settings(const SettingSchema& schema, RunKind run, const RunSettings& in_force,
                             bool friction, bool contact) {
  const char* const kind = run == RunKind::kinematic ? "kinematic" : "dynamics";
  const auto declared = [&](const SettingSpec& s) { return applies(s, run, friction, contact); };
  auto named = [&](std::string_view name) {
    return std::find_if(in_force.begin(), in_force.end(),
                        [&](const auto& value) { return value.first == name; });
  };
  RunSettings out;
  for (const SettingSpec& s : schema) {
    if (!declared(s)) continue;
    const auto value = named(s.name);
    if (value == in_force.end())
      throw std::logic_error(fmt::format("a {} run gives no value for {}", kind, s.name));
    out.push_back(*value);
  }
  for (auto value = in_force.begin(); value != in_force.end(); ++value) {
    const std::string& name = value->first;
    if (named(name) != value)
      throw std::logic_error(fmt::format("a {} run gives {} twice", kind, name));
    if (std::none_of(schema.begin(), schema.end(),
                     [&](const SettingSpec& s) { return s.name == name && declared(s); }))
      throw std::logic_error(
          fmt::format("a {} run gives {}, which its schema does not declare for it", kind, name));
  }
  return out;
}

std::string format_number(double v) {
  return fmt::format("{:.6g}", v);
}

std::pair<std::string, std::string> friction_load_value(bool extrapolated) {
  return {"friction_load", extrapolated ? "extrapolated" : "last"};
}

SettingSpec shared_setting(std::string_view name) {
  using enum SettingKind;
  if (name == "max_steps")
    return {.name = "max_steps",
            .kind = count,
            .default_value = std::to_string(kDefaultMaxSteps),
            .doc = "the most steps of a run (refused before it starts)",
            .most = kMostSteps};
  if (name == "perturb_link")
    return {.name = "perturb_link",
            .kind = text,
            .default_value = "none",
            .doc = "test hook: that link's points scaled in the scene only",
            .allowed = "none, or <moving link>:<positive factor>"};
  // Declared alike by the engines that bound joint friction per step (FrictionLoads).
  if (name == "friction_load")
    return {.name = "friction_load",
            .kind = choice,
            .default_value = "extrapolated",
            .doc =
                "joint friction's load (mu r |R|, mu |N|) for a step: last, the reactions of "
                "the step before; extrapolated, linearly from the two steps before",
            .words = {"extrapolated", "last"},
            .friction = true};
  // Declared by the engines that mesh a cam (SceneContact::cam_polygon).
  if (name == "cam_facets")
    return {.name = "cam_facets",
            .kind = count,
            .default_value = std::to_string(kDefaultCamFacets),
            .doc =
                "a cam profile that is not a disc: its convex mesh's facets a turn, the "
                "vertices on the profile",
            .most = 1'000'000,
            .least = 3,  // a polygon
            .contact = true};
  if (name == "divergence_energy")
    return {.name = "divergence_energy",
            .kind = number,
            .default_value = "1",
            .doc = "forward dynamics: beyond it (of the energy scale) the run stops: diverged",
            .range = kPositive,
            .applies_to = AppliesTo::dynamics};
  // Declared alike by Bullet, ODE and Simbody (MuJoCo's differ: its gap is a cut's, its driver
  // and conditioning thresholds have other defaults).
  if (name == "gap_threshold")
    return {.name = "gap_threshold",
            .kind = number,
            .default_value = "auto",
            .doc = "a larger joint gap [m] in a sample's stencil flags loop_gap; auto: 1e-4 x size",
            .range = kPositive,
            .words = {"auto"}};
  if (name == "divergence_gap")
    return {.name = "divergence_gap",
            .kind = number,
            .default_value = "0.1",
            .doc = "beyond this gap (of the size) the run stops: diverged",
            .range = kPositive};
  if (name == "driver_threshold")
    return {.name = "driver_threshold",
            .kind = number,
            .default_value = "auto",
            .doc =
                "a driver further from its law [rad or m] is lost; auto: 1e-4 rad (1e-4 x size "
                "for a slider)",
            .range = kPositive,
            .words = {"auto"},
            .applies_to = AppliesTo::kinematic};
  if (name == "singular_rcond")
    return {.name = "singular_rcond",
            .kind = number,
            .default_value = "0.03",
            .doc = "samples conditioned worse than this fraction of the chain's own are singular",
            .range = kRcond};
  if (name == "branch_distance")
    return {.name = "branch_distance",
            .kind = number,
            .default_value = "0.0001",
            .doc =
                "a closed configuration this far from the reference's (of the size, or rad) is "
                "branch_jump",
            .range = kPositive,
            .applies_to = AppliesTo::kinematic};
  if (name == "energy_threshold")
    return {.name = "energy_threshold",
            .kind = number,
            .default_value = "0.001",
            .doc = "forward dynamics: an energy error over the energy scale beyond it is a note",
            .range = kPositive,
            .applies_to = AppliesTo::dynamics};
  // Reported by every engine's runs.
  if (name == "mass_model")
    return {.name = "mass_model",
            .doc = "the masses and inertias the scene is built with",
            .reported = true};
  if (name == "driver")
    return {.name = "driver",
            .doc = "forward dynamics: what moves the driven coordinate",
            .applies_to = AppliesTo::dynamics,
            .reported = true};
  if (name == "energy_scale")
    return {.name = "energy_scale",
            .doc = "forward dynamics: the energy [J] the energy thresholds are fractions of",
            .applies_to = AppliesTo::dynamics,
            .reported = true};
  throw std::logic_error(fmt::format("no shared setting {}", name));
}

SettingValues::SettingValues(const SettingSchema& schema, std::string_view engine,
                             const RunSettings& overrides)
    : schema_(schema), given_(schema.size(), false) {
  for (const SettingSpec& s : schema) text_.push_back(s.default_value);
  for (const auto& setting : overrides) {
    const std::string& name = setting.first;    // a plain reference: clang 14 cannot capture a
    const std::string& value = setting.second;  // structured binding in the lambda below
    const auto it = std::find_if(schema.begin(), schema.end(),
                                 [&](const SettingSpec& s) { return s.name == name; });
    if (it == schema.end()) {
      std::string known;
      for (const SettingSpec& s : schema)
        if (!s.reported) known += (known.empty() ? "" : ", ") + s.name;
      throw std::invalid_argument(
          fmt::format("unknown {} setting \"{}\" (known: {})", engine, name, known));
    }
    const SettingSpec& spec = *it;
    if (spec.reported)
      throw std::invalid_argument(
          fmt::format("{} setting \"{}\" is reported by the run, not set", engine, name));
    const bool word = std::find(spec.words.begin(), spec.words.end(), value) != spec.words.end();
    if (spec.kind == SettingKind::choice && !word) refuse(name, value, allowed_values(spec));
    if (spec.kind == SettingKind::number && !word && !within(value, spec.range))
      refuse(name, value, allowed_values(spec));
    if (spec.kind == SettingKind::count && !word)
      (void)setting_count(name, value, spec.most, spec.least);
    const auto i = static_cast<size_t>(it - schema.begin());
    text_[i] = value;
    given_[i] = true;
  }
}

const SettingSpec& SettingValues::spec(std::string_view name) const {
  for (const SettingSpec& s : schema_)
    if (s.name == name && !s.reported) return s;
  throw std::logic_error(fmt::format("setting {} is not declared (or only reported)", name));
}

const std::string& SettingValues::text(std::string_view name) const {
  return text_[static_cast<size_t>(&spec(name) - schema_.data())];
}

bool SettingValues::given(std::string_view name) const {
  return given_[static_cast<size_t>(&spec(name) - schema_.data())];
}

double SettingValues::number(std::string_view name) const {
  return setting_number(name, text(name), spec(name).range);
}

long SettingValues::count(std::string_view name) const {
  return setting_count(name, text(name), spec(name).most, spec(name).least);
}

Mechanism perturbed(const Mechanism& m, const std::string& text) {
  if (text.empty() || text == "none") return m;
  const size_t colon = text.rfind(':');
  const int link = colon == std::string::npos ? -1 : m.find_link(text.substr(0, colon));
  const std::optional<double> factor =
      colon == std::string::npos ? std::nullopt : finite(text.substr(colon + 1));
  if (link < 0 || m.links[static_cast<size_t>(link)].ground || !factor || !(*factor > 0.0)) {
    std::string links;
    for (const Link& l : m.links)
      if (!l.ground) links += (links.empty() ? "" : ", ") + l.name;
    refuse("perturb_link", text,
           fmt::format("\"<moving link>:<positive factor>\" (moving links: {})", links));
  }
  Mechanism out = m;
  for (Point& p : out.links[static_cast<size_t>(link)].points) p.local *= *factor;
  for (Line& l : out.links[static_cast<size_t>(link)].lines) l.origin *= *factor;
  return out;
}

}  // namespace crosslink::sim
