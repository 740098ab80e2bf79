#include "analytic/model/loader_reader.h"

namespace crosslink::loading {

namespace {

// A point given as `point = "P"` (a named point of the link) or `at = [x, y]` (local, file
// units) in table `t`. Returns false (after an error) when neither or both are there.
bool read_place(Reader& r, const Mechanism& m, const toml::table& t, int link,
                std::string_view what, Eigen::Vector2d& local, std::string& name) {
  const toml::node* point = t.get("point");
  const toml::node* at = t.get("at");
  if ((point != nullptr) == (at != nullptr)) {
    r.error(r.at(point ? point
                 : at  ? at
                       : &t),
            fmt::format("{} needs exactly one of 'point' (a point of link '{}') or 'at' "
                        "([x, y] in its frame)",
                        what, m.links[static_cast<size_t>(link)].name));
    return false;
  }
  if (point) {
    const std::optional<std::string> n = r.string(t, "point", what, true);
    if (!n) return false;
    const int p = resolve_point(r, m, link, point, *n, what);
    if (p < 0) return false;
    local = m.links[static_cast<size_t>(link)].points[static_cast<size_t>(p)].local;
    name = *n;
    return true;
  }
  const auto xy = r.numbers(*at, fmt::format("'at' of {} ([x, y])", what),
                            {length_scale(m.units), length_scale(m.units)});
  if (!xy) return false;
  local = Eigen::Vector2d((*xy)[0], (*xy)[1]);
  return true;
}

}  // namespace

// [[load]]: a force at a point of a link or a torque on a link, constant or a table over the
// driver coordinate.
void read_loads(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "load");
  if (!array) return;
  const double torque_unit = m.units.force * m.units.length;
  for (size_t index = 0; index < array->size(); ++index) {
    const toml::table& t = *(*array)[index].as_table();
    const std::string what = fmt::format("load #{}", index + 1);
    r.known_keys(t, "[[load]]",
                 {"name", "link", "point", "at", "force", "torque", "force_table", "torque_table"});
    Load load;
    load.where = r.at(t);
    load.name = r.string(t, "name", what, false).value_or(fmt::format("load{}", index + 1));
    load.link = resolve_link(r, m, t, "link", what);
    const char* kinds[] = {"force", "torque", "force_table", "torque_table"};
    std::vector<std::string> given;
    for (const char* k : kinds)
      if (t.get(k)) given.emplace_back(k);
    if (given.size() != 1) {
      r.error(load.where, fmt::format("{} needs exactly one of 'force' = [fx, fy], 'torque', "
                                      "'force_table' = [[driver, fx, fy], ...] or 'torque_table' "
                                      "= [[driver, torque], ...]{}",
                                      what, given.empty() ? "" : " (it has " + join(given) + ")"));
      continue;
    }
    if (load.link < 0) continue;
    if (m.links[static_cast<size_t>(load.link)].ground)
      r.error(r.at(t.get("link")), fmt::format("{}: a load on the ground does no work and moves "
                                               "nothing; put it on a moving link",
                                               what));
    const std::string kind = given.front();
    load.kind = kind.starts_with("force") ? Load::Kind::force : Load::Kind::torque;
    load.table = kind.ends_with("_table");
    if (load.table && refused_in_time(r, m, load.where,
                                      "a load's table is over the driver's value; with {} the "
                                      "sweep runs in time: give a constant force or torque"))
      continue;
    if (load.kind == Load::Kind::force) {
      if (!read_place(r, m, t, load.link, what, load.local, load.point)) continue;
    } else if (t.get("point") || t.get("at")) {
      r.error(r.at(t.get("point") ? t.get("point") : t.get("at")),
              fmt::format("{}: a torque acts on the whole link; remove '{}'", what,
                          t.get("point") ? "point" : "at"));
      continue;
    }
    const Scale unit = load.kind == Load::Kind::force
                           ? Scale{m.units.force, m.units.force_name, limits::kForce}
                           : Scale{torque_unit, "", limits::kTorque};
    const size_t width = load.kind == Load::Kind::force ? 2 : 1;
    const toml::node& value = *t.get(kind);
    load.over_turns = load.table && m.swept().angular();
    if (!load.table) {
      std::optional<std::vector<double>> v;
      if (width == 2)
        v = r.numbers(value, fmt::format("'force' of {} ([fx, fy])", what), {unit, unit});
      else if (const auto torque = r.number(value, fmt::format("'torque' of {}", what), unit))
        v = std::vector<double>{*torque};
      if (!v) continue;
      load.rows.emplace_back(0.0, (*v)[0], width == 2 ? (*v)[1] : 0.0);
      m.loads.push_back(load);
      continue;
    }
    const auto* rows = value.as_array();
    if (!rows || rows->size() < 2) {
      r.error(r.at(value), fmt::format("{}: '{}' must list at least 2 rows", what, kind));
      continue;
    }
    bool good = true;
    for (const toml::node& row : *rows) {
      std::vector<Scale> scales = {driver_scale(m, m.swept()), unit};
      if (width == 2) scales.push_back(unit);
      const auto v = r.numbers(row,
                               fmt::format("a row of '{}' of {} ([driver, {}])", kind, what,
                                           width == 2 ? "fx, fy" : "torque"),
                               scales);
      if (!v) {
        good = false;
        break;
      }
      const double d = (*v)[0];
      if (!load.rows.empty() && d <= load.rows.back()(0)) {
        r.error(r.at(row),
                fmt::format("{}: driver values in '{}' must increase strictly", what, kind));
        good = false;
        break;
      }
      load.rows.emplace_back(d, (*v)[1], width == 2 ? (*v)[2] : 0.0);
    }
    if (good) m.loads.push_back(load);
  }
}

