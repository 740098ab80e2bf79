// What both engines share in reading their settings (--set NAME=VALUE) before any run: a
// number's text and the values it may take, a whole count, and the perturb_link test hook. Each
// reader throws std::invalid_argument naming the setting, its text and what it takes, so that a
// bad value is bad input (exit 2), never a failed run.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "analytic/mechanism.h"

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

// A finite number in `range` (any finite number by default).
double setting_number(std::string_view name, const std::string& text,
                      const SettingRange& range = {});
// Finite numbers separated by spaces ("0.02 1").
std::vector<double> setting_numbers(std::string_view name, const std::string& text);
// A whole number from 1 to `most` ("50", "5e1"; not "2.5" nor "3e9" beyond an int).
int setting_count(std::string_view name, const std::string& text,
                  int most = std::numeric_limits<int>::max());

// The test hook perturb_link = "<moving link>:<positive factor>": that link's points and line
// origins scaled, so the scene is assembled for a valid but wrong linkage. "" or "none": `m` as
// it is. The link must be a moving link of `m`.
Mechanism perturbed(const Mechanism& m, const std::string& text);

}  // namespace crosslink::sim
