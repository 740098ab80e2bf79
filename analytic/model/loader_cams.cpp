// A cam joint (docs/mechanism-format.md, "Cams"): the follower's contact on a profile cut in the
// cam, the profile synthesised from the follower's motion law (analytic/model/cam.h). Every
// problem is said at its key: a law that does not close at its segment, a profile that undercuts
// at `roller_radius`, a cusp at `base_radius`, a follower that cannot reach the base circle at
// the dimension that keeps it off.
#include "analytic/model/cam.h"
#include "analytic/model/loader_reader.h"

namespace crosslink::loading {
namespace {

const std::vector<std::pair<std::string_view, cam::Law>> kLaws = {
    {"dwell", cam::Law::dwell},
    {"uniform", cam::Law::uniform},
    {"simple_harmonic", cam::Law::simple_harmonic},
    {"cycloidal", cam::Law::cycloidal},
    {"polynomial_345", cam::Law::polynomial_345},
    {"polynomial_4567", cam::Law::polynomial_4567},
};

// The number k of a message "segment k: ..." or "point k: ..." (0 if it names none).
size_t numbered(const std::string& message, std::string_view prefix) {
  if (message.rfind(prefix, 0) != 0) return 0;
  return static_cast<size_t>(std::atoi(message.c_str() + prefix.size()));
}

// `[[angle, value], ...]` at `key` through a periodic cubic spline (MotionProgram::table), each
// fault at its point.
std::optional<cam::MotionProgram> read_spline(Reader& r, const toml::node& key,
                                              const toml::array& array, const std::string& what,
                                              const Scale& angle, const Scale& value) {
  const size_t before = r.diagnostics().size();
  std::vector<std::pair<double, double>> points;
  for (size_t k = 0; k < array.size(); ++k) {
    const auto v = r.numbers(array[k], fmt::format("point {} of {}", k + 1, what), {angle, value});
    if (v) points.emplace_back((*v)[0], (*v)[1]);
  }
  if (r.diagnostics().size() != before) return std::nullopt;
  try {
    return cam::MotionProgram::table(points);
  } catch (const std::invalid_argument& e) {
    const size_t k = numbered(e.what(), "point ");
    r.error(r.at(k > 0 ? array[k - 1] : key), fmt::format("{}: {}", what, e.what()));
    return std::nullopt;
  }
}

// `motion = [{ law, span, to }, ...]` from `start`, or `table = [[angle, s], ...]`.
std::optional<cam::MotionProgram> read_motion(Reader& r, const toml::table& p,
                                              const std::string& what, const Scale& displacement,
                                              const Scale& angle) {
  const toml::node* motion = p.get("motion");
  const toml::node* table = p.get("table");
  if ((motion != nullptr) == (table != nullptr)) {
    r.error(motion && table ? r.at(*table) : r.inside(p),
            fmt::format("{} needs one of 'motion' (segments of standard laws) or 'table' (cam "
                        "angle and displacement points)",
                        what));
    return std::nullopt;
  }
  const toml::array* array = (motion ? motion : table)->as_array();
  if (!array || array->empty()) {
    r.error(r.at(motion ? *motion : *table),
            fmt::format("'{}' in {} must be a non-empty array", motion ? "motion" : "table", what));
    return std::nullopt;
  }
  if (table) return read_spline(r, *table, *array, what, angle, displacement);
  const size_t before = r.diagnostics().size();
  std::vector<cam::Segment> segments;
  const double start = r.number(p, "start", what, false, displacement).value_or(0.0);
  double at = start;
  for (size_t k = 0; k < array->size(); ++k) {
    const std::string swhat = fmt::format("segment {} of {}'s motion", k + 1, what);
    const auto* g = (*array)[k].as_table();
    if (!g) {
      r.error(r.at((*array)[k]), fmt::format("{} must be a table, e.g. {{ law = \"cycloidal\", "
                                             "span = 90, to = 20 }}",
                                             swhat));
      continue;
    }
    r.known_keys(*g, swhat, {"law", "span", "to"});
    cam::Segment segment;
    if (const auto law = r.string(*g, "law", swhat, true)) {
      const auto found =
          std::find_if(kLaws.begin(), kLaws.end(), [&](const auto& l) { return l.first == *law; });
      if (found == kLaws.end()) {
        std::vector<std::string> names;
        for (const auto& l : kLaws) names.emplace_back(l.first);
        r.error(r.at(g->get("law")),
                fmt::format("{}: unknown law '{}' (valid laws: {})", swhat, *law, join(names)));
      } else {
        segment.law = found->second;
      }
    }
    segment.span = r.number(*g, "span", swhat, true, angle).value_or(0.0);
    const std::optional<double> to =
        r.number(*g, "to", swhat, segment.law != cam::Law::dwell, displacement);
    segment.to = to.value_or(at);
    at = segment.to;
    segments.push_back(segment);
  }
  if (r.diagnostics().size() != before) return std::nullopt;
  try {
    return cam::MotionProgram(start, segments);
  } catch (const std::invalid_argument& e) {
    const size_t k = numbered(e.what(), "segment ");
    r.error(r.at(k > 0 ? &(*array)[k - 1] : motion), fmt::format("{}: {}", what, e.what()));
  }
  return std::nullopt;
}

// The key a refused profile's message belongs at.
const char* key_of(std::string_view message, bool oscillating) {
  if (message.find("undercut") != std::string_view::npos) return "roller_radius";
  if (message.find("roller's radius") != std::string_view::npos) return "roller_radius";
  if (message.find("cusp") != std::string_view::npos) return "base_radius";
  if (message.find("base circle") != std::string_view::npos) return "base_radius";
  if (message.find("offset") != std::string_view::npos) return "offset";
  if (message.find("arm") != std::string_view::npos) return oscillating ? "arm" : "follower";
  return nullptr;
}

// A shape's refusal "key: why" at its key; the contour's refusals are the follower's.
void refuse_shape(Reader& r, const toml::table& p, const std::string& what, const toml::node* face,
                  const std::string& message) {
  const size_t colon = message.find(": ");
  const std::string key = colon == std::string::npos ? "" : message.substr(0, colon);
  if (const toml::node* at = key.empty() ? nullptr : p.get(key)) {
    r.error(r.at(at), fmt::format("{}: {}", what, message.substr(colon + 2)));
    return;
  }
  r.error(face ? r.at(*face)
               : r.at(p.get("roller_radius") ? p.get("roller_radius")
                                             : static_cast<const toml::node*>(&p)),
          fmt::format("{}: {}", what, message));
}

// The follower a shape's profile holds: a flat face, a roller (`roller_radius`) or a knife edge.
cam::Follower shape_follower(Reader& r, const Mechanism& m, const toml::table& p,
                             const std::string& what, const toml::node* face) {
  cam::Follower f;
  const std::optional<double> roller =
      r.number(p, "roller_radius", what, false, length_scale(m.units));
  f.kind = face     ? cam::FollowerKind::flat_faced
           : roller ? cam::FollowerKind::roller
                    : cam::FollowerKind::knife_edge;
  f.roller_radius = roller.value_or(0.0);
  return f;
}

// `shape = "eccentric"`: a disc of `radius` whose centre is `eccentricity` from the cam's, at
// `lobe_angle` in the cam's frame.
std::shared_ptr<const cam::Contour> read_eccentric(Reader& r, const Mechanism& m,
                                                   const toml::table& p, const std::string& what,
                                                   const toml::node* face) {
  r.known_keys(p, what, {"shape", "radius", "eccentricity", "lobe_angle", "roller_radius"});
  const Scale length = length_scale(m.units);
  const size_t before = r.diagnostics().size();
  cam::EccentricCam shape;
  shape.radius = r.number(p, "radius", what, true, length).value_or(0.0);
  shape.eccentricity = r.number(p, "eccentricity", what, true, length).value_or(0.0);
  shape.angle = r.number(p, "lobe_angle", what, false, angle_scale(m.units)).value_or(0.0);
  cam::Follower f = shape_follower(r, m, p, what, face);
  f.base_radius = shape.radius - shape.eccentricity;
  if (r.diagnostics().size() != before) return nullptr;
  try {
    return std::make_shared<const cam::Contour>(shape, f);
  } catch (const std::invalid_argument& e) {
    refuse_shape(r, p, what, face, e.what());
  }
  return nullptr;
}

// `shape = "points"`: the profile's surface through `points = [[angle, radius], ...]` in the cam's
// frame (a periodic cubic spline, polar about the cam's centre).
std::shared_ptr<const cam::Contour> read_points(Reader& r, const Mechanism& m, const toml::table& p,
                                                const std::string& what, const toml::node* face) {
  r.known_keys(p, what, {"shape", "points", "roller_radius"});
  const size_t before = r.diagnostics().size();
  cam::Follower f = shape_follower(r, m, p, what, face);
  const toml::node* points = p.get("points");
  const toml::array* array = points ? points->as_array() : nullptr;
  if (!array || array->empty())
    r.error(points ? r.at(*points) : r.inside(p),
            fmt::format("{} needs 'points', a non-empty array of [angle, radius] of the "
                        "profile in the cam's frame",
                        what));
  if (r.diagnostics().size() != before) return nullptr;
  std::optional<cam::MotionProgram> surface =
      read_spline(r, *points, *array, what, angle_scale(m.units), length_scale(m.units));
  if (!surface) return nullptr;
  try {
    f.base_radius = 0.0;  // the least radius: the profile's own, below
    cam::Contour contour = cam::Contour::from_points(std::move(*surface), f);
    return std::make_shared<const cam::Contour>(std::move(contour));
  } catch (const std::invalid_argument& e) {
    refuse_shape(r, p, what, face, e.what());
  }
  return nullptr;
}

// `shape = "tangent"`: the base circle, the lift and the angle of ascent or the nose's radius;
// `shape = "eccentric"`: read_eccentric; `shape = "points"`: read_points.
std::shared_ptr<const cam::Contour> read_shape(Reader& r, const Mechanism& m, const toml::table& p,
                                               const std::string& what, const toml::node* face) {
  const std::string shape = r.string(p, "shape", what, true).value_or("");
  if (shape == "eccentric") return read_eccentric(r, m, p, what, face);
  if (shape == "points") return read_points(r, m, p, what, face);
  r.known_keys(
      p, what,
      {"shape", "base_radius", "roller_radius", "lift", "ascent", "nose_radius", "nose_angle"});
  if (shape != "tangent") {
    r.error(r.at(p.get("shape")),
            fmt::format("{}: unknown shape '{}' (valid shapes: tangent, eccentric, points)", what,
                        shape));
    return nullptr;
  }
  const Scale length = length_scale(m.units), angle = angle_scale(m.units);
  const size_t before = r.diagnostics().size();
  const double base = r.number(p, "base_radius", what, true, length).value_or(0.0);
  const double lift = r.number(p, "lift", what, true, length).value_or(0.0);
  const std::optional<double> ascent = r.number(p, "ascent", what, false, angle);
  const std::optional<double> nose = r.number(p, "nose_radius", what, false, length);
  if (ascent.has_value() == nose.has_value())
    r.error(ascent ? r.at(p.get("nose_radius")) : r.inside(p),
            fmt::format("{} needs one of 'ascent' (the angle of ascent) or 'nose_radius'", what));
  const double nose_angle = r.number(p, "nose_angle", what, false, angle).value_or(0.0);
  cam::Follower f = shape_follower(r, m, p, what, face);
  f.base_radius = base;
  if (r.diagnostics().size() != before) return nullptr;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  try {
    const cam::TangentCam cam = cam::TangentCam::from_lift(base, lift, ascent.value_or(nan),
                                                           nose.value_or(nan), nose_angle);
    return std::make_shared<const cam::Contour>(cam, f);
  } catch (const std::invalid_argument& e) {
    refuse_shape(r, p, what, face, e.what());
  }
  return nullptr;
}

}  // namespace

Joint read_cam(Reader& r, const Mechanism& m, const toml::table& t, const std::string& joint_what) {
  Joint joint;
  joint.type = JointType::cam;
  joint.where = r.at(t);
  const std::string what = fmt::format("{} (cam)", joint_what);
  r.known_keys(
      t, what,
      {"type", "name", "cam", "centre", "follower", "point", "face", "closure", "profile"});
  if (const std::optional<std::string> closure = r.string(t, "closure", what, false)) {
    if (*closure != "force" && *closure != "form")
      r.error(r.at(t.get("closure")),
              fmt::format("'closure' of {} must be \"force\" (a spring or gravity keeps the "
                          "follower on; the default) or \"form\" (a groove holds it both ways), "
                          "not '{}'",
                          what, *closure));
    joint.form_closed = *closure == "form";
  }
  joint.link_a = resolve_link(r, m, t, "cam", what);
  joint.link_b = resolve_link(r, m, t, "follower", what);
  if (joint.link_a >= 0 && joint.link_a == joint.link_b)
    r.error(r.at(t.get("follower")),
            fmt::format("{}: the cam and its follower are the same link", what));
  const std::optional<std::string> centre = r.string(t, "centre", what, true);
  if (joint.link_a >= 0 && centre)
    joint.centre_a = resolve_point(r, m, joint.link_a, t.get("centre"), *centre, what);
  const toml::node* face_node = t.get("face");
  if (face_node && t.get("point"))
    r.error(r.at(*face_node), fmt::format("{} gives both 'point' and 'face': a knife edge or "
                                          "roller touches at a point, a flat face along a line",
                                          what));
  const std::optional<std::string> face =
      face_node ? r.string(t, "face", what, true) : std::nullopt;
  const std::optional<std::string> point =
      face_node ? std::nullopt : r.string(t, "point", what, true);
  if (joint.link_b >= 0 && face)
    joint.line = resolve_line(r, m, joint.link_b, face_node, *face, what);
  if (joint.link_b >= 0 && point)
    joint.point_b = resolve_point(r, m, joint.link_b, t.get("point"), *point, what);
  joint.name = r.string(t, "name", what, false)
                   .value_or(joint.link_b >= 0 ? m.links[joint.link_b].name + "/cam" : "cam");

  const toml::table* p = r.table(t, "profile", what, true);
  if (!p) return joint;
  const std::string pwhat = fmt::format("the profile of {}", what);
  if (p->get("shape")) {  // the profile given, the follower's motion its guide's
    joint.contour = read_shape(r, m, *p, pwhat, face_node);
    return joint;
  }
  r.known_keys(*p, pwhat,
               {"follower", "base_radius", "roller_radius", "offset", "pivot", "arm", "start",
                "motion", "table"});
  cam::Follower f;
  const std::string kind = r.string(*p, "follower", pwhat, true).value_or("translating");
  if (kind != "translating" && kind != "oscillating")
    r.error(r.at(p->get("follower")),
            fmt::format("'follower' in {} must be \"translating\" or \"oscillating\", not '{}'",
                        pwhat, kind));
  f.oscillating = kind == "oscillating";
  const Scale length = length_scale(m.units);
  f.base_radius = r.number(*p, "base_radius", pwhat, true, length).value_or(0.0);
  const std::optional<double> roller = r.number(*p, "roller_radius", pwhat, false, length);
  f.kind = face     ? cam::FollowerKind::flat_faced
           : roller ? cam::FollowerKind::roller
                    : cam::FollowerKind::knife_edge;
  if (roller && face)
    r.error(r.at(p->get("roller_radius")),
            fmt::format("{} gives 'roller_radius' for a flat face", pwhat));
  f.roller_radius = roller.value_or(0.0);
  auto refuse = [&](const char* key, std::string_view why) {
    if (p->get(key)) r.error(r.at(p->get(key)), fmt::format("'{}' in {} {}", key, pwhat, why));
  };
  if (f.oscillating) {
    refuse("offset", "is a translating follower's: an oscillating one has 'pivot' and 'arm'");
    if (const toml::node* pivot = p->get("pivot")) {
      if (const auto v = r.numbers(*pivot, fmt::format("'pivot' in {}", pwhat), {length, length}))
        f.pivot = {(*v)[0], (*v)[1]};
    } else {
      r.error(r.inside(*p), fmt::format("{} needs 'pivot' = [x, y]: the arm's pivot from the "
                                        "cam's centre",
                                        pwhat));
    }
    f.arm = r.number(*p, "arm", pwhat, true, length).value_or(0.0);
  } else {
    refuse("pivot", "is an oscillating follower's");
    refuse("arm", "is an oscillating follower's");
    f.offset = r.number(*p, "offset", pwhat, false, length).value_or(0.0);
  }
  const Scale displacement = f.oscillating ? angle_scale(m.units) : length;
  std::optional<cam::MotionProgram> motion =
      read_motion(r, *p, pwhat, displacement, angle_scale(m.units));
  if (!motion) return joint;
  try {
    joint.contour = std::make_shared<const cam::Contour>(std::move(*motion), f);
  } catch (const std::invalid_argument& e) {
    const char* key = key_of(e.what(), f.oscillating);
    if (face && f.oscillating) {
      r.error(r.at(face_node), fmt::format("{}: {}", what, e.what()));
    } else {
      r.error(r.at(key && p->get(key) ? p->get(key) : static_cast<const toml::node*>(p)),
              fmt::format("{}: {}", pwhat, e.what()));
    }
    return joint;
  }
  // A flat face's normal, its line's direction turned by +90 degrees, points away from the cam.
  if (face && joint.line >= 0 && joint.centre_a >= 0) {
    const Link& follower = m.links[joint.link_b];
    const Line& line = follower.lines[joint.line];
    const Eigen::Vector2d origin = drawn_point(follower, line.origin);
    const Eigen::Vector2d normal =
        Eigen::Rotation2Dd(drawn_pose(follower)(2)) * perp(line.direction);
    const Eigen::Vector2d c =
        drawn_point(m.links[joint.link_a], m.links[joint.link_a].points[joint.centre_a].local);
    if (!(normal.dot(c - origin) < 0.0))
      r.error(r.at(face_node),
              fmt::format("{}: the cam's centre {} is drawn on the left of face '{}': the face's "
                          "normal (its direction turned +90 deg) must point away from the cam, so "
                          "draw the line the other way (its angle + 180)",
                          what, *centre, line.name));
  }
  return joint;
}

}  // namespace crosslink::loading
