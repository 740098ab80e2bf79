#include "methods/study.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <map>
#include <optional>

#include "methods/engines.h"
#include "methods/jobs.h"
#include "methods/registry.h"
#include "sim/sampling.h"

namespace crosslink::methods {
namespace {

// The texts of `all` with an ENGINE: prefix, by engine, each prefix an engine's.
std::map<std::string, std::vector<std::string>> prefixed_settings(
    const std::vector<std::string>& all) {
  const std::vector<std::string> engines = engine_names();
  std::map<std::string, std::vector<std::string>> prefixed;
  for (const std::string& s : all) {
    (void)engine_settings("", {s});  // KEY=VALUE
    const std::string key = s.substr(0, s.find('='));
    if (const size_t colon = key.find(':'); colon != std::string::npos) {
      const std::string engine = key.substr(0, colon);
      if (std::find(engines.begin(), engines.end(), engine) == engines.end())
        throw std::invalid_argument(fmt::format("--set {}: '{}' is not an engine (engines: {})", s,
                                                engine, fmt::join(engines, ", ")));
      prefixed[engine].push_back(s);
    }
  }
  return prefixed;
}

compare::Tolerances tolerances_of(const Mechanism& m, const CompareOptions& options) {
  compare::Tolerances tolerances = default_tolerances(m);
  if (options.accuracy_pct)  // the accuracy asked for is the engines' tolerance
    for (const char* q :
         {"position", "angle", "velocity", "acceleration", "force", "torque", "energy"})
      tolerances.apply(fmt::format("{}={:.17g}", q, *options.accuracy_pct));
  for (const std::string& t : options.tolerances) {
    try {
      tolerances.apply(t);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("--tolerance: {}", e.what()));
    }
  }
  return tolerances;
}

// An explicit time step is refused before any engine runs when it would take more than the run's
// max_steps over the reference's span.
void check_engine_steps(const compare::MethodRun& reference, const std::string& engine,
                        const sim::Settings& settings) {
  const Trajectory& r = reference.trajectory;
  const double span = r.samples() > 1 ? r.time(r.samples() - 1) - r.time(0) : 0.0;
  std::optional<double> dt;
  long max_steps = sim::kDefaultMaxSteps;
  for (const auto& [key, value] : settings) {  // checked by the engine's schema
    if (key == "dt" && value != "auto") dt = sim::setting_number(key, value);
    if (key == "max_steps") max_steps = sim::setting_count(key, value, sim::kMostSteps);
  }
  if (dt) check_time_step(span, *dt, max_steps, fmt::format("--set dt={:g} ({})", *dt, engine));
}

// Each engine with a failing channel rerun at half its time step, every engine at once: one
// failing channel's max % of peak there (compare::StepProbe).
std::vector<compare::StepProbe> probe_steps(const Mechanism& m, const compare::Comparison& cmp,
                                            const std::vector<std::string>& names,
                                            const std::vector<sim::Settings>& settings,
                                            const compare::Tolerances& tolerances,
                                            const compare::ExactValues& exact, int jobs) {
  std::vector<compare::StepProbe> probes;
  std::vector<sim::Settings> halved;
  for (size_t k = 0; k < names.size(); ++k) {
    const compare::MethodRun* run = cmp.method(names[k]);
    if (!run || !run->ok || !find_engine(names[k])) continue;
    // The failing channel of the least differentiated class, the largest there: a position's
    // difference shows the step's order where an acceleration's is noisy, or saturated once
    // the motions part (a chaotic one's).
    const auto rank = [](Quantity q) {
      return q == Quantity::position || q == Quantity::angle ? 0
             : q == Quantity::velocity                       ? 1
             : q == Quantity::acceleration                   ? 2
                                                             : 3;
    };
    compare::StepProbe probe;
    probe.method = names[k];
    int best = 4;
    for (const compare::ChannelResult& c : cmp.channels) {
      if (c.method != names[k] || c.verdict != compare::Verdict::fail) continue;
      const int r = rank(c.metrics.quantity);
      if (r < best || (r == best && c.metrics.max_pct_of_peak > probe.pct)) {
        best = r;
        probe.channel = c.metrics.channel;
        probe.pct = c.metrics.max_pct_of_peak;
      }
    }
    if (probe.channel.empty() || !(run->cost.time_step > 0.0)) continue;  // passes, or no step
    probe.dt = run->cost.time_step;
    probe.half_dt = probe.dt / 2.0;
    sim::Settings half = settings[k];
    std::erase_if(half, [](const auto& kv) { return kv.first == "dt"; });
    half.emplace_back("dt", fmt::format("{:.17g}", probe.half_dt));
    probes.push_back(std::move(probe));
    halved.push_back(std::move(half));
  }
  run_jobs(jobs, probes.size(), [&](size_t k) {
    compare::StepProbe& probe = probes[k];
    compare::MethodRun run = run_method(probe.method, m, cmp.reference(), halved[k]);
    if (!run.ok) {
      probe.message = run.message;
      return;
    }
    const compare::Comparison half =
        compare::compare_methods(m, {cmp.reference(), std::move(run)}, tolerances, exact);
    for (const compare::ChannelResult& c : half.channels)
      if (c.metrics.channel == probe.channel && c.metrics.usable > 0) {
        probe.ok = true;
        probe.half_pct = c.metrics.max_pct_of_peak;
      }
    if (!probe.ok) probe.message = "no usable sample of " + probe.channel + " at half the step";
  });
  return probes;
}

}  // namespace

