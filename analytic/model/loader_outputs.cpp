#include "analytic/model/loader_reader.h"

namespace crosslink::loading {

namespace {

// "Q", "Q.field": the [[derived]] quantities and their fields, for a message.
std::string derived_names(const Mechanism& m) {
  std::string out;
  for (const DerivedSpec& d : m.derived) {
    const std::vector<std::string> fields = derived_fields(d.kind);
    out += fmt::format("{}{} (fields {})", out.empty() ? ": " : "; ", d.name, join(fields));
  }
  return out;
}

// SI factor for a [[reference]] value, from its channel's kind (see docs/mechanism-format.md).
std::optional<double> reference_factor(const Mechanism& m, std::string_view quantity) {
  const std::string_view kind = quantity.substr(0, quantity.find('.'));
  // The kinds a reference may name: kinematic, a cam's, and forces and moments.
  static const std::vector<std::string_view> kinematic = {
      "angle", "omega", "alpha", "x", "y", "vx", "vy", "v", "ax", "ay", "a", "s", "sdot", "sddot"};
  static const std::vector<std::string_view> cam = {"phi", "jerk", "angular_jerk"};
  static const std::vector<std::string_view> forces = {
      "fx",         "fy",         "f",      "fn",     "force",
      "shaking_fx", "shaking_fy", "torque", "moment", "shaking_moment"};
  const auto in = [&](const std::vector<std::string_view>& kinds) {
    return std::find(kinds.begin(), kinds.end(), kind) != kinds.end();
  };
  if (!in(kinematic) && !in(cam) && !in(forces)) return std::nullopt;
  return Trajectory::unit_in(m.units, quantity).si;
}

// The names a reference channel may end in: the mechanism's outputs.
std::vector<std::string> reference_objects(const Mechanism& m) {
  std::vector<std::string> objects;
  for (const Link& l : m.links)
    if (!l.ground) objects.push_back(l.name);
  for (const auto& p : m.named_points()) objects.push_back(p.name);
  for (const Joint& j : m.joints)
    if (std::find(objects.begin(), objects.end(), j.name) == objects.end())
      objects.push_back(j.name);
  objects.push_back("driver");
  // Without a ground link (an error said already) there is no ground's name.
  if (const int ground = m.ground(); ground >= 0)
    objects.push_back(m.links[static_cast<size_t>(ground)].name);
  return objects;
}

bool names_object(const std::vector<std::string>& objects, std::string_view quantity) {
  const size_t dot = quantity.find('.');
  if (dot == std::string_view::npos) return false;
  return std::find(objects.begin(), objects.end(), quantity.substr(dot + 1)) != objects.end();
}

// The unit of the last digit of a number as written: "57.3" 0.1, "-12.00" 0.01, "240" 1,
// "1.5e3" 100; 0 when it is not a plain decimal literal.
double last_digit(std::string_view literal) {
  const size_t exponent = literal.find_first_of("eE");
  const std::string_view mantissa = literal.substr(0, exponent);
  if (mantissa.empty() || mantissa.find_first_not_of("+-0123456789._") != std::string_view::npos)
    return 0.0;
  const size_t point = mantissa.find('.');
  int decimals = 0;
  if (point != std::string_view::npos)
    for (const char c : mantissa.substr(point + 1)) decimals += c >= '0' && c <= '9';
  int power = 0;
  if (exponent != std::string_view::npos) {
    const std::string e(literal.substr(exponent + 1));
    char* end = nullptr;
    const long p = std::strtol(e.c_str(), &end, 10);
    if (end == e.c_str() || *end != '\0' || std::abs(p) > 300) return 0.0;
    power = static_cast<int>(p);
  }
  return std::pow(10.0, power - decimals);
}

std::vector<std::string> channels_of(const Reader& r, const Mechanism& m);

// The channel that is the driver's own coordinate (up to a constant), or "": over the driver's
// values it only moves one way, so it has no reversal, no stroke between reversals, no dead point.
std::string driven_channel(const Mechanism& m) {
  const Driver& d = m.swept();
  const int g = m.ground();
  if (d.type == DriverType::slider && d.joint >= 0)
    return "s." + m.joints[static_cast<size_t>(d.joint)].name;
  if (d.type == DriverType::link_angle && d.link >= 0)
    return "angle." + m.links[static_cast<size_t>(d.link)].name;
  if (d.type == DriverType::joint_angle && d.joint >= 0) {
    // Measured in the ground's frame (or the ground's direction in the link's): a link's angle.
    const Joint& j = m.joints[static_cast<size_t>(d.joint)];
    if (j.link_a == g && j.link_b >= 0)
      return "angle." + m.links[static_cast<size_t>(j.link_b)].name;
    if (j.link_b == g && j.link_a >= 0)
      return "angle." + m.links[static_cast<size_t>(j.link_a)].name;
  }
  return "";
}

}  // namespace

// [[derived]]: a quantity read off the sweep (analytic/derived/derived.h), named for [[reference]]
// and [expect.derived].
void read_derived(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "derived", limits::kReferences);
  if (!array) return;
  if (refused_in_time(r, m, *array,
                      "[[derived]] quantities are read over one driver's sweep; this definition "
                      "has {}"))
    return;
  const std::vector<std::string> objects = reference_objects(m);
  // The channels a sweep has (none when an earlier error leaves no linkage to lay them out).
  const std::vector<std::string> channels = channels_of(r, m);
  using K = DerivedSpec::Kind;
  const std::vector<K> kinds = {K::extremes,   K::stroke,       K::time_ratio,   K::dead_points,
                                K::toggles,    K::transmission, K::straightness, K::circularity,
                                K::jump_speed, K::least_radius};
  std::vector<std::string> kind_names;
  for (const K k : kinds) kind_names.emplace_back(to_string(k));
  const Driver& d = m.swept();
  for (const toml::node& entry : *array) {
    const toml::table& t = *entry.as_table();
    r.known_keys(t, "[[derived]]", {"name", "quantity", "channel", "point", "cam", "range"});
    DerivedSpec spec;
    spec.where = r.at(t);
    spec.name = r.string(t, "name", "[[derived]]", true).value_or("");
    const std::string quantity = r.string(t, "quantity", "[[derived]]", true).value_or("");
    bool ok = !spec.name.empty() && !quantity.empty();
    if (!spec.name.empty()) {
      if (spec.name.find_first_of(". ") != std::string::npos ||
          reference_factor(m, spec.name + ".") || spec.name == "mu") {
        r.error(r.at(t.get("name")),
                fmt::format("[[derived]] name '{}' must be a word without '.' or spaces, not a "
                            "channel kind (it is written \"{}\" or \"{}.<field>\" in "
                            "[[reference]] and [expect.derived])",
                            spec.name, spec.name, spec.name));
        ok = false;
      }
      for (const DerivedSpec& other : m.derived)
        if (other.name == spec.name) {
          r.error(r.at(t.get("name")),
                  fmt::format("[[derived]] name '{}' is already used at line {}", spec.name,
                              other.where.line));
          ok = false;
        }
    }
    if (!quantity.empty()) {
      const auto k = std::find(kind_names.begin(), kind_names.end(), quantity);
      if (k == kind_names.end()) {
        r.error(r.at(t.get("quantity")),
                fmt::format("[[derived]]: unknown quantity '{}' (valid: {})", quantity,
                            join(kind_names)));
        ok = false;
      } else {
        spec.kind = kinds[static_cast<size_t>(k - kind_names.begin())];
      }
    }
    if (!ok) continue;
    const bool reads_channel = spec.kind == K::extremes || spec.kind == K::stroke ||
                               spec.kind == K::time_ratio || spec.kind == K::dead_points;
    const bool reads_point = spec.kind == K::straightness || spec.kind == K::circularity;
    const bool reads_cam = spec.kind == K::jump_speed || spec.kind == K::least_radius;
    const std::string valid_keys = reads_point     ? "point"
                                   : reads_channel ? "channel"
                                   : reads_cam     ? "cam"
                                                   : "range";
    for (const char* key : {"channel", "point", "cam"})
      if (const toml::node* n = t.get(key); n && valid_keys != key) {
        r.error(r.at(n), fmt::format("[[derived]] quantity '{}' takes no '{}'", quantity, key));
        ok = false;
      }
    if (reads_channel) {
      spec.channel = r.string(t, "channel", "[[derived]]", true).value_or("");
      const Quantity q = Trajectory::quantity_of(spec.channel);
      if (spec.channel.empty()) {
        ok = false;
      } else if (!reference_factor(m, spec.channel) || !names_object(objects, spec.channel) ||
                 q == Quantity::force || q == Quantity::torque) {
        r.error(r.at(t.get("channel")),
                fmt::format("[[derived]]: '{}' is not a kinematic channel of this linkage "
                            "(kind.name, kind one of angle, omega, alpha, x, y, vx, vy, v, ax, "
                            "ay, a, s, sdot, sddot, phi (a cam's pressure angle), jerk or "
                            "angular_jerk (a cam's follower's); names: {})",
                            spec.channel, join(objects)));
        ok = false;
      } else if (!channels.empty() &&
                 std::find(channels.begin(), channels.end(), spec.channel) == channels.end()) {
        // A kind its object does not have ("angle.B" of a point B) has no values to read.
        const std::string object = spec.channel.substr(spec.channel.find('.') + 1);
        std::vector<std::string> its;
        for (const std::string& c : channels)
          if (c.substr(c.find('.') + 1) == object &&
              Trajectory::quantity_of(c) != Quantity::force &&
              Trajectory::quantity_of(c) != Quantity::torque)
            its.push_back(c);
        r.error(r.at(t.get("channel")),
                fmt::format("[[derived]]: '{}' is no channel of this linkage ({})", spec.channel,
                            its.empty() ? fmt::format("'{}' has no kinematic channel", object)
                                        : fmt::format("those of '{}': {}", object, join(its))));
        ok = false;
      } else if (spec.kind != K::extremes && spec.channel == driven_channel(m)) {
        r.error(
            r.at(t.get("channel")),
            fmt::format("[[derived]] '{}': '{}' is the driver's own coordinate, which moves "
                        "one way over the sweep and never turns back, so it has no {} (read "
                        "the 'extremes' of it, or the {} of a channel that reverses)",
                        quantity, spec.channel,
                        spec.kind == K::dead_points ? "dead points" : "stroke between reversals",
                        quantity));
        ok = false;
      } else if (q != Quantity::position && q != Quantity::angle &&
                 d.law.kind != MotionLaw::Kind::constant_speed) {
        r.error(r.at(t.get("channel")),
                fmt::format("[[derived]]: '{}' is a rate: its extremes over the driver need a "
                            "driver at constant speed (the law here is '{}')",
                            spec.channel, to_string(d.law.kind)));
        ok = false;
      }
    }
    if (reads_point) {
      spec.point = r.string(t, "point", "[[derived]]", true).value_or("");
      const auto points = m.named_points();
      if (!spec.point.empty() &&
          std::none_of(points.begin(), points.end(),
                       [&](const Mechanism::NamedPoint& p) { return p.name == spec.point; })) {
        std::vector<std::string> names;
        for (const auto& p : points) names.push_back(p.name);
        r.error(r.at(t.get("point")),
                fmt::format("[[derived]]: no point '{}' (points: {})", spec.point, join(names)));
      }
      if (spec.point.empty()) ok = false;
    }
    if (reads_cam) {
      spec.cam = r.string(t, "cam", "[[derived]]", true).value_or("");
      const bool jump = spec.kind == K::jump_speed;  // of a force-closed cam, over the cycle
      std::vector<std::string> cams;
      for (const Joint& j : m.joints)
        if (j.type == JointType::cam && !(jump && j.form_closed)) cams.push_back(j.name);
      const int j = m.find_joint(spec.cam);
      if (spec.cam.empty()) {
        ok = false;
      } else if (j < 0 || m.joints[static_cast<size_t>(j)].type != JointType::cam) {
        r.error(
            r.at(t.get("cam")),
            fmt::format("[[derived]] '{}': '{}' is no cam joint ({}cams: {})", quantity, spec.cam,
                        jump ? "force-closed " : "", cams.empty() ? "none" : join(cams)));
        ok = false;
      } else if (jump && m.joints[static_cast<size_t>(j)].form_closed) {
        r.error(r.at(t.get("cam")),
                fmt::format("[[derived]] 'jump_speed': cam '{}' is form-closed (a groove holds "
                            "its follower both ways), so it never jumps",
                            spec.cam));
        ok = false;
      }
      if (const toml::node* range = t.get("range"); range && jump) {
        r.error(r.at(*range), "[[derived]] 'jump_speed' is the whole cycle's: it takes no 'range'");
        ok = false;
      }
    }
    if (spec.kind == K::transmission) {
      if (const auto fb = four_bar(m)) {
        spec.channel = "mu." + fb->c;
      } else {
        r.error(r.at(t.get("quantity")),
                "[[derived]] 'transmission': the transmission angle is defined here for a "
                "four-bar (between its coupler and rocker at C); this linkage is not one");
        ok = false;
      }
    }
    if (const toml::node* range = t.get("range")) {
      const Scale scale = driver_scale(m, m.swept());
      if (const auto v = r.numbers(*range, "[[derived]] 'range' ([lower, upper] driver values)",
                                   {scale, scale})) {
        const double unit = driver_unit_of(d, m.units).scale;
        const double turn = 2.0 * std::numbers::pi;
        // A sweep over its own [driver] range holds no other driver values (a whole turn's
        // or more is read modulo a turn).
        const bool outside =
            d.range && !(d.angular() && d.range->second - d.range->first >= turn) &&
            ((*v)[0] < d.range->first - 1e-12 * unit || (*v)[1] > d.range->second + 1e-12 * unit);
        if (!((*v)[0] < (*v)[1]))
          r.error(r.at(*range), "[[derived]] 'range' must be [lower, upper] with lower < upper");
        else if (outside)
          r.error(r.at(*range),
                  fmt::format("[[derived]] 'range' [{:g}, {:g}] is outside the sweep, the "
                              "[driver] range [{:g}, {:g}]",
                              (*v)[0] / unit, (*v)[1] / unit, d.range->first / unit,
                              d.range->second / unit));
        else
          spec.range = std::make_pair((*v)[0], (*v)[1]);
      }
    }
    if (ok) m.derived.push_back(spec);
  }
}