// [[spring]]: a linear spring and damper between points of two links.
void read_springs(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "spring");
  if (!array) return;
  for (size_t index = 0; index < array->size(); ++index) {
    const toml::table& t = *(*array)[index].as_table();
    const std::string what = fmt::format("spring #{}", index + 1);
    r.known_keys(t, "[[spring]]",
                 {"name", "links", "points", "stiffness", "free_length", "damping"});
    Spring spring;
    spring.where = r.at(t);
    std::vector<std::string> names[2];
    for (const auto& [key, out] : {std::pair{"links", &names[0]}, std::pair{"points", &names[1]}}) {
      const toml::node* n = t.get(key);
      const auto* a = n ? n->as_array() : nullptr;
      if (!a || a->size() != 2 || !(*a)[0].is_string() || !(*a)[1].is_string()) {
        r.error(n ? r.at(*n) : spring.where,
                fmt::format("{} needs '{}' = [\"first\", \"second\"]", what, key));
        continue;
      }
      for (const toml::node& e : *a) out->push_back(*e.value<std::string>());
    }
    if (names[0].size() != 2 || names[1].size() != 2) continue;
    int* links[2] = {&spring.link_a, &spring.link_b};
    Eigen::Vector2d* locals[2] = {&spring.local_a, &spring.local_b};
    bool good = true;
    for (int e = 0; e < 2; ++e) {
      *links[e] = m.find_link(names[0][e]);
      if (*links[e] < 0) {
        r.error(r.at(t.get("links")), fmt::format("{}: unknown link '{}' (valid links: {})", what,
                                                  names[0][e], join(link_names(m))));
        good = false;
        continue;
      }
      const int p = resolve_point(r, m, *links[e], t.get("points"), names[1][e], what);
      if (p < 0) {
        good = false;
        continue;
      }
      *locals[e] = m.links[static_cast<size_t>(*links[e])].points[static_cast<size_t>(p)].local;
    }
    if (!good) continue;
    if (spring.link_a == spring.link_b) {
      r.error(r.at(t.get("links")),
              fmt::format("{} joins two points of one link ('{}'): it would never change length",
                          what, names[0][0]));
      continue;
    }
    spring.point_a = names[1][0];
    spring.point_b = names[1][1];
    spring.name = r.string(t, "name", what, false).value_or(spring.point_a + "-" + spring.point_b);
    const double per_length = m.units.force / m.units.length;
    const std::string force_per_length = m.units.force_name + "/" + m.units.length_name;
    const auto stiffness =
        r.number(t, "stiffness", what, false, {per_length, force_per_length, limits::kStiffness});
    const auto free_length = r.number(t, "free_length", what, false, length_scale(m.units));
    const auto damping =
        r.number(t, "damping", what, false,
                 {per_length, m.units.force_name + " s/" + m.units.length_name, limits::kDamping});
    // A value refused above has said so already.
    if ((t.get("stiffness") && !stiffness) || (t.get("free_length") && !free_length) ||
        (t.get("damping") && !damping))
      continue;
    if (!stiffness && !damping) {
      r.error(spring.where, fmt::format("{} needs 'stiffness' (force unit per length unit) "
                                        "and 'free_length', or 'damping', or both",
                                        what));
      continue;
    }
    if (stiffness && !free_length) {
      r.error(r.at(t.get("stiffness")),
              fmt::format("{}: 'stiffness' needs 'free_length' (length unit)", what));
      continue;
    }
    for (const auto& [key, v] :
         {std::pair{"stiffness", stiffness}, std::pair{"free_length", free_length},
          std::pair{"damping", damping}})
      if (v && *v < 0.0) {
        r.error(r.at(t.get(key)), fmt::format("{}: '{}' must not be negative", what, key));
        good = false;
      }
    if (!good) continue;
    spring.stiffness = stiffness.value_or(0.0);
    spring.free_length = free_length.value_or(0.0);
    spring.damping = damping.value_or(0.0);
    m.springs.push_back(spring);
  }
}

}  // namespace crosslink::loading
