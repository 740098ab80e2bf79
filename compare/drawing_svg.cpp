#include "compare/drawing_svg.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <stdexcept>

#include "analytic/model/planar.h"
#include "compare/report.h"

namespace crosslink::compare {

std::vector<LinkSegment> link_segments(const Mechanism& m, const Trajectory& t) {
  std::vector<LinkSegment> out;
  for (const Link& link : m.links) {
    if (link.ground) continue;
    std::vector<const Point*> points;
    for (const Point& p : link.points)
      if (std::find(t.point_names.begin(), t.point_names.end(), p.name) != t.point_names.end())
        points.push_back(&p);
    // The convex hull in the link's frame, counterclockwise (Andrew's monotone chain): a rigid
    // link's at every pose. Points on an edge or inside it are left to their dots.
    std::sort(points.begin(), points.end(), [](const Point* a, const Point* b) {
      return std::pair(a->local.x(), a->local.y()) < std::pair(b->local.x(), b->local.y());
    });
    const auto turn = [](const Point* o, const Point* a, const Point* b) {
      const Eigen::Vector2d u = a->local - o->local, v = b->local - o->local;
      return u.x() * v.y() - u.y() * v.x();
    };
    std::vector<const Point*> hull;
    for (int pass = 0; pass < 2; ++pass) {  // the lower chain left to right, the upper back
      const size_t base = hull.size();
      for (const Point* p : points) {
        while (hull.size() >= base + 2 && turn(hull[hull.size() - 2], hull.back(), p) <= 0.0)
          hull.pop_back();
        hull.push_back(p);
      }
      hull.pop_back();  // the chain's last point starts the other
      std::reverse(points.begin(), points.end());
    }
    if (hull.size() < 2) continue;
    for (size_t i = 0; i < (hull.size() == 2 ? 1 : hull.size()); ++i)
      out.push_back({link.name, hull[i]->name, hull[(i + 1) % hull.size()]->name});
  }
  return out;
}

std::vector<std::string> moving_points(const Mechanism& m) {
  std::vector<std::string> out;
  for (const Mechanism::NamedPoint& p : m.named_points())
    if (!m.links[static_cast<size_t>(p.link)].ground) out.push_back(p.name);
  return out;
}

namespace {
// A link's frame at a sample: a point given in it, placed from the link's first point and angle.
struct Placement {
  Eigen::Vector2d first, first_local;
  Eigen::Rotation2Dd rotation{0.0};
  Eigen::Vector2d operator()(const Eigen::Vector2d& local) const {
    return first + rotation * (local - first_local);
  }
};
}  // namespace

std::vector<GuideOutline> guide_outlines(const Mechanism& m, const Trajectory& t, int k,
                                         double reach) {
  const auto where = [&](const std::string& name) -> std::optional<Eigen::Vector2d> {
    const auto p = std::find(t.point_names.begin(), t.point_names.end(), name);
    if (p == t.point_names.end()) return std::nullopt;
    const auto c = static_cast<Eigen::Index>(p - t.point_names.begin());
    return Eigen::Vector2d(t.x(k, c), t.y(k, c));
  };
  // Where link `l` is at `k`: its first point and its angle; none without a position.
  const auto placed = [&](int l) -> std::optional<Placement> {
    const Link& link = m.links[static_cast<size_t>(l)];
    const int moving = m.moving_index(l);
    if (link.points.empty()) return std::nullopt;
    if (moving < 0)
      return Placement{link.points[0].local, link.points[0].local, Eigen::Rotation2Dd(0.0)};
    const auto p0 = where(link.points[0].name);
    if (!p0) return std::nullopt;
    return Placement{*p0, link.points[0].local, Eigen::Rotation2Dd(t.angle(k, moving))};
  };
  std::vector<GuideOutline> out;
  for (size_t l = 0; l < m.links.size(); ++l) {
    const Link& link = m.links[l];
    if (link.lines.empty()) continue;
    const auto at = placed(static_cast<int>(l));
    if (!at) continue;
    for (const Line& line : link.lines) {
      const Eigen::Vector2d o = (*at)(line.origin), u = at->rotation * line.direction;
      out.push_back({line.name, link.name, !link.ground, {o - reach * u, o + reach * u}});
    }
  }
  for (const Joint& j : m.joints) {
    if (j.type != JointType::pin_in_spline && j.type != JointType::pin_in_arc) continue;
    const auto at = placed(j.link_a);
    if (!at) continue;
    const Link& guide = m.links[static_cast<size_t>(j.link_a)];
    GuideOutline slot{j.name, guide.name, !guide.ground, {}};
    for (int i = 0; i <= 48; ++i) {
      if (j.type == JointType::pin_in_arc) {
        const double angle = 2.0 * std::numbers::pi * i / 48.0;
        slot.points.push_back(
            (*at)(guide.points[static_cast<size_t>(j.centre_a)].local +
                  j.radius_a * Eigen::Vector2d(std::cos(angle), std::sin(angle))));
      } else {
        const double x = j.slot->first() + (j.slot->last() - j.slot->first()) * i / 48.0;
        slot.points.push_back(
            (*at)(j.chord_start + x * j.chord_axis + j.slot->at(x).y * perp(j.chord_axis)));
      }
    }
    out.push_back(std::move(slot));
  }
  return out;
}

namespace {

// The report's link colours (Vega's category10, in link order).
constexpr std::array<const char*, 10> kColours = {"#1f77b4", "#ff7f0e", "#2ca02c", "#d62728",
                                                  "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                                                  "#bcbd22", "#17becf"};

std::string number(double v) {
  return fmt::format("{:.6g}", v + 0.0);  // + 0.0: no "-0"
}

}  // namespace

std::string drawing_svg(const Mechanism& m, const Trajectory& t, int row, double animate_seconds) {
  if (row < 0 || row >= t.samples()) throw std::invalid_argument("drawing_svg: no such sample");
  const double unit = m.units.length;
  const auto column = [&](const std::string& name) {
    return static_cast<Eigen::Index>(std::find(t.point_names.begin(), t.point_names.end(), name) -
                                     t.point_names.begin());
  };
  // The samples with a position, in order: the paths and the animation's frames.
  std::vector<int> shown;
  for (int k = 0; k < t.samples(); ++k) {
    bool finite = has_position(t.status[static_cast<size_t>(k)]);
    for (Eigen::Index p = 0; finite && p < t.x.cols(); ++p)
      finite = std::isfinite(t.x(k, p)) && std::isfinite(t.y(k, p));
    if (finite) shown.push_back(k);
  }
  if (std::find(shown.begin(), shown.end(), row) == shown.end())
    throw std::invalid_argument(fmt::format("{}: the sample to draw has no position ({})", m.file,
                                            to_string(t.status[static_cast<size_t>(row)])));
  // In the file's length unit, y down as SVG draws it.
  const auto X = [&](int k, Eigen::Index p) { return t.x(k, p) / unit; };
  const auto Y = [&](int k, Eigen::Index p) { return -t.y(k, p) / unit; };

  // Each cam's profile at sample k, closed, and its roller's centre and radius (0: a knife edge or
  // a face): the cam turned with its link about its centre.
  struct CamOutline {
    std::string link;
    std::vector<Eigen::Vector2d> profile;
    Eigen::Vector2d roller_centre;
    double roller = 0.0;
  };
  // Each cam's profile in its own frame, about its centre: the same at every sample.
  std::vector<std::vector<Eigen::Vector2d>> profiles;
  for (const Trajectory::CamChannel& cam : t.cams) profiles.push_back(cam.reading.outline(360));
  const auto cams_at = [&](int k) {
    std::vector<CamOutline> out;
    for (size_t ci = 0; ci < t.cams.size(); ++ci) {
      const Trajectory::CamChannel& cam = t.cams[ci];
      const CamReading::Pose p = cam.at(t, k);
      const ConstraintRows& rows = cam.reading.rows;
      const Joint& joint = m.joints[static_cast<size_t>(m.find_joint(cam.reading.joint))];
      CamOutline c{m.links[static_cast<size_t>(joint.link_a)].name,
                   {},
                   p.at,
                   rows.kind == ConstraintRows::Kind::cam_face
                       ? 0.0
                       : rows.contour->follower().roller_radius};
      const Eigen::Rotation2Dd R(p.cam_angle);
      for (const Eigen::Vector2d& u : profiles[ci]) c.profile.push_back(p.centre + R * u);
      c.profile.push_back(c.profile.front());
      out.push_back(std::move(c));
    }
    return out;
  };
  std::vector<std::vector<CamOutline>> cam_outlines(static_cast<size_t>(t.samples()));
  if (!t.cams.empty())
    for (const int k : shown) cam_outlines[static_cast<size_t>(k)] = cams_at(k);

  // The frame: every point, curved slot, line guide's origin and cam at every shown sample, with
  // a margin of 8 % of the larger span.
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  const auto frame = [&](double x, double y) {
    x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  };
  for (const int k : shown) {
    for (Eigen::Index p = 0; p < t.x.cols(); ++p) frame(X(k, p), Y(k, p));
    for (const GuideOutline& g : guide_outlines(m, t, k, 0.0))
      for (const Eigen::Vector2d& v : g.points) frame(v.x() / unit, -v.y() / unit);
    for (const CamOutline& c : cam_outlines[static_cast<size_t>(k)]) {
      for (const Eigen::Vector2d& v : c.profile) frame(v.x() / unit, -v.y() / unit);
      const Eigen::Vector2d r = c.roller_centre / unit;
      frame(r.x() - c.roller / unit, -r.y() - c.roller / unit);
      frame(r.x() + c.roller / unit, -r.y() + c.roller / unit);
    }
  }
  const double span = std::max({x1 - x0, y1 - y0, m.size() / unit * 1e-3});
  const double margin = 0.08 * span;
  x0 -= margin, x1 += margin, y0 -= margin, y1 += margin;
  const double width_px = 720.0, height_px = width_px * (y1 - y0) / (x1 - x0);
  const double thick = span / 110.0, thin = span / 450.0, dot = span / 120.0;

  std::string out = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{:.0f}\" height=\"{:.0f}\" "
      "viewBox=\"{} {} {} {}\">\n<title>{}</title>\n"
      "<desc>crosslink: {} ({}), lengths in {}; paths of the moving points in grey</desc>\n"
      "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"white\"/>\n",
      width_px, height_px, number(x0), number(y0), number(x1 - x0), number(y1 - y0),
      html_escape(m.name), html_escape(m.name), html_escape(m.file),
      html_escape(m.units.length_name), number(x0), number(y0), number(x1 - x0), number(y1 - y0));

