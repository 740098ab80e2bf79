#include "analytic/reference/tracer.h"

#include "analytic/model/planar.h"
#include "analytic/model/units_text.h"

namespace crosslink::sweeping {

namespace {
constexpr double kPi = std::numbers::pi;
}  // namespace

// A change point between two nodes of a step. Newton is ill-posed right at it (the other branch
// is as near as this one), so det [C; t] is sampled on this branch at 3, 2, 1 x delta on either
// side of a first estimate, predicting outward-in from the step's ends, and the root is taken
// from the quintic through them (the branch is analytic there). Returns the root and the six
// nodes (to serve as path nodes near the change point), or nothing when a solve fails.
std::optional<double> locate_change_point(Tracer& tracer, const Tracer::Node& cur,
                                          const Tracer::Node& next, double unit,
                                          std::vector<Tracer::Node>& nodes) {
  if (std::abs(cur.t_driver) < 1e-3 || std::abs(next.t_driver) < 1e-3) return std::nullopt;
  double root = cur.driver +
                (next.driver - cur.driver) * cur.orientation / (cur.orientation - next.orientation);
  const double dir = sign_of(next.driver - cur.driver);
  const double delta = 2e-3 * unit;
  for (int pass = 0; pass < 2; ++pass) {
    nodes.clear();
    Eigen::Matrix<double, 6, 6> v;
    Eigen::Matrix<double, 6, 1> f;
    for (int side = -1; side <= 1; side += 2) {
      Tracer::Node near = side < 0 ? cur : next;
      for (int k = 3; k >= 1; --k) {
        const double x = side * k;
        Tracer::Node at;
        if (!tracer.correct_driver(cur, root + dir * x * delta, at, near)) return std::nullopt;
        const int row = static_cast<int>(nodes.size());
        for (int c = 0; c < 6; ++c) v(row, c) = std::pow(x, c);
        f(row) = at.orientation;
        nodes.push_back(at);
        near = at;
      }
    }
    const Eigen::Matrix<double, 6, 1> poly = v.fullPivLu().solve(f);
    double x = 0.0;
    for (int it = 0; it < 50; ++it) {
      double p = 0.0, dp = 0.0;
      for (int c = 5; c >= 0; --c) {
        dp = dp * x + p;
        p = p * x + poly(c);
      }
      if (dp == 0.0) break;
      const double dx = p / dp;
      x -= dx;
      if (std::abs(dx) < 1e-15) break;
    }
    if (!(std::abs(x) < 1.0)) return std::nullopt;
    root += dir * x * delta;
  }
  std::sort(nodes.begin(), nodes.end(),
            [](const Tracer::Node& a, const Tracer::Node& b) { return a.s < b.s; });
  return root;
}

// A leg fails where the chain moves through kHeldArc of arclength (in z: lengths / size, angles
// in rad, so ten link turns) while the driver spans less than kHeldDriver of its unit (rad, or
// the chain's size): the driver does not set the pose there. Near a toggle the driver varies as
// the square of the arclength, with a curvature set by the chain's proportions, so a drawn chain
// moves its driver by far more over ten turns; a degenerate one does not (a Wanzer triangle drawn
// a million metres long spins on its slots with the disk held, its driver wobbling by 3e-5 rad:
// tests/fuzz/regressions/), nor does a branch on which the driver link stays put (a kite four-bar).
constexpr double kHeldArc = 20.0 * kPi;
constexpr double kHeldDriver = 1e-3;

// A leg also fails where a link's point moves farther from where the leg began than kEscape
// times the chain's size for each moving link: no closed chain of links within that size can put
// a point there (revolute chains reach at most twice their links' summed extents), so the chain
// runs off to infinity, as two slots turning parallel send a block along them while the driver
// nears an asymptote (tests/fuzz/regressions/wanzer_parallel_slots_runaway.toml).
constexpr double kEscape = 4.0;

// Every drawn point of the moving links, in the world, at q (in link and point order).
std::vector<Eigen::Vector2d> moving_points(const Mechanism& m, const Eigen::VectorXd& q) {
  std::vector<Eigen::Vector2d> out;
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const BodyMotion b = BodyMotion::of(k, q, nullptr, nullptr);
    for (const Point& p : m.links[l].points) out.push_back(b.position(p.local));
  }
  return out;
}

// The farthest any of `from` (moving_points at the leg's start) has moved at q.
double farthest_move(const Mechanism& m, const std::vector<Eigen::Vector2d>& from,
                     const Eigen::VectorXd& q) {
  double farthest = 0.0;
  size_t i = 0;
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0) continue;
    const BodyMotion b = BodyMotion::of(k, q, nullptr, nullptr);
    for (const Point& p : m.links[l].points)
      farthest = std::max(farthest, (b.position(p.local) - from[i++]).norm());
  }
  return farthest;
}

