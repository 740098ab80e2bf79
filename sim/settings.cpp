#include "sim/settings.h"

#include <fmt/format.h>

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

}  // namespace

double setting_number(std::string_view name, const std::string& text, const SettingRange& range) {
  const std::optional<double> v = finite(text);
  if (!v || *v < range.low || (range.low_open && *v == range.low) || *v > range.high ||
      (range.high_open && *v == range.high))
    refuse(name, text, describe(range));
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

int setting_count(std::string_view name, const std::string& text, int most) {
  const std::optional<double> v = finite(text);
  if (!v || *v < 1.0 || *v > most || *v != std::floor(*v))
    refuse(name, text, fmt::format("a whole number from 1 to {}", most));
  return static_cast<int>(*v);
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
