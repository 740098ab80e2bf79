#include "analytic/derived/claims.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "analytic/derived/derived.h"
#include "analytic/model/fourbar.h"
#include "analytic/model/units_text.h"

namespace crosslink {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// How claims of one kind are read: their SI scale (a floor under the relative tolerance), the
// file's unit (value / factor, and its name), and whether they are angles a turn apart.
struct Reading {
  double scale = 1.0;
  double factor = 1.0;
  std::string unit;
  bool periodic = false;
};

class Judge {
 public:
  explicit Judge(const Mechanism& m) : tolerance_(claim_tolerance_pct(*m.expect) / 100.0) {}

  bool close(double claimed, double computed, const Reading& r) const {
    double d = computed - claimed;
    if (r.periodic) d = std::remainder(d, kTwoPi);
    return std::abs(d) <= tolerance_ * std::max(std::abs(claimed), r.scale);
  }
  std::string text(double si, const Reading& r) const {
    return fmt::format("{:.12g}{}{}", si / r.factor, r.unit.empty() ? "" : " ", r.unit);
  }
  std::string list(const std::vector<double>& si, const Reading& r) const {
    std::string out;
    for (double v : si) out += (out.empty() ? "" : ", ") + text(v, r);
    return "[" + out + "]";
  }

 private:
  double tolerance_;
};

Reading driver_reading(const Mechanism& m) {
  const DriverUnit u = driver_unit_of(m);
  return {m.swept().angular() ? 1.0 : m.size(), u.scale, u.name, false};
}

// Positions claimed against those found, as sorted lists: the same count, each within tolerance.
Claim positions(const Mechanism& m, const Judge& judge, std::string_view key,
                std::vector<double> claimed, const SourceLocation& at,
                const std::vector<SingularPosition>& singular, SingularKind kind) {
  std::vector<double> found;
  for (const SingularPosition& p : singular)
    if (p.kind == kind) found.push_back(p.driver);
  std::sort(claimed.begin(), claimed.end());
  std::sort(found.begin(), found.end());
  const Reading r = driver_reading(m);
  Claim c{fmt::format("[expect] '{}'", key), at, judge.list(claimed, r), judge.list(found, r)};
  c.holds = claimed.size() == found.size() &&
            std::equal(claimed.begin(), claimed.end(), found.begin(),
                       [&](double a, double b) { return judge.close(a, b, r); });
  return c;
}

Claim limits(const Mechanism& m, const Judge& judge) {
  const Expectations& e = *m.expect;
  const Reading r = driver_reading(m);
  Claim c{"[expect] 'limits'", e.limits_at, judge.list({e.limits->first, e.limits->second}, r), ""};
  const AssemblingRange range = assembling_range(m);
  if (!range.unknown.empty() || range.full_cycle) {
    c.computed = range.explain(m);
    return c;
  }
  c.computed = judge.list({range.lower, range.upper}, r);
  c.holds =
      judge.close(e.limits->first, range.lower, r) && judge.close(e.limits->second, range.upper, r);
  return c;
}

Claim derived(const Mechanism& m, const Judge& judge, const Expectations::Derived& claim,
              const std::vector<DerivedValue>& values) {
  const DerivedSpec* spec = nullptr;
  const DerivedUnit unit = *derived_unit_of(m, claim.quantity, &spec);  // the loader checked it
  const bool angle =
      unit == DerivedUnit::angle || (unit == DerivedUnit::driver && m.swept().angular());
  const bool length = unit == DerivedUnit::length || unit == DerivedUnit::driver;
  const Reading r{angle    ? 1.0
                  : length ? m.size()
                           : 1.0,
                  derived_factor(m, *spec, unit), derived_unit_name(m, *spec, unit),
                  angle && unit == DerivedUnit::driver};
  Claim c{fmt::format("[expect.derived] '{}'", claim.quantity), claim.where,
          judge.text(claim.value, r), ""};
  const auto value = std::find_if(values.begin(), values.end(),
                                  [&](const DerivedValue& v) { return v.spec == spec; });
  const std::optional<double> computed = derived_value(values, claim.quantity);
  if (!computed) {
    c.computed =
        value != values.end() && !value->reason.empty() ? "none: " + value->reason : "none";
    return c;
  }
  c.computed = judge.text(*computed, r);
  c.holds = judge.close(claim.value, *computed, r);
  return c;
}

}  // namespace

double claim_tolerance_pct(const Expectations& e) {
  return e.tolerance_pct.value_or(kClaimTolerancePct);
}

std::vector<Claim> judge_claims(const Mechanism& m, const std::vector<DerivedValue>& derived_values,
                                const std::vector<SingularPosition>& singular) {
  std::vector<Claim> claims;
  if (!m.expect) return claims;
  const Expectations& e = *m.expect;
  const Judge judge(m);
  if (e.limits) claims.push_back(limits(m, judge));
  if (e.toggles_at.line > 0 || !e.toggles.empty())
    claims.push_back(
        positions(m, judge, "toggles", e.toggles, e.toggles_at, singular, SingularKind::toggle));
  if (e.change_points_at.line > 0 || !e.change_points.empty())
    claims.push_back(positions(m, judge, "change_points", e.change_points, e.change_points_at,
                               singular, SingularKind::change_point));
  if (!e.grashof.empty()) {
    const std::optional<FourBar> fb = four_bar(m);
    Claim c{"[expect] 'grashof'", e.grashof_at, e.grashof,
            fb ? std::string(to_string(fb->grashof)) : "none: not a four-bar"};
    c.holds = fb && c.computed == e.grashof;
    claims.push_back(std::move(c));
  }
  for (const Expectations::Derived& d : e.derived)
    claims.push_back(derived(m, judge, d, derived_values));
  return claims;
}

}  // namespace crosslink