  // The ground's guides dashed: its lines across the frame, its curved slots as they lie.
  const double across = 2.0 * std::hypot(x1 - x0, y1 - y0) * unit;
  const auto polyline = [&](const std::vector<Eigen::Vector2d>& points) {
    std::string text;
    for (const Eigen::Vector2d& v : points)
      text += fmt::format("{}{},{}", text.empty() ? "" : " ", number(v.x() / unit),
                          number(-v.y() / unit));
    return text;
  };
  for (const GuideOutline& g : guide_outlines(m, t, row, across)) {
    if (g.moving) continue;
    out += fmt::format(
        "<polyline points=\"{}\" fill=\"none\" stroke=\"#888\" stroke-width=\"{}\" "
        "stroke-dasharray=\"{} {}\"><title>{}</title></polyline>\n",
        polyline(g.points), number(thin), number(4 * thin), number(3 * thin), html_escape(g.name));
  }

  // The paths of the moving points, one polyline per run of shown samples.
  for (const std::string& name : moving_points(m)) {
    const Eigen::Index p = column(name);
    std::string run;
    for (size_t i = 0; i < shown.size(); ++i) {
      if (i > 0 && shown[i] != shown[i - 1] + 1 && !run.empty()) {
        out += fmt::format(
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#bbb\" "
            "stroke-width=\"{}\"/>\n",
            run, number(thin));
        run.clear();
      }
      run += fmt::format("{}{},{}", run.empty() ? "" : " ", number(X(shown[i], p)),
                         number(Y(shown[i], p)));
    }
    if (!run.empty())
      out += fmt::format(
          "<polyline points=\"{}\" fill=\"none\" stroke=\"#bbb\" stroke-width=\"{}\"><title>path "
          "of {}</title></polyline>\n",
          run, number(thin), html_escape(name));
  }

