#include "methods/engines.h"

#include <fmt/format.h>

#include <algorithm>

#include "sim/bullet/bullet_engine.h"
#include "sim/mujoco/mujoco_engine.h"
#include "sim/ode/ode_engine.h"
#include "sim/simbody/simbody_engine.h"

namespace crosslink::methods {
namespace {

// Kinematic cases. Positions, angles, velocities, accelerations: closed loops stepped against the
// exact sweep. Forces and torques: measured at the engines' defaults over every bundled
// mechanism, without and with gravity (bench/force_accuracy, docs/engines-measured.md "Forces"),
// worst channel: MuJoCo 0.014 %, Bullet 0.21 % (polycentric hinge near its limits; 0.10 %
// elsewhere). Energy: only dynamics cases have energy channels.
constexpr compare::ClassTolerances kKinematic = {1e-2, 1e-2, 0.1, 1.0, 0.05, 0.05, 1e-2};
// Forward dynamics (docs/dynamics.md, "Engines"). A run's error is mostly a phase error that
// grows along it and shows in positions, velocities and accelerations alike (measured within
// 25 % of each other), so they share the kinematic position tolerance, 1e-4 of the scale, and so
// does the energy balance (of the energy scale); accelerations (and forces) are sensitive next
// to singular positions, 10 times looser. Measured at the defaults on IFToMM A02 with N = 2 over
// 10 s (position / velocity / acceleration / force / energy, % of scale): MuJoCo 0.0031 /
// 0.0031 / 0.0038 / 0.011 / 0.0027, Bullet 0.0038 / 0.0038 / 0.0047 / 0.014 / 0.0034.
constexpr compare::ClassTolerances kDynamics = {0.01, 0.01, 0.01, 0.1, 0.05, 0.05, 0.01};

// Bullet's forces: its measured worst (above) under 0.3 %.
compare::ClassTolerances with_forces(compare::ClassTolerances t, double percent) {
  t.force = t.torque = percent;
  return t;
}

std::function<sim::Settings(double)> fixed(sim::Settings s) {
  return [s](double) { return s; };
}

std::vector<EngineEntry> make_table() {
  return {
      {.name = "mujoco",
       .description = "MuJoCo 2.2.2 scene",
       .style = {"#1f77b4", {6, 2}},
       .make = sim::make_mujoco_engine,
       .tolerances = kKinematic,
       .dynamics_tolerances = kDynamics,
       .variants =
           {
               {"Euler/Newton", fixed({})},
               // Both trip the engine's 1e-3 rad driver watch on the first step of its start-up
               // (measured; docs/sweep.md): watched at 0.05 rad instead, so their errors show.
               {"implicit/Newton, driver watch 0.05 rad",
                fixed({{"integrator", "implicit"}, {"driver_threshold", "0.05"}})},
               {"RK4/Newton, driver watch 0.05 rad",
                fixed({{"integrator", "RK4"}, {"driver_threshold", "0.05"}})},
               {"Euler/CG", fixed({{"solver", "CG"}})},
               {"Euler/PGS", fixed({{"solver", "PGS"}})},
               // The engine-notes' softness: time constant 2 dt, damping ratio 0.5.
               {"Euler/Newton solref (2dt, 0.5)",
                [](double dt) {
                  return sim::Settings{{"solref", fmt::format("{:.9g} 0.5", 2.0 * dt)}};
                }},
               // MuJoCo's own defaults for the loop constraints (the driver stays stiff).
               {"Euler/Newton soft (MuJoCo default solref 0.02 1)",
                fixed({{"solref", "0.02 1"}, {"solimp", "0.9 0.95 0.001 0.5 2"}})},
           },
       // Forward dynamics: no driver to watch; its integrators and solvers, its own default
       // softness.
       .dynamics_variants =
           {
               {"Euler/Newton", fixed({})},
               {"implicit/Newton", fixed({{"integrator", "implicit"}})},
               {"RK4/Newton", fixed({{"integrator", "RK4"}})},
               {"Euler/CG", fixed({{"solver", "CG"}})},
               {"Euler/PGS", fixed({{"solver", "PGS"}})},
               {"Euler/Newton soft (MuJoCo default solref 0.02 1)",
                fixed({{"solref", "0.02 1"}, {"solimp", "0.9 0.95 0.001 0.5 2"}})},
           },
       // Joint friction (docs/engines.md, "Joint friction"): its load one step late, and
       // MuJoCo's own friction softness.
       .friction_variants =
           {
               {"Euler/Newton friction load of the last step", fixed({{"friction_load", "last"}})},
               {"Euler/Newton friction solref 0.02 1 (MuJoCo default)",
                fixed({{"friction_solref", "0.02 1"}})},
           }},
      {.name = "bullet",
       .description = "Bullet 3.24 float64 scene",
       .style = {"#d62728", {4, 2, 1, 2}},
       .make = sim::make_bullet_engine,
       .tolerances = with_forces(kKinematic, 0.3),
       .dynamics_tolerances = with_forces(kDynamics, 0.3),
       .variants =
           {
               {"rigid/MLCP Dantzig erp 1", fixed({})},
               {"multibody/MLCP Dantzig erp 1", fixed({{"formulation", "multibody"}})},
               {"rigid/MLCP Dantzig erp 0.2", fixed({{"erp", "0.2"}})},
               {"rigid/SI 100 it erp 1",
                fixed({{"solver", "sequential_impulse"}, {"iterations", "100"}})},
               {"rigid/SI 10 it erp 1",
                fixed({{"solver", "sequential_impulse"}, {"iterations", "10"}})},
               {"multibody/SI 100 it erp 1", fixed({{"formulation", "multibody"},
                                                    {"solver", "sequential_impulse"},
                                                    {"iterations", "100"}})},
           },
       // Forward dynamics: its formulations and solvers.
       .dynamics_variants =
           {
               {"rigid/MLCP Dantzig erp 1", fixed({})},
               {"multibody/MLCP Dantzig erp 1", fixed({{"formulation", "multibody"}})},
               {"rigid/MLCP Dantzig erp 0.2", fixed({{"erp", "0.2"}})},
               {"rigid/SI 100 it erp 1",
                fixed({{"solver", "sequential_impulse"}, {"iterations", "100"}})},
               {"multibody/SI 100 it erp 1", fixed({{"formulation", "multibody"},
                                                    {"solver", "sequential_impulse"},
                                                    {"iterations", "100"}})},
           },
       // Joint friction: its load one step late, and softer friction rows.
       .friction_variants =
           {
               {"rigid/MLCP Dantzig friction load of the last step",
                fixed({{"friction_load", "last"}})},
               {"rigid/MLCP Dantzig friction cfm 1e-6", fixed({{"friction_cfm", "1e-6"}})},
           }},
      {.name = "ode",
       .description = "ODE 0.16 double-precision scene",
       .style = {"#ff7f0e", {10, 3}},
       .make = sim::make_ode_engine,
       // Bullet's rigid bodies' tolerances: the same scene (maximal coordinates, an exact solve,
       // ERP 1, semi-implicit Euler) gives the same numbers to 3 digits on every bundled
       // definition (measured with compare and bench/force_accuracy; docs/engines.md, "ODE").
       .tolerances = with_forces(kKinematic, 0.3),
       .dynamics_tolerances = with_forces(kDynamics, 0.3),
       .variants =
           {
               {"dWorldStep erp 1 cfm 1e-10", fixed({})},
               {"dWorldQuickStep 20 it", fixed({{"stepper", "quick"}})},
               {"dWorldQuickStep 100 it", fixed({{"stepper", "quick"}, {"iterations", "100"}})},
               {"dWorldStep erp 0.2 (ODE default)", fixed({{"erp", "0.2"}})},
               {"dWorldStep cfm 1e-5 (ODE float default)", fixed({{"cfm", "1e-5"}})},
               {"dWorldStep finite rotation off", fixed({{"finite_rotation", "0"}})},
           },
       // Forward dynamics: the same solvers and softness.
       .dynamics_variants =
           {
               {"dWorldStep erp 1 cfm 1e-10", fixed({})},
               {"dWorldQuickStep 20 it", fixed({{"stepper", "quick"}})},
               {"dWorldQuickStep 100 it", fixed({{"stepper", "quick"}, {"iterations", "100"}})},
               {"dWorldStep erp 0.2 (ODE default)", fixed({{"erp", "0.2"}})},
               {"dWorldStep cfm 1e-5 (ODE float default)", fixed({{"cfm", "1e-5"}})},
               {"dWorldStep finite rotation off", fixed({{"finite_rotation", "0"}})},
           },
       // Joint friction: its load one step late, and softer friction motors.
       .friction_variants =
           {
               {"dWorldStep friction load of the last step", fixed({{"friction_load", "last"}})},
               {"dWorldStep friction cfm 1e-6", fixed({{"friction_cfm", "1e-6"}})},
           }},
      // Simbody: reduced coordinates, error-controlled integration and constraint projection
      // (docs/engines.md, "Simbody"). Its forces are read at exact states (crank-rocker under
      // gravity: 1.4e-9 % of peak; A02 over its first 0.6 s: 7.3e-11 m), far inside the common
      // tolerances. Variants: its integrators, its error control (which at the default report
      // spacing sets nothing: 1e-6 and 1e-10 gave the same numbers, measured), interpolated
      // reports, and a loose projection.
      {.name = "simbody",
       .description = "Simbody 3.7 multibody system",
       .style = {"#17becf", {3, 3, 9, 3}},
       .make = sim::make_simbody_engine,
       .tolerances = kKinematic,
       .dynamics_tolerances = kDynamics,
       .variants =
           {
               {"Merson accuracy 1e-8", fixed({})},
               {"Merson interpolated reports", fixed({{"interpolate", "1"}})},
               {"RK3 accuracy 1e-8", fixed({{"integrator", "rk3"}})},
               {"Merson constraint tolerance 1e-6", fixed({{"constraint_tolerance", "1e-6"}})},
           },
       .dynamics_variants =
           {
               {"Merson accuracy 1e-8", fixed({})},
               {"Merson accuracy 1e-6", fixed({{"accuracy", "1e-6"}})},
               {"Merson accuracy 1e-10", fixed({{"accuracy", "1e-10"}})},
               {"Feldberg accuracy 1e-8", fixed({{"integrator", "feldberg"}})},
               {"CPodes accuracy 1e-8", fixed({{"integrator", "cpodes"}})},
               {"Merson constraint tolerance 1e-6", fixed({{"constraint_tolerance", "1e-6"}})},
           },
       // Joint friction: its regularisation's transition speed either side of the default, and
       // its load from the step's start alone.
       .friction_variants =
           {
               {"Merson friction speed 1e-3", fixed({{"friction_speed", "1e-3"}})},
               {"Merson friction speed 1e-5", fixed({{"friction_speed", "1e-5"}})},
               {"Merson friction load of the step's start", fixed({{"friction_load", "last"}})},
           }},
  };
}

// The runs that print a setting.
std::string runs_of(const sim::SettingSpec& s) {
  const char* const with = s.friction ? " with joint friction" : s.contact ? " with a cam" : "";
  switch (s.applies_to) {
    case sim::AppliesTo::kinematic:
      return fmt::format("kinematic{}", with);
    case sim::AppliesTo::dynamics:
      return fmt::format("dynamics{}", with);
    case sim::AppliesTo::both:
      break;
  }
  return fmt::format("both{}", with);
}

}  // namespace

const std::vector<EngineEntry>& engine_table() {
  static const std::vector<EngineEntry> table = make_table();
  return table;
}

const EngineEntry* find_engine(std::string_view name) {
  const auto& table = engine_table();
  const auto it = std::find_if(table.begin(), table.end(),
                               [&](const EngineEntry& e) { return e.name == name; });
  return it == table.end() ? nullptr : &*it;
}

std::vector<std::string> engine_names() {
  std::vector<std::string> out;
  for (const EngineEntry& e : engine_table()) out.push_back(e.name);
  return out;
}

std::string settings_markdown(const EngineEntry& engine) {
  // A table cell holds no '|'.
  auto cell = [](std::string text) {
    for (size_t at = text.find('|'); at != std::string::npos; at = text.find('|', at + 2))
      text.replace(at, 1, "\\|");
    return text;
  };
  std::string out = "| setting | default | takes | runs | what |\n|---|---|---|---|---|\n";
  for (const sim::SettingSpec& s : engine.make()->settings_schema())
    out += fmt::format("| `{}` | {} | {} | {} | {} |\n", s.name,
                       s.reported ? "" : fmt::format("`{}`", s.default_value),
                       cell(sim::allowed_values(s)), runs_of(s), cell(s.doc));
  return out;
}

std::string engines_listing(bool markdown) {
  std::string out;
  for (const EngineEntry& e : engine_table()) {
    if (markdown) {
      out += fmt::format("{}{}: {}\n\n{}", out.empty() ? "" : "\n", e.name, e.description,
                         settings_markdown(e));
      continue;
    }
    out += fmt::format("{}{}  {}\n", out.empty() ? "" : "\n", e.name, e.description);
    for (const sim::SettingSpec& s : e.make()->settings_schema()) {
      const std::string runs = s.applies_to == sim::AppliesTo::both && !s.friction
                                   ? ""
                                   : fmt::format("; {} runs", runs_of(s));
      out += s.reported ? fmt::format("  {} ({}{})\n      {}\n", s.name, sim::allowed_values(s),
                                      runs, s.doc)
                        : fmt::format("  {} (default {}; {}{})\n      {}\n", s.name,
                                      s.default_value, sim::allowed_values(s), runs, s.doc);
    }
  }
  return out;
}

compare::EngineTolerances engine_tolerances(bool dynamics) {
  compare::EngineTolerances out;
  // A method from elsewhere (a file of printed values) is judged as an engine at the common
  // defaults.
  out.others = dynamics ? kDynamics : kKinematic;
  for (const EngineEntry& e : engine_table())
    out.engines.emplace_back(e.name, dynamics ? e.dynamics_tolerances : e.tolerances);
  return out;
}

compare::Tolerances default_tolerances(const Mechanism& mechanism) {
  return compare::Tolerances(engine_tolerances(mechanism.dynamics.has_value()),
                             mechanism.tolerances);
}

}  // namespace crosslink::methods
