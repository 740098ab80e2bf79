#include "analytic/derived/derived.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <numbers>

#include "analytic/derived/golden.h"
#include "analytic/derived/jump.h"
#include "analytic/kinematics/newton.h"
#include "analytic/model/planar.h"
#include "analytic/model/units_text.h"

namespace crosslink {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

// A scalar function of a pose, read from one row of a trajectory: its value and, where the
// trajectory's rates give it, its derivative in the driver coordinate at driver rate `rate`.
struct Scalar {
  bool positions = true;  // the value reads positions only (it exists at a singular pose)
  // A link's angle: over a whole cycle it may gain whole turns (a crank's), so that its value at
  // a cycle's end is its value at the start plus those turns, not the start's value.
  bool winds = false;
  std::function<double(const Trajectory&, int)> value;
  std::function<double(const Trajectory&, int, double rate)> slope;  // empty: none
};

double at(const Trajectory& t, const std::string& channel, int row) {
  return *t.sample(channel, row);
}

// The channel's value, and its slope from the next derivative the trajectory holds (positions
// from velocities, velocities from accelerations: at constant speed d/dt = rate d/d driver).
Scalar channel_scalar(const std::string& channel) {
  Scalar f;
  const Quantity q = Trajectory::quantity_of(channel);
  f.positions = q == Quantity::position || q == Quantity::angle;
  f.winds = q == Quantity::angle;
  f.value = [channel](const Trajectory& t, int row) { return at(t, channel, row); };
  const std::string kind = channel.substr(0, channel.find('.'));
  const std::string object = channel.substr(channel.find('.'));
  static const std::vector<std::pair<std::string, std::string>> next = {
      {"x", "vx"},  {"y", "vy"},  {"s", "sdot"},     {"angle", "omega"},
      {"vx", "ax"}, {"vy", "ay"}, {"sdot", "sddot"}, {"omega", "alpha"}};
  for (const auto& [from, to] : next)
    if (kind == from)
      f.slope = [rate_channel = to + object](const Trajectory& t, int row, double rate) {
        return at(t, rate_channel, row) / rate;
      };
  if (kind == "v")
    f.slope = [object](const Trajectory& t, int row, double rate) {
      const double vx = at(t, "vx" + object, row), vy = at(t, "vy" + object, row);
      const double v = std::hypot(vx, vy);
      return v > 0.0
                 ? (vx * at(t, "ax" + object, row) + vy * at(t, "ay" + object, row)) / (v * rate)
                 : 0.0;
    };
  return f;
}

// The component of a point's position along the unit vector n.
Scalar along(const std::string& point, Eigen::Vector2d n) {
  Scalar f;
  f.value = [point, n](const Trajectory& t, int row) {
    return n.x() * at(t, "x." + point, row) + n.y() * at(t, "y." + point, row);
  };
  f.slope = [point, n](const Trajectory& t, int row, double rate) {
    return (n.x() * at(t, "vx." + point, row) + n.y() * at(t, "vy." + point, row)) / rate;
  };
  return f;
}

// A sample of the interval: its row and driver value, shifted by whole cycles so that the
// interval's samples increase along it.
struct Sample {
  int row;
  double v;
};

struct Located {
  double v = 0.0;
  double value = 0.0;
  bool reversal = true;  // inside the interval (the channel turns back), not at one of its ends
  std::vector<double> ties = {};  // other locations of the same value within rounding (extreme())
};

// Finds the extreme of f near a sample, and f at a driver value between two samples.
class Locator {
 public:
  virtual ~Locator() = default;
  virtual std::optional<Located> refine(const Scalar& f, const Sample& lo, const Sample& mid,
                                        const Sample& hi, bool max) = 0;
  virtual std::optional<double> value_at(const Scalar& f, double v, const Sample& a,
                                         const Sample& b) = 0;
  // A point's position at driver value v, from the samples lo, near, hi around it (near the
  // nearest).
  virtual std::optional<Eigen::Vector2d> position(const std::string& point, double v,
                                                  const Sample& lo, const Sample& near,
                                                  const Sample& hi) = 0;
};

// Exact: Newton at any driver value from the coordinates of the sweep sample beside it.
class ExactLocator : public Locator {
 public:
  ExactLocator(const Mechanism& m, const Trajectory& sweep)
      : m_(m), sweep_(sweep), solver_(m), state_(m) {
    one_.resize(m, 1);
    const Driver& d = m.swept();
    constant_speed_ = d.law.kind == MotionLaw::Kind::constant_speed && !d.at_rest();
    rate_ = constant_speed_ ? d.law.speed : 1.0;
  }
  double rate() const { return rate_; }

  // The exact pose at `v` (the interval's driver value of sample `near`), or nullptr; with
  // `positions`, a singular pose too (its rates do not exist).
  const Trajectory* pose(double v, const Sample& near, bool positions = false) {
    const double driver = sweep_.swept(near.row) + (v - near.v);
    coordinates(near.row);
    state_.swept() = {constant_speed_ ? (driver - m_.swept().start) / rate_ : 0.0, driver, rate_,
                      0.0};
    state_.factorized = false;
    const SolveReport r = solver_.solve(state_);
    if (!(positions ? has_position(r.status) : usable(r.status))) return nullptr;
    solver_.write_sample(state_, r, one_, 0);
    return &one_;
  }

