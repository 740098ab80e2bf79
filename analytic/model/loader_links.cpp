#include "analytic/model/loader_reader.h"

#include <algorithm>

namespace crosslink::loading {

namespace {

// A link's `mass`, `com` and `inertia`: all three or none (then the default model, filled in
// once the mechanism's size is known).
void read_mass(Reader& r, const toml::table& t, const Units& units, Link& link) {
  const std::string what = fmt::format("link '{}'", link.name);
  const toml::node* mass = t.get("mass");
  const toml::node* com = t.get("com");
  const toml::node* inertia = t.get("inertia");
  if (!mass) {
    if (com || inertia)
      r.error(r.at(com ? com : inertia),
              fmt::format("{} gives '{}' but no 'mass': give mass, com and inertia together, or "
                          "none for the default model",
                          what, com ? "com" : "inertia"));
    return;
  }
  if (!com || !inertia) {
    r.error(r.at(*mass),
            fmt::format("{} gives 'mass' but no '{}': give mass, com (a point name or [x, y]) "
                        "and inertia (about the centre of mass; 0 for a point mass) together",
                        what, com ? "inertia" : "com"));
    return;
  }
  const std::optional<double> m = r.number(*mass, fmt::format("'mass' of {}", what),
                                           Scale{units.mass, units.mass_name, limits::kMass});
  const std::optional<double> i =
      r.number(*inertia, fmt::format("'inertia' of {}", what),
               Scale{units.mass * units.length * units.length, "", limits::kInertia});
  if (m && *m < 0.0) r.error(r.at(*mass), fmt::format("{}: 'mass' must not be negative", what));
  if (i && *i < 0.0)
    r.error(r.at(*inertia), fmt::format("{}: 'inertia' must not be negative", what));
  if (m && i && *m == 0.0 && *i > 0.0)
    r.error(r.at(*mass), fmt::format("{}: a link of zero mass cannot have inertia {}", what, *i));
  std::optional<Eigen::Vector2d> centre;
  if (const auto* name = com->as_string()) {
    const int p = link.find_point(name->get());
    if (p < 0)
      r.error(r.at(*com), fmt::format("{}: 'com' names point '{}', which is not on it (its "
                                      "points: {})",
                                      what, name->get(), join(point_names(link))));
    else
      centre = link.points[static_cast<size_t>(p)].local;
  } else if (const auto xy =
                 r.numbers(*com, fmt::format("'com' of {} (a point name or [x, y])", what),
                           {length_scale(units), length_scale(units)})) {
    centre = Eigen::Vector2d((*xy)[0], (*xy)[1]);
  }
  if (!m || !i || !centre || *m < 0.0 || *i < 0.0) return;
  link.mass.mass = *m;
  link.mass.inertia = *i;
  link.mass.com = *centre;
  link.mass.assumed = false;
}

// A polar point: `length` from point `from` of the same link, at `angle` counter-clockwise
// from the link's x axis, or from the direction from -> `toward` when that is given.
struct PolarPoint {
  std::string from;
  std::optional<std::string> toward;  // none: the x axis
  const toml::node* from_node = nullptr;
  const toml::node* toward_node = nullptr;
  double length = 0.0, angle = 0.0;  // SI
};

// Reads `{ from = "P", length = l, angle = a [, toward = "Q"] }`, with `names` the points of
// its link; nullopt after its errors.
std::optional<PolarPoint> read_polar(Reader& r, const toml::table& t, const std::string& what,
                                     const std::string& link, const std::vector<std::string>& names,
                                     const Units& units) {
  r.known_keys(t, what, {"from", "toward", "length", "angle"});
  const std::optional<std::string> from = r.string(t, "from", what, true);
  const std::optional<std::string> toward = r.string(t, "toward", what, false);
  const std::optional<double> length = r.number(t, "length", what, true, length_scale(units));
  const std::optional<double> angle = r.number(t, "angle", what, true, angle_scale(units));
  bool good = from && length && angle && (toward || !t.get("toward"));
  for (const auto& [key, name] : {std::pair{"from", from}, std::pair{"toward", toward}})
    if (name && std::find(names.begin(), names.end(), *name) == names.end()) {
      r.error(r.at(t.get(key)), fmt::format("{}: '{}' names point '{}', which is not on link '{}' "
                                            "(its points: {})",
                                            what, key, *name, link, join(names)));
      good = false;
    }
  if (from && toward && *from == *toward) {
    r.error(r.at(t.get("toward")),
            fmt::format("{}: 'from' and 'toward' are both '{}': the angle is measured from the "
                        "direction from -> toward, which needs two points",
                        what, *toward));
    good = false;
  }
  // A point at distance 0 would have no use for its angle; a negative distance is an angle
  // a half turn off.
  if (length && *length <= 0.0) {
    r.error(r.at(t.get("length")),
            fmt::format("{}: 'length' must be positive (the distance from '{}')", what,
                        from.value_or("from")));
    good = false;
  }
  if (!good) return std::nullopt;
  return PolarPoint{*from, toward, t.get("from"), t.get("toward"), *length, *angle};
}

// A link's points, [x, y] or polar (read_polar) in the link's frame, kept in the table's order.
// A polar point may refer to points listed after it, or polar themselves: each is placed once
// the points it refers to are, and a circle of references is reported once.
void read_points(Reader& r, const toml::table& points, const Units& units, Link& link) {
  std::vector<std::string> names;
  for (auto&& [key, node] : points) names.emplace_back(key.str());
  std::map<std::string, Eigen::Vector2d> placed;
  std::map<std::string, PolarPoint> waiting;
  std::set<std::string> failed;  // reported; what refers to them is not placed, silently
  for (auto&& [key, node] : points) {
    const std::string name(key.str());
    const std::string what = fmt::format("point '{}' of link '{}'", name, link.name);
    std::optional<PolarPoint> polar;
    std::optional<std::vector<double>> xy;
    if (const toml::table* t = node.as_table())
      polar = read_polar(r, *t, what, link.name, names, units);
    else if (node.is_array())
      xy = r.numbers(node, what, {length_scale(units), length_scale(units)});
    else
      r.error(r.at(node), fmt::format("{} must be [x, y] or {{ from = \"P\", length = ..., "
                                      "angle = ... }}",
                                      what));
    if (polar)
      waiting.emplace(name, *polar);
    else if (xy)
      placed.emplace(name, Eigen::Vector2d((*xy)[0], (*xy)[1]));
    else
      failed.insert(name);
  }

  // Where a polar point is, once the points it refers to are placed or have failed; nullopt
  // when one failed (reported) or they are one place.
  auto place = [&](const std::string& name, const PolarPoint& p) -> std::optional<Eigen::Vector2d> {
    if (failed.count(p.from) || (p.toward && failed.count(*p.toward))) return std::nullopt;
    const Eigen::Vector2d& from = placed.at(p.from);
    double zero = 0.0;  // the angle's zero: the x axis, or the direction from -> toward
    if (p.toward) {
      const Eigen::Vector2d d = placed.at(*p.toward) - from;
      if (d.norm() < 1e-12) {
        r.error(r.at(p.toward_node),
                fmt::format("point '{}' of link '{}' is measured from the direction '{}' -> '{}', "
                            "but they are the same place",
                            name, link.name, p.from, *p.toward));
        return std::nullopt;
      }
      zero = std::atan2(d.y(), d.x());
    }
    return from + p.length * Eigen::Vector2d(std::cos(zero + p.angle), std::sin(zero + p.angle));
  };
  // Place what can be placed until nothing more can; what waits then is on a circle or
  // refers to one.
  auto done = [&](const std::string& name) { return placed.count(name) || failed.count(name); };
  for (bool progress = true; progress;) {
    progress = false;
    for (auto it = waiting.begin(); it != waiting.end();) {
      const PolarPoint& p = it->second;
      if (!done(p.from) || (p.toward && !done(*p.toward))) {
        ++it;
        continue;
      }
      if (const std::optional<Eigen::Vector2d> xy = place(it->first, p))
        placed.emplace(it->first, *xy);
      else
        failed.insert(it->first);
      it = waiting.erase(it);
      progress = true;
    }
  }
  std::set<std::string> reported;
  for (const auto& entry : waiting) {
    // Follow the references that wait until one repeats: the circle. via[k] is the key by
    // which path[k] refers to path[k + 1].
    std::vector<std::string> path{entry.first};
    std::vector<const toml::node*> via;
    size_t start = 0;
    for (;;) {
      const PolarPoint& q = waiting.at(path.back());
      const bool by_from = waiting.count(q.from) > 0;
      via.push_back(by_from ? q.from_node : q.toward_node);
      path.push_back(by_from ? q.from : *q.toward);
      start = static_cast<size_t>(std::find(path.begin(), path.end(), path.back()) - path.begin());
      if (start + 1 < path.size()) break;
    }
    if (reported.count(path[start])) continue;
    std::string circle;
    for (size_t k = start; k < path.size(); ++k) circle += (k == start ? "" : " -> ") + path[k];
    reported.insert(path.begin() + static_cast<std::ptrdiff_t>(start), path.end());
    r.error(r.at(via[start]),
            fmt::format("points of link '{}' are measured from one another in a circle: {} "
                        "(give one of them as [x, y]; its points: {})",
                        link.name, circle, join(names)));
  }

  for (auto&& [key, node] : points)
    if (const auto p = placed.find(std::string(key.str())); p != placed.end())
      link.points.push_back({p->first, p->second, r.at(node)});
}

}  // namespace

// Reads one [[link]] entry.
Link read_link(Reader& r, const toml::table& t, const Units& units, int index) {
  Link link;
  const std::string what = fmt::format("link #{}", index + 1);
  r.known_keys(
      t, what,
      {"name", "ground", "points", "lines", "pose", "description", "mass", "com", "inertia"});
  link.where = r.at(t);
  link.name = r.string(t, "name", what, true).value_or(fmt::format("link{}", index + 1));
  if (const toml::node* g = t.get("ground")) {
    if (const auto* b = g->as_boolean())
      link.ground = b->get();
    else
      r.error(r.at(*g), "'ground' must be true or false");
  }

  const toml::table* points = r.table(t, "points", fmt::format("link '{}'", link.name), true);
  if (points && points->size() > limits::kPoints) {
    r.error(r.at(*points), fmt::format("link '{}' has {} points: the limit is {} in all links",
                                       link.name, points->size(), limits::kPoints));
  } else if (points) {
    if (points->empty()) r.error(r.at(*points), fmt::format("link '{}' has no points", link.name));
    read_points(r, *points, units, link);
  }

  const toml::table* lines = r.table(t, "lines", what, false);
  if (lines && lines->size() > limits::kLines) {
    r.error(r.at(*lines), fmt::format("link '{}' has {} lines: the limit is {} in all links",
                                      link.name, lines->size(), limits::kLines));
  } else if (lines) {
    for (auto&& [key, node] : *lines) {
      const std::string line_what = fmt::format("line '{}' of link '{}'", key.str(), link.name);
      const auto* lt = node.as_table();
      if (!lt) {
        r.error(r.at(node), fmt::format("{} must be a table {{ through = \"P\", angle = ... }} or "
                                        "{{ through = \"P\", toward = \"Q\" }}",
                                        line_what));
        continue;
      }
      r.known_keys(*lt, line_what, {"through", "toward", "angle"});
      Line line;
      line.name = std::string(key.str());
      line.where = r.at(node);
      const std::optional<std::string> through = r.string(*lt, "through", line_what, true);
      const int from = through ? link.find_point(*through) : -1;
      if (through && from < 0) {
        std::vector<std::string> names;
        for (const Point& p : link.points) names.push_back(p.name);
        r.error(r.at(lt->get("through")),
                fmt::format("{}: point '{}' is not on link '{}' (its points: {})", line_what,
                            *through, link.name, join(names)));
        continue;
      }
      if (from < 0) continue;
      line.origin = link.points[from].local;
      const std::optional<std::string> toward = r.string(*lt, "toward", line_what, false);
      if ((lt->get("toward") != nullptr) == (lt->get("angle") != nullptr)) {
        r.error(line.where,
                fmt::format("{} needs exactly one of 'toward' (a point) or 'angle'", line_what));
        continue;
      }
      const std::optional<double> angle =
          r.number(*lt, "angle", line_what, false, angle_scale(units));
      if (!toward && !angle) continue;  // reported
      if (toward) {
        const int to = link.find_point(*toward);
        if (to < 0) {
          r.error(r.at(lt->get("toward")),
                  fmt::format("{}: point '{}' is not on link '{}'", line_what, *toward, link.name));
          continue;
        }
        const Eigen::Vector2d d = link.points[to].local - line.origin;
        if (d.norm() < 1e-12) {
          r.error(r.at(lt->get("toward")),
                  fmt::format("{} is degenerate: '{}' and '{}' are the same place", line_what,
                              *through, *toward));
          continue;
        }
        line.direction = d.normalized();
      } else {
        line.direction = Eigen::Vector2d(std::cos(*angle), std::sin(*angle));
      }
      if (link.find_line(line.name) >= 0)
        r.error(line.where, fmt::format("duplicate line name '{}'", line.name));
      link.lines.push_back(line);
    }
  }

  if (const toml::node* pose = t.get("pose")) {
    link.pose_where = r.at(*pose);
    if (const auto p = r.numbers(*pose, fmt::format("pose of link '{}' ([x, y, angle])", link.name),
                                 {length_scale(units), length_scale(units), angle_scale(units)}))
      link.pose = Eigen::Vector3d((*p)[0], (*p)[1], (*p)[2]);
  }
  read_mass(r, t, units, link);
  return link;
}

std::vector<std::string> link_names(const Mechanism& m) {
  std::vector<std::string> names;
  for (const Link& l : m.links) names.push_back(l.name);
  return names;
}

// Resolves a link name from key `key` of `t`; reports an unknown name with the valid ones.
int resolve_link(Reader& r, const Mechanism& m, const toml::table& t, std::string_view key,
                 std::string_view what) {
  const std::optional<std::string> name = r.string(t, key, what, true);
  if (!name) return -1;
  const int index = m.find_link(*name);
  if (index < 0)
    r.error(r.at(t.get(key)), fmt::format("{}: unknown link '{}' (valid links: {})", what, *name,
                                          join(link_names(m))));
  return index;
}

int resolve_point(Reader& r, const Mechanism& m, int link, const toml::node* node,
                  const std::string& name, std::string_view what) {
  const int index = m.links[link].find_point(name);
  if (index < 0)
    r.error(r.at(node), fmt::format("{}: point '{}' is not on link '{}' (its points: {})", what,
                                    name, m.links[link].name, join(point_names(m.links[link]))));
  return index;
}

int resolve_line(Reader& r, const Mechanism& m, int link, const toml::node* node,
                 const std::string& name, std::string_view what) {
  const int index = m.links[link].find_line(name);
  if (index < 0) {
    std::vector<std::string> names;
    for (const Line& l : m.links[link].lines) names.push_back(l.name);
    r.error(r.at(node), fmt::format("{}: line '{}' is not on link '{}' (its lines: {})", what, name,
                                    m.links[link].name, join(names)));
  }
  return index;
}

Eigen::Vector3d drawn_pose(const Link& link) {
  return link.pose.value_or(Eigen::Vector3d::Zero());
}

Eigen::Vector2d drawn_point(const Link& link, const Eigen::Vector2d& local) {
  const Eigen::Vector3d p = drawn_pose(link);
  return p.head<2>() + Eigen::Rotation2Dd(p(2)) * local;
}

namespace {

// A joint's `friction = { ... }` (docs/mechanism-format.md, "Joint friction"): a Coulomb
// coefficient with the pin's radius (revolute) or the slider's bearing length (prismatic,
// optional), and a load-independent torque or force.
void read_friction(Reader& r, const Mechanism& m, const toml::table& t, Joint& joint,
                   const std::string& what) {
  const toml::node* node = t.get("friction");
  if (!node) return;
  if (joint.type == JointType::pin_in_slot || joint.type == JointType::pin_in_arc ||
      joint.type == JointType::pin_in_spline) {
    r.error(r.at(*node),
            fmt::format("{}: friction on a pin in a slot is not modelled (its contact rolls and "
                        "slides at once): model the pin as a block on a prismatic joint",
                        what));
    return;
  }
  if (!joint.is_slide() && joint.type != JointType::revolute) return;
  const auto* table = node->as_table();
  if (!table) {
    r.error(r.at(*node), fmt::format("'friction' in {} must be a table, e.g. friction = {{ "
                                     "coefficient = 0.1, {} }}",
                                     what, joint.is_slide() ? "length = 20" : "radius = 5"));
    return;
  }
  const bool revolute = joint.type == JointType::revolute;
  const std::string fwhat = fmt::format("the friction of {}", what);
  const char* constant_key = revolute ? "torque" : "force";
  r.known_keys(*table, fwhat,
               {"coefficient", "static_coefficient", revolute ? "radius" : "length",
                std::string(constant_key)});
  JointFriction f;
  f.where = r.at(*node);
  const Scale length = length_scale(m.units);
  const std::optional<double> mu =
      r.number(*table, "coefficient", fwhat, false, {1.0, "", limits::kFrictionCoefficient});
  const std::optional<double> size =
      r.number(*table, revolute ? "radius" : "length", fwhat, false, length);
  const Scale constant_scale = revolute ? Scale{m.units.force * m.units.length, "", limits::kTorque}
                                        : Scale{m.units.force, m.units.force_name, limits::kForce};
  const std::optional<double> constant =
      r.number(*table, constant_key, fwhat, false, constant_scale);
  auto positive = [&](const char* key, std::optional<double> value, bool zero_ok) {
    if (value && (*value < 0.0 || (!zero_ok && *value == 0.0)))
      r.error(r.at(table->get(key)), fmt::format("'{}' in {} must be {}", key, fwhat,
                                                 zero_ok ? "zero or positive" : "positive"));
  };
  positive("coefficient", mu, true);
  positive(revolute ? "radius" : "length", size, false);
  positive(constant_key, constant, true);
  if (mu && !size && revolute)
    r.error(
        r.at(table->get("coefficient")),
        fmt::format("{} needs 'radius': the pin's radius, whose friction circle mu r carries the "
                    "coefficient's moment",
                    fwhat));
  if (!mu && size)
    r.error(
        r.at(table->get(revolute ? "radius" : "length")),
        fmt::format("{} gives '{}' without 'coefficient'", fwhat, revolute ? "radius" : "length"));
  if (!mu && !constant)
    r.error(r.at(*node), fmt::format("{} needs 'coefficient' or '{}'", fwhat, constant_key));
  const std::optional<double> mu_static =
      r.number(*table, "static_coefficient", fwhat, false, {1.0, "", limits::kFrictionCoefficient});
  if (mu_static && !(*mu_static >= mu.value_or(0.0)))
    r.error(r.at(table->get("static_coefficient")),
            fmt::format("'static_coefficient' in {} must be at least 'coefficient' ({:g}): what "
                        "holds a joint at rest is no less than what slows it",
                        fwhat, mu.value_or(0.0)));
  if (mu_static && !mu)
    r.error(r.at(table->get("static_coefficient")),
            fmt::format("{} gives 'static_coefficient' without 'coefficient'", fwhat));
  f.coefficient = mu.value_or(0.0);
  f.static_coefficient = mu_static.value_or(f.coefficient);
  (revolute ? f.radius : f.length) = size.value_or(0.0);
  f.constant = constant.value_or(0.0);
  joint.friction = f;
}

// A pin in a curved slot: `arc = { centre = "C", radius = 40 }` in place of `line`, the slot's
// centreline a circle about point C of the guide (docs/mechanism-format.md, "Curved slots").
void read_arc(Reader& r, const Mechanism& m, const toml::node& node, const std::string& what,
              Joint& joint) {
  joint.type = JointType::pin_in_arc;
  const auto* arc = node.as_table();
  if (!arc) {
    r.error(r.at(node), fmt::format("'arc' in {} must be a table, e.g. arc = {{ centre = \"C\", "
                                    "radius = 40 }}: the slot's centre on the guide and its radius",
                                    what));
    return;
  }
  const std::string awhat = fmt::format("the arc of {}", what);
  r.known_keys(*arc, awhat, {"centre", "radius"});
  const std::optional<std::string> centre = r.string(*arc, "centre", awhat, true);
  const std::optional<double> radius = r.number(*arc, "radius", awhat, true, length_scale(m.units));
  if (radius && !(*radius > 0.0))
    r.error(r.at(arc->get("radius")), fmt::format("'radius' in {} must be positive", awhat));
  joint.radius_a = radius.value_or(0.0);
  if (joint.link_a >= 0 && centre)
    joint.centre_a = resolve_point(r, m, joint.link_a, arc->get("centre"), *centre, awhat);
}

// A pin in a spline slot: `spline = { through = ["S1", "S2", "S3"] }` in place of `line`, the
// slot's centreline a natural cubic spline through points of the guide in order, a graph over
// its chord from the first to the last (docs/mechanism-format.md, "Curved slots").
void read_spline(Reader& r, const Mechanism& m, const toml::node& node, const std::string& what,
                 Joint& joint) {
  joint.type = JointType::pin_in_spline;
  const auto* spline = node.as_table();
  const std::string swhat = fmt::format("the spline of {}", what);
  const toml::node* through = spline ? spline->get("through") : nullptr;
  const auto* names = through ? through->as_array() : nullptr;
  if (!spline || !names) {
    r.error(r.at(through ? *through : node),
            fmt::format("'spline' in {} must be a table of the guide's points it runs through, "
                        "in order, e.g. spline = {{ through = [\"S1\", \"S2\", \"S3\"] }}",
                        what));
    return;
  }
  r.known_keys(*spline, swhat, {"through"});
  if (joint.link_a < 0) return;
  std::vector<Eigen::Vector2d> at;
  for (const toml::node& n : *names) {
    const std::optional<std::string> name = n.value<std::string>();
    const int point = name ? resolve_point(r, m, joint.link_a, &n, *name, swhat) : -1;
    if (!name) r.error(r.at(n), fmt::format("'through' in {} holds point names", swhat));
    if (point < 0) return;
    joint.through.push_back(point);
    at.push_back(m.links[joint.link_a].points[point].local);
  }
  if (at.size() < 3) {
    r.error(r.at(*through), fmt::format("'through' in {} needs at least three points (two make "
                                        "a straight slot: a line)",
                                        swhat));
    return;
  }
  const Eigen::Vector2d chord = at.back() - at.front();
  if (!(chord.norm() > 0.0)) {
    r.error(r.at(*through), fmt::format("{} ends where it starts: a slot has two ends (a closed "
                                        "groove is a cam joint's)",
                                        swhat));
    return;
  }
  // The centreline as y(x) over the chord: each point further along it than the one before.
  const Eigen::Vector2d along = chord.normalized();
  std::vector<double> x, y;
  for (size_t i = 0; i < at.size(); ++i) {
    x.push_back(along.dot(at[i] - at.front()));
    y.push_back(cross(along, at[i] - at.front()));
    if (i > 0 && !(x[i] > x[i - 1])) {
      r.error(r.at((*names)[i]),
              fmt::format("{}: point '{}' is not further along the chord (from '{}' to '{}') "
                          "than the point before it: the slot is held as a curve over its chord, "
                          "so it may bend, but not turn back (split it, or use an arc)",
                          swhat, m.links[joint.link_a].points[joint.through[i]].name,
                          m.links[joint.link_a].points[joint.through.front()].name,
                          m.links[joint.link_a].points[joint.through.back()].name));
      return;
    }
  }
  joint.chord_start = at.front();
  joint.chord_axis = along;
  joint.slot = std::make_shared<const NaturalSpline>(std::move(x), std::move(y));
}

}  // namespace

Joint read_joint(Reader& r, const Mechanism& m, const toml::table& t, int index) {
  Joint joint;
  joint.where = r.at(t);
  const std::string what = fmt::format("joint #{}", index + 1);
  const std::string type = r.string(t, "type", what, true).value_or("");
  if (type == "revolute") {
    r.known_keys(t, what + " (revolute)", {"type", "name", "links", "point", "friction"});
    joint.type = JointType::revolute;
    const toml::node* links = t.get("links");
    const auto* array = links ? links->as_array() : nullptr;
    if (!array || array->size() != 2 || !(*array)[0].is_string() || !(*array)[1].is_string()) {
      r.error(links ? r.at(*links) : joint.where,
              fmt::format("{} needs 'links' = [\"first\", \"second\"] (two link names)", what));
      return joint;
    }
    const std::optional<std::string> point = r.string(t, "point", what, true);
    joint.name = r.string(t, "name", what, false).value_or(point.value_or(""));
    int* ends[2] = {&joint.link_a, &joint.link_b};
    int* pts[2] = {&joint.point_a, &joint.point_b};
    for (int e = 0; e < 2; ++e) {
      const std::string name = *(*array)[static_cast<size_t>(e)].value<std::string>();
      *ends[e] = m.find_link(name);
      if (*ends[e] < 0) {
        r.error(r.at((*array)[static_cast<size_t>(e)]),
                fmt::format("{}: unknown link '{}' (valid links: {})", what, name,
                            join(link_names(m))));
        continue;
      }
      if (point) *pts[e] = resolve_point(r, m, *ends[e], t.get("point"), *point, what);
    }
    if (joint.link_a >= 0 && joint.link_a == joint.link_b)
      r.error(r.at(*links),
              fmt::format("{} joins link '{}' to itself", what, m.links[joint.link_a].name));
    read_friction(r, m, t, joint, fmt::format("{} ('{}')", what, joint.name));
    return joint;
  }
  if (type == "prismatic" || type == "pin_in_slot") {
    joint.type = type == "prismatic" ? JointType::prismatic : JointType::pin_in_slot;
    const std::string twhat = fmt::format("{} ({})", what, type);
    std::vector<std::string> keys = {"type",   "name",  "guide",   "line",
                                     "slider", "point", "friction"};
    if (joint.type == JointType::prismatic) keys.push_back("angle");
    if (joint.type == JointType::pin_in_slot) {
      keys.push_back("arc");
      keys.push_back("spline");
    }
    r.known_keys(t, twhat, keys);
    joint.link_a = resolve_link(r, m, t, "guide", twhat);
    joint.link_b = resolve_link(r, m, t, "slider", twhat);
    const toml::node* arc = t.get("arc");
    const toml::node* spline = t.get("spline");
    if ((arc != nullptr) + (spline != nullptr) + (t.get("line") != nullptr) > 1) {
      r.error(r.at(arc ? *arc : *spline),
              fmt::format("{} gives more than one of 'line', 'arc' and 'spline': a slot is "
                          "straight (line), a circular arc (arc) or a curve through points "
                          "(spline)",
                          twhat));
      return joint;
    }
    if (arc) read_arc(r, m, *arc, twhat, joint);
    if (spline) read_spline(r, m, *spline, twhat, joint);
    const bool curved = arc || spline;
    const std::optional<std::string> line =
        curved ? std::nullopt : r.string(t, "line", twhat, true);
    const std::optional<std::string> point = r.string(t, "point", twhat, true);
    if (joint.link_a >= 0 && line)
      joint.line = resolve_line(r, m, joint.link_a, t.get("line"), *line, twhat);
    if (joint.link_b >= 0 && point)
      joint.point_b = resolve_point(r, m, joint.link_b, t.get("point"), *point, twhat);
    if (joint.link_a >= 0 && joint.link_a == joint.link_b)
      r.error(joint.where, fmt::format("{}: guide and slider are the same link", twhat));
    const std::string default_name =
        (joint.link_b >= 0 ? m.links[joint.link_b].name : std::string("?")) + "/" +
        (arc      ? std::string("arc")
         : spline ? std::string("spline")
                  : line.value_or("?"));
    joint.name = r.string(t, "name", twhat, false).value_or(default_name);
    if (joint.type == JointType::prismatic) {
      if (const auto angle = r.number(t, "angle", twhat, false, angle_scale(m.units))) {
        joint.relative_angle = *angle;
      } else if (joint.link_a >= 0 && joint.link_b >= 0) {
        // The slider keeps the relative angle it is drawn at (0 where a pose is not given).
        joint.relative_angle =
            drawn_pose(m.links[joint.link_b])(2) - drawn_pose(m.links[joint.link_a])(2);
      }
    }
    read_friction(r, m, t, joint, fmt::format("{} ('{}')", twhat, joint.name));
    return joint;
  }
  if (type == "cam") return read_cam(r, m, t, what);
  if (type == "gear" || type == "rack_pinion") {  // completed by read_gearing
    joint.type = type == "gear" ? JointType::gear : JointType::rack_pinion;
    return joint;
  }
  r.error(t.get("type") ? r.at(t.get("type")) : joint.where,
          fmt::format("{}: unknown joint type '{}' (valid types: revolute, prismatic, "
                      "pin_in_slot, cam, gear, rack_pinion)",
                      what, type));
  return joint;
}

namespace {

// The point of the carrier that gear `gear` turns about: the one point name the two links share
// (one name is one place, joined by revolutes: check_structure). -1, reported, when there is none
// or more than one.
int gear_centre(Reader& r, const Mechanism& m, int gear, int carrier, const toml::node* at,
                std::string_view what) {
  std::vector<int> shared;
  for (const Point& p : m.links[gear].points)
    if (const int c = m.links[carrier].find_point(p.name); c >= 0) shared.push_back(c);
  if (shared.size() == 1) return shared.front();
  std::vector<std::string> names;
  for (int c : shared) names.push_back(m.links[carrier].points[c].name);
  r.error(r.at(at),
          shared.empty()
              ? fmt::format("{}: '{}' turns about no point of its carrier '{}' (a gear turns "
                            "about a point of the link both centres are fixed on: give the two "
                            "links that point's name, joined by a revolute)",
                            what, m.links[gear].name, m.links[carrier].name)
              : fmt::format("{}: '{}' shares {} points with its carrier '{}' ({}): a gear turns "
                            "about one",
                            what, m.links[gear].name, shared.size(), m.links[carrier].name,
                            join(names)));
  return -1;
}

}  // namespace

// A gear pair's or a rack and pinion's links, centres, pitch radii, ratio and phase
// (docs/mechanism-format.md, "Gear pairs"), once every joint is read: a rack names its slide.
void read_gearing(Reader& r, Mechanism& m, const toml::table& t, int index) {
  Joint& joint = m.joints[static_cast<size_t>(index)];
  const bool gear = joint.type == JointType::gear;
  const std::string what = fmt::format("joint #{} ({})", index + 1, to_string(joint.type));
  const Scale length = length_scale(m.units), angle = angle_scale(m.units);
  joint.pressure_angle = 20.0 * std::numbers::pi / 180.0;  // ISO 53's standard involute
  if (const auto p = r.number(t, "pressure_angle", what, false, angle)) {
    if (!(*p >= 0.0 && *p < 0.5 * std::numbers::pi))
      r.error(r.at(t.get("pressure_angle")),
              fmt::format("{}: 'pressure_angle' must be from 0 to less than 90 degrees", what));
    joint.pressure_angle = *p;
  }
  const std::optional<double> phase = r.number(t, "phase", what, false, gear ? angle : length);
  if (const toml::node* friction = t.get("friction"))
    r.error(r.at(*friction),
            fmt::format("{}: its teeth have no friction in crosslink (a mesh's sliding changes "
                        "side at the pitch point); give friction at the gears' revolute joints",
                        what));
  if (gear) {
    r.known_keys(t, what,
                 {"type", "name", "gears", "carrier", "teeth", "radii", "mesh", "phase",
                  "pressure_angle", "friction"});
    const toml::node* gears = t.get("gears");
    const auto* array = gears ? gears->as_array() : nullptr;
    if (!array || array->size() != 2 || !(*array)[0].is_string() || !(*array)[1].is_string()) {
      r.error(gears ? r.at(*gears) : joint.where,
              fmt::format("{} needs 'gears' = [\"first\", \"second\"] (the two gear links)", what));
      return;
    }
    int* ends[2] = {&joint.link_a, &joint.link_b};
    for (size_t e = 0; e < 2; ++e) {
      const std::string name = *(*array)[e].value<std::string>();
      *ends[e] = m.find_link(name);
      if (*ends[e] < 0)
        r.error(r.at((*array)[e]), fmt::format("{}: unknown link '{}' (valid links: {})", what,
                                               name, join(link_names(m))));
    }
    joint.carrier = t.get("carrier") ? resolve_link(r, m, t, "carrier", what) : m.ground();
    if (joint.link_a < 0 || joint.link_b < 0 || joint.carrier < 0) return;
    joint.name = r.string(t, "name", what, false)
                     .value_or(m.links[joint.link_a].name + "/" + m.links[joint.link_b].name);
    if (joint.link_a == joint.link_b || joint.link_a == joint.carrier ||
        joint.link_b == joint.carrier) {
      r.error(r.at(*gears), fmt::format("{}: the two gears and the carrier ('{}') must be three "
                                        "different links",
                                        what, m.links[joint.carrier].name));
      return;
    }
    const std::optional<std::string> mesh = r.string(t, "mesh", what, false);
    if (mesh && *mesh != "external" && *mesh != "internal")
      r.error(r.at(t.get("mesh")),
              fmt::format("{}: 'mesh' is \"external\" or \"internal\", not '{}'", what, *mesh));
    const bool internal = mesh.value_or("external") == "internal";
    joint.centre_a = gear_centre(r, m, joint.link_a, joint.carrier, gears, what);
    joint.centre_b = gear_centre(r, m, joint.link_b, joint.carrier, gears, what);
    if (joint.centre_a < 0 || joint.centre_b < 0) return;
    const Link& carrier = m.links[joint.carrier];
    const double d =
        (carrier.points[joint.centre_b].local - carrier.points[joint.centre_a].local).norm();
    const toml::node* teeth = t.get("teeth");
    const toml::node* radii = t.get("radii");
    if ((teeth != nullptr) == (radii != nullptr)) {
      r.error(teeth ? r.at(*teeth) : joint.where,
              fmt::format("{} needs exactly one of 'teeth' = [z1, z2] or 'radii' = [r1, r2] (the "
                          "pitch radii)",
                          what));
      return;
    }
    if (teeth) {
      const auto z = r.numbers(*teeth, fmt::format("'teeth' in {}", what),
                               {Scale{1.0, "", 1e6}, Scale{1.0, "", 1e6}});
      if (!z) return;
      if (!((*z)[0] >= 1 && (*z)[1] >= 1 && std::floor((*z)[0]) == (*z)[0] &&
            std::floor((*z)[1]) == (*z)[1])) {
        r.error(r.at(*teeth), fmt::format("{}: 'teeth' are two whole numbers of at least 1", what));
        return;
      }
      // The pitch circles roll on each other: their radii are in the teeth's ratio and add up
      // to the centre distance (external), or differ by it (internal).
      const double sum = internal ? std::abs((*z)[1] - (*z)[0]) : (*z)[0] + (*z)[1];
      if (sum == 0.0 || d == 0.0) {
        r.error(r.at(*teeth),
                fmt::format("{}: an internal pair needs a ring with more teeth than its pinion "
                            "and centres apart",
                            what));
        return;
      }
      joint.radius_a = d * (*z)[0] / sum;
      joint.radius_b = d * (*z)[1] / sum;
    } else {
      const auto rr = r.numbers(*radii, fmt::format("'radii' in {}", what), {length, length});
      if (!rr) return;
      joint.radius_a = (*rr)[0];
      joint.radius_b = (*rr)[1];
      const double need =
          internal ? std::abs(joint.radius_b - joint.radius_a) : joint.radius_a + joint.radius_b;
      if (!(joint.radius_a > 0.0 && joint.radius_b > 0.0) ||
          std::abs(need - d) > 1e-9 * std::max(d, need)) {
        r.error(
            r.at(*radii),
            fmt::format("{}: pitch circles of radii {:g} and {:g} {} mesh {} {:g} {} apart; "
                        "the centres '{}' and '{}' on '{}' are {:g} {} apart",
                        what, joint.radius_a / m.units.length, joint.radius_b / m.units.length,
                        m.units.length_name, internal ? "internally" : "externally",
                        need / m.units.length, m.units.length_name,
                        carrier.points[joint.centre_a].name, carrier.points[joint.centre_b].name,
                        carrier.name, d / m.units.length, m.units.length_name));
        return;
      }
    }
    joint.ratio = (internal ? -1.0 : 1.0) * joint.radius_b / joint.radius_a;
    // The gears mesh as drawn (0 where no pose is given), as a prismatic keeps its drawn angle.
    auto turned = [&](int l) { return drawn_pose(m.links[l])(2) - drawn_pose(carrier)(2); };
    joint.phase = phase.value_or(turned(joint.link_a) + joint.ratio * turned(joint.link_b));
    return;
  }

  r.known_keys(t, what,
               {"type", "name", "pinion", "rack", "radius", "phase", "pressure_angle", "friction"});
  joint.link_a = resolve_link(r, m, t, "pinion", what);
  const std::optional<std::string> rack = r.string(t, "rack", what, true);
  const std::optional<double> radius = r.number(t, "radius", what, true, length);
  if (joint.link_a < 0 || !rack || !radius) return;
  joint.slide = m.find_joint(*rack);
  if (joint.slide < 0 || m.joints[joint.slide].type != JointType::prismatic) {
    std::vector<std::string> names;
    for (const Joint& j : m.joints)
      if (j.type == JointType::prismatic) names.push_back(j.name);
    r.error(r.at(t.get("rack")),
            fmt::format("{}: 'rack' names the prismatic joint that carries the rack; '{}' is {} "
                        "(prismatic joints: {})",
                        what, *rack, joint.slide < 0 ? "no joint" : "not prismatic", join(names)));
    joint.slide = -1;
    return;
  }
  const Joint& slide = m.joints[joint.slide];
  // A rack whose own joint is refused (its line or point unknown) is not read further: its
  // fault is already said at the prismatic.
  if (slide.link_a < 0 || slide.link_b < 0 || slide.line < 0 || slide.point_b < 0) {
    joint.slide = -1;
    return;
  }
  joint.carrier = slide.link_a;
  joint.link_b = slide.link_b;
  joint.name = r.string(t, "name", what, false)
                   .value_or(m.links[joint.link_a].name + "/" + m.links[joint.link_b].name);
  if (joint.link_a == m.ground()) {
    r.error(r.at(t.get("pinion")),
            fmt::format("{}: the pinion turns on the rack's guide; the ground cannot be it", what));
    return;
  }
  if (joint.link_a == joint.carrier || joint.link_a == joint.link_b) {
    r.error(
        r.at(t.get("pinion")),
        fmt::format("{}: the pinion must be another link than the rack's guide and slider", what));
    return;
  }
  if (!(*radius > 0.0)) {
    r.error(r.at(t.get("radius")),
            fmt::format("{}: 'radius' (the pitch radius) must be positive", what));
    return;
  }
  joint.radius_a = *radius;
  joint.centre_a = gear_centre(r, m, joint.link_a, joint.carrier, t.get("pinion"), what);
  if (joint.centre_a < 0) return;
  const Link& guide = m.links[joint.carrier];
  const Line& line = guide.lines[static_cast<size_t>(slide.line)];
  const double side = perp(line.direction).dot(guide.points[joint.centre_a].local - line.origin);
  if (std::abs(side) <= 1e-9 * m.size()) {
    r.error(r.at(t.get("pinion")),
            fmt::format("{}: the pinion's centre '{}' is on the rack's line '{}': the pinion "
                        "rolls on one side of it",
                        what, guide.points[joint.centre_a].name, line.name));
    return;
  }
  // Rolling without slip: the rack moves with the pinion's point on the side of the line,
  // s' = r (theta_p - theta_guide)' when the centre is on the line's left.
  joint.ratio = side > 0.0 ? *radius : -*radius;
  const Link& rack_link = m.links[joint.link_b];
  const Eigen::Vector2d origin = drawn_point(guide, line.origin);
  const Eigen::Vector2d u = Eigen::Rotation2Dd(drawn_pose(guide)(2)) * line.direction;
  const double s = u.dot(drawn_point(rack_link, rack_link.points[slide.point_b].local) - origin);
  joint.phase = phase.value_or(
      s - joint.ratio * (drawn_pose(m.links[joint.link_a])(2) - drawn_pose(guide)(2)));
}

void check_friction(Reader& r, const Mechanism& m) {
  const std::vector<int> friction = m.friction_joints();
  if (friction.empty()) return;
  const double unit = m.units.length;
  const std::string& name = m.units.length_name;
  const double size = m.size();
  // A pin's journal must fit: no larger than the mechanism, and two journals on one link either
  // side by side or one inside the other (an eccentric's sheave holds its shaft), never crossing.
  for (size_t a = 0; a < m.joints.size(); ++a) {
    const Joint& ja = m.joints[a];
    if (!ja.friction || ja.type != JointType::revolute) continue;
    const double ra = ja.friction->radius;
    if (ra > size)
      r.error(ja.friction->where,
              fmt::format("the pin of joint '{}' (radius {:g} {}) is larger than the mechanism "
                          "({:g} {} across)",
                          ja.name, ra / unit, name, size / unit, name));
    for (size_t b = a + 1; b < m.joints.size(); ++b) {
      const Joint& jb = m.joints[b];
      if (!jb.friction || jb.type != JointType::revolute) continue;
      const double rb = jb.friction->radius;
      for (const auto& [la, pa] : {std::pair{ja.link_a, ja.point_a}, {ja.link_b, ja.point_b}})
        for (const auto& [lb, pb] : {std::pair{jb.link_a, jb.point_a}, {jb.link_b, jb.point_b}}) {
          if (la != lb || pa < 0 || pb < 0) continue;
          const Link& link = m.links[static_cast<size_t>(la)];
          const double d = (link.points[static_cast<size_t>(pa)].local -
                            link.points[static_cast<size_t>(pb)].local)
                               .norm();
          // (Round-off aside: an eccentric's sheave holding its shaft touches it inside.)
          const double slack = 1e-9 * size;
          if (d > std::abs(ra - rb) + slack && d < ra + rb - slack)
            r.error(
                jb.friction->where,
                fmt::format("the pins of joints '{}' (radius {:g} {}) and '{}' (radius {:g} "
                            "{}) cross on link '{}': their centres are {:g} {} apart, less "
                            "than the {:g} {} side by side and more than the {:g} {} of one "
                            "inside the other",
                            ja.name, ra / unit, name, jb.name, rb / unit, name, link.name, d / unit,
                            name, (ra + rb) / unit, name, std::abs(ra - rb) / unit, name));
        }
    }
  }
}

}  // namespace crosslink::loading
