// Console, JSON and CSV reports, and the units they show values in.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <tuple>

#include "analytic/model/units_text.h"
#include "compare/report.h"

namespace crosslink::compare {

DisplayUnit display_unit(const Mechanism& m, std::string_view channel) {
  // A [[derived]] quantity or field ("Q", "S.at_max"): its own unit.
  const DerivedSpec* spec = nullptr;
  if (const std::optional<DerivedUnit> unit = derived_unit_of(m, channel, &spec))
    return {derived_factor(m, *spec, *unit), derived_unit_name(m, *spec, *unit)};
  Trajectory::Unit unit = Trajectory::unit_in(m.units, channel);
  return {unit.si, std::move(unit.name)};
}

bool samples_in_time(const Mechanism& m) {
  return m.dynamics.has_value() || m.axis().timed();
}

DisplayUnit driver_unit(const Mechanism& m) {
  const DriverUnit u = axis_unit_of(m);
  return {u.scale, u.name};
}

DriverTurns driver_turns(const Mechanism& m, double value) {
  const DisplayUnit du = driver_unit(m);
  const double v = value / du.scale;
  if (m.axis().timed() || !m.swept().angular() || !std::isfinite(v)) return {v, 0};
  const double turn = 2.0 * std::numbers::pi / du.scale;
  // Within (-turn, turn], or [-turn, 0) below zero: a cycle's last sample is 360 deg, no turn on.
  double within = std::fmod(v, turn);
  if (within == 0.0 && v != 0.0) within = std::copysign(turn, v);
  return {within, std::lround((v - within) / turn)};
}

std::string driver_text(const Mechanism& m, double value, int decimals) {
  const DriverTurns t = driver_turns(m, value);
  return fmt::format(
      "{:.{}f} {}{}", t.within, decimals, driver_unit(m).name,
      t.turns == 0 ? ""
                   : fmt::format(" {:+d} turn{}", t.turns, std::labs(t.turns) == 1 ? "" : "s"));
}

std::string reference_note(const ReferenceRow& r) {
  const std::optional<bool> holds = r.holds();
  if (!holds) return r.exact_ok && r.reference.within_rounding(r.exact) ? "within rounding" : "";
  return fmt::format("{} ({})", *holds ? "pass" : "FAIL",
                     r.reference.to_rounding ? std::string("rounding")
                                             : fmt::format("{:g} %", *r.reference.tolerance_pct));
}

std::string reference_failure_text(const Mechanism& m, const ReferenceRow& r) {
  const Reference& ref = r.reference;
  const std::string what = fmt::format(
      "[[reference]] {}{} ({})", ref.quantity,
      ref.derived ? "" : " at driver = " + driver_text(m, ref.driver_value, 2), ref.where.str());
  const std::string printed =
      ref.printed.empty() ? fmt::format("{:.6g}", ref.value) + " (SI)" : ref.printed;
  if (!r.exact_ok) return fmt::format("{}: printed {}, no exact value there", what, printed);
  const DisplayUnit u = display_unit(m, ref.quantity);
  const bool angle = Trajectory::quantity_of(ref.quantity) == Quantity::angle;
  const double exact = (angle ? wrap_positive_angle(r.exact) : r.exact) / u.scale;
  if (ref.to_rounding)
    return fmt::format("{}: printed {}, exact {:.6g}: beyond its printed rounding (+-{:g})", what,
                       printed, exact, 0.5 * ref.precision / u.scale);
  const double pct = r.percent(ref.value, r.exact);
  return std::isnan(pct) ? fmt::format(
                               "{}: printed {}, exact {:.6g}: a round-off zero, no % "
                               "difference (judge it with tolerance = \"rounding\")",
                               what, printed, exact)
                         : fmt::format(
                               "{}: printed {}, exact {:.6g}: {:.3g} % from it > its "
                               "tolerance {:g} %",
                               what, printed, exact, std::abs(pct), *ref.tolerance_pct);
}

namespace {

// A number, or "n/a" where it is not a finite one (a % of a zero peak, an order of log 0).
std::string number_or_na(double value, std::string_view spec) {
  return std::isfinite(value) ? fmt::format(fmt::runtime(spec), value) : std::string("n/a");
}

// How close a row is to failing: max % of peak over its tolerance.
double severity(const ChannelResult& c) {
  if (c.verdict == Verdict::not_applicable) return -1.0;
  if (c.tolerance <= 0.0) return c.metrics.max_pct_of_peak > 0.0 ? INFINITY : 0.0;
  return c.metrics.max_pct_of_peak / c.tolerance;
}

std::string worst_at(const Comparison& cmp, const ChannelResult& c) {
  if (c.metrics.worst_sample < 0) return "-";
  if (samples_in_time(*cmp.mechanism))
    return fmt::format("t = {:.3f} s #{}", cmp.reference().trajectory.time(c.metrics.worst_sample),
                       c.metrics.worst_sample);
  return fmt::format(
      "{} #{}",
      driver_text(*cmp.mechanism, cmp.reference().trajectory.along(c.metrics.worst_sample), 2),
      c.metrics.worst_sample);
}

std::string settings_text(const RunSettings& settings) {
  std::string text;
  for (const auto& [k, v] : settings) text += (text.empty() ? "" : " ") + k + "=" + v;
  return text;
}

// Wraps `text` to lines of at most `width` columns, each after `indent` spaces.
void print_wrapped(std::FILE* out, const std::string& text, int indent, int width) {
  std::string line;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t next = text.find(' ', pos);
    if (next == std::string::npos) next = text.size();
    const std::string word = text.substr(pos, next - pos);
    if (!line.empty() && static_cast<int>(line.size() + 1 + word.size()) > width - indent) {
      fmt::print(out, "{:{}}{}\n", "", indent, line);
      line.clear();
    }
    line += (line.empty() ? "" : " ") + word;
    pos = next + 1;
  }
  if (!line.empty()) fmt::print(out, "{:{}}{}\n", "", indent, line);
}

// What the reference is at a failure's worst sample: its conditioning, when a decade or more
// worse than its median, and its nearest singular position ("" when neither).
std::string worst_context_text(const Mechanism& m, const WorstContext& c) {
  // Conditioning a decade worse than the median is a singular position's neighbourhood (one grid
  // step from a dead point it is 10 to 40 times worse); within it, it says nothing.
  constexpr double kIllConditioned = 10.0;
  std::string text;
  if (!std::isnan(c.rcond) && c.rcond * kIllConditioned <= c.median_rcond)
    text = fmt::format(
        "there the reference's constraint Jacobian is conditioned {:.3g} times worse than its "
        "median (rcond {:.2g} against {:.2g})",
        c.median_rcond / c.rcond, c.rcond, c.median_rcond);
  if (c.nearest_singular) {
    const DisplayUnit du = driver_unit(m);
    const std::string distance =
        samples_in_time(m) ? fmt::format("{:.4g} s", std::abs(c.distance))
                           : fmt::format("{:.4g} {}", std::abs(c.distance) / du.scale, du.name);
    const std::string at = samples_in_time(m)
                               ? fmt::format("t = {:.6g} s", c.nearest_singular->driver)
                               : "driver = " + driver_text(m, c.nearest_singular->driver, 4);
    text += fmt::format("{}its nearest singular position is {} {} ({}): {}",
                        text.empty() ? "" : "; ", distance, c.distance >= 0.0 ? "after" : "before",
                        at, c.nearest_singular->message);
  }
  return text;
}

// "step probe: ..." of a failing engine rerun at half its step (StepProbe).
std::string step_probe_text(const StepProbe& p) {
  const std::string head = fmt::format(
      "step probe: {} at half its step (dt = {:.6g} s, was {:.6g} s)", p.method, p.half_dt, p.dt);
  if (!p.ok) return fmt::format("{}: not run to the end ({})", head, p.message);
  const double order = p.order();
  // An order that is not a number (a difference of 0 at either step) is not printed as one.
  const char* reading = std::isnan(order) ? "no order: a difference of 0 at one of the steps"
                        : order >= 0.5 ? "it falls with the step: the engine's discretisation error"
                        : order > -0.5
                            ? "it does not fall with the step: not the step's error (a modelling "
                              "difference, the reference, or a singular position)"
                            : "it grows as the step falls";
  return fmt::format("{}: {} {} -> {} % of peak (order {}); {}", head, p.channel,
                     number_or_na(p.pct, "{:.4g}"), number_or_na(p.half_pct, "{:.4g}"),
                     number_or_na(order, "{:.2g}"), reading);
}

constexpr std::string_view kRowFormat = "{:<24} {:<8} {:>12} {:>11} {:>11} {:>19} {:>6}\n";

// A metric of a channel, "-" when no sample is in its verdict (the value does not exist), "n/a"
// when it has no scale (a % of a peak of zero: a reference at rest).
std::string metric_text(const ChannelResult& c, double value) {
  return c.metrics.usable > 0 ? number_or_na(value, "{:.3g}") : "-";
}

void print_row(std::FILE* out, const Comparison& cmp, const ChannelResult& c) {
  fmt::print(out, kRowFormat, c.metrics.channel, c.method,
             metric_text(c, c.metrics.max_pct_of_peak), metric_text(c, c.metrics.rms_pct_of_peak),
             fmt::format("{:.3g}", c.tolerance), worst_at(cmp, c), to_string(c.verdict));
}

void print_header(std::FILE* out) {
  fmt::print(out, kRowFormat, "channel", "method", "max % peak", "RMS % peak", "tolerance %",
             "worst at (sample)", "verdict");
  fmt::print(out, "{:-<98}\n", "");
}

// Every sample kept out of a verdict, counted per method and the channels that share the same
// reasons (kinematic channels and forces usually differ), and every place the reference's two
// exact methods disagree: nothing is dropped without a word.
void print_kept_out(std::FILE* out, const Comparison& cmp) {
  const Trajectory& ref = cmp.reference().trajectory;
  std::vector<std::tuple<std::string, std::string, std::vector<std::string>>> groups;
  for (const ChannelResult& c : cmp.channels) {
    std::string why;
    int total = 0;
    for (const auto& [reason, count] : c.metrics.excluded()) {
      why += fmt::format("{}{} {}", why.empty() ? "" : ", ", count, reason);
      total += count;
    }
    if (total == 0) continue;
    why = fmt::format("{} of {} samples ({})", total, ref.samples(), why);
    const std::string q(to_string(c.metrics.quantity));
    auto it = std::find_if(groups.begin(), groups.end(), [&](const auto& g) {
      return std::get<0>(g) == c.method && std::get<1>(g) == why;
    });
    if (it == groups.end()) {
      groups.push_back({c.method, why, {q}});
    } else if (std::find(std::get<2>(*it).begin(), std::get<2>(*it).end(), q) ==
               std::get<2>(*it).end()) {
      std::get<2>(*it).push_back(q);
    }
  }
  if (!groups.empty()) {
    fmt::print(out, "\nkept out of verdicts (docs/compare.md, 'What is kept out of a verdict')\n");
    for (const auto& [method, why, quantities] : groups) {
      std::string kinds;
      for (const std::string& q : quantities) kinds += (kinds.empty() ? "" : ", ") + q;
      print_wrapped(out, fmt::format("{} {}: {}", method, kinds, why), 2, 100);
    }
  }
  for (const Trajectory::Event& e : ref.events)
    if (e.kind == PoseStatus::exact_methods_disagree) {
      print_wrapped(
          out,
          fmt::format("reference at {}: {}",
                      samples_in_time(*cmp.mechanism) ? fmt::format("t = {:.6g} s", e.driver)
                                                      : driver_text(*cmp.mechanism, e.driver, 4),
                      e.message),
          2, 100);
    }
}

}  // namespace