  std::optional<Located> refine(const Scalar& f, const Sample& lo, const Sample& mid,
                                const Sample& hi, bool max) override {
    const double sign = max ? 1.0 : -1.0;
    // Rising then falling (for a max): bisection on the exact slope. Where a bracket's end has
    // no rate (a singular pose), golden section on the value below.
    const Trajectory* p = f.slope ? pose(lo.v, mid) : nullptr;
    const double fa = p ? sign * f.slope(*p, 0, rate_) : 0.0;
    p = p ? pose(hi.v, mid) : nullptr;
    if (p) {
      double a = lo.v, b = hi.v;
      const double fb = sign * f.slope(*p, 0, rate_);
      if (fa >= 0.0 && fb <= 0.0) {
        for (int i = 0; i < 200 && b - a > 4e-16 * (1.0 + std::abs(a)); ++i) {
          const double c = 0.5 * (a + b);
          p = pose(c, mid);
          if (!p) return std::nullopt;
          if (sign * f.slope(*p, 0, rate_) >= 0.0)
            a = c;
          else
            b = c;
        }
        const double v = 0.5 * (a + b);
        p = pose(v, mid);
        if (!p) return std::nullopt;
        return Located{v, f.value(*p, 0)};
      }
    }
    // Golden-section search on the exact value.
    auto value = [&](double v) -> std::optional<double> {
      const Trajectory* p = pose(v, mid, f.positions);
      if (!p) return std::nullopt;
      return sign * f.value(*p, 0);
    };
    const double v = golden_section_max(value, lo.v, hi.v);
    const std::optional<double> fv = value(v);
    if (!fv) return std::nullopt;
    return Located{v, sign * *fv};
  }

  std::optional<double> value_at(const Scalar& f, double v, const Sample& a,
                                 const Sample& b) override {
    const Trajectory* p = pose(v, std::abs(v - a.v) <= std::abs(v - b.v) ? a : b, f.positions);
    if (!p) return std::nullopt;
    return f.value(*p, 0);
  }

  std::optional<Eigen::Vector2d> position(const std::string& point, double v, const Sample&,
                                          const Sample& near, const Sample&) override {
    const Trajectory* p = pose(v, near, true);
    if (!p) return std::nullopt;
    return Eigen::Vector2d(at(*p, "x." + point, 0), at(*p, "y." + point, 0));
  }

 private:
  // state_.q from a sample: each moving link's angle, and its frame's origin from where its
  // first point is (a point name is one place).
  void coordinates(int row) {
    for (size_t l = 0; l < m_.links.size(); ++l) {
      const int k = m_.moving_index(static_cast<int>(l));
      if (k < 0) continue;
      const Point& p = m_.links[l].points.front();
      const auto c = static_cast<Eigen::Index>(
          std::find(sweep_.point_names.begin(), sweep_.point_names.end(), p.name) -
          sweep_.point_names.begin());
      const double theta = sweep_.angle(row, k);
      const Eigen::Vector2d world(sweep_.x(row, c), sweep_.y(row, c));
      const Eigen::Vector2d origin =
          world - Eigen::Vector2d(std::cos(theta) * p.local.x() - std::sin(theta) * p.local.y(),
                                  std::sin(theta) * p.local.x() + std::cos(theta) * p.local.y());
      state_.q.segment<3>(3 * k) << origin.x(), origin.y(), theta;
    }
  }

  const Mechanism& m_;
  const Trajectory& sweep_;
  NewtonSolver solver_;
  KinematicState state_;
  Trajectory one_;
  bool constant_speed_ = false;
  double rate_ = 1.0;
};

// From samples alone: the vertex of the parabola through three samples; linear between two.
class SampledLocator : public Locator {
 public:
  explicit SampledLocator(const Trajectory& t) : t_(t) {}
  std::optional<Located> refine(const Scalar& f, const Sample& lo, const Sample& mid,
                                const Sample& hi, bool) override {
    const double x0 = lo.v - mid.v, x2 = hi.v - mid.v;
    const double y0 = f.value(t_, lo.row), y1 = f.value(t_, mid.row), y2 = f.value(t_, hi.row);
    // y = y1 + b x + c x^2 through (x0, y0), (0, y1), (x2, y2).
    const double d0 = (y0 - y1) / x0, d2 = (y2 - y1) / x2;
    const double c = (d2 - d0) / (x2 - x0), b = d0 - c * x0;
    if (c == 0.0) return Located{mid.v, y1};
    const double x = std::clamp(-b / (2.0 * c), x0, x2);
    return Located{mid.v + x, y1 + b * x + c * x * x};
  }
  std::optional<double> value_at(const Scalar& f, double v, const Sample& a,
                                 const Sample& b) override {
    const double w = a.v == b.v ? 0.0 : (v - a.v) / (b.v - a.v);
    return f.value(t_, a.row) + w * (f.value(t_, b.row) - f.value(t_, a.row));
  }
  // The parabola through the three samples (Lagrange), in x and in y.
  std::optional<Eigen::Vector2d> position(const std::string& point, double v, const Sample& lo,
                                          const Sample& near, const Sample& hi) override {
    Eigen::Vector2d p = Eigen::Vector2d::Zero();
    const Sample* s[3] = {&lo, &near, &hi};
    for (int i = 0; i < 3; ++i) {
      double w = 1.0;
      for (int j = 0; j < 3; ++j)
        if (j != i) w *= (v - s[j]->v) / (s[i]->v - s[j]->v);
      p += w * Eigen::Vector2d(at(t_, "x." + point, s[i]->row), at(t_, "y." + point, s[i]->row));
    }
    return p;
  }

