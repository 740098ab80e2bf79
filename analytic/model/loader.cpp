#include "analytic/model/loader.h"

#include "analytic/model/loader_reader.h"

namespace crosslink {
namespace loading {

namespace {

// [[branch]]: an assembly mode by name, `points` = three named points, `turn` = "ccw" | "cw"
// (BranchChoice).
void read_branches(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "branch", limits::kJoints);
  if (!array) return;
  const std::vector<Mechanism::NamedPoint> named = m.named_points();
  std::vector<std::string> all;
  for (const auto& p : named) all.push_back(p.name);
  for (const toml::node& entry : *array) {
    const toml::table& t = *entry.as_table();
    r.known_keys(t, "[[branch]]", {"points", "turn"});
    BranchChoice b;
    b.where = r.at(t);
    const toml::node* points = t.get("points");
    const auto* list = points ? points->as_array() : nullptr;
    if (!list || list->size() != 3) {
      r.error(points ? r.at(*points) : b.where,
              "[[branch]] needs 'points': the names of three points, whose triangle's 'turn' "
              "names the assembly");
      continue;
    }
    for (const toml::node& p : *list) {
      const auto* name = p.as_string();
      const auto found = name ? std::find_if(named.begin(), named.end(),
                                             [&](const auto& n) { return n.name == name->get(); })
                              : named.end();
      if (found == named.end()) {
        r.error(r.at(p), fmt::format("[[branch]] 'points': {} is not a named point (points: {})",
                                     name ? "'" + name->get() + "'" : "a value", join(all)));
        continue;
      }
      if (std::find(b.names.begin(), b.names.end(), found->name) != b.names.end())
        r.error(r.at(p), fmt::format("[[branch]] 'points' names '{}' twice", found->name));
      b.names.push_back(found->name);
      b.points.emplace_back(found->link, found->point);
    }
    const std::optional<std::string> turn = r.string(t, "turn", "[[branch]]", true);
    if (turn && *turn != "ccw" && *turn != "cw")
      r.error(r.at(t.get("turn")), "[[branch]] 'turn' must be \"ccw\" or \"cw\"");
    if (b.names.size() != 3 || !turn) continue;
    b.counter_clockwise = *turn == "ccw";
    m.branches.push_back(b);
  }
}

// Structure: one ground, unique names, named points that are one place, a connected chain,
// and a mobility that one driver can drive (reported at `driver`, the [driver] table, if any).
void check_structure(Reader& r, const Mechanism& m, const toml::node* driver) {
  std::vector<int> grounds;
  for (size_t i = 0; i < m.links.size(); ++i)
    if (m.links[i].ground) grounds.push_back(static_cast<int>(i));
  if (grounds.empty())
    r.error(m.links.front().where,
            "no link has ground = true: one link must be the frame (add ground = true to it)");
  if (!grounds.empty() && m.links[grounds[0]].pose_where.line > 0)
    r.error(m.links[grounds[0]].pose_where,
            fmt::format("link '{}' is the ground: its frame is the world's, so it takes no "
                        "'pose' (its points are world coordinates)",
                        m.links[grounds[0]].name));
  for (size_t i = 1; i < grounds.size(); ++i)
    r.error(m.links[grounds[i]].where,
            fmt::format("link '{}' is a second ground (the first is '{}'): exactly one link is "
                        "the frame",
                        m.links[grounds[i]].name, m.links[grounds[0]].name));
  for (size_t i = 0; i < m.joints.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (!m.joints[i].name.empty() && m.joints[i].name == m.joints[j].name)
        r.error(m.joints[i].where,
                fmt::format("duplicate joint name '{}' (first at line {}); give one a 'name'",
                            m.joints[i].name, m.joints[j].where.line));
  if (!r.diagnostics().empty()) return;

  // Links joined through revolute joints; a named point must be one place, so every link that
  // names it must be joined to the others at that point.
  const size_t n = m.links.size();
  std::vector<size_t> parent(n);
  auto find = [&](size_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  std::map<std::string, std::vector<int>> named_on;
  for (size_t l = 0; l < n; ++l)
    for (const Point& p : m.links[l].points) named_on[p.name].push_back(static_cast<int>(l));
  for (const auto& [name, links] : named_on) {
    if (links.size() < 2) continue;
    std::iota(parent.begin(), parent.end(), 0);
    for (const Joint& j : m.joints)
      if (j.type == JointType::revolute && m.links[j.link_a].points[j.point_a].name == name)
        parent[find(static_cast<size_t>(j.link_a))] = find(static_cast<size_t>(j.link_b));
    for (int l : links)
      if (find(static_cast<size_t>(l)) != find(static_cast<size_t>(links[0]))) {
        const Point& p = m.links[l].points[m.links[l].find_point(name)];
        r.error(p.where, fmt::format("point '{}' is named on links '{}' and '{}', which no "
                                     "revolute joint at '{}' connects: one name is one place "
                                     "(rename one of them)",
                                     name, m.links[links[0]].name, m.links[l].name, name));
      }
  }

  // Every link must be connected to the ground.
  std::iota(parent.begin(), parent.end(), 0);
  for (const Joint& j : m.joints)
    parent[find(static_cast<size_t>(j.link_a))] = find(static_cast<size_t>(j.link_b));
  const int g = m.ground();
  bool connected = true;
  for (size_t l = 0; l < n; ++l)
    if (find(l) != find(static_cast<size_t>(g))) {
      connected = false;
      r.error(m.links[l].where,
              fmt::format("link '{}' is not connected to the ground by any chain of joints",
                          m.links[l].name));
    }
  if (!connected) return;  // its mobility count would only repeat the fault

  const Mobility mob = mobility(m);
  const auto* several = driver ? driver->as_array() : nullptr;
  if (several && several->is_array_of_tables() && several->size() > 1) {
    const int count = static_cast<int>(several->size());
    if (mob.mobility == count) return;
    const std::string counted = fmt::format(
        "mobility {} with {} drivers. Grübler–Kutzbach: {} ({} links, {} full "
        "joints, {} half joints)",
        mob.mobility, count, mob.explain(), mob.links, mob.full_joints, mob.half_joints);
    // Too many: at the first driver beyond the mobility; too few: at the first driver.
    if (mob.mobility < count)
      r.error(r.at((*several)[static_cast<size_t>(std::max(mob.mobility, 0))]),
              fmt::format("{}: each driver fixes one freedom, so this driver is one too many "
                          "(drive {} of the coordinates, or free a joint)",
                          counted, std::max(mob.mobility, 0)));
    else
      r.error(r.at((*several)[0]),
              fmt::format("{}: {} freedom{} left undriven (add a [[driver]] for each, or a "
                          "joint)",
                          counted, mob.mobility - count, mob.mobility - count == 1 ? "" : "s"));
    return;
  }
  if (mob.mobility != 1) {
    // Say which side of the count is off: the links' freedoms or the joints' constraints.
    const int off = std::abs(mob.mobility - 1);
    const std::string freedoms = fmt::format("freedom{}", off == 1 ? "" : "s");
    const std::string verdict =
        mob.mobility < 1
            ? fmt::format(
                  "the chain is over-constrained, {} {} too few for the one driver: a "
                  "joint too many (a revolute or prismatic takes 2, a pin_in_slot or gear pair 1), "
                  "a revolute or prismatic where a pin_in_slot belongs, or a link "
                  "missing",
                  off, freedoms)
            : fmt::format(
                  "the chain is under-constrained, {} {} more than the one driver "
                  "fixes: a joint missing (a revolute or prismatic takes 2, a "
                  "pin_in_slot or gear pair 1), a pin_in_slot where a revolute or prismatic "
                  "belongs, or a link too many",
                  off, freedoms);
    r.error(r.at(driver), fmt::format("mobility {} with 1 driver. Grübler–Kutzbach: {} ({} "
                                      "links, {} full joints, {} half joints): the joints take "
                                      "{} of the {} freedoms of the {} moving links. {}",
                                      mob.mobility, mob.explain(), mob.links, mob.full_joints,
                                      mob.half_joints, 2 * mob.full_joints + mob.half_joints,
                                      3 * (mob.links - 1), mob.links - 1, verdict));
  }
}

// Screens the text before toml++ parses it: a key with more dotted parts, or arrays and inline
// tables nested deeper, than limits.h allows is refused at its place, since the parser recurses
// once per level. A light scan: strings and comments are skipped, and every dot outside them
// counts toward the key or value it is in (a float has one), up to the next = , [ ] { } or line.
std::optional<Diagnostic> screen(std::string_view text, const std::string& file) {
  int line = 1, column = 1, depth = 0, dots = 0;
  size_t i = 0;
  auto advance = [&](size_t n) {
    for (size_t end = std::min(text.size(), i + n); i < end; ++i) {
      if (text[i] == '\n') {
        ++line;
        column = 1;
      } else {
        ++column;
      }
    }
  };
  auto starts = [&](std::string_view token) { return text.substr(i, token.size()) == token; };
  // Past the string opening at i (quote ' or "; three of them for a multi-line string).
  auto skip_string = [&] {
    const char quote = text[i];
    const bool multi = starts(std::string(3, quote));
    advance(multi ? 3 : 1);
    while (i < text.size()) {
      if (multi ? starts(std::string(3, quote)) : text[i] == quote) {
        advance(multi ? 3 : 1);
        return;
      }
      if (!multi && text[i] == '\n') return;  // unterminated: the parser says so
      advance(quote == '"' && text[i] == '\\' ? 2 : 1);
    }
  };
  while (i < text.size()) {
    const char c = text[i];
    if (c == '"' || c == '\'') {
      skip_string();
      continue;
    }
    if (c == '#') {
      while (i < text.size() && text[i] != '\n') advance(1);
      continue;
    }
    if (c == '[' || c == '{') {
      dots = 0;
      if (++depth > limits::kNesting)
        return Diagnostic{{file, line, column},
                          fmt::format("arrays and tables nested deeper than {} levels, the limit "
                                      "of a definition",
                                      limits::kNesting)};
    } else if (c == ']' || c == '}') {
      depth = std::max(0, depth - 1);
      dots = 0;
    } else if (c == '=' || c == ',' || c == '\n') {
      dots = 0;
    } else if (c == '.' && ++dots >= limits::kKeyParts) {
      return Diagnostic{{file, line, column},
                        fmt::format("a key of more than {} dotted parts, the limit of a definition",
                                    limits::kKeyParts)};
    }
    advance(1);
  }
  return std::nullopt;
}

// Points and lines over all links within their limits (each link's were checked as read), and
// a mechanism large enough for its size to scale tolerances.
void check_counts(Reader& r, const Mechanism& m) {
  size_t points = 0, lines = 0;
  for (const Link& link : m.links) {
    points += link.points.size();
    lines += link.lines.size();
    if (points > limits::kPoints || lines > limits::kLines) {
      r.error(link.where, fmt::format("{} points and {} lines up to link '{}': the limits are {} "
                                      "points and {} lines in all links",
                                      points, lines, link.name, limits::kPoints, limits::kLines));
      return;
    }
  }
  if (r.diagnostics().empty() && m.size() < limits::kSmallestSize)
    r.error(m.links.front().where,
            fmt::format("the mechanism's size (the largest distance between its drawn points) is "
                        "{:g} m: the limit is {:g} m",
                        m.size(), limits::kSmallestSize));
}

Mechanism read(Reader& r, const toml::table& root, const std::string& file) {
  Mechanism m;
  m.file = file;
  r.set_root(root);
  r.known_keys(root, "the definition",
               {"name", "description", "citation", "units", "link", "joint", "driver", "reference",
                "derived", "tolerance", "expect", "gravity", "load", "spring", "dynamics", "branch",
                "summary"});
  m.name = r.string(root, "name", "a mechanism", true).value_or("");
  m.description = r.string(root, "description", "a mechanism", false).value_or("");
  m.citation = r.string(root, "citation", "a mechanism", false).value_or("");

  if (const toml::table* units = r.table(root, "units", "a mechanism", true)) {
    r.known_keys(*units, "[units]", {"length", "angle", "mass", "force"});
    if (!units->get("length")) r.error(r.at(*units), "[units] needs 'length' (mm, cm or m)");
    if (!units->get("angle")) r.error(r.at(*units), "[units] needs 'angle' (deg or rad)");
    m.units.length =
        unit_factor(r, *units, "[units]", "length", kLengthUnits, "m", &m.units.length_name)
            .value_or(1.0);
    m.units.angle =
        unit_factor(r, *units, "[units]", "angle", kAngleUnits, "rad", &m.units.angle_name)
            .value_or(1.0);
    r.set_angle_unit(m.units.angle);
    m.units.mass = unit_factor(r, *units, "[units]", "mass", kMassUnits, "kg", &m.units.mass_name)
                       .value_or(1.0);
    m.units.force =
        unit_factor(r, *units, "[units]", "force", kForceUnits, "N", &m.units.force_name)
            .value_or(1.0);
  }

  const toml::node* links = root.get("link");
  const auto* link_array = links ? links->as_array() : nullptr;
  if (!link_array || !link_array->is_array_of_tables() || link_array->empty()) {
    r.error(links ? r.at(*links) : r.file(), "a mechanism needs [[link]] tables");
    r.throw_if_any();
  }
  if (link_array->size() > limits::kLinks) {
    r.error(r.at((*link_array)[limits::kLinks]),
            fmt::format("{} [[link]] tables: the limit is {}", link_array->size(), limits::kLinks));
    r.throw_if_any();
  }
  for (size_t i = 0; i < link_array->size(); ++i)
    m.links.push_back(read_link(r, *(*link_array)[i].as_table(), m.units, static_cast<int>(i)));
  check_counts(r, m);
  r.throw_if_any();
  // Names must be unique before joints refer to them.
  for (size_t i = 0; i < m.links.size(); ++i)
    for (size_t j = 0; j < i; ++j)
      if (m.links[i].name == m.links[j].name)
        r.error(m.links[i].where,
                fmt::format("duplicate link name '{}' (first at line {}); link names must be "
                            "unique",
                            m.links[i].name, m.links[j].where.line));
  for (const Link& link : m.links)
    for (size_t i = 0; i < link.points.size(); ++i)
      for (size_t j = 0; j < i; ++j)
        if (link.points[i].name == link.points[j].name)
          r.error(link.points[i].where,
                  fmt::format("duplicate point '{}' on link '{}'", link.points[i].name, link.name));
  r.throw_if_any();
  const double size = m.size();
  for (Link& link : m.links)
    if (link.mass.assumed) link.mass = default_mass_properties(link, size);
  if (const toml::node* g = root.get("gravity"))
    if (const auto v = r.numbers(*g, "'gravity' ([gx, gy] in the length unit per s^2)",
                                 {Scale{m.units.length, "", limits::kGravity},
                                  Scale{m.units.length, "", limits::kGravity}}))
      m.gravity = Eigen::Vector2d((*v)[0], (*v)[1]);

  const toml::node* joints = root.get("joint");
  const auto* joint_array = joints ? joints->as_array() : nullptr;
  if (!joint_array || !joint_array->is_array_of_tables()) {
    r.error(joints ? r.at(*joints) : r.file(), "a mechanism needs [[joint]] tables");
  } else if (joint_array->size() > limits::kJoints) {
    r.error(
        r.at((*joint_array)[limits::kJoints]),
        fmt::format("{} [[joint]] tables: the limit is {}", joint_array->size(), limits::kJoints));
  } else {
    for (size_t i = 0; i < joint_array->size(); ++i)
      m.joints.push_back(read_joint(r, m, *(*joint_array)[i].as_table(), static_cast<int>(i)));
    for (size_t i = 0; i < joint_array->size(); ++i)
      if (m.joints[i].is_gearing())
        read_gearing(r, m, *(*joint_array)[i].as_table(), static_cast<int>(i));
  }
  r.throw_if_any();

  check_structure(r, m, root.get("driver"));
  read_drivers(r, m, root);
  read_dynamics(r, m, root);
  read_loads(r, m, root);
  read_springs(r, m, root);
  read_tolerances(r, m, root);
  read_derived(r, m, root);
  add_design_summary(r, m, root);
  read_references(r, m, root);
  read_expect(r, m, root);
  read_branches(r, m, root);
  check_locked(r, m);
  check_friction(r, m);
  r.throw_if_any();
  return m;
}

}  // namespace
}  // namespace loading

using loading::read;
using loading::Reader;
using loading::screen;

Mechanism parse_definition(std::string_view text, const std::string& file) {
  Reader reader(file, text);
  if (text.size() > static_cast<size_t>(limits::kDefinitionBytes)) {
    reader.error(reader.file(), fmt::format("the file has more than {} bytes, the limit of a "
                                            "definition",
                                            limits::kDefinitionBytes));
    reader.throw_if_any();
  }
  if (std::optional<Diagnostic> fault = screen(text, file)) throw DefinitionError({*fault});
  toml::table root;
  try {
    root = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    reader.error(reader.at(e.source()), fmt::format("TOML syntax: {}", e.description()));
    reader.throw_if_any();
  }
  return read(reader, root, file);
}

Mechanism read_definition(const std::string& path) {
  // "-" is standard input, named <stdin> in diagnostics.
  const bool standard_input = path == "-";
  const std::string name = standard_input ? "<stdin>" : path;
  std::ifstream file;
  if (!standard_input) file.open(path, std::ios::binary);
  std::istream& in = standard_input ? std::cin : file;
  auto refuse = [&](std::string message) {
    Diagnostic problem;
    problem.where.file = name;
    problem.message = std::move(message);
    throw DefinitionError({problem});
  };
  if (!in) refuse("cannot open the file");
  // One byte over the limit is enough to refuse it (and /dev/zero is not read for ever).
  std::string text(static_cast<size_t>(limits::kDefinitionBytes) + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  if (!in && !in.eof()) refuse("cannot read the file");  // a directory, say
  text.resize(static_cast<size_t>(in.gcount()));
  return parse_definition(text, name);
}

}  // namespace crosslink
