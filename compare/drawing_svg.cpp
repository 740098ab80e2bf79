#include "compare/drawing_svg.h"

#include <fmt/format.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "compare/report.h"

namespace crosslink::compare {

std::vector<LinkSegment> link_segments(const Mechanism& m, const Trajectory& t) {
  std::vector<LinkSegment> out;
  for (const Link& link : m.links) {
    if (link.ground) continue;
    std::vector<std::string> names;
    for (const Point& p : link.points)
      if (std::find(t.point_names.begin(), t.point_names.end(), p.name) != t.point_names.end())
        names.push_back(p.name);
    if (names.size() < 2) continue;
    for (size_t i = 0; i < (names.size() == 2 ? 1 : names.size()); ++i)
      out.push_back({link.name, names[i], names[(i + 1) % names.size()]});
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

  // The frame: every point at every shown sample, with a margin of 8 % of the larger span.
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const int k : shown)
    for (Eigen::Index p = 0; p < t.x.cols(); ++p) {
      x0 = std::min(x0, X(k, p)), x1 = std::max(x1, X(k, p));
      y0 = std::min(y0, Y(k, p)), y1 = std::max(y1, Y(k, p));
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

  // The ground's guides, across the frame.
  const Link& ground = m.links[static_cast<size_t>(m.ground())];
  for (const Line& line : ground.lines) {
    const Eigen::Vector2d o = line.origin / unit, u = line.direction;
    const double reach = 2.0 * std::hypot(x1 - x0, y1 - y0);
    out += fmt::format(
        "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"#888\" stroke-width=\"{}\" "
        "stroke-dasharray=\"{} {}\"/>\n",
        number(o.x() - reach * u.x()), number(-(o.y() - reach * u.y())),
        number(o.x() + reach * u.x()), number(-(o.y() + reach * u.y())), number(thin),
        number(4 * thin), number(3 * thin));
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
  const auto animation = [&](const char* attribute, auto value) {
    if (animate_seconds <= 0.0) return std::string();
    std::string values;
    for (const int k : shown) {
      if (!values.empty()) values += ';';
      values += number(value(k));
    }
    return fmt::format(
        "<animate attributeName=\"{}\" dur=\"{}s\" repeatCount=\"indefinite\" values=\"{}\"/>",
        attribute, number(animate_seconds), values);
  };

  // The links, in the report's colours.
  std::vector<std::string> link_names;
  for (const Link& link : m.links)
    if (!link.ground) link_names.push_back(link.name);
  for (const LinkSegment& s : link_segments(m, t)) {
    const Eigen::Index p = column(s.p), q = column(s.q);
    const auto colour =
        kColours[static_cast<size_t>(std::find(link_names.begin(), link_names.end(), s.link) -
                                     link_names.begin()) %
                 kColours.size()];
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