 private:
  const Trajectory& t_;
};

// The samples of an interval, in driver order along it.
struct Interval {
  std::vector<Sample> samples;
  bool periodic = false;  // the sweep's whole cycle: the last sample's neighbour is the first
  double period = 0.0;
  // A whole cycle's repeated last sample (-1: none solved) and the sign of its driver value less
  // the first sample's: it tells the turns a winding channel gains over the cycle.
  int closing_row = -1;
  double closing_sign = 1.0;
  double lower = 0.0, upper = 0.0;  // the interval's ends (not periodic)
  std::string empty_reason;
};

// How many times the value turns back over a whole cycle's samples, a turn counted once the
// value has come back from its extreme by 1e-3 of its range (a method's noise at a dwell is no
// turn): 2 for a rocker driven by a crank, 4 for one that swings twice a turn.
int reversals(const Scalar& f, const Trajectory& t, const Interval& in) {
  std::vector<double> v;
  for (const Sample& s : in.samples) v.push_back(f.value(t, s.row));
  if (v.size() < 3) return 0;
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  const double band = 1e-3 * (*hi - *lo);
  // One lap from the global max, falling first.
  const size_t n = v.size(), start = static_cast<size_t>(hi - v.begin());
  int turns = 0;
  bool rising = false;
  double extreme = *hi;
  for (size_t k = 1; k <= n; ++k) {
    const double x = v[(start + k) % n];
    if (rising ? x > extreme : x < extreme) {
      extreme = x;
    } else if (std::abs(x - extreme) > band) {
      ++turns;
      rising = !rising;
      extreme = x;
    }
  }
  return turns + (rising ? 1 : 0);  // back up to the max it started from: that turn too
}

Interval interval_of(const Mechanism& m, const DerivedSpec& spec, const Trajectory& t,
                     bool positions_only) {
  Interval out;
  const Driver& d = m.swept();
  const int n = t.samples();
  // An engine's sample outside its run holds no value, whatever the flag it keeps: counted, and
  // the interval then has no value from this method (never a placeholder, never across a gap).
  int not_run = 0;
  auto has = [&](int k) {
    const PoseStatus s = t.status[static_cast<size_t>(k)];
    const bool counts = positions_only ? has_position(s) : usable(s);
    if (counts && !t.was_run(k)) ++not_run;
    return counts && t.was_run(k);
  };
  const bool cycle = d.angular() && d.law.kind == MotionLaw::Kind::constant_speed && n > 2 &&
                     std::abs(t.along(n - 1) - t.along(0)) >= kTwoPi * (1.0 - 1e-9);
  if (!spec.range && cycle) {
    out.periodic = true;
    out.period = kTwoPi;
    const double direction = t.along(n - 1) > t.along(0) ? 1.0 : -1.0;
    // The cycle's samples in increasing driver order, its repeated last sample left out.
    for (int k = 0; k < n; ++k) {
      if (std::abs(t.along(k) - t.along(0)) >= kTwoPi * (1.0 - 1e-12)) {
        if (out.closing_row < 0 && has(k) && has(0)) out.closing_row = k;
        continue;
      }
      if (has(k)) out.samples.push_back({k, t.along(k)});
    }
    out.closing_sign = direction;
    if (direction < 0.0) std::reverse(out.samples.begin(), out.samples.end());
  } else {
    out.lower = spec.range ? spec.range->first : std::min(t.along(0), t.along(n - 1));
    out.upper = spec.range ? spec.range->second : std::max(t.along(0), t.along(n - 1));
    for (int k = 0; k < n; ++k) {
      // A whole cycle's repeated last sample is its first.
      if (spec.range && cycle && std::abs(t.along(k) - t.along(0)) >= kTwoPi * (1.0 - 1e-12))
        continue;
      double v = t.along(k);
      // An angular driver's interval is read modulo a turn from its lower end.
      if (spec.range && cycle)
        v = out.lower + std::fmod(std::fmod(v - out.lower, kTwoPi) + kTwoPi, kTwoPi);
      if (v >= out.lower - 1e-12 && v <= out.upper + 1e-12 && has(k)) out.samples.push_back({k, v});
    }
    std::sort(out.samples.begin(), out.samples.end(),
              [](const Sample& a, const Sample& b) { return a.v < b.v; });
  }
  if (not_run > 0)
    out.empty_reason = fmt::format(
        "the method was not run at {} of the interval's samples (outside its run: no value "
        "there), so its extremes over the interval are not known",
        not_run);
  else if (out.samples.size() < 3)
    out.empty_reason =
        fmt::format("the interval holds {} solved sample(s): 3 are needed", out.samples.size());
  return out;
}

// What f gains from a driver value to the same value a cycle later (increasing driver): the
// whole turns of a winding channel (a crank turning with the driver gains one), else 0.
double cycle_gain(const Scalar& f, const Trajectory& t, const Interval& in) {
  if (!in.periodic || !f.winds || in.closing_row < 0) return 0.0;
  const double gain = in.closing_sign * (f.value(t, in.closing_row) - f.value(t, 0));
  return kTwoPi * std::round(gain / kTwoPi);
}

// A local extreme of f located between its sample's neighbours (lo, mid, hi).
struct Turn {
  Located at;
  double v;  // at.v before a whole cycle's wrap: within [lo.v, hi.v]
  Sample lo, mid, hi;
};

// Every sample inside the interval that is a local max (or min) of f, refined by the locator
// (a whole cycle's first and last samples neighbour each other); with `limit`, only that many
// of the largest (smallest).
std::vector<Turn> turns(const Scalar& f, const Trajectory& t, const Interval& in, Locator& locator,
                        bool max, size_t limit = 0) {
  const auto& s = in.samples;
  const int n = static_cast<int>(s.size());
  const double sign = max ? 1.0 : -1.0;
  std::vector<double> y(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i)
    y[static_cast<size_t>(i)] = sign * f.value(t, s[static_cast<size_t>(i)].row);
  // Across the cycle's seam the neighbour is a cycle away: a crank's angle there is a turn on,
  // which is no reversal (read as one, its stroke was 361 degrees).
  const double gain = sign * cycle_gain(f, t, in);
  std::vector<int> local;
  for (int i = 0; i < n; ++i) {
    const bool first = i == 0, last = i == n - 1;
    if (!in.periodic && (first || last)) continue;
    const int ip = first ? n - 1 : i - 1, in_ = last ? 0 : i + 1;
    const double yi = y[static_cast<size_t>(i)];
    const double before = y[static_cast<size_t>(ip)] - (first ? gain : 0.0);
    const double after = y[static_cast<size_t>(in_)] + (last ? gain : 0.0);
    if (yi >= before && yi > after) local.push_back(i);
  }
  if (limit > 0 && local.size() > limit) {
    std::stable_sort(local.begin(), local.end(), [&](int a, int b) {
      return y[static_cast<size_t>(a)] > y[static_cast<size_t>(b)];
    });
    local.resize(limit);
  }
  std::vector<Turn> out;
  for (const int i : local) {
    const bool first = i == 0, last = i == n - 1;
    const int ip = first ? n - 1 : i - 1, in_ = last ? 0 : i + 1;
    Sample lo = s[static_cast<size_t>(ip)], hi = s[static_cast<size_t>(in_)];
    if (first) lo.v -= in.period;
    if (last) hi.v += in.period;
    std::optional<Located> c = locator.refine(f, lo, s[static_cast<size_t>(i)], hi, max);
    if (!c) continue;
    const double v = c->v;
    // A whole cycle's driver values are given within [0, 2 pi).
    if (in.periodic) c->v = std::fmod(std::fmod(c->v, in.period) + in.period, in.period);
    out.push_back({*c, v, lo, s[static_cast<size_t>(i)], hi});
  }
  return out;
}

// The largest (max) or smallest value of f over the interval: every sample that is a local
// extreme refined by the locator, and the interval's ends (not periodic).
// In a whole cycle without a local extreme (a crank's angle) there is none: `turns_back` is
// then false.
std::optional<Located> extreme(const Scalar& f, const Trajectory& t, const Interval& in,
                               Locator& locator, bool max, bool* turns_back = nullptr) {
  const auto& s = in.samples;
  const int n = static_cast<int>(s.size());
  const double sign = max ? 1.0 : -1.0;
  std::vector<Located> candidates;
  const std::vector<Turn> found = turns(f, t, in, locator, max);
  for (const Turn& turn : found) candidates.push_back(turn.at);
  if (turns_back) *turns_back = !in.periodic || !found.empty() || cycle_gain(f, t, in) == 0.0;
  if (!in.periodic) {
    for (const bool lower : {true, false}) {
      const double v = lower ? in.lower : in.upper;
      const Sample& a = lower ? s[0] : s[static_cast<size_t>(n - 1)];
      const Sample& b = lower ? s[1] : s[static_cast<size_t>(n - 2)];
      // An end that cannot be solved leaves the extreme unknown, never the other end's.
      const std::optional<double> value = locator.value_at(f, v, a, b);
      if (!value) return std::nullopt;
      candidates.push_back(Located{v, *value, false});
    }
  }
  std::optional<Located> best;
  for (const Located& c : candidates)
    if (!best || sign * c.value > sign * best->value) best = c;
  if (!best) return best;
  // Equal extremes (a symmetric motion's two maxima) are a tie: within rounding, 1e-9 of the
  // channel's magnitude over the interval, each is the extreme's location.
  double magnitude = 0.0;
  for (const Sample& x : s) magnitude = std::max(magnitude, std::abs(f.value(t, x.row)));
  for (const Located& c : candidates)
    if (c.v != best->v && std::abs(c.value - best->value) <= 1e-9 * magnitude)
      best->ties.push_back(c.v);
  return best;
}

// Circularity: the zone between two concentric circles holding a point's path.
struct Annulus {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double inner = 0.0, outer = 0.0;
  double width() const { return outer - inner; }
};

Annulus about(const std::vector<Eigen::Vector2d>& q, const Eigen::Vector2d& c) {
  Annulus a{c, INFINITY, -INFINITY};
  for (const Eigen::Vector2d& p : q) {
    a.inner = std::min(a.inner, (p - c).norm());
    a.outer = std::max(a.outer, (p - c).norm());
  }
  return a;
}

// The narrowest annulus holding a few points: its centre is equidistant from three of them (a
// vertex of their nearest- or farthest-point Voronoi diagram) or from two pairs (two points on
// each circle: where the pairs' bisectors cross), so every such centre is tried. None when no
// centre is finite (the points are collinear).
std::optional<Annulus> narrowest_annulus(std::vector<Eigen::Vector2d> q) {
  // About the first point, so that |p|^2 keeps the digits of the differences.
  const Eigen::Vector2d origin = q.front();
  for (Eigen::Vector2d& p : q) p -= origin;
  std::optional<Annulus> best;
  // The centre c with (b - a).c = (|b|^2 - |a|^2) / 2 and (d - c').c = (|d|^2 - |c'|^2) / 2.
  auto bisectors = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                       const Eigen::Vector2d& d) {
    const Eigen::Vector2d u = b - a, w = d - c;
    const double det = cross(u, w);
    if (!(std::abs(det) > 1e-14 * u.norm() * w.norm())) return;
    const double e = 0.5 * (b.squaredNorm() - a.squaredNorm()),
                 f = 0.5 * (d.squaredNorm() - c.squaredNorm());
    const Eigen::Vector2d centre((e * w.y() - f * u.y()) / det, (u.x() * f - w.x() * e) / det);
    const Annulus zone = about(q, centre);
    if (!best || zone.width() < best->width()) best = zone;
  };
  const size_t m = q.size();
  for (size_t i = 0; i < m; ++i)
    for (size_t j = i + 1; j < m; ++j) {
      for (size_t k = j + 1; k < m; ++k) bisectors(q[i], q[j], q[i], q[k]);  // three equidistant
      for (size_t k = i + 1; k < m; ++k)                                     // two pairs
        for (size_t l = k + 1; l < m; ++l)
          if (k != j && l != j) bisectors(q[i], q[j], q[k], q[l]);
    }
  if (best) best->centre += origin;
  return best;
}