void print_console(const Comparison& cmp, std::FILE* out, const ConsoleOptions& options) {
  const Mechanism& m = *cmp.mechanism;
  const Trajectory& ref = cmp.reference().trajectory;
  const DisplayUnit du = driver_unit(m);
  int excluded = 0;
  for (PoseStatus s : ref.status) excluded += usable(s) ? 0 : 1;
  fmt::print(out, "{} ({})\n", m.name, m.file);
  const bool dynamics = m.dynamics.has_value();
  // Several drivers sweep in time (each driver's value is a channel of its own).
  if (samples_in_time(m))
    fmt::print(out, "reference: {}, {} samples from t = {:.4g} to {:.4g} s",
               dynamics ? "exact forward dynamics" : "analytic Newton", ref.samples(),
               ref.samples() ? ref.time(0) : 0.0,
               ref.samples() ? ref.time(ref.samples() - 1) : 0.0);
  else
    fmt::print(out, "reference: analytic Newton, {} samples from {:.4g} to {:.4g} {}",
               ref.samples(), ref.samples() ? ref.along(0) / du.scale : 0.0,
               ref.samples() ? ref.along(ref.samples() - 1) / du.scale : 0.0, du.name);
  fmt::print(out, "{}\n",
             excluded ? fmt::format(", {} flagged (kept out of verdicts)", excluded) : "");

  // Channel rows: everything, or a summary per quantity class and the worst channels.
  std::vector<const ChannelResult*> rows;
  for (const ChannelResult& c : cmp.channels) rows.push_back(&c);
  fmt::print(out, "\n");
  if (options.all) {
    print_header(out);
    for (const ChannelResult* c : rows) print_row(out, cmp, *c);
  } else {
    // Summary: per method and quantity class, its worst channel.
    std::map<std::pair<std::string, Quantity>, const ChannelResult*> worst;
    // pass, fail of the channels the method computes (the prescribed ones are counted apart in
    // the verdict line)
    std::map<std::pair<std::string, Quantity>, std::pair<int, int>> counts;
    for (const ChannelResult* c : rows) {
      const auto key = std::pair{c->method, c->metrics.quantity};
      auto& [p, f] = counts[key];
      p += c->verdict == Verdict::pass && !c->prescribed;
      f += c->verdict == Verdict::fail && !c->prescribed;
      if (!worst[key] || severity(*c) > severity(*worst[key])) worst[key] = c;
    }
    fmt::print(out,
               "summary per quantity class (worst channel of each method; pass/fail of the "
               "channels it computes)\n");
    fmt::print(out, "{:<13} {:<8} {:<22} {:>11} {:>11} {:>17} {:>10}\n", "quantity", "method",
               "worst channel", "max % peak", "tolerance %", "worst at", "pass/fail");
    fmt::print(out, "{:-<98}\n", "");
    for (const MethodRun& run : cmp.methods)
      for (Quantity q :
           {Quantity::position, Quantity::angle, Quantity::velocity, Quantity::acceleration,
            Quantity::force, Quantity::torque, Quantity::energy}) {
        const auto it = worst.find(std::pair{run.name, q});
        if (it == worst.end() || !it->second) continue;
        const ChannelResult& c = *it->second;
        const auto [p, f] = counts[it->first];
        std::string at = worst_at(cmp, c);
        fmt::print(out, "{:<13} {:<8} {:<22} {:>11} {:>11} {:>17} {:>10}\n", to_string(q), run.name,
                   c.metrics.channel, metric_text(c, c.metrics.max_pct_of_peak),
                   fmt::format("{:.3g}", c.tolerance), at.substr(0, at.find(" #")),
                   fmt::format("{}/{}", p, f));
      }
    // Per channel, its worst method; the closest to failing first.
    std::map<std::string, const ChannelResult*> per_channel;
    for (const ChannelResult* c : rows) {
      const ChannelResult*& w = per_channel[c->metrics.channel];
      if (!w || severity(*c) > severity(*w)) w = c;
    }
    std::vector<const ChannelResult*> list;
    for (const auto& [name, c] : per_channel) list.push_back(c);
    std::stable_sort(list.begin(), list.end(),
                     [](auto* a, auto* b) { return severity(*a) > severity(*b); });
    int shown = 0;
    const int total = static_cast<int>(list.size());
    if (total > 0) {
      fmt::print(out, "\nworst method per channel, closest to its tolerance first\n");
      print_header(out);
    }
    for (const ChannelResult* c : list) {
      if (shown >= options.worst_rows && c->verdict != Verdict::fail) break;
      print_row(out, cmp, *c);
      ++shown;
    }
    if (shown < total)
      fmt::print(out, "... {} more channels within tolerance (--all lists every row)\n",
                 total - shown);
  }

  print_kept_out(out, cmp);

  print_derived(out, m, cmp.derived);

  // [[reference]] rows: printed values against the exact one.
  if (!cmp.references.empty()) {
    fmt::print(out, "\n[[reference]] values (file units; %: difference from exact)\n");
    fmt::print(out, "{:<18} {:>7} {:>10} {:>11} {:>7} {:>15} {:>9}  {}\n", "quantity", "at",
               "printed", "exact", "%", "", "methods%", "source");
    fmt::print(out, "{:-<114}\n", "");
    for (const ReferenceRow& r : cmp.references) {
      const DisplayUnit u = display_unit(m, r.reference.quantity);
      const bool angle = Trajectory::quantity_of(r.reference.quantity) == Quantity::angle;
      auto shown_value = [&](double si) {
        return (angle ? wrap_positive_angle(si) : si) / u.scale;
      };
      double worst_method = NAN;  // fmax skips the NaN of a round-off zero
      for (const auto& v : r.values)
        if (v.method != "analytic")
          worst_method = std::fmax(worst_method, r.percent(v.value, r.exact));
      // A % against a round-off zero is not given ("-").
      auto pct = [](double v, const char* spec) {
        return std::isnan(v) ? std::string("-") : fmt::format(fmt::runtime(spec), v);
      };
      // The printed value as printed; the exact one blank where it does not exist.
      const std::string printed = r.reference.printed.empty()
                                      ? fmt::format("{:.5g}", r.reference.value / u.scale)
                                      : r.reference.printed;
      // A [[derived]] quantity is of the whole sweep: no driver value.
      fmt::print(out, "{:<18} {:>7} {:>10} {:>11} {:>7} {:>15} {:>9}  {}\n", r.reference.quantity,
                 r.reference.derived ? "sweep"
                                     : fmt::format("{:.4g}", r.reference.driver_value / du.scale),
                 printed, r.exact_ok ? fmt::format("{:.6g}", shown_value(r.exact)) : "",
                 pct(r.percent(r.reference.value, r.exact), "{:.3f}"), reference_note(r),
                 pct(worst_method, "{:.2g}"), r.reference.source.substr(0, 40));
    }
    fmt::print(out,
               "(methods%: the largest % difference of any other method from exact; a value "
               "with a 'tolerance' is judged: pass or FAIL)\n");
  }

  // Methods, after the results: status, cost and every setting in force.
  fmt::print(out, "\nmethods\n");
  for (const MethodRun& run : cmp.methods) {
    if (!run.available) {
      fmt::print(out, "  {:<9} not run: {}\n", run.name, run.message);
      continue;
    }
    fmt::print(out, "  {:<9} {:<7} {:.3f} s wall, {:.3g} s per {}, {} {}\n", run.name,
               run.ok ? "ok" : "FAILED", run.cost.wall_seconds, run.cost.wall_seconds_per_cycle,
               dynamics ? "simulated s" : "cycle", run.cost.steps,
               dynamics && run.name == "analytic" ? "evaluations" : "steps");
    print_wrapped(out, run.description, 12, 100);
    if (!run.ok || !run.message.empty()) print_wrapped(out, run.message, 12, 100);
    print_wrapped(out, settings_text(run.settings), 12, 100);
  }

  // Verdict, with every failing channel named at its worst sample.
  fmt::print(out, "\n");
  const auto failure = [&cmp](const std::string& name) {
    return fmt::format("method {} {}", name,
                       cmp.method(name)->ok ? "flagged every sample: no usable sample to compare"
                                            : "did not complete: " + cmp.method(name)->message);
  };
  for (const std::string& name : cmp.failed_methods) fmt::print(out, "FAIL: {}\n", failure(name));
  for (const ChannelResult& c : cmp.channels)
    if (c.verdict == Verdict::fail) {
      const DisplayUnit u = display_unit(m, c.metrics.channel);
      const int k = c.metrics.worst_sample;
      const std::string where = samples_in_time(m) ? fmt::format("t = {:.4f} s", ref.time(k))
                                                   : "driver = " + driver_text(m, ref.along(k), 4);
      fmt::print(out,
                 "FAIL: {} ({}) {}: {:.4g} % of peak > tolerance {:.3g} % at {} "
                 "(sample {}): {} = {:.6g} {}, analytic = {:.6g} {}\n",
                 c.metrics.channel, to_string(c.metrics.quantity), c.method,
                 c.metrics.max_pct_of_peak, c.tolerance, where, k, c.method,
                 *cmp.method(c.method)->trajectory.sample(c.metrics.channel, k) / u.scale, u.name,
                 *ref.sample(c.metrics.channel, k) / u.scale, u.name);
      if (const std::string why = worst_context_text(m, worst_context(ref, k, samples_in_time(m)));
          !why.empty())
        print_wrapped(out, why, 6, 100);
    }
  for (const DerivedCheck& c : cmp.derived.checks)
    if (c.verdict == Verdict::fail)
      fmt::print(out, "FAIL: derived {} {}: {:.4g} % of scale > tolerance {:.3g} %\n", c.quantity(),
                 c.method, c.pct_of_scale(), c.tolerance);
  for (const ReferenceRow& r : cmp.references)
    if (r.holds() == false) print_wrapped(out, "FAIL: " + reference_failure_text(m, r), 0, 100);
  for (const StepProbe& p : cmp.step_probes) print_wrapped(out, step_probe_text(p), 0, 100);
  // A method that failed as a whole is named on the verdict line itself: its channels are not
  // among the counts (a scene MuJoCo refused read "FAIL (70 channel comparisons: 70 pass, 0 fail").
  if (cmp.nothing_compared()) {
    fmt::print(out,
               "verdict: NOTHING TO COMPARE (only the reference, {}, ran: 0 channel "
               "comparisons; name another method with --engines{})\n",
               cmp.reference().name,
               cmp.references.empty()
                   ? ""
                   : fmt::format("; {} [[reference]] value{} shown, not judged: give one a "
                                 "'tolerance' to judge it",
                                 cmp.references.size(), cmp.references.size() == 1 ? "" : "s"));
    return;
  }
  std::string failed;
  for (const std::string& name : cmp.failed_methods) failed += failure(name) + "; ";
  fmt::print(out, "verdict: {} ({}{})\n", cmp.pass() ? "PASS" : "FAIL", failed, cmp.counts_text());
}