  // An attribute at `row` (an animation's first frame too), and its animation through the shown
  // samples.
  const auto animated = [&](const char* attribute, auto value) {
    return fmt::format(" {}=\"{}\"", attribute, number(value(row)));
  };
  // An attribute's values through the shown samples, `text(k)` each.
  const auto frames = [&](const char* attribute, auto text) {
    if (animate_seconds <= 0.0) return std::string();
    std::string values;
    for (const int k : shown) {
      if (!values.empty()) values += ';';
      values += text(k);
    }
    return fmt::format(
        "<animate attributeName=\"{}\" dur=\"{}s\" repeatCount=\"indefinite\" values=\"{}\"/>",
        attribute, number(animate_seconds), values);
  };
  const auto animation = [&](const char* attribute, auto value) {
    return frames(attribute, [&](int k) { return number(value(k)); });
  };

  // The links, their slots and cams in the report's colours.
  std::vector<std::string> link_names;
  for (const Link& link : m.links)
    if (!link.ground) link_names.push_back(link.name);
  const auto colour_of = [&](const std::string& link) {
    return kColours[static_cast<size_t>(std::find(link_names.begin(), link_names.end(), link) -
                                        link_names.begin()) %
                    kColours.size()];
  };
  // The slots on moving links, thin, at every sample drawn.
  const double reach = m.size();
  std::vector<std::vector<GuideOutline>> guides_at(static_cast<size_t>(t.samples()));
  for (const int k : animate_seconds > 0.0 ? shown : std::vector<int>{row})
    guides_at[static_cast<size_t>(k)] = guide_outlines(m, t, k, reach);
  const std::vector<GuideOutline>& guides = guides_at[static_cast<size_t>(row)];
  for (size_t g = 0; g < guides.size(); ++g) {
    if (!guides[g].moving) continue;
    out += fmt::format(
        "<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"><title>{}"
        "</title>{}</polyline>\n",
        polyline(guides[g].points), colour_of(guides[g].link), number(2 * thin),
        html_escape(guides[g].name), frames("points", [&](int k) {
          return polyline(guides_at[static_cast<size_t>(k)][g].points);
        }));
  }
  // The cams' profiles, and their rollers.
  const std::vector<CamOutline>& cams = cam_outlines[static_cast<size_t>(row)];
  for (size_t c = 0; c < cams.size(); ++c) {
    const std::string& name = t.cams[c].reading.joint;
    out += fmt::format(
        "<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{}\"><title>{} "
        "profile</title>{}</polyline>\n",
        polyline(cams[c].profile), colour_of(cams[c].link), number(2 * thin), html_escape(name),
        frames("points",
               [&](int k) { return polyline(cam_outlines[static_cast<size_t>(k)][c].profile); }));
    if (cams[c].roller <= 0.0) continue;
    const auto x = [&](int k) {
      return cam_outlines[static_cast<size_t>(k)][c].roller_centre.x() / unit;
    };
    const auto y = [&](int k) {
      return -cam_outlines[static_cast<size_t>(k)][c].roller_centre.y() / unit;
    };
    out += fmt::format(
        "<circle{}{} r=\"{}\" fill=\"none\" stroke=\"#222\" stroke-width=\"{}\"><title>{} "
        "roller</title>{}{}</circle>\n",
        animated("cx", x), animated("cy", y), number(cams[c].roller / unit), number(thin),
        html_escape(name), animation("cx", x), animation("cy", y));
  }