// The distance of a point from c, with its rate.
Scalar distance_from(const std::string& point, const Eigen::Vector2d& c) {
  Scalar f;
  f.value = [point, c](const Trajectory& t, int row) {
    return std::hypot(at(t, "x." + point, row) - c.x(), at(t, "y." + point, row) - c.y());
  };
  f.slope = [point, c](const Trajectory& t, int row, double rate) {
    const double dx = at(t, "x." + point, row) - c.x(), dy = at(t, "y." + point, row) - c.y();
    const double r = std::hypot(dx, dy);
    return r > 0.0 ? (dx * at(t, "vx." + point, row) + dy * at(t, "vy." + point, row)) / (r * rate)
                   : 0.0;
  };
  return f;
}

// The polar angle of a point about c on the branch within pi of `branch`, with its rate.
Scalar polar_angle(const std::string& point, const Eigen::Vector2d& c, double branch) {
  Scalar f;
  f.value = [point, c, branch](const Trajectory& t, int row) {
    const double a = std::atan2(at(t, "y." + point, row) - c.y(), at(t, "x." + point, row) - c.x());
    return branch + std::remainder(a - branch, kTwoPi);
  };
  f.slope = [point, c](const Trajectory& t, int row, double rate) {
    const Eigen::Vector2d r(at(t, "x." + point, row) - c.x(), at(t, "y." + point, row) - c.y());
    const Eigen::Vector2d v(at(t, "vx." + point, row), at(t, "vy." + point, row));
    return r.squaredNorm() > 0.0 ? cross(r, v) / (r.squaredNorm() * rate) : 0.0;
  };
  return f;
}