sim::Settings engine_settings(std::string_view engine, const std::vector<std::string>& all,
                              long max_steps) {
  sim::Settings out;
  if (max_steps > 0) out.emplace_back("max_steps", std::to_string(max_steps));
  for (const std::string& s : all) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos)
      throw std::invalid_argument(fmt::format("setting '{}': expected KEY=VALUE", s));
    std::string key = s.substr(0, eq);
    if (const size_t colon = key.find(':'); colon != std::string::npos) {
      if (key.substr(0, colon) != engine) continue;
      key = key.substr(colon + 1);
    }
    out.emplace_back(key, s.substr(eq + 1));
  }
  return out;
}

void check_setting_texts(const Mechanism& m, const std::vector<std::string>& all,
                         const std::vector<std::string>& runs) {
  std::map<std::string, std::vector<std::string>> prefixed = prefixed_settings(all);
  for (const std::string& engine : engine_names()) {
    const bool running = std::find(runs.begin(), runs.end(), engine) != runs.end();
    try {
      check_engine_settings(engine, m,
                            engine_settings(engine, running ? all : prefixed[engine], 0));
    } catch (const std::invalid_argument& e) {
      // A name one engine knows (or only reports) may be meant for another engine alone.
      const std::string_view what = e.what();
      const bool bare =
          running &&
          (what.starts_with("unknown") || what.ends_with("is reported by the run, not set")) &&
          std::any_of(all.begin(), all.end(), [](const std::string& s) {
            return s.substr(0, s.find('=')).find(':') == std::string::npos;
          });
      throw std::invalid_argument(fmt::format(
          "--set: {}{}", e.what(),
          bare ? "; a bare KEY=VALUE goes to every engine that runs, ENGINE:KEY=VALUE to one"
               : ""));
    }
  }
}

void check_time_step(double span, double dt, long max_steps, std::string_view option) {
  try {
    sim::check_steps(span / dt, dt, max_steps);
  } catch (const std::runtime_error& e) {
    throw std::invalid_argument(fmt::format("{}: {}", option, e.what()));
  }
}

void check_compare(const Mechanism& m, const CompareOptions& options) {
  const bool dynamics = m.dynamics.has_value();
  if (dynamics && options.step != 0.0)
    throw std::invalid_argument(
        "--step: a dynamics case is sampled at its [dynamics] interval, not swept");
  for (const std::string& n : options.methods)
    if (!is_method(n))
      throw std::invalid_argument(fmt::format("--engines: unknown method '{}' (valid: {})", n,
                                              fmt::join(method_names(), ", ")));
  (void)tolerances_of(m, options);
  check_setting_texts(m, options.settings, options.methods);
  SweepOptions sweep;
  sweep.step = options.step;
  if (dynamics)
    check_simulation_work(m, {}, "", options.limits);
  else
    check_sweep_work(m, sweep, options.limits);
  check_reference_work(m, options.limits);
  if (options.at && !dynamics)  // a report draws the pose there (solve_at)
    check_solve_at_work(m, *options.at, {}, options.limits);
}

compare::Comparison run_compare(const Mechanism& m, const CompareOptions& options) {
  check_compare(m, options);
  const compare::Tolerances tolerances = tolerances_of(m, options);
  SweepOptions sweep;
  sweep.step = options.step;
  std::vector<compare::MethodRun> runs;
  runs.push_back(m.dynamics ? run_simulation(m, {.max_solves = options.limits.max_solves})
                            : run_reference(m, sweep));
  std::vector<std::string> others;
  std::vector<sim::Settings> settings;
  for (const std::string& n : options.methods) {
    if (n == "analytic") continue;
    others.push_back(n);
    settings.push_back(engine_settings(n, options.settings, options.max_steps));
    if (find_engine(n)) check_engine_steps(runs.front(), n, settings.back());
  }
  // An accuracy search runs engine by engine (its runs over the threads) and says what it chose
  // in order; then every method at once, each into its slot.
  std::optional<ReferenceLadder> ladder;  // it solves the reference's exact values once
  if (options.accuracy_pct) {
    ladder.emplace(m, sweep, runs.front());
    for (size_t k = 0; k < others.size(); ++k) {
      if (!find_engine(others[k])) continue;
      const Selection s = cheapest_setting(m, *ladder, others[k], *options.accuracy_pct,
                                           accuracy_time_steps(ladder->interval()), settings[k],
                                           options.progress, 1, options.jobs);
      if (options.chose) options.chose(s);
      if (s.found) settings[k] = s.chosen.overrides;
    }
  }
  const size_t first = runs.size();
  runs.resize(first + others.size());
  run_jobs(options.jobs, others.size(), [&](size_t k) {
    runs[first + k] = run_method(others[k], m, runs.front(), settings[k]);
  });
  const compare::ExactValues exact =
      ladder ? ladder->exact_of(ladder->base()) : exact_values(m, runs.front());
  compare::Comparison cmp = compare::compare_methods(m, std::move(runs), tolerances, exact);
  cmp.step_probes = probe_steps(m, cmp, others, settings, tolerances, exact, options.jobs);
  return cmp;
}

}  // namespace crosslink::methods