// The design summary: what a designer reads about the output, as [[derived]] quantities the file
// need not declare (docs/mechanism-format.md, "Design summary"). The output is `[summary]
// output` (a moving link or a slider joint), else the last slider on the ground, else the last
// moving link; the driven coordinate is never the output. Its stroke (a rocker's swing), time
// ratio and dead points; the toggles; a four-bar's transmission angle; and the path of each
// coupler point (a named point on a link with no ground joint that no joint uses): its extent
// and straightness. None for several drivers, a dynamics case or a driver at rest; one the file
// declares already (the same kind of the same channel or point, or the same name) is not added.
void add_design_summary(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::table* t = r.table(root, "summary", "a mechanism", false);
  std::string output;
  if (t) {
    r.known_keys(*t, "[summary]", {"output"});
    output = r.string(*t, "output", "[summary]", false).value_or("");
  }
  // A definition with errors so far may be incomplete (no ground): each was reported already.
  if (!r.diagnostics().empty() || m.ground() < 0) return;
  if (m.axis().timed() || m.dynamics || m.swept().at_rest()) return;
  const int g = m.ground();
  const std::string driven = driven_channel(m);
  std::vector<std::string> outputs;  // the candidates' channels, in order
  for (size_t l = 0; l < m.links.size(); ++l)
    if (static_cast<int>(l) != g) outputs.push_back("angle." + m.links[l].name);
  for (const Joint& j : m.joints)
    if (j.type == JointType::prismatic && (j.link_a == g || j.link_b == g))
      outputs.push_back("s." + j.name);
  std::erase(outputs, driven);
  std::string channel;
  if (!output.empty()) {
    for (const std::string& c : outputs)
      if (c.substr(c.find('.') + 1) == output) channel = c;
    if (channel.empty()) {
      std::vector<std::string> names;
      for (const std::string& c : outputs) names.push_back(c.substr(c.find('.') + 1));
      r.error(r.at(t->get("output")),
              fmt::format("[summary] 'output': '{}' is no moving link or slider on the ground "
                          "but the driven one (valid: {})",
                          output, join(names)));
      return;
    }
  } else if (!outputs.empty()) {
    // outputs lists the links first, then the sliders: the last slider, else the last link
    const auto slider = std::find_if(outputs.rbegin(), outputs.rend(),
                                     [](const std::string& c) { return c.starts_with("s."); });
    channel = slider != outputs.rend() ? *slider : outputs.back();
  }
  using K = DerivedSpec::Kind;
  const auto add = [&](std::string name, K kind, std::string on, std::string point,
                       std::string cam = "") {
    for (const DerivedSpec& d : m.derived)
      if (d.name == name ||
          (d.kind == kind && d.channel == on && d.point == point && d.cam == cam && !d.range))
        return;
    DerivedSpec spec;
    spec.name = std::move(name);
    spec.kind = kind;
    spec.channel = std::move(on);
    spec.point = std::move(point);
    spec.cam = std::move(cam);
    spec.summary = true;
    spec.where = t ? r.at(*t) : r.file();
    m.derived.push_back(std::move(spec));
  };
  if (!channel.empty()) {
    add("output_stroke", K::stroke, channel, "");
    add("output_time_ratio", K::time_ratio, channel, "");
    add("output_dead_points", K::dead_points, channel, "");
  }
  add("toggles", K::toggles, "", "");
  if (const auto fb = four_bar(m)) add("transmission", K::transmission, "mu." + fb->c, "");
  // Each cam's pressure angle; a flat face's is the same throughout (its normal is the face's).
  for (const CamReading& cam : cam_readings(m))
    if (cam.rows.kind != ConstraintRows::Kind::cam_face)
      add("pressure_angle_" + cam.joint, K::extremes, "phi." + cam.joint, "");
  // Each cam's follower's jerk, a rate: over the driver it is its motion in time at constant
  // speed (a step of it, where a law meets a dwell, is located at its edge).
  for (const CamReading& cam : cam_readings(m))
    if (m.swept().law.kind == MotionLaw::Kind::constant_speed)
      add("jerk_" + cam.joint, K::extremes, cam.jerk_channel(), "");
  // Each cam's least radius of curvature where its follower touches it.
  for (const Joint& j : m.joints)
    if (j.type == JointType::cam) add("least_radius_" + j.name, K::least_radius, "", "", j.name);
  // The jump speed of each force-closed cam at the driver's constant speed.
  if (m.swept().law.kind == MotionLaw::Kind::constant_speed)
    for (const Joint& j : m.joints)
      if (j.type == JointType::cam && !j.form_closed)
        add("jump_speed_" + j.name, K::jump_speed, "", "", j.name);
  // The links a joint holds to the ground (the ground among them): no coupler's.
  std::vector<bool> grounded(m.links.size(), false);
  grounded[static_cast<size_t>(g)] = true;
  for (const Joint& j : m.joints)
    if (j.link_a == g || j.link_b == g)
      for (const int l : {j.link_a, j.link_b})
        if (l >= 0) grounded[static_cast<size_t>(l)] = true;
  for (const Mechanism::NamedPoint& p : m.named_points()) {
    const auto joins = [&](const Joint& j) {
      return (j.link_a == p.link && j.point_a == p.point) ||
             (j.link_b == p.link && j.point_b == p.point);
    };
    if (grounded[static_cast<size_t>(p.link)] ||
        std::any_of(m.joints.begin(), m.joints.end(), joins))
      continue;
    add("path_" + p.name, K::straightness, "", p.name);
  }
}