// The path's points nearest to and farthest from c: the located turns of its distance (the few
// largest and smallest: the rest are not the zone's) and the interval's ends.
std::optional<std::vector<Eigen::Vector2d>> radial_extremes(const std::string& point,
                                                            const Eigen::Vector2d& c,
                                                            const Trajectory& t, const Interval& in,
                                                            Locator& locator) {
  const Scalar f = distance_from(point, c);
  std::vector<Eigen::Vector2d> out;
  for (const bool max : {true, false})
    for (const Turn& turn : turns(f, t, in, locator, max, 4)) {
      const auto p = locator.position(point, turn.v, turn.lo, turn.mid, turn.hi);
      if (!p) return std::nullopt;
      out.push_back(*p);
    }
  if (!in.periodic) {
    const auto& s = in.samples;
    const size_t n = s.size();
    const auto lower = locator.position(point, in.lower, s[1], s[0], s[2]);
    const auto upper = locator.position(point, in.upper, s[n - 2], s[n - 1], s[n - 3]);
    if (!lower || !upper) return std::nullopt;
    out.push_back(*lower);
    out.push_back(*upper);
  }
  return out;
}

// The minimum-zone circle of the point's path over the interval, from the centre c (Remez's
// exchange, as for a Chebyshev fit): the path's extreme points about c and the last zone's
// contacts give a narrower zone's centre; a zone of some of the path's points is never wider
// than the path's own minimum zone, so once the path's zone about c is as narrow (to `within`
// of its radius), c is the centre. `why` says why there is none.
std::optional<Annulus> min_zone_circle(const std::string& point, Eigen::Vector2d c,
                                       const Trajectory& t, const Interval& in, Locator& locator,
                                       double within, std::string& why) {
  std::vector<Eigen::Vector2d> contacts;
  std::optional<Annulus> best;
  double best_gap = INFINITY;
  for (int iteration = 0; iteration < 40; ++iteration) {
    const auto extremes = radial_extremes(point, c, t, in, locator);
    if (!extremes) {
      why = "a pose of the path could not be solved";
      return std::nullopt;
    }
    const Annulus path = about(*extremes, c);
    std::vector<Eigen::Vector2d> q = contacts;
    q.insert(q.end(), extremes->begin(), extremes->end());
    const std::optional<Annulus> next = narrowest_annulus(q);
    double size = 0.0;
    for (const Eigen::Vector2d& p : q) size = std::max(size, (p - q.front()).norm());
    // A centre a million times the path's size away: the zone tends to the minimum-zone line.
    if (!next || next->outer > 1e6 * size) {
      why =
          "no circle fits the path better than a straight line (the narrowest zone's radius "
          "grows without bound)";
      return std::nullopt;
    }
    const double gap = path.width() - next->width();
    if (!best || path.width() < best->width()) {
      best = path;
      best_gap = gap;
    } else if (iteration > 3) {
      break;  // no narrower: round-off
    }
    if (gap <= within * path.outer) return path;
    contacts.clear();
    for (const Eigen::Vector2d& p : q) {
      const double r = (p - next->centre).norm();
      if (std::abs(r - next->inner) <= 1e-9 * next->outer ||
          std::abs(r - next->outer) <= 1e-9 * next->outer)
        contacts.push_back(p);
    }
    c = next->centre;
  }
  if (best && best_gap <= within * best->outer) return best;
  why = "the minimum zone did not converge";
  return std::nullopt;
}