namespace {
// The samples a channel keeps out of its verdict, per reason: [{"reason", "samples"}].
nlohmann::json excluded_json(const ChannelMetrics& metrics) {
  nlohmann::json out = nlohmann::json::array();
  for (const auto& [reason, count] : metrics.excluded())
    out.push_back({{"reason", reason}, {"samples", count}});
  return out;
}
}  // namespace

nlohmann::json to_json(const Comparison& cmp) {
  using nlohmann::json;
  const Mechanism& m = *cmp.mechanism;
  const Trajectory& ref = cmp.reference().trajectory;
  json j;
  j["mechanism"] = m.name;
  j["file"] = m.file;
  j["units"] = "SI";
  j["pass"] = cmp.pass();
  j["reference_method"] = cmp.reference().name;
  j["dynamics"] = m.dynamics.has_value();
  j["samples"] = ref.samples();
  int excluded = 0;
  for (PoseStatus s : ref.status) excluded += usable(s) ? 0 : 1;
  j["flagged_reference_samples"] = excluded;

  j["methods"] = json::array();
  for (const MethodRun& run : cmp.methods) {
    json settings = json::object();
    for (const auto& [k, v] : run.settings) settings[k] = v;
    j["methods"].push_back({{"name", run.name},
                            {"description", run.description},
                            {"available", run.available},
                            {"ok", run.ok},
                            {"message", run.message},
                            {"settings", settings},
                            {"cost",
                             {{"wall_seconds", run.cost.wall_seconds},
                              {"wall_seconds_per_cycle", run.cost.wall_seconds_per_cycle},
                              {"steps", run.cost.steps},
                              {"simulated_seconds", run.cost.simulated_seconds}}}});
  }

  j["channels"] = json::array();
  for (const ChannelResult& c : cmp.channels) {
    const int k = c.metrics.worst_sample;
    // A channel with no sample in its verdict has no difference and no peak: null, not 0.
    // Nor a % of a peak of zero (a reference at rest): null.
    const auto measured = [&](double v) {
      return c.metrics.usable > 0 && std::isfinite(v) ? json(v) : json(nullptr);
    };
    j["channels"].push_back(
        {{"channel", c.metrics.channel},
         {"quantity", std::string(to_string(c.metrics.quantity))},
         {"method", c.method},
         {"max_pct_of_peak", measured(c.metrics.max_pct_of_peak)},
         {"rms_pct_of_peak", measured(c.metrics.rms_pct_of_peak)},
         {"max_local_pct", measured(c.metrics.max_local_pct)},
         {"max_abs", measured(c.metrics.max_abs)},
         {"rms_abs", measured(c.metrics.rms_abs)},
         {"peak", measured(c.metrics.peak_used)},
         {"usable_samples", c.metrics.usable},
         {"excluded", excluded_json(c.metrics)},
         {"worst_sample", k >= 0 ? json(k) : json(nullptr)},
         {"worst_driver_value", k >= 0 ? json(ref.driver_field(k)) : json(nullptr)},
         {"worst_time", k >= 0 ? json(ref.time(k)) : json(nullptr)},
         {"tolerance_pct", c.tolerance},
         {"verdict", c.verdict == Verdict::fail ? "fail" : std::string(to_string(c.verdict))},
         {"prescribed", c.prescribed}});
    if (c.verdict == Verdict::fail) {
      const WorstContext w = worst_context(ref, k, samples_in_time(m));
      const auto number = [](double v) { return std::isnan(v) ? json(nullptr) : json(v); };
      json& context =
          j["channels"].back()["worst_context"] = {{"rcond", number(w.rcond)},
                                                   {"median_rcond", number(w.median_rcond)},
                                                   {"nearest_singular", nullptr}};
      if (w.nearest_singular)
        context["nearest_singular"] = {{"at", w.nearest_singular->driver},
                                       {"distance", w.distance},
                                       {"message", w.nearest_singular->message}};
    }
  }

  j["step_probes"] = json::array();
  for (const StepProbe& p : cmp.step_probes)
    j["step_probes"].push_back(
        {{"method", p.method},
         {"dt", p.dt},
         {"half_dt", p.half_dt},
         {"ok", p.ok},
         {"message", p.message},
         {"channel", p.channel},
         {"max_pct_of_peak", std::isfinite(p.pct) ? json(p.pct) : json(nullptr)},
         {"half_step_max_pct_of_peak",
          p.ok && std::isfinite(p.half_pct) ? json(p.half_pct) : json(nullptr)},
         {"order", p.ok && !std::isnan(p.order()) ? json(p.order()) : json(nullptr)}});

  j["references"] = json::array();
  for (const ReferenceRow& r : cmp.references) {
    json methods = json::object();
    for (const auto& v : r.values)
      methods[v.method] = {{"value", v.value},
                           {"interpolated", v.interpolated},
                           {"pct_difference_vs_exact",
                            r.exact_ok ? json(r.percent(v.value, r.exact)) : json(nullptr)},
                           {"pct_difference_vs_printed", r.percent(v.value, r.reference.value)}};
    j["references"].push_back(
        {{"quantity", r.reference.quantity},
         {"driver_value", r.reference.driver_value},
         {"value", r.reference.value},
         {"printed", r.reference.printed},
         {"precision", r.reference.precision > 0.0 ? json(r.reference.precision) : json(nullptr)},
         {"within_rounding",
          r.exact_ok ? json(r.reference.within_rounding(r.exact)) : json(nullptr)},
         {"tolerance", r.reference.to_rounding     ? json("rounding")
                       : r.reference.tolerance_pct ? json(*r.reference.tolerance_pct)
                                                   : json(nullptr)},
         {"verdict", r.holds() ? json(*r.holds() ? "pass" : "fail") : json(nullptr)},
         {"source", r.reference.source},
         {"exact", r.exact_ok ? json(r.exact) : json(nullptr)},
         {"pct_difference_vs_exact",
          r.exact_ok ? json(r.percent(r.reference.value, r.exact)) : json(nullptr)},
         {"methods", methods}});
    if (r.reference.derived) {
      j["references"].back()["derived"] = true;
      j["references"].back()["driver_value"] = nullptr;
    }
  }
  if (!cmp.derived.empty()) j["derived"] = derived_json(cmp.derived.exact, &cmp.derived);
  j["legend"] = json::object();
  for (const auto& [term, definition] : metric_legend()) j["legend"][term] = definition;
  return j;
}