namespace {

// Every channel a method writes for the mechanism, its forces' included; none while the definition
// has errors (the mechanism may be incomplete: each was reported already).
std::vector<std::string> channels_of(const Reader& r, const Mechanism& m) {
  if (!r.diagnostics().empty() || m.ground() < 0) return {};
  Trajectory shape;
  shape.resize(m, 0, true);
  return shape.channel_names();
}

}  // namespace

void read_references(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::array* array = r.tables(root, "reference", limits::kReferences);
  if (!array) return;
  if (refused_in_time(r, m, *array,
                      "[[reference]] 'at' is a driver value; this definition has {} (its "
                      "sweep runs in time)"))
    return;
  const std::vector<std::string> objects = reference_objects(m);
  const std::vector<std::string> channels = channels_of(r, m);
  for (const toml::node& entry : *array) {
    const toml::table& t = *entry.as_table();
    r.known_keys(t, "[[reference]]",
                 {"quantity", "at", "value", "precision", "source", "tolerance"});
    Reference ref;
    ref.where = r.at(t);
    ref.quantity = r.string(t, "quantity", "[[reference]]", true).value_or("");
    ref.source = r.string(t, "source", "[[reference]]", true).value_or("");
    const DerivedSpec* spec = nullptr;
    const std::optional<DerivedUnit> derived = derived_unit_of(m, ref.quantity, &spec);
    ref.derived = derived.has_value();
    if (ref.derived && t.get("at"))
      r.error(r.at(t.get("at")),
              fmt::format("[[reference]]: '{}' is a [[derived]] quantity of the whole sweep: it "
                          "takes no 'at'",
                          ref.quantity));
    const std::optional<double> at =
        ref.derived ? std::optional<double>(0.0)
                    : r.number(t, "at", "[[reference]]", true, driver_scale(m, m.swept()));
    const std::optional<double> factor = ref.derived
                                             ? std::optional(derived_factor(m, *spec, *derived))
                                             : reference_factor(m, ref.quantity);
    const std::optional<double> value = r.number(
        t, "value", "[[reference]]", true, {factor.value_or(1.0), "", limits::kReferenceValue});
    if (!ref.quantity.empty() && !factor) {
      r.error(r.at(t.get("quantity")),
              fmt::format("[[reference]]: unknown quantity '{}' (expected kind.name with kind "
                          "one of angle, omega, alpha, x, y, vx, vy, v, ax, ay, a, s, sdot, "
                          "sddot, fx, fy, f, fn, moment, torque, force, shaking_fx, shaking_fy, "
                          "shaking_moment, phi (a cam's pressure angle); or a [[derived]] "
                          "name{})",
                          ref.quantity, derived_names(m)));
      continue;
    }
    if (factor && !ref.derived && !names_object(objects, ref.quantity)) {
      r.error(r.at(t.get("quantity")),
              fmt::format("[[reference]]: '{}' names no moving link, point, joint, slider, "
                          "driver or ground (valid names: {})",
                          ref.quantity, join(objects)));
      continue;
    }
    // A kind that the named object does not have ("sdot.A" of a point A) would compare with
    // nothing and pass: the kinds it has are listed.
    if (factor && !ref.derived && !channels.empty() &&
        std::find(channels.begin(), channels.end(), ref.quantity) == channels.end()) {
      const std::string object = ref.quantity.substr(ref.quantity.find('.') + 1);
      std::vector<std::string> its;
      for (const std::string& c : channels)
        if (c.substr(c.find('.') + 1) == object) its.push_back(c);
      r.error(r.at(t.get("quantity")),
              fmt::format("[[reference]]: '{}' is no channel of this mechanism ({})", ref.quantity,
                          its.empty() ? fmt::format("'{}' has none", object)
                                      : fmt::format("those of '{}': {}", object, join(its))));
      continue;
    }
    if (!at || !value || !factor) continue;
    ref.driver_value = *at;
    ref.value = *value;
    // An expression is kept as written, without its quotes.
    const toml::node& printed = *t.get("value");
    ref.printed = printed.is_string() ? *printed.value<std::string>() : r.literal(printed);
    if (const auto precision =
            r.number(t, "precision", "[[reference]] (the unit of the printed value's last digit)",
                     false, {*factor, "", limits::kReferenceValue})) {
      if (*precision <= 0.0)
        r.error(r.at(t.get("precision")), "[[reference]] 'precision' must be positive");
      ref.precision = *precision;
    } else {
      ref.precision = last_digit(ref.printed) * *factor;
    }
    // 'tolerance': a % of the exact value, or "rounding" (within half the last printed digit).
    if (const toml::node* tolerance = t.get("tolerance")) {
      ref.to_rounding = tolerance->value<std::string>() == "rounding";
      if (!ref.to_rounding) {
        ref.tolerance_pct = r.number(
            *tolerance, "[[reference]] 'tolerance' (a % of the exact value, or \"rounding\")",
            {1.0, "", limits::kTolerance});
        if (ref.tolerance_pct && !(*ref.tolerance_pct > 0.0))
          r.error(r.at(tolerance), "[[reference]] 'tolerance' must be positive");
      }
    }
    m.references.push_back(ref);
  }
}