// The algebraic least-squares circle through the samples (Kasa's), a start for the zone's
// centre; none when the samples are collinear.
std::optional<Eigen::Vector2d> least_squares_centre(const std::string& point, const Trajectory& t,
                                                    const Interval& in) {
  const auto n = static_cast<Eigen::Index>(in.samples.size());
  const Eigen::Vector2d origin(at(t, "x." + point, in.samples[0].row),
                               at(t, "y." + point, in.samples[0].row));
  Eigen::MatrixXd a(n, 3);
  Eigen::VectorXd b(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const int row = in.samples[static_cast<size_t>(i)].row;
    const Eigen::Vector2d p =
        Eigen::Vector2d(at(t, "x." + point, row), at(t, "y." + point, row)) - origin;
    a.row(i) << p.x(), p.y(), 1.0;
    b(i) = -p.squaredNorm();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::Vector3d s = svd.singularValues();
  if (!(s(2) > 1e-12 * s(0))) return std::nullopt;
  const Eigen::Vector3d def = svd.solve(b);
  if (!def.allFinite()) return std::nullopt;
  return origin - 0.5 * Eigen::Vector2d(def(0), def(1));
}

// The angle the path spans seen from c: max - min of its polar angle followed along the path (a
// whole cycle around c: a full turn per winding).
std::optional<double> angular_extent(const std::string& point, const Eigen::Vector2d& c,
                                     const Trajectory& t, const Interval& in, Locator& locator) {
  const auto& s = in.samples;
  const size_t n = s.size();
  std::vector<double> phi(n);
  for (size_t i = 0; i < n; ++i) {
    const double a =
        std::atan2(at(t, "y." + point, s[i].row) - c.y(), at(t, "x." + point, s[i].row) - c.x());
    phi[i] = i == 0 ? a : phi[i - 1] + std::remainder(a - phi[i - 1], kTwoPi);
  }
  if (in.periodic) {
    const double winding =
        std::round((phi[n - 1] + std::remainder(phi[0] - phi[n - 1], kTwoPi) - phi[0]) / kTwoPi);
    if (winding != 0.0) return kTwoPi * std::abs(winding);
  }
  // Each extreme on the branch of its own samples.
  double lo = INFINITY, hi = -INFINITY;
  for (size_t i = 0; i < n; ++i) {
    const bool first = i == 0, last = i + 1 == n;
    if (!in.periodic && (first || last)) continue;
    const size_t ip = first ? n - 1 : i - 1, in_ = last ? 0 : i + 1;
    for (const bool max : {true, false}) {
      const double sign = max ? 1.0 : -1.0;
      if (!(sign * phi[i] >= sign * phi[ip] && sign * phi[i] > sign * phi[in_])) continue;
      Sample a = s[ip], b = s[in_];
      if (first) a.v -= in.period;
      if (last) b.v += in.period;
      const std::optional<Located> e =
          locator.refine(polar_angle(point, c, phi[i]), a, s[i], b, max);
      if (!e) return std::nullopt;
      lo = std::min(lo, e->value);
      hi = std::max(hi, e->value);
    }
  }
  if (!in.periodic)
    for (const bool lower : {true, false}) {
      const size_t i = lower ? 0 : n - 1, j = lower ? 1 : n - 2;
      const std::optional<double> e =
          locator.value_at(polar_angle(point, c, phi[i]), lower ? in.lower : in.upper, s[i], s[j]);
      if (!e) return std::nullopt;
      lo = std::min(lo, *e);
      hi = std::max(hi, *e);
    }
  return hi - lo;
}

DerivedValue none(const DerivedSpec& spec, std::string reason) {
  DerivedValue out;
  out.spec = &spec;
  for (const std::string& name : derived_fields(spec.kind))
    out.fields.push_back({name, DerivedUnit::channel, std::nullopt});
  out.reason = std::move(reason);
  return out;
}

DerivedValue compute(const Mechanism& m, const DerivedSpec& spec, const Trajectory& t,
                     Locator& locator, bool exact) {
  using K = DerivedSpec::Kind;
  DerivedValue out = none(spec, "");
  for (DerivedField& f : out.fields) f.unit = derived_field_unit(spec.kind, f.name);
  auto set = [&](std::string_view name, double value) {
    for (DerivedField& f : out.fields)
      if (f.name == name) f.value = value;
  };
  auto fail = [&](std::string reason) {
    DerivedValue v = none(spec, std::move(reason));
    for (DerivedField& f : v.fields) f.unit = derived_field_unit(spec.kind, f.name);
    return v;
  };
  if (t.samples() == 0) return fail("the method has no samples");
  // A channel the method does not report (a follower's jerk, in an engine): one sample asked.
  if (!spec.channel.empty() && !t.sample(spec.channel, 0))
    return fail(fmt::format("the method does not report {}", spec.channel));
  if (spec.kind == K::toggles) {
    if (!exact) return fail("toggles are located by the exact tracer, not read off samples");
    std::vector<double> toggles;
    for (const Trajectory::Event& e : t.events)
      if (e.kind == PoseStatus::singular && e.message.starts_with("toggle:"))
        toggles.push_back(e.driver);
    if (toggles.empty()) return fail("the sweep meets no toggle");
    out.fields.clear();
    for (size_t i = 0; i < toggles.size(); ++i)
      out.fields.push_back({fmt::format("toggle{}", i + 1), DerivedUnit::driver, toggles[i]});
    return out;
  }
  if (spec.kind == K::jump_speed) {
    if (!exact)
      return fail(
          "the jump speed is found from exact kinetostatic solves at three speeds at each pose; "
          "a method's samples, at one speed, do not give it");
    const JumpSpeed jump = jump_speed(m, m.find_joint(spec.cam));
    if (!jump.speed) return fail(jump.reason);
    set("speed", *jump.speed);
    set("at", jump.at);
    return out;
  }
  const bool positions = spec.kind == K::straightness || spec.kind == K::circularity ||
                         spec.kind == K::least_radius ||
                         Trajectory::quantity_of(spec.channel) == Quantity::position ||
                         Trajectory::quantity_of(spec.channel) == Quantity::angle;
  const Interval in = interval_of(m, spec, t, positions);
  if (!in.empty_reason.empty()) return fail(in.empty_reason);

  if (spec.kind == K::straightness) {
    // The minimum-zone line: the direction whose normal strip holding the path is narrowest,
    // coarse over the samples, then by golden section on the located width.
    auto width = [&](double theta, Locator& loc) -> std::optional<double> {
      const Scalar f = along(spec.point, {-std::sin(theta), std::cos(theta)});
      const auto hi = extreme(f, t, in, loc, true), lo = extreme(f, t, in, loc, false);
      if (!hi || !lo) return std::nullopt;
      return hi->value - lo->value;
    };
    SampledLocator coarse(t);
    const int directions = 720;
    double best = 0.0, best_width = INFINITY;
    for (int i = 0; i < directions; ++i) {
      const double theta = std::numbers::pi * i / directions;
      const Scalar f = along(spec.point, {-std::sin(theta), std::cos(theta)});
      double lo = INFINITY, hi = -INFINITY;
      for (const Sample& s : in.samples) {
        lo = std::min(lo, f.value(t, s.row));
        hi = std::max(hi, f.value(t, s.row));
      }
      if (hi - lo < best_width) {
        best_width = hi - lo;
        best = theta;
      }
    }
    const double g = 0.5 * (std::sqrt(5.0) - 1.0);
    double a = best - 2.0 * std::numbers::pi / directions,
           b = best + 2.0 * std::numbers::pi / directions;
    double c = b - g * (b - a), d = a + g * (b - a);
    std::optional<double> wc = width(c, locator), wd = width(d, locator);
    for (int i = 0; i < 60 && wc && wd; ++i) {
      if (*wc < *wd) {
        b = d;
        d = c;
        wd = wc;
        c = b - g * (b - a);
        wc = width(c, locator);
      } else {
        a = c;
        c = d;
        wc = wd;
        d = a + g * (b - a);
        wd = width(d, locator);
      }
    }
    const double theta = 0.5 * (a + b);
    const std::optional<double> w = width(theta, locator);
    const Scalar u = along(spec.point, {std::cos(theta), std::sin(theta)});
    const auto far = extreme(u, t, in, locator, true), near = extreme(u, t, in, locator, false);
    if (!w || !far || !near) return fail("a pose of the path could not be solved");
    set("deviation", 0.5 * *w);
    set("extent", far->value - near->value);
    set("direction", theta);
    return out;
  }

  if (spec.kind == K::circularity) {
    // Started from the samples' least-squares circle, the zone of the sampled path first (cheap;
    // its points are O(h^3) off the path, so to 1e-6 of the radius), then of the located one (to
    // round-off).
    const std::optional<Eigen::Vector2d> start = least_squares_centre(spec.point, t, in);
    if (!start)
      return fail(
          "the path is straight (its points are collinear): a circle through it has no "
          "finite radius");
    std::string why;
    SampledLocator coarse(t);
    std::optional<Annulus> zone = min_zone_circle(spec.point, *start, t, in, coarse, 1e-6, why);
    if (zone && exact)
      zone = min_zone_circle(spec.point, zone->centre, t, in, locator,
                             4.0 * std::numeric_limits<double>::epsilon(), why);
    if (!zone) return fail(why);
    const std::optional<double> extent = angular_extent(spec.point, zone->centre, t, in, locator);
    if (!extent) return fail("a pose of the path could not be solved");
    set("deviation", 0.5 * zone->width());
    set("radius", 0.5 * (zone->inner + zone->outer));
    set("centre_x", zone->centre.x());
    set("centre_y", zone->centre.y());
    set("extent", *extent);
    return out;
  }

  if (spec.kind == K::least_radius) {
    // The largest curvature at the contact over the interval, read from positions.
    const auto cam = std::find_if(t.cams.begin(), t.cams.end(),
                                  [&](const auto& c) { return c.reading.joint == spec.cam; });
    if (cam == t.cams.end())
      return fail(fmt::format("cam '{}' has no follower guided on the ground to read", spec.cam));
    // The same cam in any trajectory of the mechanism (an exact pose's too): by its place.
    const auto index = static_cast<size_t>(cam - t.cams.begin());
    Scalar curvature;
    curvature.value = [index](const Trajectory& p, int row) {
      return p.cams[index].at(p, row).curvature;
    };
    double least = INFINITY, most = -INFINITY;
    for (const Sample& s : in.samples) {
      least = std::min(least, curvature.value(t, s.row));
      most = std::max(most, curvature.value(t, s.row));
    }
    if (!(most > 0.0)) return fail("the profile is nowhere convex where the follower touches it");
    if (most - least <= 1e-12 * most) {  // one radius throughout (a disc): least everywhere
      set("radius", 1.0 / most);
      set("at", in.samples.front().v);
      return out;
    }
    const std::optional<Located> hi = extreme(curvature, t, in, locator, true);
    if (!hi) return fail("a pose near the largest curvature could not be solved");
    set("radius", 1.0 / hi->value);
    set("at", hi->v);
    out.fields.back().ties = hi->ties;
    return out;
  }
  const Scalar f = channel_scalar(spec.channel);
  bool hi_turns = true, lo_turns = true;
  const std::optional<Located> hi = extreme(f, t, in, locator, true, &hi_turns);
  const std::optional<Located> lo = extreme(f, t, in, locator, false, &lo_turns);
  if (!hi_turns || !lo_turns)
    return fail(
        fmt::format("{} turns whole turns over the cycle without turning back: it has no "
                    "max or min",
                    spec.channel));
  if (!hi || !lo) return fail("a pose near an extreme could not be solved");
  set("max", hi->value);
  set("at_max", hi->v);
  set("min", lo->value);
  set("at_min", lo->v);
  for (DerivedField& field : out.fields)
    if (field.name == "at_max" || field.name == "at_min")
      field.ties = field.name == "at_max" ? hi->ties : lo->ties;
  if (spec.kind == K::extremes || spec.kind == K::transmission) return out;
  if (hi->value - lo->value <= 1e-12 * std::max(1.0, std::abs(hi->value)))
    return fail(fmt::format("{} does not move over the interval", spec.channel));
  for (const Located* e : {&*lo, &*hi})
    if (!e->reversal)
      return fail(
          fmt::format("{} does not turn back inside the interval: its {} is at the interval's end",
                      spec.channel, e == &*hi ? "max" : "min"));
  set("stroke", hi->value - lo->value);
  if (spec.kind != K::time_ratio) return out;
  const Driver& d = m.swept();
  if (d.law.kind != MotionLaw::Kind::constant_speed)
    return fail("a time ratio needs a driver at constant speed (times are then driver spans)");
  if (!in.periodic)
    return fail("a time ratio needs the driver's whole cycle: the sweep is not periodic");
  if (const int turns = reversals(f, t, in); turns > 2)
    return fail(
        fmt::format("{} turns back {} times over the cycle: there is no one forward and "
                    "return stroke to time",
                    spec.channel, turns));
  // Driver travel from the min to the max, the way the driver turns.
  const double direction = d.law.speed > 0.0 ? 1.0 : -1.0;
  const double rising = std::fmod(std::fmod(direction * (hi->v - lo->v), kTwoPi) + kTwoPi, kTwoPi);
  const double falling = kTwoPi - rising;
  set("increasing", rising);
  set("decreasing", falling);
  set("ratio", std::max(rising, falling) / std::min(rising, falling));
  return out;
}

// A field that is not finite (samples a billion sizes out, whose parabola has no vertex) makes the
// quantity one that does not exist here: never a number passed on.
DerivedValue finite(DerivedValue v) {
  for (const DerivedField& f : v.fields)
    if (f.value && !std::isfinite(*f.value))
      return none(*v.spec, fmt::format("its {} is not a finite number on these samples", f.name));
  return v;
}

}  // namespace