  for (const LinkSegment& s : link_segments(m, t)) {
    const Eigen::Index p = column(s.p), q = column(s.q);
    const auto colour = colour_of(s.link);
    const auto xp = [&](int k) { return X(k, p); };
    const auto yp = [&](int k) { return Y(k, p); };
    const auto xq = [&](int k) { return X(k, q); };
    const auto yq = [&](int k) { return Y(k, q); };
    out += fmt::format(
        "<line{}{}{}{} stroke=\"{}\" stroke-width=\"{}\" stroke-linecap=\"round\" "
        "opacity=\"0.8\"><title>{}</title>{}{}{}{}</line>\n",
        animated("x1", xp), animated("y1", yp), animated("x2", xq), animated("y2", yq), colour,
        number(thick), html_escape(s.link), animation("x1", xp), animation("y1", yp),
        animation("x2", xq), animation("y2", yq));
  }

  // The points: the ground's pivots as triangles, the moving ones as dots, named when still.
  for (const Mechanism::NamedPoint& np : m.named_points()) {
    const Eigen::Index p = column(np.name);
    if (p >= t.x.cols()) continue;
    const auto xp = [&](int k) { return X(k, p); };
    const auto yp = [&](int k) { return Y(k, p); };
    if (m.links[static_cast<size_t>(np.link)].ground) {
      const double x = xp(row), y = yp(row), s = 1.6 * dot;
      out += fmt::format(
          "<polygon points=\"{},{} {},{} {},{}\" fill=\"#444\"><title>{}</title></polygon>\n",
          number(x), number(y), number(x - s), number(y + 1.6 * s), number(x + s),
          number(y + 1.6 * s), html_escape(np.name));
    } else {
      out += fmt::format("<circle{}{} r=\"{}\" fill=\"#222\"><title>{}</title>{}{}</circle>\n",
                         animated("cx", xp), animated("cy", yp), number(dot), html_escape(np.name),
                         animation("cx", xp), animation("cy", yp));
    }
    if (animate_seconds <= 0.0)
      out += fmt::format(
          "<text x=\"{}\" y=\"{}\" font-family=\"sans-serif\" font-size=\"{}\">{}</text>\n",
          number(xp(row) + 1.5 * dot), number(yp(row) - 1.5 * dot), number(span / 30.0),
          html_escape(np.name));
  }
  out += "</svg>\n";
  return out;
}

}  // namespace crosslink::compare
