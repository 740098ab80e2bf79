#include "methods/sweep_ranking.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "methods/engines.h"

namespace crosslink::methods {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The row's largest error over its limit and the class of it; infinity where a class the row
// must meet has no value (NaN: it cannot be judged).
std::pair<double, std::string> worst_ratio(const SweepRow& r, const ClassLimits& limits) {
  double worst = 0.0;
  std::string which;
  for (ErrorClass c : kErrorClasses) {
    const double e = r.error(c);
    if (c == ErrorClass::force && std::isnan(e)) continue;  // forces not read
    const double ratio = std::isnan(e) ? std::numeric_limits<double>::infinity()
                                       : e / limits.pct[static_cast<size_t>(c)];
    if (ratio > worst || which.empty()) worst = ratio, which = std::string(to_string(c));
  }
  if (!std::isnan(r.energy_pct) && r.energy_pct / limits.energy_pct > worst)
    worst = r.energy_pct / limits.energy_pct, which = "energy";
  return {worst, which};
}

// The engines with a row, in the order of their first row.
std::vector<std::string> engines_of(const std::vector<SweepRow>& rows) {
  std::vector<std::string> engines;
  for (const SweepRow& r : rows)
    if (r.engine != "analytic" &&
        std::find(engines.begin(), engines.end(), r.engine) == engines.end())
      engines.push_back(r.engine);
  return engines;
}

}  // namespace

std::string EngineRank::text() const {
  const char* per = std::isnan(row.energy_pct) ? "cycle" : "simulated s";
  if (met)
    return fmt::format(
        "{}: {} at {:.3g} s CPU per {} (work {:.4g}); worst class {} at {:.2g} of "
        "its limit",
        engine, row.setting_label(), row.cost(), per, row.work(), worst_class, worst_ratio);
  if (!has_row) return fmt::format("{}: never meets it: no run with status ok", engine);
  return fmt::format("{}: never meets it: best {} ({:.3g} s CPU per {}), {} {:.3g} times its limit",
                     engine, row.setting_label(), row.cost(), per, worst_class, worst_ratio);
}

ClassLimits common_tolerances(const std::vector<std::string>& engines, bool dynamics) {
  ClassLimits out;
  out.pct.fill(std::numeric_limits<double>::infinity());
  out.energy_pct = std::numeric_limits<double>::infinity();
  for (const std::string& name : engines) {
    const EngineEntry* entry = find_engine(name);
    if (!entry) continue;
    const compare::ClassTolerances& t = dynamics ? entry->dynamics_tolerances : entry->tolerances;
    const auto tighten = [](double& limit, double v) { limit = std::min(limit, v); };
    tighten(out.pct[static_cast<size_t>(ErrorClass::position)], std::min(t.position, t.angle));
    tighten(out.pct[static_cast<size_t>(ErrorClass::velocity)], t.velocity);
    tighten(out.pct[static_cast<size_t>(ErrorClass::acceleration)], t.acceleration);
    tighten(out.pct[static_cast<size_t>(ErrorClass::force)], std::min(t.force, t.torque));
    tighten(out.energy_pct, t.energy);
  }
  return out;
}

EngineRanking rank_engines(const std::vector<SweepRow>& rows, const ClassLimits& limits,
                           std::string rule) {
  EngineRanking out{limits, std::move(rule), {}};
  for (const std::string& engine : engines_of(rows)) {
    EngineRank rank;
    rank.engine = engine;
    const Selection s = select_cheapest(engine, limits, rows);
    if (s.found) {
      rank.met = rank.has_row = true;
      rank.row = s.chosen;
      std::tie(rank.worst_ratio, rank.worst_class) = worst_ratio(s.chosen, limits);
    } else {
      for (const SweepRow& r : rows) {
        if (r.engine != engine || r.status != RunStatus::ok) continue;
        const auto [ratio, which] = worst_ratio(r, limits);
        if (std::isfinite(ratio) && (!rank.has_row || ratio < rank.worst_ratio)) {
          rank.has_row = true;
          rank.row = r;
          rank.worst_ratio = ratio;
          rank.worst_class = which;
        }
      }
    }
    out.engines.push_back(std::move(rank));
  }
  // Met first, by CPU time; then not met, closest to the limits first; then no row. Stable: the
  // sweep's engine order among equals.
  const auto key = [](const EngineRank& r) {
    return std::make_pair(r.met       ? 0
                          : r.has_row ? 1
                                      : 2,
                          r.met       ? r.row.cost()
                          : r.has_row ? r.worst_ratio
                                      : 0.0);
  };
  std::stable_sort(out.engines.begin(), out.engines.end(),
                   [&](const EngineRank& a, const EngineRank& b) { return key(a) < key(b); });
  return out;
}

EngineRanking rank_engines(const SettingsSweep& sweep) {
  if (const std::optional<double> accuracy_pct = sweep.accuracy_pct)
    return rank_engines(sweep.rows, ClassLimits::uniform(*accuracy_pct),
                        fmt::format("--accuracy {:g} %: every class (and the energy balance) "
                                    "within {:g} % of peak",
                                    *accuracy_pct, *accuracy_pct));
  // No engine ran (each "not run" line says why): no tolerance to take the tightest of, and no
  // limit written as a number that does not exist.
  if (engines_of(sweep.rows).empty())
    return rank_engines(sweep.rows, {}, "no engine ran: nothing to rank");
  const ClassLimits limits = common_tolerances(engines_of(sweep.rows), sweep.dynamics);
  std::string rule = fmt::format(
      "no --accuracy: each class within the tightest default tolerance of the engines ranked "
      "(position {:g}, velocity {:g}, acceleration {:g}, force {:g} % of peak",
      limits.pct[0], limits.pct[1], limits.pct[2], limits.pct[3]);
  rule += sweep.dynamics ? fmt::format(", energy {:g} % of its scale)", limits.energy_pct) : ")";
  return rank_engines(sweep.rows, limits, std::move(rule));
}

}  // namespace crosslink::methods