// Ends the leg at its last node, where the tracer lost the curve: a branch_jump, with why.
Leg& fail(Leg& leg, std::string message) {
  const Tracer::Node& last = leg.nodes.back();
  leg.failed = true;
  leg.singular.push_back(
      {SingularKind::branch_jump, last.driver, sign_of(last.t_driver), std::move(message)});
  leg.singular_node.push_back(static_cast<int>(leg.nodes.size()) - 1);
  leg.singular_key.push_back(leg.key.back());
  leg.end_key = leg.key.back();
  return leg;
}

// Traces from `start` (already oriented) until a toggle (when stopping there), a whole driver
// turn without toggles, the loop closing back on the start pose, or the reach.
Leg trace_leg(const NewtonSolver& solver, const Tracer::Node& start, const LegLimits& limits) {
  Tracer tracer(solver);
  Leg leg;
  leg.nodes.push_back(start);
  leg.base.push_back(0);
  leg.key.push_back(0.0);
  // h bounds the predicted move of every coordinate (|arc t|_inf in z: a link's turn in rad, a
  // point's move per size), not the arclength: where N loops move together the unit tangent
  // spreads over them, and an arclength cap took sqrt(N) times the steps per turn of the driver
  // for the same move of each link (A02: 580 steps at N = 2, 3,987 at N = 160).
  const double h_max = 0.02, h_min = 1e-11;
  const double unit = limits.angular ? 1.0 : solver.length_scale();
  // A driver value in a message, in the file's units.
  const auto at = [&](double driver) {
    return driver_unit_of(solver.mechanism()).text(driver, 12);
  };
  const double start_driver = start.driver;
  const double sigma = sign_of(start.t_driver) != 0 ? sign_of(start.t_driver) : 1.0;
  double h = h_max;
  double travel = 0.0;  // |driver change| summed along the leg
  int toggles = 0;
  // The driver's span over the current window of kHeldArc arclength, from held_key.
  double held_lo = start.driver, held_hi = start.driver, held_key = 0.0;
  const Mechanism& m = solver.mechanism();
  const std::vector<Eigen::Vector2d> start_points = moving_points(m, start.q);
  const double escape_sizes = kEscape * m.moving_count();
  for (int steps = 0; steps < limits.steps; ++steps) {
    const int i = static_cast<int>(leg.nodes.size()) - 1;
    const Tracer::Node cur = leg.nodes[static_cast<size_t>(i)];
    Tracer::Node next;
    const double arc = h / cur.t.lpNorm<Eigen::Infinity>();
    // Newton may only polish the prediction, and the tangent may only turn a little: a step
    // that would land on another branch is refused and shortened.
    bool ok = tracer.correct(cur, arc, next);
    if (ok) {
      ok = tracer.correction(cur, next, arc) <= 0.3 * h + 1e-9 && next.t.dot(cur.t) >= 0.9;
    }
    if (!ok) {
      h *= 0.5;
      if (h < h_min) {
        return fail(leg, fmt::format("branch_jump: the chain cannot be followed beyond driver = "
                                     "{}: the only nearby solutions are on another branch",
                                     at(cur.driver)));
      }
      continue;
    }
    // Singular positions inside this step, in the order of s.
    std::vector<std::pair<SingularKind, Tracer::Node>> found;
    Tracer::Node from = cur;  // the bracket's low end: s = 0 on the hyperplanes of `cur`
    from.s = 0.0;
    if (sign_of(cur.t_driver) * sign_of(next.t_driver) < 0)
      found.push_back(
          {SingularKind::toggle,
           locate(
               tracer, cur, from, next, [](const Tracer::Node& n) { return n.t_driver; }, 1e-300)});
    if (sign_of(cur.orientation) * sign_of(next.orientation) < 0) {
      std::vector<Tracer::Node> around;
      if (const auto root = locate_change_point(tracer, cur, next, unit, around)) {
        // The nodes around it become path nodes; the change point itself is only an event.
        for (const Tracer::Node& n : around)
          if (n.s > 0.0 && n.s < arc) found.push_back({SingularKind::branch_jump, n});
        Tracer::Node at = around[2];
        at.s = 0.5 * (around[2].s + around[3].s);
        at.driver = *root;
        found.push_back({SingularKind::change_point, at});
      } else {
        found.push_back({SingularKind::change_point,
                         locate(
                             tracer, cur, from, next,
                             [](const Tracer::Node& n) { return n.orientation; }, 1e-300, true)});
      }
    }
    std::sort(found.begin(), found.end(),
              [](const auto& a, const auto& b) { return a.second.s < b.second.s; });
    bool stop = false;
    for (auto& [kind, node] : found) {
      if (kind == SingularKind::branch_jump) {  // a plain node near a change point
        leg.nodes.push_back(node);
        leg.base.push_back(i);
        leg.key.push_back(leg.key[static_cast<size_t>(i)] + node.s);
        continue;
      }
      const double dir = sign_of(cur.t_driver);
      const double key = leg.key[static_cast<size_t>(i)] + node.s;
      leg.singular_key.push_back(key);
      if (kind == SingularKind::change_point) {
        leg.singular_node.push_back(-1);  // no path node: its tangent is not defined
      } else {
        leg.nodes.push_back(node);
        leg.base.push_back(i);
        leg.key.push_back(key);
        leg.singular_node.push_back(static_cast<int>(leg.nodes.size()) - 1);
      }
      if (kind == SingularKind::toggle) {
        ++toggles;
        leg.singular.push_back(
            {kind, node.driver, dir,
             fmt::format("toggle: dead point at driver = {}: the chain cannot close beyond "
                         "it (limit of the assembling range); the sweep {} here",
                         at(node.driver),
                         limits.stop_at_toggle ? "stops" : "reverses the driver")});
        if (limits.stop_at_toggle) {
          stop = true;
          leg.end_key = leg.key.back();
          break;
        }
        // Back at the start pose, drawn on this toggle: the loop closes here (the driver turns
        // back at the start value, so it never passes it again as the test below asks). Both
        // are folds at one driver value to ~1e-12, so their poses agree to its square root.
        if (std::abs(node.driver - start_driver) < 1e-9 * unit &&
            tracer.distance(node.q, start.q, true) < 1e-4) {
          leg.closed = true;
          leg.end_key = leg.key.back();
          return leg;
        }
      } else {
        leg.singular.push_back(
            {kind, node.driver, dir,
             fmt::format("change_point at driver = {}: two branches cross; the sweep "
                         "continues on the smooth branch (continuous velocity), leaving the "
                         "assembly mode it had",
                         at(node.driver))});
      }
    }
    if (stop) return leg;
    travel += std::abs(next.driver - cur.driver);
    leg.nodes.push_back(next);
    leg.base.push_back(i);
    leg.key.push_back(leg.key[static_cast<size_t>(i)] + arc);
    h = std::min(2.0 * h, h_max);
    // Whole turn of an angular driver without a toggle: the chain can rotate fully.
    if (toggles == 0 && limits.angular && std::abs(next.driver - start_driver) >= 2.0 * kPi) {
      leg.full_cycle = true;
      return leg;
    }
    // After a toggle: back at the start value moving the first way, on the start pose?
    if (toggles > 0 && sign_of(next.t_driver) == sigma &&
        (cur.driver - start_driver) * (next.driver - start_driver) <= 0.0) {
      Tracer::Node lo = cur, hi = next;
      lo.s = 0.0;
      const Tracer::Node at = locate(
          tracer, cur, lo, hi, [&](const Tracer::Node& n) { return n.driver - start_driver; },
          1e-15 * unit);
      if (tracer.distance(at.q, start.q, true) < 1e-6) {
        leg.closed = true;
        leg.end_key = leg.key[static_cast<size_t>(i)] + at.s;
        return leg;
      }
    }
    if (travel > limits.reach) {
      leg.end_key = leg.key.back();
      return leg;
    }
    if (farthest_move(m, start_points, next.q) > escape_sizes * solver.length_scale())
      return fail(leg, fmt::format("branch_jump: the chain runs off to infinity near driver = "
                                   "{} (a point moved {:g} times the drawing's size, {:g} "
                                   "for each moving link): the driver nears an asymptote, so the "
                                   "chain cannot be followed",
                                   at(next.driver), escape_sizes, kEscape));
    held_lo = std::min(held_lo, next.driver);
    held_hi = std::max(held_hi, next.driver);
    if (leg.key.back() - held_key < kHeldArc) continue;
    if (held_hi - held_lo > kHeldDriver * unit) {
      held_lo = held_hi = next.driver;
      held_key = leg.key.back();
    } else {
      return fail(leg, fmt::format("branch_jump: the chain moves with the driver held at driver "
                                   "= {} (ten link turns of motion with the driver within "
                                   "{:.0e} of its unit): the driver does not set the pose there, "
                                   "so the chain cannot be followed",
                                   at(next.driver), kHeldDriver));
    }
  }
  return fail(leg, fmt::format("branch_jump: the tracer's budget of {} steps ran out at driver = "
                               "{}, before a limit or a whole cycle, so the chain is not "
                               "followed beyond",
                               limits.steps, at(leg.nodes.back().driver)));
}

}  // namespace crosslink::sweeping
