// The settings sweep's HTML page: the comparator's page frame (write_page_head/tail, the inlined
// Vega-Lite scripts), tables written here, charts built in the browser by sweep_page.js from a
// REPORT object (docs/sweep.md).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "methods/engines.h"
#include "methods/registry.h"
#include "methods/settings_sweep.h"
#include "methods/sweep_ranking.h"

namespace crosslink::methods {

// The comparison report's page pieces, shared by this page.
using compare::html_escape;
using compare::metric_legend;
using compare::write_page_head;
using compare::write_page_tail;

extern const char* const kSweepPageScript;  // sweep_page.js, generated at build time

namespace {

using nlohmann::json;

json finite_or_null(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

std::string cell(double v, const char* format = "{:.3g}") {
  return std::isfinite(v) ? fmt::format(fmt::runtime(format), v) : std::string("-");
}

// A class's error; where no sample was usable, the error over the flagged samples, in brackets.
std::string error_cell(const SweepRow& r, size_t k) {
  if (std::isfinite(r.max_pct[k])) return cell(r.max_pct[k]);
  if (std::isfinite(r.raw_pct[k])) return "<i>(" + cell(r.raw_pct[k]) + ")</i>";
  return "-";
}

std::string status_text(const SettingsSweep& sweep, const SweepRow& r) {
  if (r.status == RunStatus::flagged)
    return fmt::format("flagged ({} of {} samples)", r.flagged_samples, r.samples);
  if (r.status == RunStatus::ok && r.flagged_samples > 0)  // a dynamics run's singular samples
    return with_series_note(
        sweep, r, fmt::format("ok ({} of {} samples singular)", r.flagged_samples, r.samples));
  return with_series_note(sweep, r, std::string(to_string(r.status)));
}

// The classes some row has a value of: forces only where an engine reads them (no empty charts).
std::vector<ErrorClass> measured_classes(const SettingsSweep& sweep) {
  std::vector<ErrorClass> out;
  for (ErrorClass c : kErrorClasses) {
    const auto k = static_cast<size_t>(c);
    if (std::any_of(sweep.rows.begin(), sweep.rows.end(), [&](const SweepRow& row) {
          return std::isfinite(row.max_pct[k]) || std::isfinite(row.raw_pct[k]);
        }))
      out.push_back(c);
  }
  return out;
}

json report_data(const SettingsSweep& sweep) {
  json r;
  r["classes"] = json::array();
  for (ErrorClass c : measured_classes(sweep)) r["classes"].push_back(std::string(to_string(c)));
  // The floor the exact reference is drawn at: a decade under the smallest error shown.
  double smallest = 1.0;
  for (const SweepRow& row : sweep.rows)
    for (double e : row.max_pct)
      if (std::isfinite(e) && e > 0.0) smallest = std::min(smallest, e);
  double largest = 1.0;
  for (const SweepRow& row : sweep.rows)
    for (size_t k = 0; k < kErrorClasses.size(); ++k)
      for (double e : {row.max_pct[k], row.raw_pct[k]})
        if (std::isfinite(e)) largest = std::max(largest, std::min(e, 1e3));
  const double floor = std::pow(10.0, std::floor(std::log10(smallest)) - 1.0);
  const double ceiling = std::pow(10.0, std::ceil(std::log10(largest)) + 1.0);
  r["floor"] = floor;
  r["ceiling"] = ceiling;
  r["dynamics"] = sweep.dynamics;
  r["styles"] = json::object();
  for (const auto& [name, style] : method_styles())
    if (name == "analytic" || find_engine(name))
      r["styles"][name] = {{"colour", style.colour}, {"dash", style.dash}};
  r["costTitle"] =
      sweep.dynamics ? "CPU time per simulated second [s]" : "CPU time per simulated cycle [s]";
  const EngineRanking ranking = rank_engines(sweep);
  r["ranking"]["rule"] = ranking.rule;
  r["ranking"]["engines"] = json::array();
  for (const EngineRank& e : ranking.engines)
    r["ranking"]["engines"].push_back(
        {{"engine", e.engine},
         {"met", e.met},
         {"setting", e.has_row ? json(e.row.setting_label()) : json(nullptr)},
         {"cost", e.has_row ? finite_or_null(e.row.cost()) : json(nullptr)},
         {"worst_class", e.has_row ? json(e.worst_class) : json(nullptr)},
         {"worst_ratio", finite_or_null(e.worst_ratio)}});
  r["rows"] = json::array();
  for (const SweepRow& row : sweep.rows) {
    json j;
    j["engine"] = row.engine;
    j["variant"] = row.variant;
    j["series"] = row.engine + " " + row.variant;
    j["setting"] = row.setting_label();
    j["dt"] = finite_or_null(row.dt);
    j["cost"] = finite_or_null(row.cost() > 0.0 ? row.cost() : std::nan(""));
    j["work"] = finite_or_null(row.work());
    j["status"] = std::string(to_string(row.status));
    j["gap"] = row.max_loop_gap;
    for (ErrorClass c : kErrorClasses) {
      const auto k = static_cast<size_t>(c);
      const double e = row.max_pct[k];
      // Plotted value: the error; 0 (the reference) at the floor; none (nothing comparable, the
      // run diverged or flagged every sample) at the ceiling, marked by its status.
      const double raw = row.raw_pct[k];
      double y = e;
      std::string drawn = "max % of peak";
      if (e == 0.0) {
        y = floor;
        drawn = "error 0 (the reference), drawn at the floor";
      } else if (!std::isfinite(e) && std::isfinite(raw)) {
        y = std::min(raw, ceiling);
        drawn = "no usable sample: max % of peak over the flagged samples";
      } else if (!std::isfinite(e)) {
        y = ceiling;
        drawn = "no sample recorded, drawn at the ceiling";
      } else if (e < floor) {
        y = floor;
      }
      if (y > ceiling) {
        y = ceiling;
        drawn += ", beyond the chart: drawn at the ceiling";
      }
      // A dynamics case's error at the end of the run, drawn the same way (none: the ceiling).
      const double end = row.end_pct[k];
      j["end"][to_string(c)] = finite_or_null(end);
      j["yend"][to_string(c)] = !std::isfinite(end)
                                    ? (row.engine == "analytic" && e == 0.0 ? floor : ceiling)
                                    : std::clamp(end, floor, ceiling);
      j["err"][to_string(c)] = finite_or_null(e);
      j["raw"][to_string(c)] = finite_or_null(raw);
      j["y"][to_string(c)] = y;
      // A run that reads no forces has no point on the force charts.
      if (c == ErrorClass::force && row.status == RunStatus::ok && !std::isfinite(e)) {
        j["y"][to_string(c)] = nullptr;
        j["yend"][to_string(c)] = nullptr;
        j["drawn"][to_string(c)] = "forces not read";
        j["pareto"][to_string(c)] = false;
        continue;
      }
      j["drawn"][to_string(c)] = drawn;
      j["pareto"][to_string(c)] = row.pareto[k];
    }
    r["rows"].push_back(j);
  }
  return r;
}

// The engines ranked (sweep_ranking.h): one row each, in rank order, the setting it is ranked
// by and that setting's errors against the limits.
std::string ranking_table(const SettingsSweep& sweep, const EngineRanking& ranking) {
  std::string html = fmt::format(
      "<h2>Engines ranked</h2>\n<p>Rule: {}. Each engine's cheapest setting meeting it (the "
      "coarsest time step where a variant does, the least work there); engines that meet it by "
      "that setting's CPU time, cheapest first; then those that never do, by their best run with "
      "status ok (the least ratio of a class's error to its limit), last those with none. A "
      "setting that reads no forces (force %: -) is judged on its motion, as --accuracy "
      "judges it.</p>\n"
      "<table id=\"ranking\"><tr><th>rank</th><th>engine</th><th>setting</th><th>{}</th>"
      "<th>position %</th><th>velocity %</th><th>acceleration %</th><th>force %</th>{}"
      "<th>meets</th></tr>\n",
      html_escape(ranking.rule), sweep.dynamics ? "CPU per simulated s [s]" : "CPU per cycle [s]",
      sweep.dynamics ? "<th>energy %</th>" : "");
  int place = 0;
  for (const EngineRank& e : ranking.engines) {
    ++place;
    if (!e.has_row) {
      html += fmt::format(
          "<tr class=\"status-diverged\"><td>{}</td><td>{}</td><td colspan=\"{}\">no run "
          "with status ok</td><td>no</td></tr>\n",
          place, html_escape(e.engine), sweep.dynamics ? 7 : 6);
      continue;
    }
    const SweepRow& r = e.row;
    html += fmt::format("<tr{}><td>{}</td><td>{}</td><td>{}</td><td>{}</td>",
                        e.met ? "" : " class=\"status-flagged\"", place, html_escape(e.engine),
                        html_escape(r.setting_label()), cell(r.cost(), "{:.4g}"));
    for (size_t k = 0; k < kErrorClasses.size(); ++k) html += "<td>" + error_cell(r, k) + "</td>";
    if (sweep.dynamics) html += "<td>" + cell(r.energy_pct) + "</td>";
    html += fmt::format("<td>{}</td></tr>\n", e.met ? std::string("yes")
                                                    : fmt::format("no: {} {:.3g} times its limit",
                                                                  e.worst_class, e.worst_ratio));
  }
  return html + "</table>\n";
}

std::string orders_table(const SettingsSweep& sweep) {
  const std::vector<ErrorClass> classes = measured_classes(sweep);
  std::string html = "<table><tr><th>engine</th><th>variant</th>";
  for (ErrorClass c : classes) html += fmt::format("<th>{}</th>", to_string(c));
  html += "</tr>\n";
  for (const OrderRow& o : sweep.orders) {
    html +=
        fmt::format("<tr><td>{}</td><td>{}</td>", html_escape(o.engine), html_escape(o.variant));
    for (ErrorClass c : classes) {
      const ConvergenceFit& f = o.fit[static_cast<size_t>(c)];
      html += std::isnan(f.order)
                  ? fmt::format("<td>n/a ({} point{})</td>", f.points, f.points == 1 ? "" : "s")
                  : fmt::format(
                        "<td><b>{:.2f}</b> <small>({} points, dt {:.3g} to {:.3g} s)"
                        "</small></td>",
                        f.order, f.points, f.dt_max, f.dt_min);
    }
    if (!o.not_falling.empty())
      html += fmt::format("<td class=\"status-flagged\">{}</td>", o.not_falling_text());
    html += "</tr>\n";
  }
  return html + "</table>\n";
}

// The IFToMM limits: one row per series, a column per limit.
std::string limits_table(const SettingsSweep& sweep) {
  std::string html = "<table><tr><th>engine</th><th>variant</th>";
  for (double limit : kBenchmarkLimits) html += fmt::format("<th>limit {:g}</th>", limit);
  html += "</tr>\n";
  const size_t series = sweep.limits.size() / kBenchmarkLimits.size();
  for (size_t i = 0; i < series; ++i) {
    const BenchmarkLimit& first = sweep.limits[i];
    html += fmt::format("<tr><td>{}</td><td>{}</td>", html_escape(first.engine),
                        html_escape(first.variant));
    for (size_t k = 0; k < kBenchmarkLimits.size(); ++k) {
      const BenchmarkLimit& b = sweep.limits[k * series + i];
      html += fmt::format("<td{}>{}</td>", b.met ? "" : " class=\"status-flagged\"",
                          html_escape(benchmark_limit_text(b)));
    }
    html += "</tr>\n";
  }
  return html + "</table>\n";
}

std::string rows_table(const SettingsSweep& sweep) {
  std::string html =
      "<table class=\"rows\"><tr><th>engine</th><th>setting</th><th>dt [s]</th>"
      "<th>CPU per cycle [s]</th><th>position %</th><th>velocity %</th>"
      "<th>acceleration %</th><th>force %</th><th>max loop gap [m]</th><th>status</th>"
      "<th>front</th><th>settings in force, notes</th></tr>\n";
  for (const SweepRow& r : sweep.rows) {
    std::string front;
    for (ErrorClass c : kErrorClasses)
      if (r.pareto[static_cast<size_t>(c)]) front += std::string(to_string(c)).substr(0, 3) + " ";
    std::string settings;
    for (const auto& [k, v] : r.settings)
      settings += fmt::format("<code>{}={}</code> ", html_escape(k), html_escape(v));
    if (!r.message.empty()) settings += "<br><small>" + html_escape(r.message) + "</small>";
    html += fmt::format(
        "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
        "<td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"settings\">{}</td>"
        "</tr>\n",
        r.status == RunStatus::ok ? "" : std::string("status-") + std::string(to_string(r.status)),
        html_escape(r.engine), html_escape(r.variant), cell(r.dt, "{:.4g}"),
        cell(r.cost(), "{:.4g}"), error_cell(r, 0), error_cell(r, 1), error_cell(r, 2),
        error_cell(r, 3), cell(r.max_loop_gap), html_escape(status_text(sweep, r)), front,
        settings);
  }
  return html + "</table>\n";
}

// Why the front and the pick are not the CPU times' (settings_sweep.h).
constexpr const char* kWorkText =
    "The Pareto front and the pick weigh the work instead, the engine's model evaluations per "
    "simulated second as the engine reports them (MuJoCo: steps times its integrator's stages, "
    "RK4 4, Euler and implicit 1; Bullet and ODE: 1 a step; Simbody: its realizations, which its "
    "error control chooses), which no run changes: CPU times moved by 17 to 66 % between identical "
    "sweeps on a shared "
    "machine, and any rule on them moved the front. Of settings with the same work the more "
    "accurate is on the front (errors within 10 % are equal); the pick takes, at the coarsest "
    "time step where a variant meets the accuracy, the least work, and among equals the "
    "engine's default first.";

constexpr const char* kSweepStyle = R"css(
tr.status-flagged td, td.status-flagged { background: #fff3cd; }
tr.status-diverged td { background: #fde0e0; }
)css";

// One definition's part of the page, its elements' ids led by `prefix` (a page of several
// definitions; none on a page of one).
void write_sweep_section(const SettingsSweep& sweep, const std::string& prefix, std::ostream& out) {
  const Mechanism& m = *sweep.mechanism;
  out << fmt::format("<h1>Speed against accuracy: {}</h1>\n<p>{}</p>\n", html_escape(m.name),
                     html_escape(m.description));
  if (sweep.dynamics)
    out << fmt::format(
        "<p>File <code>{}</code>, a dynamics case. Every engine setting is compared with the "
        "exact simulation ({} samples every {:.4g} s; a time step above that is the interval: "
        "an engine never steps past a sample). Error: the largest <i>max % of peak</i> over the "
        "channels of a class (position includes link angles), worst over the run and at its "
        "end. Cost: the engine's stepping CPU time per simulated second on this machine, the "
        "median of {} runs. {} Grey diamonds: the exact simulation's second integrator "
        "(dopri5) at looser tolerances, against the reference (rkf78 at 1e-13).</p>\n",
        html_escape(m.file), sweep.samples, sweep.sample_interval,
        sweep.rows.empty() ? 1 : sweep.rows.back().repeats, kWorkText);
  else
    out << fmt::format(
        "<p>File <code>{}</code>. Every engine setting is compared with the exact Newton sweep "
        "({} samples every {:.4g} s; time steps above that use every m-th driver value so "
        "samples fall on step boundaries). Error: the largest <i>max % of peak</i> over the "
        "channels of a class (position includes link angles). Cost: the engine's stepping CPU "
        "time per driver cycle on this machine, the median of {} runs. {}</p>\n",
        html_escape(m.file), sweep.samples, sweep.sample_interval,
        sweep.rows.empty() ? 1 : sweep.rows.back().repeats, kWorkText);
  for (const std::string& s : sweep.skipped)
    out << "<p><b>Not run:</b> " << html_escape(s) << "</p>\n";
  out << ranking_table(sweep, rank_engines(sweep));
  out << "<p id=\"" << prefix
      << "render-status\" data-status=\"pending\">charts not rendered (scripts did not "
         "run)</p>\n";
  if (!sweep.selections.empty()) {
    out << "<h2>Cheapest setting per engine</h2>\n<ul>\n";
    for (const Selection& s : sweep.selections)
      out << "<li>" << html_escape(s.summary()) << "</li>\n";
    out << "</ul>\n<p>Rule: time steps from coarse to fine; the first time step where a "
           "variant meets the accuracy on every class with status ok; of those, the least "
           "work, the engine's default first among equals.</p>\n";
  }
  out << "<h2>Error against cost</h2>\n<p>Log-log, one chart per quantity class. Colour: "
         "engine; shape: status (circle ok, triangle flagged samples, cross diverged). Thin "
         "lines join one variant's time steps; the thick black line joins, in order of work, the "
         "Pareto front of error against work of the engine settings with status ok (filled "
         "markers). Grey diamonds: the analytic methods "
         "(Newton is the reference, error 0, drawn at the floor). Settings with no comparable "
         "sample are drawn at the ceiling: that is where an engine's accuracy collapses.</p>\n";
  const std::vector<ErrorClass> classes = measured_classes(sweep);
  for (ErrorClass c : classes)
    out << fmt::format("<h3>{0}</h3>\n<div id=\"{1}cost-{0}\" class=\"chart\"></div>\n",
                       to_string(c), prefix);
  if (sweep.dynamics) {
    out << "<h2>Error at the end of the run against cost</h2>\n<p>The work-precision chart of "
           "the multibody benchmarks: the % of peak at the last sample.</p>\n";
    for (ErrorClass c : classes)
      out << fmt::format("<h3>{0}</h3>\n<div id=\"{1}end-{0}\" class=\"chart\"></div>\n",
                         to_string(c), prefix);
  }
  if (!sweep.limits.empty())
    out << fmt::format(
               "<h2>IFToMM accuracy limits</h2>\n<p>The multibody benchmarks' error (IFToMM A01, "
               "A02): the largest |difference| from the exact simulation of the driven link's tip "
               "<code>{}</code>, per coordinate of its position [m] and velocity [m/s], over every "
               "output step. Per series, the largest time step (the exact integrator: the "
               "loosest tolerance) of this sweep whose run meets the limit with status ok, and "
               "the CPU time of the whole run; where none does, the finest step's status or "
               "error.</p>\n",
               html_escape(benchmark_tip_point(m).value_or("?")))
        << limits_table(sweep);
  out << "<h2>Error against time step</h2>\n<p>Each variant's series; the slope is the observed "
         "order of convergence (table below).</p>\n";
  for (ErrorClass c : classes)
    out << fmt::format("<h3>{0}</h3>\n<div id=\"{1}dt-{0}\" class=\"chart\"></div>\n", to_string(c),
                       prefix);
  out << "<h2>Observed order of convergence in dt</h2>\n<p>Least-squares slope of log error "
         "against log dt over the non-saturated points of each series with status ok: points "
         "at 10 % of peak or more are left out (not yet asymptotic, or collapsed), and so is "
         "the floor, from the first pair of steps whose local order is below 0.5 (round-off or "
         "a solver tolerance).</p>\n"
      << orders_table(sweep);
  out << "<h2>Every setting</h2>\n<p>Errors in brackets: no sample was usable (flagged, or the "
         "run diverged part-way); the value is over the samples the engine recorded, flagged "
         "ones included.</p>\n"
      << rows_table(sweep);
  out << "<h2>Legend</h2>\n<dl>\n";
  for (const auto& [term, definition] : metric_legend())
    out << fmt::format("<dt>{}</dt><dd>{}</dd>\n", html_escape(term), html_escape(definition));
  out << "<dt>status</dt><dd>ok: the engine could use every sample the reference can; flagged: "
         "it flagged some (loop gap, singular, diverged), which stay out of the errors; "
         "diverged: the run did not finish.</dd>\n";
  out << "</dl>\n";
}

}  // namespace

void write_sweep_html(const SettingsSweep& sweep, const HtmlOptions& options, std::ostream& out) {
  write_page_head(fmt::format("crosslink sweep: {}", sweep.mechanism->name), kSweepStyle,
                  options.asset_dirs, out);
  write_sweep_section(sweep, "", out);
  write_page_tail(report_data(sweep).dump(), kSweepPageScript, out);
}

void write_sweeps_html(const std::vector<SweptDefinition>& sweeps, const HtmlOptions& options,
                       std::ostream& out) {
  write_page_head(fmt::format("crosslink sweep: {} definitions", sweeps.size()), kSweepStyle,
                  options.asset_dirs, out);
  out << fmt::format("<h1>Speed against accuracy: {} definitions</h1>\n<ul>\n", sweeps.size());
  for (size_t k = 0; k < sweeps.size(); ++k)
    out << fmt::format("<li><a href=\"#d{}\">{}</a> <code>{}</code></li>\n", k,
                       html_escape(sweeps[k].sweep->mechanism->name), html_escape(sweeps[k].path));
  out << "</ul>\n";
  json reports = json::array();
  for (size_t k = 0; k < sweeps.size(); ++k) {
    const std::string prefix = fmt::format("d{}-", k);
    out << fmt::format("<section id=\"d{}\">\n", k);
    write_sweep_section(*sweeps[k].sweep, prefix, out);
    out << "</section>\n";
    json data = report_data(*sweeps[k].sweep);
    data["prefix"] = prefix;
    reports.push_back(std::move(data));
  }
  // The page script once per section, REPORT the section's own inside the loop's block.
  write_page_tail(reports.dump(),
                  std::string("for (const SECTION of REPORT) {\nconst REPORT = SECTION;\n") +
                      kSweepPageScript + "\n}",
                  out);
}

}  // namespace crosslink::methods
