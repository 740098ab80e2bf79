#include "analytic/reference/trust.h"

#include "analytic/reference/sweep.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

namespace crosslink {

double driver_peak_rate(const Mechanism& mechanism, const Trajectory& trajectory) {
  double rate = 0.0;
  const Trajectory& t = trajectory;
  if (mechanism.dynamics && t.samples() >= 3) {
    // A forward-dynamics run follows no motion law: the coordinate's rate and acceleration over
    // the run by differences of the samples (a scale, not a result; a kinematic sweep of the
    // case gets its law's constant speed this way too). Fewer samples tell nothing: the law.
    // Each coordinate's in its own unit (rad, or the size for a slider).
    for (int d = 0; d < static_cast<int>(mechanism.drivers.size()); ++d) {
      double own = 0.0;
      for (int k = 1; k + 1 < t.samples(); ++k) {
        const double h0 = t.time(k) - t.time(k - 1);
        const double h1 = t.time(k + 1) - t.time(k);
        const double d0 = (t.driver_values(k, d) - t.driver_values(k - 1, d)) / h0;
        const double d1 = (t.driver_values(k + 1, d) - t.driver_values(k, d)) / h1;
        own = std::max(
            {own, std::abs(d0), std::abs(d1), std::sqrt(std::abs(2.0 * (d1 - d0) / (h0 + h1)))});
      }
      rate = std::max(
          rate, mechanism.drivers[static_cast<size_t>(d)].angular() ? own : own / mechanism.size());
    }
    return rate;
  }
  // The motion law's, over its whole cycle and at the samples' times: a property of the
  // mechanism, whatever few samples a sweep or a single pose has.
  const auto at = [&](double time) {
    for (const Driver& d : mechanism.drivers) {
      const DriverState s = d.at_time(time);
      const double unit = d.angular() ? 1.0 : mechanism.size();
      rate = std::max({rate, std::abs(s.rate) / unit, std::sqrt(std::abs(s.accel) / unit)});
    }
  };
  for (int k = 0; k < t.samples(); ++k) at(t.time(k));
  const double cycle = mechanism.cycle_period();
  if (cycle > 0.0)
    for (int k = 0; k <= 360; ++k) at(cycle * k / 360.0);
  return rate;
}

namespace {

// The characteristic scale of a kinematic channel (trust.h), or 0 for a channel that is
// not compared (forces, energy).
double channel_scale(std::string_view channel, double size, double rate) {
  const bool angular = Trajectory::angular(channel);
  switch (Trajectory::quantity_of(channel)) {
    case Quantity::position:
      return size;
    case Quantity::angle:
      return 1.0;
    case Quantity::velocity:
      return angular ? rate : rate * size;
    case Quantity::acceleration:
      return angular ? rate * rate : rate * rate * size;
    case Quantity::jerk:
      return angular ? rate * rate * rate : rate * rate * rate * size;
    default:
      return 0.0;
  }
}

}  // namespace

CrossCheck cross_check(const Mechanism& mechanism, Trajectory& reference,
                       const Trajectory& second) {
  CrossCheck out;
  out.method = second.method;
  const int n = reference.samples();
  if (second.samples() != n) return out;
  const double size = mechanism.size();
  const double typical = chain_rcond(mechanism, reference);
  // A driver at rest still has positions to compare; its rates are zero in both.
  const double rate = std::max(driver_peak_rate(mechanism, reference), 1e-12);
  struct Column {
    std::string name;
    Eigen::VectorXd a, b;
    double scale;
    bool angle;
    int order;  // 2 for accelerations: their round-off is the rates' squared, amplified twice
  };
  std::vector<Column> columns;
  for (const std::string& c : reference.channel_names()) {
    const double scale = channel_scale(c, size, rate);
    const auto b = second.channel(c);
    if (scale <= 0.0 || !b) continue;
    const Quantity q = Trajectory::quantity_of(c);
    columns.push_back({c, *reference.channel(c), *b, scale, q == Quantity::angle,
                       q == Quantity::acceleration ? 2
                       : q == Quantity::jerk       ? 3
                                                   : 1});
  }
  for (int k = 0; k < n; ++k) {
    const auto ks = static_cast<size_t>(k);
    if (!usable(reference.status[ks])) continue;
    std::string why;
    if (second.status[ks] == PoseStatus::singular) {
      // A singular position the reference's own conditioning limit let through (a change point
      // on the grid): the sample is singular, named as the reference names its own.
      reference.status[ks] = PoseStatus::singular;
      reference.events.push_back(
          {reference.along(k), PoseStatus::singular,
           fmt::format("{} find a singular position here (Newton's rcond {:.2g}): rates and "
                       "joint reactions are not determined",
                       second.method, reference.rcond(k))});
      ++out.singular;
      continue;
    }
    if (!usable(second.status[ks])) {
      why = fmt::format("{} finds the sample {}", second.method, to_string(second.status[ks]));
    } else {
      ++out.compared;
      // Round-off in the rates grows as the Jacobian's condition: the allowance grows with it
      // beyond the chain's own conditioning.
      const double amplification = std::max(1.0, typical / reference.rcond(k));
      double worst = 0.0;
      const Column* at = nullptr;
      for (const Column& c : columns) {
        double d = c.b(k) - c.a(k);
        if (c.angle) d = std::remainder(d, 2.0 * std::numbers::pi);
        const double relative =
            std::abs(d) / c.scale / (c.order == 2 ? amplification * amplification : amplification);
        if (!(relative <= worst)) {  // NaN counts as the worst
          worst = relative;
          at = &c;
        }
      }
      if (at && !(worst <= kExactAgreement))
        why = fmt::format("{} = {:.9g} against {} = {:.9g} ({:.2g} of its scale)", at->name,
                          at->a(k), second.method, at->b(k),
                          worst * (at->order == 2 ? amplification * amplification : amplification));
      else if (worst > out.worst) {
        out.worst = worst;
        out.worst_channel = at ? at->name : "";
      }
    }
    if (why.empty()) continue;
    reference.status[ks] = PoseStatus::exact_methods_disagree;
    reference.events.push_back(
        {reference.along(k), PoseStatus::exact_methods_disagree, "exact methods disagree: " + why});
    ++out.disagree;
  }
  return out;
}

double chain_rcond(const Mechanism& mechanism, const Trajectory& reference) {
  int solved = 0;
  for (int k = 0; k < reference.samples(); ++k)
    solved += usable(reference.status[static_cast<size_t>(k)]);
  if (solved >= kConditioningSamples) return typical_rcond(reference);
  // A pose or a few samples say nothing of the chain's own conditioning (one sample is its
  // own median, next to a toggle too): the sweep's, at 10 degrees (a slider's 1/36 of its range).
  SweepOptions coarse;
  if (mechanism.axis().timed() || mechanism.swept().angular())
    coarse.step = std::numbers::pi / 18.0;
  try {
    const Trajectory cycle = sweep(mechanism, coarse);
    return typical_rcond(cycle);
  } catch (const std::exception&) {
    return typical_rcond(reference);  // refused (a change point drawn): its own, as before
  }
}

double typical_rcond(const Trajectory& reference) {
  std::vector<double> solved;
  for (int k = 0; k < reference.samples(); ++k)
    if (usable(reference.status[static_cast<size_t>(k)])) solved.push_back(reference.rcond(k));
  if (solved.empty()) return 1.0;
  const auto middle = solved.begin() + static_cast<std::ptrdiff_t>(solved.size() / 2);
  std::nth_element(solved.begin(), middle, solved.end());
  return *middle;
}

std::string untrusted(const Trajectory& reference, int k, double force_rcond) {
  const PoseStatus s = reference.status[static_cast<size_t>(k)];
  if (!usable(s)) return "reference:" + std::string(to_string(s));
  if (reference.beside_singular(k)) return "beside_singular";
  if (reference.beside_stop(k)) return "beside_stop";
  if (reference.rcond(k) < force_rcond) return "ill_conditioned";
  return "";
}

}  // namespace crosslink
