#include "app/output.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "analytic/model/units_text.h"
#include "compare/comparison.h"
#include "compare/report.h"

namespace crosslink::app {
namespace {

nlohmann::json value(bool exists, double v) {
  return exists ? nlohmann::json(v) : nlohmann::json(nullptr);
}

// The forces of a usable sample in the documented schema (docs/json.md); null otherwise.
nlohmann::json forces_json(const Mechanism& m, const Trajectory& t, int row) {
  if (!t.has_forces || !usable(t.status[static_cast<size_t>(row)])) return nullptr;
  nlohmann::json f;
  if (!t.axis.timed()) {
    f["driver"] = t.effort(row, t.axis.driver);
  } else {  // several drivers: each one's effort by its name
    f["drivers"] = nlohmann::json::object();
    for (size_t d = 0; d < t.driver_names.size(); ++d)
      f["drivers"][t.driver_names[d]] = t.effort(row, static_cast<Eigen::Index>(d));
  }
  f["joints"] = nlohmann::json::object();
  size_t slide = 0, friction = 0;
  for (size_t j = 0; j < m.joints.size(); ++j) {
    const auto c = static_cast<Eigen::Index>(j);
    nlohmann::json joint = {{"fx", t.fx(row, c)}, {"fy", t.fy(row, c)}};
    if (m.joints[j].is_slide()) {
      const auto s = static_cast<Eigen::Index>(slide++);
      joint["fn"] = t.fn(row, s);
      if (m.joints[j].type == JointType::prismatic) joint["moment"] = t.moment(row, s);
    }
    if (m.joints[j].friction)
      joint["friction"] = t.friction(row, static_cast<Eigen::Index>(friction++));
    f["joints"][m.joints[j].name] = joint;
  }
  f["shaking"] = {
      {"fx", t.shaking(row, 0)}, {"fy", t.shaking(row, 1)}, {"moment", t.shaking(row, 2)}};
  return f;
}

}  // namespace

nlohmann::json sample_json(const Mechanism& m, const Trajectory& t, int row) {
  nlohmann::json j;
  j["time"] = t.time(row);
  j["driver"] = t.driver_field(row);
  if (t.axis.timed()) {  // each driver's value by its name
    j["drivers"] = nlohmann::json::object();
    for (size_t d = 0; d < t.driver_names.size(); ++d)
      j["drivers"][t.driver_names[d]] = t.driver_values(row, static_cast<Eigen::Index>(d));
  }
  j["status"] = std::string(to_string(t.status[static_cast<size_t>(row)]));
  j["links"] = nlohmann::json::object();
  const PoseStatus status = t.status[static_cast<size_t>(row)];
  const auto pos = [&](double v) { return value(has_position(status), v); };
  const auto rate = [&](double v) { return value(usable(status), v); };
  for (size_t l = 0; l < t.link_names.size(); ++l) {
    const auto c = static_cast<Eigen::Index>(l);
    j["links"][t.link_names[l]] = {{"angle", pos(t.angle(row, c))},
                                   {"omega", rate(t.omega(row, c))},
                                   {"alpha", rate(t.alpha(row, c))}};
  }
  j["points"] = nlohmann::json::object();
  for (size_t p = 0; p < t.point_names.size(); ++p) {
    const auto c = static_cast<Eigen::Index>(p);
    j["points"][t.point_names[p]] = {{"x", pos(t.x(row, c))},    {"y", pos(t.y(row, c))},
                                     {"vx", rate(t.vx(row, c))}, {"vy", rate(t.vy(row, c))},
                                     {"ax", rate(t.ax(row, c))}, {"ay", rate(t.ay(row, c))}};
  }
  j["sliders"] = nlohmann::json::object();
  for (size_t s = 0; s < t.slider_names.size(); ++s) {
    const auto c = static_cast<Eigen::Index>(s);
    j["sliders"][t.slider_names[s]] = {
        {"s", pos(t.s(row, c))}, {"sdot", rate(t.sdot(row, c))}, {"sddot", rate(t.sddot(row, c))}};
  }
  // Each cam's pressure angle and, from the exact kinematics, its follower's jerk.
  if (!t.cams.empty()) {
    j["cams"] = nlohmann::json::object();
    for (size_t c = 0; c < t.cams.size(); ++c) {
      const CamReading& r = t.cams[c].reading;
      nlohmann::json cam = {{"phi", nullptr}};
      if (has_position(status)) cam["phi"] = pos(t.cams[c].at(t, row).pressure_angle);
      if (t.has_jerk) cam[r.jerk_kind()] = rate(t.jerk(row, static_cast<Eigen::Index>(c)));
      j["cams"][r.joint] = cam;
    }
  }
  j["forces"] = forces_json(m, t, row);
  return j;
}

namespace {

// The document's fields but its samples: mechanism, file, units, method, events, and `status`
// (the first flagged sample's, else ok) for a document of samples.
nlohmann::json document_json(const Mechanism& m, const Trajectory& t, bool of_samples,
                             const std::string& event_key) {
  nlohmann::json j;
  j["mechanism"] = m.name;
  j["file"] = m.file;
  j["units"] = "SI";
  j["method"] = t.method;
  if (of_samples) {
    const auto first_flagged =
        std::find_if(t.status.begin(), t.status.end(), [](PoseStatus s) { return !usable(s); });
    j["status"] =
        std::string(to_string(first_flagged == t.status.end() ? PoseStatus::ok : *first_flagged));
  }
  j["events"] = nlohmann::json::array();
  for (const Trajectory::Event& e : t.events) {
    nlohmann::json event = {
        {event_key, e.driver}, {"kind", std::string(to_string(e.kind))}, {"message", e.message}};
    // Several drivers' singular positions: direct or inverse, and the inverse one's driver.
    if (e.singularity != ParallelSingularity::none)
      event["singularity"] = std::string(to_string(e.singularity));
    if (!e.chain.empty()) event["chain"] = e.chain;
    j["events"].push_back(std::move(event));
  }
  return j;
}

}  // namespace

nlohmann::json trajectory_json(const Mechanism& m, const Trajectory& t, std::optional<int> single,
                               const std::string& event_key,
                               const std::function<void(nlohmann::json&, int)>& extra) {
  nlohmann::json j = document_json(m, t, !single, event_key);
  if (single) {
    j.update(sample_json(m, t, *single));
    if (extra) extra(j, *single);
  } else {
    j["samples"] = nlohmann::json::array();
    for (int r = 0; r < t.samples(); ++r) {
      j["samples"].push_back(sample_json(m, t, r));
      if (extra) extra(j["samples"].back(), r);
    }
  }
  return j;
}

void print_trajectory_json(std::FILE* file, const Mechanism& m, const Trajectory& t,
                           std::optional<int> single, const std::string& event_key,
                           const std::function<void(nlohmann::json&, int)>& extra,
                           const nlohmann::json& more) {
  if (single || t.samples() == 0) {
    nlohmann::json j = trajectory_json(m, t, single, event_key, extra);
    if (more.is_object()) j.update(more);
    fmt::print(file, "{}\n", j.dump(2));
    return;
  }
  // The document without its samples, each sample written as it is made, as dump(2) indents it
  // inside the document: the whole document held at once took 70 kB a sample on the A02 chain
  // at N = 10 (3.6 GB for 49,951 samples).
  nlohmann::json j = document_json(m, t, true, event_key);
  if (more.is_object()) j.update(more);
  j["samples"] = nlohmann::json::array();
  const std::string text = j.dump(2);
  const std::string_view empty = "\n  \"samples\": []";  // a top-level key: indented by 2
  const size_t at = text.find(empty);
  std::string out = text.substr(0, at + empty.size() - 1) + "\n";
  for (int r = 0; r < t.samples(); ++r) {
    nlohmann::json sample = sample_json(m, t, r);
    if (extra) extra(sample, r);
    out += "    ";
    for (const char c : sample.dump(2)) {
      out += c;
      if (c == '\n') out += "    ";
    }
    out += r + 1 < t.samples() ? ",\n" : "\n  ]";
    std::fwrite(out.data(), 1, out.size(), file);
    out.clear();
  }
  out = text.substr(at + empty.size()) + "\n";
  std::fwrite(out.data(), 1, out.size(), file);
}

void print_csv(const Trajectory& t, const Columns& extra) {
  const std::vector<std::string> channels = t.channel_names();
  fmt::print("sample,time,driver,status");
  // Channel names hold the definition's names, which may hold commas or quotes.
  for (const std::string& c : channels) fmt::print(",{}", compare::csv_field(c));
  for (const auto& [name, column] : extra) fmt::print(",{}", compare::csv_field(name));
  fmt::print("\n");
  std::vector<Eigen::VectorXd> columns;
  std::vector<Quantity> quantities;
  for (const std::string& c : channels) {
    columns.push_back(*t.channel(c));
    quantities.push_back(Trajectory::quantity_of(c));
  }
  for (int r = 0; r < t.samples(); ++r) {
    const PoseStatus status = t.status[static_cast<size_t>(r)];
    std::string line =
        fmt::format("{},{},{},{}", r, t.time(r), t.driver_field(r), to_string(status));
    for (size_t c = 0; c < columns.size(); ++c) {
      line += ',';
      if (value_exists(status, quantities[c])) line += compare::csv_number(columns[c](r));
    }
    for (const auto& [name, column] : extra) {  // of a solved sample only (the energy)
      line += ',';
      if (usable(status)) line += compare::csv_number(column(r));
    }
    fmt::print("{}\n", line);
  }
}

std::vector<std::string> table_channels(const Mechanism& m, const Trajectory& t,
                                        const std::string& choice) {
  const std::vector<std::string> all = t.channel_names();
  const auto kind_of = [](const std::string& name) { return name.substr(0, name.find('.')); };
  std::vector<std::string> kinds;
  for (const std::string& name : all)
    if (std::find(kinds.begin(), kinds.end(), kind_of(name)) == kinds.end())
      kinds.push_back(kind_of(name));
  std::vector<std::string> words;
  if (choice.empty())
    words = {"angle", "omega", "alpha", "s", "sdot", "sddot", "jerk", "angular_jerk"};
  else
    for (size_t at = 0; at <= choice.size();) {
      const size_t comma = std::min(choice.find(',', at), choice.size());
      if (comma > at) words.push_back(choice.substr(at, comma - at));
      at = comma + 1;
    }
  std::vector<std::string> channels;
  for (const std::string& word : words) {
    const size_t before = channels.size();
    for (const std::string& name : all)
      if ((name == word || kind_of(name) == word) &&
          !(choice.empty() && compare::prescribed(m, name)))
        channels.push_back(name);
    if (channels.size() == before && !choice.empty())
      throw std::invalid_argument(fmt::format(
          "--columns: '{}' is neither a channel of this mechanism (such as {}) nor a kind of "
          "channel ({})",
          word, all.empty() ? "" : all[all.size() / 2], fmt::join(kinds, ", ")));
  }
  return channels;
}

// Notes-style tables at one sample, in the file's units.
void print_table_rows(const Mechanism& m, const Trajectory& t, bool by_time, int digits,
                      const std::vector<std::string>& channels, const std::string& note,
                      const Columns& extra) {
  const std::string axis_unit_name = by_time ? "s" : driver_unit_of(m).name;
  // An angle past one turn is shown within its turn, the whole turns in a column of their own.
  bool turns = false;
  for (int r = 0; r < t.samples() && !by_time; ++r)
    turns = turns || compare::driver_turns(m, t.swept(r)).turns != 0;
  std::string header = fmt::format("{:>10}{} {:>8}", by_time ? "t" : "driver",
                                   turns ? fmt::format(" {:>5}", "turns") : "", "status");
  std::string units = fmt::format("{:>10}{} {:>8}", "[" + axis_unit_name + "]",
                                  turns ? fmt::format(" {:>5}", "") : "", "");
  std::vector<Eigen::VectorXd> columns;
  std::vector<compare::DisplayUnit> shown;
  for (const std::string& name : channels) {
    columns.push_back(*t.channel(name));
    shown.push_back(compare::display_unit(m, name));
    const int width = std::max<int>(12, static_cast<int>(name.size()));
    header += fmt::format(" {:>{}}", name, width);
    units += fmt::format(" {:>{}}", "[" + shown.back().name + "]", width);
  }
  for (const auto& [name, column] : extra) {
    header += fmt::format(" {:>12}", name);
    units += fmt::format(" {:>12}", "");
  }
  fmt::print("{}  ({})\n{}\n{}\n", m.name, note, header, units);
  for (int r = 0; r < t.samples(); ++r) {
    const PoseStatus status = t.status[static_cast<size_t>(r)];
    const compare::DriverTurns d =
        by_time ? compare::DriverTurns{} : compare::driver_turns(m, t.swept(r));
    std::string line = fmt::format("{:>10.4f}{} {:>8}", by_time ? t.time(r) : d.within,
                                   !turns         ? ""
                                   : d.turns == 0 ? fmt::format(" {:>5}", 0)
                                                  : fmt::format(" {:>+5d}", d.turns),
                                   to_string(status));
    for (size_t c = 0; c < channels.size(); ++c) {
      const int width = std::max<int>(12, static_cast<int>(channels[c].size()));
      line += value_exists(status, Trajectory::quantity_of(channels[c]))
                  ? fmt::format(" {:>{}.{}f}", columns[c](r) / shown[c].scale, width, digits)
                  : fmt::format(" {:>{}}", "", width);
    }
    for (const auto& [name, column] : extra)
      line += usable(status) && std::isfinite(column(r)) ? fmt::format(" {:>12.3e}", column(r))
                                                         : fmt::format(" {:>12}", "");
    fmt::print("{}\n", line);
  }
}

void print_table_at(const Mechanism& m, const Trajectory& t, int row) {
  const double L = m.units.length, A = m.units.angle;
  const std::string& ln = m.units.length_name;
  const std::string& an = m.units.angle_name;
  const PoseStatus status = t.status[static_cast<size_t>(row)];
  // A value that does not exist is a blank of the column's width.
  const auto pos = [&](double v, int width, int digits) {
    return has_position(status) ? fmt::format(" {:>{}.{}f}", v, width, digits)
                                : fmt::format(" {:>{}}", "", width);
  };
  const auto rate = [&](double v, int width, int digits) {
    return usable(status) ? fmt::format(" {:>{}.{}f}", v, width, digits)
                          : fmt::format(" {:>{}}", "", width);
  };
  if (m.axis().timed()) {
    std::string drivers;
    for (size_t d = 0; d < t.driver_names.size(); ++d) {
      const Driver& driver = m.drivers[d];
      drivers += fmt::format(
          "  {} = {:.4f} {}", t.driver_names[d],
          t.driver_values(row, static_cast<Eigen::Index>(d)) / (driver.angular() ? A : L),
          driver.angular() ? an : ln);
    }
    fmt::print("{}  t = {:.6g} s{}  status: {}\n", m.name, t.time(row), drivers, to_string(status));
  } else {
    fmt::print("{}  driver = {}  t = {:.6g} s  status: {}\n", m.name,
               compare::driver_text(m, t.swept(row), 4), t.time(row), to_string(status));
  }
  fmt::print("\n{:<14} {:>12} {:>14} {:>16}\n", "link", fmt::format("angle [{}]", an),
             "omega [rad/s]", "alpha [rad/s^2]");
  for (size_t l = 0; l < t.link_names.size(); ++l) {
    const auto c = static_cast<Eigen::Index>(l);
    fmt::print("{:<14}{}{}{}\n", t.link_names[l], pos(t.angle(row, c) / A, 12, 4),
               rate(t.omega(row, c), 14, 4), rate(t.alpha(row, c), 16, 3));
  }
  fmt::print("\n{:<8} {:>10} {:>10} {:>11} {:>11} {:>11} {:>12} {:>12} {:>12}\n", "point",
             fmt::format("x [{}]", ln), fmt::format("y [{}]", ln), "vx", "vy", "|v|", "ax", "ay",
             "|a|");
  for (size_t p = 0; p < t.point_names.size(); ++p) {
    const auto c = static_cast<Eigen::Index>(p);
    const double vx = t.vx(row, c) / L, vy = t.vy(row, c) / L;
    const double ax = t.ax(row, c) / L, ay = t.ay(row, c) / L;
    fmt::print("{:<8}{}{}{}{}{}{}{}{}\n", t.point_names[p], pos(t.x(row, c) / L, 10, 4),
               pos(t.y(row, c) / L, 10, 4), rate(vx, 11, 3), rate(vy, 11, 3),
               rate(std::hypot(vx, vy), 11, 3), rate(ax, 12, 2), rate(ay, 12, 2),
               rate(std::hypot(ax, ay), 12, 2));
  }
  fmt::print("(velocities in {0}/s, accelerations in {0}/s^2)\n", ln);
  if (!t.slider_names.empty()) {
    fmt::print("\n{:<20} {:>12} {:>14} {:>16}\n", "slider", fmt::format("s [{}]", ln),
               fmt::format("sdot [{}/s]", ln), fmt::format("sddot [{}/s^2]", ln));
    for (size_t s = 0; s < t.slider_names.size(); ++s) {
      const auto c = static_cast<Eigen::Index>(s);
      fmt::print("{:<20}{}{}{}\n", t.slider_names[s], pos(t.s(row, c) / L, 12, 4),
                 rate(t.sdot(row, c) / L, 14, 3), rate(t.sddot(row, c) / L, 16, 2));
    }
  }
  if (!t.has_forces) return;
  // The sweep's force channels (print_table_rows: the file's units, 4 decimals), one a line.
  fmt::print("\n{:<24} {:>14}  {}\n", "force channel", "value", "unit");
  for (const std::string& name : t.channel_names()) {
    const Quantity q = Trajectory::quantity_of(name);
    if (q != Quantity::force && q != Quantity::torque) continue;
    const compare::DisplayUnit shown = compare::display_unit(m, name);
    fmt::print("{:<24}{}  {}\n", name, rate(*t.sample(name, row) / shown.scale, 14, 4), shown.name);
  }
}

}  // namespace crosslink::app
