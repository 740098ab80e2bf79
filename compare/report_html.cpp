// The HTML report: one self-contained page. Tables are written here as HTML; the charts are
// Vega-Lite specifications built in the browser by report_page.js (embedded into this library
// at build time) from a REPORT data object, and drawn by Vega + Vega-Lite + vega-embed, whose
// scripts are read at run time from the npm packages in report/ (docs/report.md) and inlined.
#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "analytic/kinematics/instant_centres.h"
#include "compare/drawing_svg.h"
#include "compare/report.h"

namespace crosslink::compare {

extern const char* const kReportPageScript;  // report_page.js, generated at build time

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kScripts[] = {"vega.min.js", "vega-lite.min.js", "vega-embed.min.js"};
constexpr const char* kPackages[] = {"vega", "vega-lite", "vega-embed"};

// The path of one chart script under `dir`: flat, or in an npm node_modules tree.
std::optional<fs::path> script_in(const fs::path& dir, int i) {
  for (const fs::path& p :
       {dir / kScripts[i], dir / "node_modules" / kPackages[i] / "build" / kScripts[i]})
    if (fs::is_regular_file(p)) return p;
  return std::nullopt;
}

std::string read_file(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Text safe inside <script>: no "</script" that would close the element (matched in any case;
// "<\/script" means the same inside a JS string or regular expression).
std::string script_safe(std::string text) {
  for (size_t pos = 0; (pos = text.find("</", pos)) != std::string::npos; pos += 2) {
    std::string next = text.substr(pos + 2, 6);
    for (char& c : next) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (next == "script") text.replace(pos, 2, "<\\/");
  }
  return text;
}

std::string escape(std::string_view text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// Seven significant digits are plenty for a chart and keep the page small.
double round7(double v) {
  if (!std::isfinite(v)) return v;
  // strtod, not stod: a subnormal (a round-off residue such as 1e-310) is a value, not an error.
  return std::strtod(fmt::format("{:.7g}", v).c_str(), nullptr);
}

json rounded(const Eigen::VectorXd& v, double scale) {
  json a = json::array();
  for (Eigen::Index k = 0; k < v.size(); ++k) a.push_back(round7(v(k) / scale));
  return a;
}

// A channel of a trajectory, null where its sample has no such value: a gap in the chart,
// never a number drawn as 0. The reference's flagged samples keep their positions; another
// method's flagged sample may hold no value of its own (an engine's sample outside its run keeps
// the reference's flag), so it is drawn only where usable, and where the reference's is (which
// the verdicts keep out: a sample whose friction the motion does not determine has the dyads'
// poses, but nothing to hold them against).
json channel_values(const Trajectory& t, const std::string& name, double scale,
                    const Trajectory* reference) {
  const Eigen::VectorXd v = *t.channel(name);  // channel() returns the column by value
  const Quantity q = Trajectory::quantity_of(name);
  json a = json::array();
  for (Eigen::Index k = 0; k < v.size(); ++k) {
    const auto ks = static_cast<size_t>(k);
    const PoseStatus s = t.status[ks];
    const bool shown = reference ? usable(s) && usable(reference->status[ks]) : value_exists(s, q);
    a.push_back(shown ? json(round7(v(k) / scale)) : json(nullptr));
  }
  return a;
}

double severity(const ChannelResult& c) {
  if (c.verdict == Verdict::not_applicable) return -1.0;
  return c.tolerance > 0.0 ? c.metrics.max_pct_of_peak / c.tolerance : c.metrics.max_pct_of_peak;
}

// The moving links whose mass properties are the default model (default_mass_properties: the
// definition gives none), and those the definition gives, each a comma-separated list.
std::pair<std::string, std::string> links_by_mass_source(const Mechanism& m) {
  std::string assumed, given;
  for (const Link& link : m.links)
    if (!link.ground) {
      std::string& list = link.mass.assumed ? assumed : given;
      list += (list.empty() ? "" : ", ") + link.name;
    }
  return {assumed, given};
}

// The drawing at one driver value: link segments, guide lines, points.
json drawing(const Mechanism& m, const Trajectory& pose, const DisplayUnit& length) {
  json d;
  d["unit"] = length.name;
  d["segments"] = json::array();
  d["guides"] = json::array();
  d["points"] = json::array();
  d["centres"] = json::array();
  auto where = [&](const std::string& name) -> std::optional<Eigen::Vector2d> {
    for (size_t p = 0; p < pose.point_names.size(); ++p)
      if (pose.point_names[p] == name)
        return Eigen::Vector2d(pose.x(0, static_cast<Eigen::Index>(p)),
                               pose.y(0, static_cast<Eigen::Index>(p)));
    return std::nullopt;
  };
  const double reach = m.size();
  // Guides and slots, each as its chords.
  for (const GuideOutline& g : guide_outlines(m, pose, 0, reach))
    for (size_t i = 0; i + 1 < g.points.size(); ++i) {
      const Eigen::Vector2d a = g.points[i] / length.scale, b = g.points[i + 1] / length.scale;
      d["guides"].push_back({{"line", g.name},
                             {"moving", g.moving},
                             {"x", a.x()},
                             {"y", a.y()},
                             {"x2", b.x()},
                             {"y2", b.y()}});
    }
  // p and q name the ends, so that the page can redraw the segment at any sample.
  for (const LinkSegment& s : link_segments(m, pose)) {
    const Eigen::Vector2d a = *where(s.p), b = *where(s.q);
    d["segments"].push_back({{"link", s.link},
                             {"p", s.p},
                             {"q", s.q},
                             {"x", a.x() / length.scale},
                             {"y", a.y() / length.scale},
                             {"x2", b.x() / length.scale},
                             {"y2", b.y() / length.scale}});
  }
  // Joint reactions as arrows at their points (the force of the joint's first link on its
  // second), the longest a quarter of the mechanism's size; the driver's effort as a label.
  d["forces"] = json::array();
  if (pose.has_forces && usable(pose.status.at(0))) {
    double largest = 0.0;
    for (Eigen::Index j = 0; j < pose.fx.cols(); ++j)
      largest = std::max(largest, std::hypot(pose.fx(0, j), pose.fy(0, j)));
    const double per_newton = largest > 0.0 ? 0.25 * reach / largest : 0.0;
    const double force_unit = m.units.force;
    for (size_t j = 0; j < m.joints.size(); ++j) {
      const Joint& joint = m.joints[j];
      // A mesh force, or a flat face's contact force, acts at no named point: its chart shows it.
      if (joint.is_gearing() || joint.point_b < 0) continue;
      const auto at = where(m.links[static_cast<size_t>(joint.link_b)]
                                .points[static_cast<size_t>(joint.point_b)]
                                .name);
      if (!at) continue;
      const Eigen::Vector2d f(pose.fx(0, static_cast<Eigen::Index>(j)),
                              pose.fy(0, static_cast<Eigen::Index>(j)));
      const Eigen::Vector2d tip = *at + per_newton * f;
      d["forces"].push_back({{"joint", joint.name},
                             {"x", at->x() / length.scale},
                             {"y", at->y() / length.scale},
                             {"x2", tip.x() / length.scale},
                             {"y2", tip.y() / length.scale},
                             // Clockwise from up, as Vega turns a point's shape.
                             {"angle", std::atan2(f.x(), f.y()) * 180.0 / std::numbers::pi},
                             {"label", fmt::format("{} {:.4g} {}", joint.name,
                                                   f.norm() / force_unit, m.units.force_name)}});
    }
    // Which masses the reactions come from: the page says when it is the default model.
    const auto [assumed, given] = links_by_mass_source(m);
    d["masses"] = assumed.empty() ? "the definition's masses"
                  : !given.empty()
                      ? "the definition's masses and the default uniform bars"
                      : "the default mass model, uniform bars (the definition gives no mass)";
    // Every driver's effort: "driver torque 12.5 N m", or with several named drivers
    // "torque crank2 12.5 N m, torque crank5 -3 N m".
    std::string efforts;
    for (size_t e = 0; e < m.drivers.size(); ++e) {
      const Driver& driver = m.drivers[e];
      const bool torque = driver.angular();
      const double value = pose.effort(0, static_cast<Eigen::Index>(e));
      efforts += fmt::format(
          "{}{} {:.6g} {}", efforts.empty() ? "" : ", ",
          driver.name.empty() ? fmt::format("driver {}", torque ? "torque" : "force")
                              : fmt::format("{} {}", torque ? "torque" : "force", driver.name),
          value / (torque ? force_unit * m.units.length : force_unit),
          torque ? m.units.force_name + " " + m.units.length_name : m.units.force_name);
    }
    d["effort"] = efforts;
  }
  const std::vector<Mechanism::NamedPoint> named = m.named_points();
  for (size_t p = 0; p < pose.point_names.size(); ++p) {
    const Link& link = m.links[static_cast<size_t>(named[p].link)];
    const char* kind = link.ground               ? "ground pivot"
                       : link.points.size() == 1 ? "slider block"
                                                 : "moving";
    d["points"].push_back({{"name", pose.point_names[p]},
                           {"kind", kind},
                           {"x", pose.x(0, static_cast<Eigen::Index>(p)) / length.scale},
                           {"y", pose.y(0, static_cast<Eigen::Index>(p)) / length.scale}});
  }
  return d;
}

// Each cam joint with a pressure angle (Trajectory::cams, docs/cams.md): its profile in the cam's
// frame about its centre (360 points), the roller's radius (0: a knife edge or a face), and at
// every sample with a position, from the reference's positions: the cam's centre and angle, the
// contact, the common normal, where the follower's direction of motion is taken and it, and the
// pressure angle; null at a sample without a position.
json cam_drawings(const Mechanism& m, const Trajectory& ref) {
  const DisplayUnit length = display_unit(m, "x.any"), angle = display_unit(m, "angle.any");
  json cams = json::array();
  for (const Trajectory::CamChannel& cam : ref.cams) {
    const ConstraintRows& rows = cam.reading.rows;
    const bool face = rows.kind == ConstraintRows::Kind::cam_face;
    json outline = json::array();
    double reach = 0.0;
    for (const Eigen::Vector2d& u : cam.reading.outline(360)) {
      outline.push_back({u.x() / length.scale, u.y() / length.scale});
      reach = std::max(reach, u.norm());
    }
    json poses = json::array();
    for (int k = 0; k < ref.samples(); ++k) {
      if (!ref.has_value(k, Quantity::position)) {
        poses.push_back(nullptr);
        continue;
      }
      const CamReading::Pose p = cam.at(ref, k);
      const auto xy = [&](const Eigen::Vector2d& v) {
        return json::array({v.x() / length.scale, v.y() / length.scale});
      };
      poses.push_back({{"centre", xy(p.centre)},
                       {"angle", p.cam_angle},
                       {"contact", xy(p.contact.point)},
                       {"normal", {p.contact.normal.x(), p.contact.normal.y()}},
                       {"at", xy(p.at)},
                       {"motion", {p.motion.x(), p.motion.y()}},
                       {"phi", p.pressure_angle / angle.scale}});
    }
    cams.push_back({{"name", cam.reading.joint},
                    {"outline", outline},
                    {"reach", reach / length.scale},
                    {"roller", face ? 0.0 : rows.contour->follower().roller_radius / length.scale},
                    {"face", face},
                    {"angle_unit", angle.name},
                    {"poses", poses}});
  }
  return cams;
}

// The data object the page's script draws from (file units).
json report_data(const Comparison& cmp, const Trajectory& pose) {
  const Mechanism& m = *cmp.mechanism;
  const Trajectory& ref = cmp.reference().trajectory;
  const DisplayUnit du = driver_unit(m);
  json r;
  if (samples_in_time(m)) {  // the charts' axis is the time
    r["driver"]["unit"] = "s";
    r["driver"]["title"] = "time [s]";
    r["driver"]["values"] = rounded(ref.time, 1.0);
  } else {
    r["driver"]["unit"] = du.name;
    r["driver"]["values"] = rounded(ref.driver_values.col(ref.axis.driver), du.scale);
  }
  r["driver"]["usable"] = json::array();
  for (PoseStatus s : ref.status) r["driver"]["usable"].push_back(usable(s));
  r["methods"] = json::array();
  for (const MethodRun& run : cmp.methods)
    if (run.available && run.ok) r["methods"].push_back(run.name);

  // Per channel: reference and every method's values and signed % of peak.
  r["channels"] = json::object();
  std::map<std::string, std::vector<const ChannelResult*>> by_channel;
  for (const ChannelResult& c : cmp.channels) by_channel[c.metrics.channel].push_back(&c);
  std::map<Quantity, std::vector<std::pair<double, std::string>>> per_quantity;
  for (const std::string& name : ref.channel_names()) {
    const DisplayUnit u = display_unit(m, name);
    json ch;
    ch["unit"] = u.name;
    ch["ref"] = channel_values(ref, name, u.scale, nullptr);
    ch["methods"] = json::object();
    double worst = -1.0;
    std::string label = name + " [" + u.name + "]";
    for (const ChannelResult* c : by_channel[name]) {
      const MethodRun& run = *cmp.method(c->method);
      json in = json::array(), out = json::array();
      for (bool b : c->metrics.in_verdict) in.push_back(b);
      // Why each sample is kept out of the verdict (null where it is in): the chart's bands.
      for (const std::string& why : c->metrics.reason)
        out.push_back(why.empty() ? json() : json(why));
      ch["methods"][c->method] = {{"v", channel_values(run.trajectory, name, u.scale, &ref)},
                                  {"p", rounded(c->metrics.pct_of_peak, 1.0)},
                                  {"in", in},
                                  {"out", out}};
      if (severity(*c) > worst) {
        worst = severity(*c);
        // No % of a peak of zero (a reference at rest): n/a.
        const double pct = c->metrics.max_pct_of_peak;
        label = fmt::format("{} [{}]  worst: {} {} % of peak ({})", name, u.name, c->method,
                            std::isfinite(pct) ? fmt::format("{:.3g}", pct) : "n/a",
                            to_string(c->verdict));
      }
    }
    r["channels"][name] = ch;
    per_quantity[Trajectory::quantity_of(name)].push_back({worst, label + "\x1f" + name});
  }
  r["quantities"] = json::array();
  for (auto& [q, list] : per_quantity) {
    std::stable_sort(list.begin(), list.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    json channels = json::array();
    for (const auto& [sev, text] : list) {
      const size_t sep = text.find('\x1f');
      channels.push_back({{"name", text.substr(sep + 1)}, {"label", text.substr(0, sep)}});
    }
    r["quantities"].push_back({{"name", std::string(to_string(q))}, {"channels", channels}});
  }
  // Several drivers' singular positions (direct, inverse), marked on the charts at their time.
  for (const Trajectory::Event& e : ref.events)
    if (e.singularity != ParallelSingularity::none)
      r["singular"].push_back(
          {{"driver", e.driver},
           {"kind", fmt::format("{} singularity{}", to_string(e.singularity),
                                e.chain.empty() ? "" : " (driver " + e.chain + ")")},
           {"message", e.message}});
  // The dead points and strokes of the [[derived]] quantities (the design summary's among them):
  // a dead point, where a channel turns back (a stroke's or dead_points' at_min and at_max), is
  // a rule on every chart at its driver value; a stroke's min and max are rules on its channel's.
  r["dead_points"] = json::array();
  r["strokes"] = json::array();
  std::vector<std::string> marked;  // "channel.field", each once
  using Kind = DerivedSpec::Kind;
  // A crank's dead point is found within one turn: drawn at its place in the sweep's span.
  const bool turns = !samples_in_time(m) && m.swept().angular() && ref.samples() > 1;
  const double first = turns ? ref.driver_values.col(ref.axis.driver).minCoeff() : 0.0;
  const auto in_sweep = [&](double d) {
    const double turn = 2.0 * std::numbers::pi;
    return turns ? first + std::fmod(std::fmod(d - first, turn) + turn, turn) : d;
  };
  for (const DerivedValue& v : cmp.derived.exact) {
    if (v.spec->kind != Kind::dead_points && v.spec->kind != Kind::stroke) continue;
    const std::string& channel = v.spec->channel;
    for (const char* end : {"at_min", "at_max"}) {
      const DerivedField* f = v.field(end);
      const std::string key = channel + "." + end;
      if (!f || !f->value || std::find(marked.begin(), marked.end(), key) != marked.end()) continue;
      marked.push_back(key);
      r["dead_points"].push_back(
          {{"driver", in_sweep(*f->value) / du.scale},
           {"label", fmt::format("dead point: {} {}", channel,
                                 end == std::string("at_min") ? "min" : "max")}});
    }
    const DerivedField *low = v.field("min"), *high = v.field("max"), *stroke = v.field("stroke");
    if (v.spec->kind == Kind::stroke && low && high && stroke && low->value && high->value &&
        stroke->value) {
      const DisplayUnit u = display_unit(m, channel);
      r["strokes"].push_back(
          {{"channel", channel},
           {"min", *low->value / u.scale},
           {"max", *high->value / u.scale},
           {"label", fmt::format("stroke {:.6g} {}", *stroke->value / u.scale, u.name)}});
    }
  }
  // The points whose paths the path chart draws, as the drawing draws them.
  r["paths"] = moving_points(m);
  r["drawing"] = drawing(m, pose, display_unit(m, "x.any"));
  r["drawing"]["cams"] = cam_drawings(m, ref);
  return r;
}

// Whether a --set or --tolerance assignment ("KEY=V" or "PREFIX:KEY=V") is meant for `method`
// and names `key`: a bare one goes to every engine (`bare_applies`), a prefixed one to its own.
bool assigns(std::string_view text, std::string_view method, std::string_view key,
             bool bare_applies) {
  std::string_view name = text.substr(0, text.find('='));
  if (const size_t colon = name.find(':'); colon != std::string_view::npos) {
    if (name.substr(0, colon) != method) return false;
    name = name.substr(colon + 1);
  } else if (!bare_applies) {
    return false;
  }
  return name == key;
}

// The exact methods' tolerances are fixed (tolerance.h): a bare CLASS=V or [tolerance] is not
// theirs.
bool exact_method(std::string_view method) {
  return method == "dyads" || method == "ic";
}

std::optional<double> definition_tolerance(const ToleranceOverrides& t, Quantity q) {
  switch (q) {
    case Quantity::position:
      return t.position;
    case Quantity::angle:
      return t.angle;
    case Quantity::velocity:
      return t.velocity;
    case Quantity::acceleration:
      return t.acceleration;
    case Quantity::jerk:
      return std::nullopt;
    case Quantity::force:
      return t.force;
    case Quantity::torque:
      return t.torque;
    case Quantity::energy:
      return std::nullopt;
  }
  return std::nullopt;
}

// Where one method's tolerance of one class comes from, later wins as tolerance.h applies them.
std::string tolerance_source(const Mechanism& m, const HtmlOptions& options,
                             const std::string& method, Quantity q) {
  const bool engine = !exact_method(method);
  std::string source = "default";
  if (engine && definition_tolerance(m.tolerances, q)) source = "the definition's [tolerance]";
  if (engine && options.accuracy) source = "--accuracy";
  for (const std::string& t : options.tolerances)
    if (assigns(t, method, to_string(q), engine)) source = "--tolerance " + t;
  return source;
}

// Every value the page relies on that the definition or the command line may leave to a
// default, with where each one came from.
std::string settings_in_force(const Comparison& cmp, const HtmlOptions& options) {
  const Mechanism& m = *cmp.mechanism;
  const DisplayUnit du = driver_unit(m);
  std::string html = "<ul id=\"settings-in-force\">\n";
  if (m.dynamics) {
    html += "<li>samples: every [dynamics] interval of the definition, over its duration</li>\n";
  } else {
    html += fmt::format("<li>sweep: {}</li>\n",
                        m.axis().timed() ? fmt::format("the drivers' laws in time over their "
                                                       "longest cycle, {:.6g} s",
                                                       m.cycle_period())
                        : m.swept().range
                            ? std::string("over the definition's driver range")
                            : std::string("one cycle from the driver's start, or its assembling "
                                          "range (default: the definition gives no range)"));
    html += m.axis().timed() ? std::string("<li>step between samples: 1/360 of the cycle</li>\n")
            : options.step   ? fmt::format("<li>step between samples: {:.6g} {} (--step)</li>\n",
                                           *options.step / du.scale, escape(du.name))
                             : std::string(
                                   "<li>step between samples: the default, 1 deg for an angle, "
                                     "1/360 of the swept range for a slider (--step sets it)</li>\n");
  }
  html += options.drawing.asked ? std::string("<li>drawing: at --at</li>\n")
                                : std::string(
                                      "<li>drawing: at the driver's start (default; --at sets "
                                      "it)</li>\n");
  const auto [assumed, given] = links_by_mass_source(m);
  html += fmt::format(
      "<li>mass model (every force, torque and energy channel and the drawing's reactions): "
      "{}</li>\n",
      assumed.empty() ? std::string("the definition's masses for every link")
      : given.empty()
          ? std::string("the default for every link (the definition gives no mass): a uniform "
                        "slender bar between the link's two farthest points, 1 kg per mechanism "
                        "size of length, 10:1 slender")
          : fmt::format("the default uniform bar for {}; the definition's for {}", escape(assumed),
                        escape(given)));
  // Tolerances: method x class, each with its source.
  std::vector<std::string> methods;
  std::vector<Quantity> classes;
  std::map<std::pair<std::string, Quantity>, double> value;
  for (const ChannelResult& c : cmp.channels) {
    if (c.prescribed) continue;
    if (std::find(methods.begin(), methods.end(), c.method) == methods.end())
      methods.push_back(c.method);
    if (std::find(classes.begin(), classes.end(), c.metrics.quantity) == classes.end())
      classes.push_back(c.metrics.quantity);
    value.emplace(std::pair(c.method, c.metrics.quantity), c.tolerance);
  }
  std::sort(classes.begin(), classes.end());
  html +=
      "<li>verdict tolerances [% of peak] and where each comes from:\n"
      "<table class=\"tolerances\"><tr><th>method</th>";
  for (Quantity q : classes) html += fmt::format("<th>{}</th>", to_string(q));
  html += "</tr>\n";
  for (const std::string& method : methods) {
    html += fmt::format("<tr><td>{}</td>", escape(method));
    for (Quantity q : classes) {
      const auto v = value.find({method, q});
      html += v == value.end() ? std::string("<td></td>")
                               : fmt::format("<td>{:.3g} <small>({})</small></td>", v->second,
                                             escape(tolerance_source(m, options, method, q)));
    }
    html += "</tr>\n";
  }
  html += "</table></li>\n";
  html += fmt::format(
      "<li>engine settings: as listed under \"Methods: settings and cost\"; those marked "
      "<b>--set</b> the command line set{}, every other one is the engine's default (`crosslink "
      "engines` lists them)</li>\n",
      options.accuracy
          ? fmt::format(", and the time step --accuracy {:g} % chose", *options.accuracy)
          : "");
  return html + "</ul>\n";
}

std::string methods_table(const Comparison& cmp, const HtmlOptions& options) {
  std::string html = std::string("<table><tr><th>method</th><th>status</th><th>wall [s]</th><th>") +
                     (cmp.mechanism->dynamics ? "per simulated s [s]" : "per cycle [s]") +
                     "</th>"
                     "<th>steps</th><th>settings</th></tr>\n";
  for (const MethodRun& run : cmp.methods) {
    std::string settings;
    for (const auto& entry : run.settings) {
      // Named, not a structured binding: clang (the sanitizer build) lets no lambda capture one.
      const std::string &k = entry.first, &v = entry.second;
      const bool set =
          std::any_of(options.settings.begin(), options.settings.end(), [&](const std::string& s) {
            return assigns(s, run.name, k, !exact_method(run.name) && run.name != "analytic");
          });
      settings +=
          fmt::format("<code>{}={}</code>{} ", escape(k), escape(v), set ? " <b>--set</b>" : "");
    }
    const std::string status = !run.available ? "not run: " + run.message
                               : run.ok ? "ok" + (run.message.empty() ? "" : ": " + run.message)
                                        : "FAILED: " + run.message;
    html += fmt::format(
        "<tr><td><b>{}</b><br><small>{}</small></td><td>{}</td><td>{}</td><td>{}</td>"
        "<td>{}</td><td class=\"settings\">{}</td></tr>\n",
        escape(run.name), escape(run.description), escape(status),
        run.available ? fmt::format("{:.4f}", run.cost.wall_seconds) : "",
        run.available ? fmt::format("{:.4g}", run.cost.wall_seconds_per_cycle) : "",
        run.available ? fmt::format("{}", run.cost.steps) : "", settings);
  }
  return html + "</table>\n";
}

// The verdict table, one group per kind of channel (position, angle, velocity, ..., and the
// values the definition prescribes last): a summary line (count, worst % of peak, verdict), the
// rows closest to failing first (every failing one, at least kShownRows), the rest folded.
std::string verdict_table(const Comparison& cmp) {
  constexpr size_t kShownRows = 5;
  const Mechanism& m = *cmp.mechanism;
  const DisplayUnit du = driver_unit(m);
  const std::string header =
      "<tr><th>channel</th><th>method</th><th>max % of peak</th><th>RMS % of peak</th>"
      "<th>max local %</th><th>max |d|</th><th>worst at</th><th>tolerance %</th>"
      "<th>verdict</th></tr>\n";
  const auto row = [&](const ChannelResult& c) {
    const DisplayUnit u = display_unit(m, c.metrics.channel);
    const int k = c.metrics.worst_sample;
    // No sample in the verdict: no metric exists ("-"), not 0.
    const auto metric = [&](double v) {
      return c.metrics.usable > 0 ? fmt::format("{:.3g}", v) : std::string("-");
    };
    return fmt::format(
        "<tr class=\"{}\"><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
        "<td>{}</td><td>{} {}</td><td>{}</td><td>{:.3g}</td><td>{}</td></tr>\n",
        c.verdict == Verdict::fail ? "fail" : "", escape(c.metrics.channel), escape(c.method),
        metric(c.metrics.max_pct_of_peak), metric(c.metrics.rms_pct_of_peak),
        metric(c.metrics.max_local_pct), metric(c.metrics.max_abs / u.scale), escape(u.name),
        k < 0 ? std::string("-")
        : samples_in_time(m)
            ? fmt::format("t = {:.3f} s (#{})", cmp.reference().trajectory.time(k), k)
            : fmt::format("{:.2f} {} (#{})", cmp.reference().trajectory.along(k) / du.scale,
                          escape(du.name), k),
        c.tolerance, to_string(c.verdict));
  };
  // Groups in Quantity order, the prescribed values apart (key: quantity, or -1 for them).
  std::map<int, std::vector<const ChannelResult*>> groups;
  for (const ChannelResult& c : cmp.channels)
    groups[c.prescribed ? std::numeric_limits<int>::max() : static_cast<int>(c.metrics.quantity)]
        .push_back(&c);
  if (groups.empty()) return "<p>No channel was compared.</p>\n";
  std::string html;
  for (auto& [key, rows] : groups) {
    std::stable_sort(rows.begin(), rows.end(),
                     [](auto* a, auto* b) { return severity(*a) > severity(*b); });
    const bool prescribed = key == std::numeric_limits<int>::max();
    const std::string name = prescribed ? "values the definition prescribes"
                                        : std::string(to_string(static_cast<Quantity>(key)));
    int fail = 0, pass = 0;
    for (const ChannelResult* c : rows) {
      fail += c->verdict == Verdict::fail;
      pass += c->verdict == Verdict::pass;
    }
    const ChannelResult& worst = *rows.front();
    const std::string verdict = fail ? "FAIL" : pass ? "PASS" : "n/a";
    html += fmt::format(
        "<section class=\"verdict-group\" data-group=\"{}\">\n<h3>{}: {} comparison{} ({} pass, "
        "{} fail, {} n/a); worst {} % of peak ({} {}, tolerance {:.3g} %): <b "
        "class=\"verdict-{}\">{}</b></h3>\n",
        escape(name), escape(name), rows.size(), rows.size() == 1 ? "" : "s", pass, fail,
        static_cast<int>(rows.size()) - pass - fail,
        worst.metrics.usable == 0 ? "-"
        : std::isfinite(worst.metrics.max_pct_of_peak)
            ? fmt::format("{:.3g}", worst.metrics.max_pct_of_peak)
            : "n/a",
        escape(worst.method), escape(worst.metrics.channel), worst.tolerance,
        fail ? "fail" : "pass", verdict);
    // The prescribed values agree by construction: all folded.
    const size_t shown = prescribed ? 0 : std::max(kShownRows, static_cast<size_t>(fail));
    const size_t split = std::min(shown, rows.size());
    if (split > 0) {
      html += "<table class=\"verdicts\">" + header;
      for (size_t i = 0; i < split; ++i) html += row(*rows[i]);
      html += "</table>\n";
    }
    if (split < rows.size()) {
      html += fmt::format(
          "<details><summary>{} {}row{}, closest to failing first</summary>\n<table "
          "class=\"verdicts\">{}",
          rows.size() - split, split ? "more " : "", rows.size() - split == 1 ? "" : "s", header);
      for (size_t i = split; i < rows.size(); ++i) html += row(*rows[i]);
      html += "</table>\n</details>\n";
    }
    html += "</section>\n";
  }
  return html;
}

// [[reference]] rows grouped by (quantity, driver value): every printed value, the exact one
// and each method's, with the % difference of every pair (row against column).
std::string references_table(const Comparison& cmp) {
  const Mechanism& m = *cmp.mechanism;
  const DisplayUnit du = driver_unit(m);
  std::vector<std::vector<const ReferenceRow*>> groups;
  for (const ReferenceRow& r : cmp.references) {
    bool placed = false;
    for (auto& g : groups)
      if (g.front()->reference.quantity == r.reference.quantity &&
          std::abs(g.front()->reference.driver_value - r.reference.driver_value) < 1e-12) {
        g.push_back(&r);
        placed = true;
      }
    if (!placed) groups.push_back({&r});
  }
  std::string html;
  for (const auto& g : groups) {
    const Reference& first = g.front()->reference;
    const DisplayUnit u = display_unit(m, first.quantity);
    const bool angle = Trajectory::quantity_of(first.quantity) == Quantity::angle;
    std::vector<std::pair<std::string, double>> values;  // label, SI
    auto shown = [&](double si) { return (angle ? wrap_positive_angle(si) : si) / u.scale; };
    for (const ReferenceRow* r : g)
      values.push_back(
          {r->reference.source +
               (r->reference.printed.empty() ? "" : " (printed " + r->reference.printed + ")") +
               (reference_note(*r).empty() ? "" : ": " + reference_note(*r)),
           r->reference.value});
    if (g.front()->exact_ok) values.push_back({"exact (Newton at this value)", g.front()->exact});
    for (const auto& v : g.front()->values)
      if (v.method != "analytic")
        values.push_back({v.method + (v.interpolated ? " (interpolated)" : "") +
                              (v.method == "ic" ? " (IC computed)" : ""),
                          v.value});
    // A [[derived]] quantity is of the whole sweep.
    html += first.derived
                ? fmt::format("<h3><code>{}</code> of the sweep ([[derived]]) [{}]</h3>\n",
                              escape(first.quantity), escape(u.name))
                : fmt::format("<h3><code>{}</code> at driver = {:.6g} {} [{}]</h3>\n",
                              escape(first.quantity), first.driver_value / du.scale,
                              escape(du.name), escape(u.name));
    html += "<table class=\"refs\"><tr><th>value from</th><th>value</th>";
    for (size_t j = 0; j < values.size(); ++j) html += fmt::format("<th>% vs ({})</th>", j + 1);
    html += "</tr>\n";
    for (size_t i = 0; i < values.size(); ++i) {
      html += fmt::format("<tr><td>({}) {}</td><td>{:.6g}</td>", i + 1, escape(values[i].first),
                          shown(values[i].second));
      for (size_t j = 0; j < values.size(); ++j) {
        const double pct = g.front()->percent(values[i].second, values[j].second);
        html += i == j || std::isnan(pct) ? "<td></td>" : fmt::format("<td>{:.3f}</td>", pct);
      }
      html += "</tr>\n";
    }
    html += "</table>\n";
  }
  return html;
}

constexpr const char* kStyle = R"css(
body { font: 14px/1.4 system-ui, sans-serif; margin: 1.5em auto; max-width: 1100px; color: #222; }
table { border-collapse: collapse; margin: 0.5em 0 1em; font-size: 13px; }
td, th { border: 1px solid #ccc; padding: 2px 6px; text-align: right; vertical-align: top; }
td:first-child, th:first-child { text-align: left; }
td.settings { text-align: left; max-width: 520px; }
tr.fail td { background: #fde0e0; }
.verdict-pass { color: #17692a; } .verdict-fail { color: #b00020; }
td.derived-pass { background: #e3f4e6; } td.derived-fail { background: #fde0e0; }
td.derived-na { background: #f1f1f1; color: #555; }
#render-status { font-size: 12px; color: #666; }
dt { font-weight: 600; } dd { margin: 0 0 0.4em 1.5em; }
select { margin: 0.3em 0; max-width: 100%; }
)css";

}  // namespace

std::optional<std::string> find_report_assets(const std::vector<std::string>& extra_dirs,
                                              std::string* searched) {
  std::vector<fs::path> candidates(extra_dirs.begin(), extra_dirs.end());
  if (const char* env = std::getenv("CROSSLINK_REPORT_ASSETS")) candidates.emplace_back(env);
#ifdef CROSSLINK_SOURCE_DIR
  candidates.emplace_back(fs::path(CROSSLINK_SOURCE_DIR) / "report");
#endif
  std::string looked;
  for (const fs::path& dir : candidates) {
    looked += (looked.empty() ? "" : ", ") + dir.string();
    bool all = true;
    for (int i = 0; i < 3; ++i) all = all && script_in(dir, i).has_value();
    if (all) return dir.string();
  }
  if (searched) *searched = looked;
  return std::nullopt;
}

void write_html(const Comparison& cmp, const HtmlOptions& options, std::ostream& out) {
  const Mechanism& m = *cmp.mechanism;
  std::ostringstream head;  // first, so a missing chart script fails before any work
  write_page_head(fmt::format("crosslink compare: {}", m.name), "", options.asset_dirs, head);

  // The drawing's pose, solved before (methods::drawing): at --at or the drawn start; with
  // several drivers --at is a time, the start t = 0.
  const bool timed = m.axis().timed();
  const double at = options.drawing.at;
  const Trajectory& pose = options.drawing.pose;
  if (pose.samples() != 1) throw std::logic_error("write_html: no drawing (methods::drawing)");
  const DisplayUnit du = driver_unit(m);
  json data = report_data(cmp, pose);
  data["styles"] = json::object();
  for (const auto& [name, style] : options.styles)
    data["styles"][name] = {{"colour", style.colour}, {"dash", style.dash}};
  data["drawing"]["at"] = timed ? at : at / du.scale;
  if (timed) data["drawing"]["timed"] = true;  // `at` is a time: the sample drawn is the nearest
  data["drawing"]["status"] = std::string(to_string(pose.status.at(0)));
  std::string centres_note = "No instantaneous centres: the drawn pose is singular.";
  // Instantaneous centres I(i,j), links numbered from 1 in definition order. Every placed one is
  // drawn (the page frames the linkage and points at a centre outside the frame with an arrow);
  // those at infinity are listed.
  if (options.drawing.centres) {
    const InstantCentres& ic = *options.drawing.centres;
    const DisplayUnit length = display_unit(m, "x.any");
    std::vector<std::string> at_infinity, undefined;
    for (const InstantCentre& c : ic.centres) {
      const std::string name = fmt::format("I{},{}", c.i + 1, c.j + 1);
      if (!c.placed()) {
        undefined.push_back(name);
        continue;
      }
      if (c.at_infinity()) {
        at_infinity.push_back(name);
        continue;
      }
      data["drawing"]["centres"].push_back({{"name", name},
                                            {"how", c.how},
                                            {"x", c.position().x() / length.scale},
                                            {"y", c.position().y() / length.scale}});
    }
    std::string links;
    for (size_t l = 0; l < m.links.size(); ++l)
      links += fmt::format("{}{} {}", l ? ", " : "", l + 1, m.links[l].name);
    centres_note = fmt::format(
        "Instantaneous centres (red diamonds) I<i>,<j>, links numbered {}; a centre outside the "
        "frame is a red arrow at its edge pointing at it, labelled with its distance beyond the "
        "arrow's tip.",
        links);
    const auto listed = [&](const char* title, const std::vector<std::string>& names) {
      if (names.empty()) return;
      centres_note += title;
      for (size_t i = 0; i < names.size(); ++i) centres_note += (i ? ", " : "") + names[i];
      centres_note += ".";
    };
    listed(" At infinity (a pair in relative translation): ", at_infinity);
    listed(" Undefined (a pair with no relative motion at this pose): ", undefined);
  }

  std::string legend;
  for (const auto& [term, definition] : metric_legend())
    legend += fmt::format("<dt>{}</dt><dd>{}</dd>\n", escape(term), escape(definition));
  std::string quantity_sections;
  for (const json& q : data["quantities"]) {
    const std::string name = q["name"];
    quantity_sections += fmt::format(
        "<h3>{0}</h3>\n<label>channel <select id=\"select-{0}\"></select></label>\n"
        "<div id=\"chart-{0}\" class=\"chart\"></div>\n",
        name);
  }

  out << head.str();
  out << fmt::format("<h1>{}</h1>\n<p>{}</p>\n", escape(m.name), escape(m.description));
  if (!m.citation.empty())
    out << fmt::format("<p><small>Source: {}</small></p>\n", escape(m.citation));
  out << fmt::format(
      "<p>File <code>{}</code>. Overall verdict: <b class=\"verdict-{}\">{}</b> ({}).</p>\n",
      escape(m.file), cmp.pass() ? "pass" : "fail", cmp.pass() ? "PASS" : "FAIL",
      escape(cmp.counts_text()));
  out << "<p id=\"render-status\" data-status=\"pending\">charts not rendered (scripts did not "
         "run)</p>\n";
  if (timed)
    out << fmt::format("<h2>Mechanism at t = {:.6g} s ({})</h2>\n", at,
                       to_string(pose.status.at(0)));
  else
    out << fmt::format("<h2>Mechanism at driver = {:.6g} {} ({})</h2>\n", at / du.scale,
                       escape(du.name), to_string(pose.status.at(0)));
  out << "<div id=\"drawing\" class=\"chart\"></div>\n";
  out << fmt::format(
      "<p><label>move the drawing: <input type=\"range\" id=\"sample\" min=\"0\" max=\"{}\" "
      "value=\"0\"> <span id=\"sample-value\"></span></label><br><small>Grey lines: the paths "
      "of the moving points (exact). Instantaneous centres, reactions and slots on moving links "
      "are drawn at the pose above; the dotted line in the charts follows the "
      "drawing.</small></p>\n",
      std::max(0, cmp.reference().trajectory.samples() - 1));
  out << "<p><small>" << escape(centres_note) << "</small></p>\n";
  out << "<p><small id=\"drawing-left-out\"></small></p>\n";
  out << (samples_in_time(m) ? "<h2>Channels against time</h2>\n"
                             : "<h2>Channels against the driver</h2>\n")
      << "<p>Every method overlaid on the exact values; "
         "under each chart the signed difference from exact in % of the exact peak. A red band "
         "marks each sample flagged by the reference (singular, a limit, a loop gap: kept out of "
         "verdicts); a value that does not exist there is a gap, never drawn.</p>\n";
  out << quantity_sections;
  if (!data["paths"].empty())
    out << "<h2>Paths of the points</h2>\n<p>A point's path in the plane over the sweep, every "
           "method overlaid on the exact one (the coupler curve of a coupler point).</p>\n"
           "<label>point <select id=\"select-path\"></select></label>\n"
           "<div id=\"chart-path\" class=\"chart\"></div>\n";
  out << "<h2>Verdicts</h2>\n" << verdict_table(cmp);
  if (!cmp.references.empty())
    out << "<h2>Published values ([[reference]])</h2>\n<p>Each cell: % difference of the row's "
           "value from the column's, 100 |row - column| / |column|.</p>\n"
        << references_table(cmp);
  if (!cmp.derived.empty())
    out << "<h2 id=\"derived\">Derived quantities ([[derived]])</h2>\n<p>Exact: located on the "
           "exact solution. "
           "Each method's from its samples (the parabola through the extreme sample and its "
           "neighbours); its verdict on its difference from the same estimate on the "
           "reference's samples, in % of the quantity's scale.</p>\n"
        << derived_table_html(*cmp.mechanism, cmp.derived);
  out << "<h2>Methods: settings and cost</h2>\n" << methods_table(cmp, options);
  out << "<h2>Settings in force: defaults and what set the others</h2>\n"
      << settings_in_force(cmp, options);
  out << "<h2>Legend</h2>\n<dl>\n" << legend << "</dl>\n";
  write_page_tail(data.dump(), kReportPageScript, out);
}

void write_page_head(std::string_view title, std::string_view extra_style,
                     const std::vector<std::string>& asset_dirs, std::ostream& out) {
  std::string searched;
  const std::optional<std::string> assets = find_report_assets(asset_dirs, &searched);
  if (!assets)
    throw std::runtime_error(fmt::format(
        "the HTML report needs vega.min.js, vega-lite.min.js and vega-embed.min.js; looked in "
        "{} (run scripts/setup.sh, or `npm ci` in report/, or set CROSSLINK_REPORT_ASSETS)",
        searched));
  out << "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  out << fmt::format("<title>{}</title>\n", escape(title));
  out << "<style>" << kStyle << extra_style << "</style>\n";
  for (int i = 0; i < 3; ++i)
    out << "<script>/* " << kPackages[i] << " (npm) */\n"
        << script_safe(read_file(*script_in(*assets, i))) << "\n</script>\n";
  out << "</head>\n<body>\n";
}

void write_page_tail(std::string_view report_json, std::string_view page_script,
                     std::ostream& out) {
  out << "<script>const REPORT = " << script_safe(std::string(report_json)) << ";</script>\n";
  out << "<script>\n" << script_safe(std::string(page_script)) << "\n</script>\n";
  out << "</body>\n</html>\n";
}

std::string html_escape(std::string_view text) {
  return escape(text);
}

}  // namespace crosslink::compare