const DerivedField* DerivedValue::field(std::string_view name) const {
  if (fields.empty()) return nullptr;
  if (name.empty() || (spec && name == spec->name)) return &fields.front();
  for (const DerivedField& f : fields)
    if (f.name == name) return &f;
  return nullptr;
}

std::vector<DerivedValue> derived_exact(const Mechanism& mechanism, const Trajectory& sweep) {
  std::vector<DerivedValue> out;
  if (mechanism.derived.empty()) return out;  // (none in a sweep in time: the loader refuses them)
  ExactLocator locator(mechanism, sweep);
  for (const DerivedSpec& spec : mechanism.derived)
    out.push_back(finite(compute(mechanism, spec, sweep, locator, true)));
  return out;
}

std::vector<DerivedValue> derived_sampled(const Mechanism& mechanism, const Trajectory& samples) {
  std::vector<DerivedValue> out;
  SampledLocator locator(samples);
  for (const DerivedSpec& spec : mechanism.derived)
    out.push_back(finite(compute(mechanism, spec, samples, locator, false)));
  return out;
}

std::optional<double> derived_value(const std::vector<DerivedValue>& values,
                                    std::string_view quantity) {
  const size_t dot = quantity.find('.');
  const std::string_view name = quantity.substr(0, dot);
  for (const DerivedValue& v : values) {
    if (!v.spec || v.spec->name != name) continue;
    const DerivedField* f =
        v.field(dot == std::string_view::npos ? std::string_view() : quantity.substr(dot + 1));
    if (f) return f->value;
  }
  return std::nullopt;
}

}  // namespace crosslink