void read_tolerances(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::table* t = r.table(root, "tolerance", "a mechanism", false);
  if (!t) return;
  r.known_keys(*t, "[tolerance]",
               {"position", "angle", "velocity", "acceleration", "force", "torque"});
  auto read = [&](std::string_view key, std::optional<double>& out) {
    if (const auto v =
            r.number(*t, key, "[tolerance] (% of peak)", false, {1.0, "%", limits::kTolerance})) {
      if (*v <= 0.0)
        r.error(r.at(t->get(key)), fmt::format("[tolerance] '{}' must be positive", key));
      else
        out = *v;
    }
  };
  read("position", m.tolerances.position);
  read("angle", m.tolerances.angle);
  read("velocity", m.tolerances.velocity);
  read("acceleration", m.tolerances.acceleration);
  read("force", m.tolerances.force);
  read("torque", m.tolerances.torque);
}

// [expect]: the singular behaviour the definition's author derived in closed form.
void read_expect(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::table* t = r.table(root, "expect", "a mechanism", false);
  if (!t) return;
  r.known_keys(*t, "[expect]",
               {"limits", "toggles", "change_points", "grashof", "derived", "tolerance"});
  Expectations e;
  e.where = r.at(*t);
  if (refused_in_time(r, m, e.where, "[expect] gives one driver's values; this definition has {}"))
    return;
  const Scale value_scale = driver_scale(m, m.swept());
  if (const toml::node* tolerance = t->get("tolerance")) {
    e.tolerance_pct = r.number(*tolerance, "[expect] 'tolerance'", {1.0, "", limits::kTolerance});
    if (e.tolerance_pct && !(*e.tolerance_pct > 0.0))
      r.error(r.at(*tolerance),
              fmt::format("[expect] 'tolerance' must be a positive percentage of the claimed value "
                          "such as 0.1, at most {:g}",
                          limits::kTolerance));
  }
  if (const toml::node* range = t->get("limits")) {
    e.limits_at = r.at(*range);
    if (const auto v =
            r.numbers(*range, "[expect] 'limits' ([lower, upper])", {value_scale, value_scale}))
      e.limits = std::make_pair((*v)[0], (*v)[1]);
  }
  for (const auto& [key, out, at] :
       {std::tuple{"toggles", &e.toggles, &e.toggles_at},
        std::tuple{"change_points", &e.change_points, &e.change_points_at}}) {
    const toml::node* node = t->get(key);
    if (!node) continue;
    *at = r.at(*node);
    const auto* array = node->as_array();
    if (!array) {
      r.error(r.at(*node), fmt::format("[expect] '{}' must be an array of driver values", key));
      continue;
    }
    if (array->size() > limits::kExpectedPositions) {
      r.error(r.at(*node), fmt::format("[expect] '{}' lists {} values: the limit is {}", key,
                                       array->size(), limits::kExpectedPositions));
      continue;
    }
    for (const toml::node& v : *array)
      if (const auto x = r.number(v, fmt::format("[expect] '{}'", key), value_scale))
        out->push_back(*x);
  }
  if (const toml::table* derived = r.table(*t, "derived", "[expect]", false))
    for (const auto& [key, node] : *derived) {
      const std::string quantity(key.str());
      const DerivedSpec* spec = nullptr;
      const std::optional<DerivedUnit> unit = derived_unit_of(m, quantity, &spec);
      if (!unit) {
        r.error(r.at(key.source()),
                fmt::format("[expect.derived]: '{}' is no [[derived]] quantity or field{}",
                            quantity, derived_names(m)));
        continue;
      }
      if (const auto x = r.number(node, fmt::format("[expect.derived] '{}'", quantity),
                                  {derived_factor(m, *spec, *unit), "", limits::kReferenceValue}))
        e.derived.push_back({quantity, *x, r.at(node)});
    }
  e.grashof = r.string(*t, "grashof", "[expect]", false).value_or("");
  if (const toml::node* grashof = t->get("grashof")) e.grashof_at = r.at(*grashof);
  if (!e.grashof.empty() && e.grashof != "Grashof" && e.grashof != "change point" &&
      e.grashof != "non-Grashof")
    r.error(r.at(t->get("grashof")),
            "[expect] 'grashof' must be \"Grashof\", \"change point\" "
            "or \"non-Grashof\"");
  m.expect = e;
}

}  // namespace crosslink::loading
