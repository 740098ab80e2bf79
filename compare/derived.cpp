#include "compare/derived.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <stdexcept>
#include <utility>

#include "compare/comparison.h"
#include "compare/metrics.h"
#include "compare/report.h"

namespace crosslink::compare {
namespace {

// The class a field is judged in: its channel's; a driver value's as an angle (or a slider's
// position); a ratio's as the angles it is made of; a path's deviation and extent as positions.
Quantity quantity_of(const DerivedSpec& spec, DerivedUnit unit, bool angular) {
  switch (unit) {
    case DerivedUnit::channel:
      return Trajectory::quantity_of(spec.channel);
    case DerivedUnit::driver:
      return angular ? Quantity::angle : Quantity::position;
    case DerivedUnit::ratio:
    case DerivedUnit::angle:
      return Quantity::angle;
    case DerivedUnit::length:
      return Quantity::position;
    case DerivedUnit::speed:
      return Quantity::velocity;
  }
  return Quantity::position;
}

// The scale of a field's % (metrics.h's peak P of its kind): the channel's peak over the
// reference's trusted samples (the size L for positions, pi for angles), pi for a driver angle or
// an angle, L for a slider's driver value and a path's lengths, the exact ratio itself.
double scale_of(const Mechanism& m, const DerivedSpec& spec, DerivedUnit unit,
                const Trajectory& ref, std::optional<double> exact) {
  const double size = m.size();
  switch (unit) {
    case DerivedUnit::channel: {
      std::vector<bool> usable(static_cast<size_t>(ref.samples()));
      for (int k = 0; k < ref.samples(); ++k)
        usable[static_cast<size_t>(k)] = crosslink::usable(ref.status[static_cast<size_t>(k)]);
      return channel_peak(spec.channel, *ref.channel(spec.channel), usable, size);
    }
    case DerivedUnit::driver:
      return m.swept().angular() ? std::numbers::pi : size;
    case DerivedUnit::angle:
      return std::numbers::pi;
    case DerivedUnit::length:
      return size;
    case DerivedUnit::ratio:
    case DerivedUnit::speed:
      return exact ? std::abs(*exact) : 0.0;
  }
  return 0.0;
}

const DerivedValue* find(const std::vector<DerivedValue>& values, const DerivedSpec* spec) {
  for (const DerivedValue& v : values)
    if (v.spec == spec) return &v;
  return nullptr;
}

std::optional<double> value_of(const DerivedValue* v, const std::string& field) {
  if (!v) return std::nullopt;
  const DerivedField* f = v->field(field);
  return f ? f->value : std::nullopt;
}

std::vector<double> ties_of(const DerivedValue* v, const std::string& field) {
  const DerivedField* f = v ? v->field(field) : nullptr;
  return f ? f->ties : std::vector<double>{};
}

// A field in the file's units, "" where it does not exist.
std::string shown(const Mechanism& m, const DerivedSpec& spec, DerivedUnit unit,
                  std::optional<double> si) {
  if (!si) return "";
  if (unit == DerivedUnit::driver) return driver_text(m, *si, 4);
  return fmt::format("{:.6g}", *si / derived_factor(m, spec, unit));
}

std::string unit_text(const Mechanism& m, const DerivedSpec& spec, DerivedUnit unit) {
  const std::string name = derived_unit_name(m, spec, unit);
  return name.empty() ? "" : " " + name;
}

std::string pct_text(double pct) {
  return std::isfinite(pct) ? fmt::format("{:.3g}", pct) : std::string("-");
}

}  // namespace

namespace {

// The pair of locations, one of each side's tied ones, nearest each other (a tie is a tie: either
// place is the extreme's); the values themselves without ties.
std::pair<double, double> nearest(double a, const std::vector<double>& a_ties, double b,
                                  const std::vector<double>& b_ties, bool angle) {
  std::pair<double, double> best{a, b};
  double gap = INFINITY;
  for (size_t i = 0; i <= a_ties.size(); ++i)
    for (size_t j = 0; j <= b_ties.size(); ++j) {
      const double x = i == 0 ? a : a_ties[i - 1], y = j == 0 ? b : b_ties[j - 1];
      const double d = std::abs(angle ? wrap_angle(x - y) : x - y);
      if (d < gap) {
        gap = d;
        best = {x, y};
      }
    }
  return best;
}

}  // namespace

double DerivedCheck::pct_vs_exact() const {
  if (!value || !exact) return NAN;
  const auto [v, e] = nearest(*value, value_ties, *exact, exact_ties, false);
  if (!(std::abs(e) >= std::numeric_limits<double>::min())) return NAN;  // 0 or subnormal
  return percent_difference(v, e);
}

double DerivedCheck::pct_of_scale() const {
  if (!value || !estimate || scale <= 0.0) return NAN;
  const bool angle = unit == DerivedUnit::driver && scale == std::numbers::pi;
  const auto [v, e] = nearest(*value, value_ties, *estimate, estimate_ties, angle);
  double d = v - e;
  if (angle) d = wrap_angle(d);
  return 100.0 * std::abs(d) / scale;
}

int DerivedResults::failures() const {
  int n = 0;
  for (const DerivedCheck& c : checks) n += c.verdict == Verdict::fail ? 1 : 0;
  return n;
}

DerivedResults compare_derived(const Mechanism& m, const std::vector<MethodRun>& methods,
                               const Tolerances& tolerances, std::vector<DerivedValue> exact) {
  DerivedResults out;
  if (m.derived.empty() || methods.empty()) return out;
  if (exact.size() != m.derived.size())
    throw std::logic_error("compare_derived: the exact values are not the mechanism's quantities");
  const Trajectory& ref = methods.front().trajectory;
  out.exact = std::move(exact);
  out.estimate = derived_sampled(m, ref);
  for (size_t i = 1; i < methods.size(); ++i) {
    const MethodRun& run = methods[i];
    // A method that does not compute every channel (the instantaneous centres: velocities) has
    // no [[derived]] values: its other channels are copies.
    if (!run.available || !run.kinds.empty()) continue;
    out.methods.push_back({run.name, derived_sampled(m, run.trajectory)});
    if (!run.ok)
      for (DerivedValue& v : out.methods.back().values) {
        for (DerivedField& f : v.fields) f.value.reset();
        v.reason = "the method did not complete: " + run.message;
      }
  }
  for (const DerivedValue& exact : out.exact)
    for (const DerivedField& f : exact.fields)
      for (const DerivedResults::Method& method : out.methods) {
        DerivedCheck c;
        c.spec = exact.spec;
        c.field = f.name;
        c.unit = f.unit;
        c.method = method.name;
        const DerivedValue* own = find(method.values, exact.spec);
        c.value = value_of(own, f.name);
        c.exact = f.value;
        c.estimate = value_of(find(out.estimate, exact.spec), f.name);
        c.value_ties = ties_of(own, f.name);
        c.exact_ties = f.ties;
        c.estimate_ties = ties_of(find(out.estimate, exact.spec), f.name);
        c.scale = scale_of(m, *exact.spec, f.unit, ref, f.value);
        c.quantity_class = quantity_of(*exact.spec, f.unit, m.swept().angular());
        c.tolerance = tolerances.of(method.name, c.quantity_class);
        c.verdict = Verdict::not_applicable;
        if (!c.value)
          c.reason = own && !own->reason.empty() ? own->reason : "the method has no such value";
        else if (!c.estimate)
          c.reason = "the reference's samples give none: " + exact.reason;
        else if (exact.spec->summary)  // a tied extreme's place moves with any error
          c.reason = "the design summary is compared, not judged (a [[derived]] entry is)";
        else
          c.verdict = c.pct_of_scale() <= c.tolerance ? Verdict::pass : Verdict::fail;
        out.checks.push_back(std::move(c));
      }
  return out;
}

std::string derived_exact_text(const Mechanism& m, const std::vector<DerivedValue>& exact,
                               int indent) {
  const std::string pad(static_cast<size_t>(indent), ' ');
  std::string out;
  for (const DerivedValue& v : exact) {
    const DerivedSpec& spec = *v.spec;
    const std::string of = spec.point.empty() ? spec.channel : "point " + spec.point;
    out += fmt::format("{}{} ({}{}{}{})\n", pad, spec.name, to_string(spec.kind),
                       of.empty() ? "" : " of ", of, spec.summary ? "; design summary" : "");
    if (!v.reason.empty()) {
      out += fmt::format("{}  none: {}\n", pad, v.reason);
      continue;
    }
    for (const DerivedField& f : v.fields) {
      std::string expected;
      if (m.expect)
        for (const Expectations::Derived& e : m.expect->derived)
          if (derived_value(exact, e.quantity) == f.value &&
              (e.quantity == spec.name + "." + f.name ||
               (e.quantity == spec.name && &f == &v.fields.front())))
            expected = "  ([expect.derived] " + shown(m, spec, f.unit, e.value) + ")";
      // A driver value's text has its unit.
      out += fmt::format("{}  {:<12} {}{}{}\n", pad, f.name, shown(m, spec, f.unit, f.value),
                         f.unit == DerivedUnit::driver ? "" : unit_text(m, spec, f.unit), expected);
    }
  }
  return out;
}

void print_derived_exact(std::FILE* out, const Mechanism& m,
                         const std::vector<DerivedValue>& exact) {
  if (exact.empty()) return;
  fmt::print(out, "\n[[derived]] quantities (exact: located on the exact solution; file units)\n{}",
             derived_exact_text(m, exact, 2));
}

void print_derived(std::FILE* out, const Mechanism& m, const DerivedResults& results) {
  if (results.empty()) return;
  print_derived_exact(out, m, results.exact);
  if (results.checks.empty()) return;
  fmt::print(out,
             "\n[[derived]] by method, from its samples (parabola through the extreme sample and "
             "its neighbours): % vs exact; verdict on |method - reference's samples| in % of "
             "scale\n");
  fmt::print(out, "{:<22} {:<8} {:>16} {:>16} {:>9} {:>9} {:>9} {:>9}  {}\n", "quantity", "method",
             "value", "exact", "% exact", "est. %", "% scale", "tol", "verdict");
  for (const DerivedCheck& c : results.checks) {
    const double estimate_pct =
        c.estimate && c.exact && *c.exact != 0.0 ? percent_difference(*c.estimate, *c.exact) : NAN;
    fmt::print(out, "{:<22} {:<8} {:>16} {:>16} {:>9} {:>9} {:>9} {:>9}  {}\n", c.quantity(),
               c.method, shown(m, *c.spec, c.unit, c.value), shown(m, *c.spec, c.unit, c.exact),
               pct_text(c.pct_vs_exact()), pct_text(estimate_pct), pct_text(c.pct_of_scale()),
               fmt::format("{:g}", c.tolerance),
               c.verdict == Verdict::not_applicable ? "n/a: " + c.reason
                                                    : std::string(to_string(c.verdict)));
  }
  fmt::print(out,
             "(est. %: the same estimate from the reference's own samples against exact: the "
             "estimate's own error at this step)\n");
}

nlohmann::json derived_json(const std::vector<DerivedValue>& exact, const DerivedResults* results) {
  using json = nlohmann::json;
  auto number = [](std::optional<double> v) { return v ? json(*v) : json(nullptr); };
  json out = json::array();
  for (const DerivedValue& v : exact) {
    const DerivedSpec& spec = *v.spec;
    json fields = json::object();
    for (const DerivedField& f : v.fields) {
      json field = {{"exact", number(f.value)}};
      if (results) {
        field["estimate_from_reference_samples"] =
            number(value_of(find(results->estimate, &spec), f.name));
        json methods = json::object();
        for (const DerivedCheck& c : results->checks)
          if (c.spec == &spec && c.field == f.name) {
            const double pct = c.pct_vs_exact(), scaled = c.pct_of_scale();
            methods[c.method] = {
                {"value", number(c.value)},
                {"pct_difference_vs_exact", std::isfinite(pct) ? json(pct) : json(nullptr)},
                {"pct_of_scale", std::isfinite(scaled) ? json(scaled) : json(nullptr)},
                {"scale", c.scale},
                {"tolerance_pct", c.tolerance},
                {"verdict",
                 c.verdict == Verdict::fail ? "fail" : std::string(to_string(c.verdict))},
                {"reason", c.reason.empty() ? json(nullptr) : json(c.reason)}};
          }
        field["methods"] = methods;
      }
      fields[f.name] = field;
    }
    out.push_back(
        {{"name", spec.name},
         {"quantity", to_string(spec.kind)},
         {"channel", spec.channel.empty() ? json(nullptr) : json(spec.channel)},
         {"point", spec.point.empty() ? json(nullptr) : json(spec.point)},
         {"range", spec.range ? json({spec.range->first, spec.range->second}) : json(nullptr)},
         {"value", number(v.fields.empty() ? std::nullopt : v.fields.front().value)},
         {"reason", v.reason.empty() ? json(nullptr) : json(v.reason)},
         {"summary", spec.summary},
         {"fields", fields}});
  }
  return out;
}

void write_derived_csv(const DerivedResults& results, std::ostream& out) {
  for (const DerivedCheck& c : results.checks) {
    auto number = [](std::optional<double> v) { return v ? csv_number(*v) : std::string(); };
    const bool both = c.value && c.exact;
    const double scaled = c.pct_of_scale();
    out << fmt::format(
        "{},{},{},,,,,{},{},{},{},{},{},{},\n", csv_field(c.method),
        csv_field("derived:" + c.quantity()), to_string(c.quantity_class),
        c.verdict == Verdict::not_applicable ? 0 : 1, csv_field(c.reason), number(c.exact),
        number(c.value), both ? csv_number(*c.value - *c.exact) : std::string(),
        std::isnan(scaled) ? std::string() : csv_number(scaled), csv_number(c.pct_vs_exact()));
  }
}

std::string derived_table_html(const Mechanism& m, const DerivedResults& results) {
  // One row per quantity's field, one column per method: the value in the file's units (a number:
  // the unit has its column), the method's difference as a % of the quantity's scale and the
  // verdict, coloured. A value that does not exist is no number: the cell says why.
  const auto number = [&](const DerivedSpec& spec, DerivedUnit unit, std::optional<double> si) {
    return si ? fmt::format("{:.6g}", *si / derived_factor(m, spec, unit)) : std::string();
  };
  std::string head = "<tr><th>quantity</th><th>kind</th><th>unit</th><th>exact</th>";
  for (const DerivedResults::Method& method : results.methods)
    head += fmt::format("<th>{}</th>", html_escape(method.name));
  std::string rows;
  for (const DerivedValue& v : results.exact)
    for (const DerivedField& f : v.fields) {
      rows += fmt::format("<tr><td><code>{}.{}</code></td><td>{}{}</td><td>{}</td><td>{}</td>",
                          html_escape(v.spec->name), html_escape(f.name), to_string(v.spec->kind),
                          v.spec->summary ? " (design summary)" : "",
                          html_escape(derived_unit_name(m, *v.spec, f.unit)),
                          f.value ? number(*v.spec, f.unit, f.value)
                                  : "<small>none: " + html_escape(v.reason) + "</small>");
      for (const DerivedResults::Method& method : results.methods) {
        const auto c = std::find_if(results.checks.begin(), results.checks.end(), [&](auto& c) {
          return c.spec == v.spec && c.field == f.name && c.method == method.name;
        });
        if (c == results.checks.end()) {
          rows += "<td></td>";
          continue;
        }
        const bool judged = c->verdict != Verdict::not_applicable;
        const double pct = c->pct_of_scale();
        // Not judged: the % where it exists, the reason (long, the same down a column) as the
        // cell's tooltip; a value that does not exist says why in the cell.
        const std::string note =
            judged ? fmt::format("{} % of scale (limit {:g}): <b>{}</b>", pct_text(pct),
                                 c->tolerance, to_string(c->verdict))
            : c->value && std::isfinite(pct)
                ? fmt::format("{} % of scale, not judged", pct_text(pct))
                : "n/a: " + html_escape(c->reason);
        rows += fmt::format("<td class=\"derived-{}\" title=\"{}\">{}<br><small>{}</small></td>",
                            c->verdict == Verdict::pass ? "pass"
                            : judged                    ? "fail"
                                                        : "na",
                            judged ? "" : html_escape(c->reason),
                            number(*v.spec, c->unit, c->value), note);
      }
      rows += "</tr>\n";
    }
  return "<table class=\"derived\">" + head + "</tr>\n" + rows + "</table>\n";
}

}  // namespace crosslink::compare