std::string csv_number(double value) {
  return std::isfinite(value) ? fmt::format("{}", value) : std::string();
}

std::string csv_field(std::string_view text) {
  if (text.find_first_of(",\"\r\n") == std::string_view::npos) return std::string(text);
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

void write_csv(const Comparison& cmp, std::ostream& out) {
  const Trajectory& ref = cmp.reference().trajectory;
  out << "method,channel,quantity,sample,driver,reference_status,method_status,in_verdict,"
         "reason,reference,value,difference,pct_of_peak,local_pct,time\n";
  for (const ChannelResult& c : cmp.channels) {
    const MethodRun& run = *cmp.method(c.method);
    const Quantity q = c.metrics.quantity;
    const Eigen::VectorXd r = *ref.channel(c.metrics.channel);
    const Eigen::VectorXd v = *run.trajectory.channel(c.metrics.channel);
    for (int k = 0; k < ref.samples(); ++k) {
      const auto ks = static_cast<size_t>(k);
      // A value that does not exist (a rate at a singular sample, any value where the chain
      // does not close, an engine's sample outside its run) is an empty field, and so is every
      // difference it enters.
      const bool has_ref = ref.has_value(k, q);
      const bool has_value = run.trajectory.has_value(k, q);
      const auto field = [](bool exists, double x) { return exists ? csv_number(x) : ""; };
      out << fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", csv_field(c.method),
                         csv_field(c.metrics.channel), to_string(q), k, ref.driver_field(k),
                         to_string(ref.status[ks]), to_string(run.trajectory.status[ks]),
                         c.metrics.in_verdict[ks] ? 1 : 0, c.metrics.reason[ks],
                         field(has_ref, r(k)), field(has_value, v(k)),
                         field(has_ref && has_value, c.metrics.difference(k)),
                         field(has_ref && has_value, c.metrics.pct_of_peak(k)),
                         field(has_ref && has_value, c.metrics.local_pct(k)), ref.time(k));
    }
  }
  write_derived_csv(cmp.derived, out);
}

}  // namespace crosslink::compare
