// The Python module `crosslink` (docs/python.md): the library's own calls, their results as
// Python objects and numpy arrays. It holds no study of its own: check, solve, compare, sweep and
// merge are the methods:: calls the command makes, so every value is the command's to the bit.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "analytic/model/loader.h"
#include "analytic/model/units_text.h"
#include "analytic/physics/dynamics.h"
#include "analytic/reference/budget.h"
#include "compare/derived.h"
#include "compare/report.h"
#include "methods/check.h"
#include "methods/engines.h"
#include "methods/solve.h"
#include "methods/study.h"
#include "methods/sweep_parts.h"
#include "sim/settings.h"

namespace py = pybind11;

namespace crosslink::python {
namespace {

// A loaded definition, shared by every result made from it (a result reads its names).
struct PyMechanism {
  std::shared_ptr<const Mechanism> m;
};

// A trajectory (a solution, a simulation, one method of a comparison) and what owns it, kept
// alive by every array viewing it.
struct PySolution {
  std::shared_ptr<const void> owner;
  const Trajectory* trajectory = nullptr;
  std::string method;                // which method made it, and why
  nlohmann::json derived = nullptr;  // a solution's [[derived]] values
  // A simulation's energies per sample [J] (kinetic, potential, work, balance); else empty.
  std::vector<std::pair<std::string, Eigen::VectorXd>> energy;
  const Trajectory& t() const { return *trajectory; }
};

// A masked numpy array over `data` (not copied), masked where the sample holds no `quantity`.
py::object masked(const Trajectory& t, const py::array_t<double>& data, Quantity quantity) {
  py::array_t<bool> mask(static_cast<py::ssize_t>(t.samples()));
  auto flags = mask.mutable_unchecked<1>();
  for (py::ssize_t r = 0; r < flags.shape(0); ++r)
    flags(r) = !value_exists(t.status[static_cast<size_t>(r)], quantity);
  return py::module_::import("numpy.ma")
      .attr("MaskedArray")(data, py::arg("mask") = mask, py::arg("copy") = false);
}

// A stored channel is a read-only view of its column, owned by the solution (no copy); one
// computed from others (a magnitude, mu, phi) a new array. Either is masked where its value does
// not exist at the sample's status: a flagged sample is no number (numpy.ma).
py::object channel(const PySolution& s, const std::string& name) {
  const Trajectory& t = s.t();
  const auto n = static_cast<py::ssize_t>(t.samples());
  py::array_t<double> data;
  if (const double* column = t.stored(name)) {
    // The capsule holds the owner for as long as the array (or a view of it) lives.
    const py::capsule owner(new std::shared_ptr<const void>(s.owner),
                            [](void* p) { delete static_cast<std::shared_ptr<const void>*>(p); });
    data = py::array_t<double>({n}, {static_cast<py::ssize_t>(sizeof(double))}, column, owner);
    data.attr("setflags")(py::arg("write") = false);
  } else if (const std::optional<Eigen::VectorXd> computed = t.channel(name)) {
    data = py::array_t<double>(n, computed->data());
  } else {
    throw py::key_error(name);
  }
  return masked(t, data, Trajectory::quantity_of(name));
}

PyMechanism load(const std::string& path) {
  return {std::make_shared<const Mechanism>(load_mechanism(path))};
}

PyMechanism loads(const std::string& text, const std::string& name) {
  return {std::make_shared<const Mechanism>(parse_mechanism(text, name))};
}

PySolution solve(const PyMechanism& pm, std::optional<double> step, std::optional<double> at,
                 const std::string& method, const std::string& at_limit, long max_samples) {
  const Mechanism& m = *pm.m;
  // In the file's units, as the command's --step and --at.
  const double scale = axis_unit_of(m).scale;
  methods::SolveOptions options;
  options.method = method;
  if (step) options.sweep.step = *step * scale;
  if (at) options.at = *at * scale;
  if (at_limit == "reverse")
    options.sweep.at_limit = SweepOptions::AtLimit::reverse;
  else if (at_limit != "stop")
    throw std::invalid_argument("at_limit '" + at_limit + "': stop or reverse");
  options.limits.max_samples = max_samples;
  std::shared_ptr<const methods::Solution> solution;
  {
    py::gil_scoped_release unlocked;  // the exact solver reads no Python object
    solution = std::make_shared<const methods::Solution>(methods::solve(m, options));
  }
  return {solution,
          &solution->trajectory,
          solution->method,
          compare::derived_json(solution->derived),
          {}};
}

// A dynamics case's exact forward dynamics, as `crosslink simulate` (its CSV's energy columns:
// not a number where the sample holds no motion).
PySolution simulate_case(const PyMechanism& pm, std::optional<double> duration,
                         const std::string& integrator, double tolerance, long max_solves) {
  const Mechanism& m = *pm.m;
  if (!m.dynamics)
    throw std::invalid_argument(
        "not a dynamics case: simulate needs a [dynamics] table (docs/dynamics.md); solve gives "
        "a prescribed motion");
  SimulationOptions options{.integrator = integrator, .tolerance = tolerance};
  if (duration) options.duration = *duration;
  check_simulation_work(m, options, "duration", WorkLimits{.max_solves = max_solves});
  options.max_solves = max_solves;
  std::shared_ptr<const Simulation> run;
  {
    py::gil_scoped_release unlocked;
    run = std::make_shared<const Simulation>(crosslink::simulate(m, options));
  }
  if (run->over_budget) throw DefinitionError({Diagnostic{m.dynamics->where, run->message}});
  PySolution out{run, &run->trajectory, run->trajectory.method, nullptr, {}};
  Eigen::VectorXd balance(run->trajectory.samples());
  for (int k = 0; k < balance.size(); ++k) balance(k) = run->energy_balance(k);
  out.energy = {{"kinetic", run->kinetic},
                {"potential", run->potential},
                {"work", run->work},
                {"balance", balance}};
  return out;
}

// A comparison, as `crosslink compare`: its JSON, and each method's trajectory.
struct PyComparison {
  std::shared_ptr<const Mechanism> m;
  std::shared_ptr<const compare::Comparison> comparison;
};

PyComparison compare_methods(const PyMechanism& pm, std::optional<std::vector<std::string>> engines,
                             const std::vector<std::string>& tolerances,
                             const std::vector<std::string>& settings,
                             std::optional<double> accuracy, std::optional<double> step,
                             std::optional<double> at, int jobs, long max_steps) {
  const Mechanism& m = *pm.m;
  const double scale = axis_unit_of(m).scale;
  methods::CompareOptions options;
  if (engines) options.methods = *engines;
  options.tolerances = tolerances;
  options.settings = settings;
  options.accuracy_pct = accuracy;
  if (step) options.step = *step * scale;
  if (at) options.at = *at * scale;
  options.max_steps = max_steps;
  options.jobs = jobs;
  std::shared_ptr<const compare::Comparison> comparison;
  {
    py::gil_scoped_release unlocked;
    comparison = std::make_shared<const compare::Comparison>(methods::run_compare(m, options));
  }
  return {pm.m, std::move(comparison)};
}

py::object from_json(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump());
}

// A settings sweep of definitions (files or folders), or of shard "I/N" of them, as `crosslink
// sweep --json`: the part's document. A Dask task, a Slurm array task or one process writes the
// same part; merge joins them.
py::object sweep_definitions(const std::vector<std::string>& paths,
                             std::optional<std::vector<std::string>> engines,
                             const std::vector<double>& dts, double step, int repeat,
                             const std::string& accuracy, const std::string& shard, int jobs,
                             long max_steps, long max_samples) {
  const methods::Shard part = methods::parse_shard(shard);
  methods::SweepRun run;
  if (engines) run.engines = *engines;
  run.dts = dts;
  run.step = step;
  run.repeat = repeat;
  run.accuracy = accuracy;
  run.max_steps = max_steps;
  run.jobs = jobs;
  run.limits.max_samples = max_samples;
  nlohmann::json document;
  {
    py::gil_scoped_release unlocked;
    const std::vector<methods::DefinitionFile> definitions = methods::definition_files(paths);
    methods::ShardSweeps swept = methods::prepare_shard(definitions, part, run);
    methods::sweep_shard(swept);
    document = methods::sweep_document(part, methods::sweep_settings(run), definitions, swept.swept,
                                       swept.sweeps);
  }
  return from_json(document);
}

// Parts (sweep's documents, in any order) joined into the document of one run, as `crosslink
// merge --json`; a part is named "part K" (from 1) in messages.
py::object merge_parts(const py::list& parts) {
  const py::object dumps = py::module_::import("json").attr("dumps");
  std::vector<std::pair<std::string, nlohmann::json>> given;
  for (size_t k = 0; k < parts.size(); ++k)
    given.emplace_back("part " + std::to_string(k + 1),
                       nlohmann::json::parse(dumps(parts[k]).cast<std::string>()));
  return from_json(methods::merge_parts(given).document);
}

// `crosslink check`'s report: its text (the command's stdout), the error where the definition
// cannot start (its stderr) and the command's exit code (1: a claim fails; 2: it cannot start).
py::dict check(const PyMechanism& pm, long max_samples) {
  methods::CheckReport report;
  {
    py::gil_scoped_release unlocked;
    WorkLimits limits;
    limits.max_samples = max_samples;
    report = methods::check_report(*pm.m, limits);
  }
  return py::dict(py::arg("exit_code") = report.exit_code, py::arg("report") = report.out,
                  py::arg("errors") = report.err);
}

py::list engines() {
  py::list out;
  for (const methods::EngineEntry& e : methods::engine_table()) {
    py::list settings;
    for (const sim::SettingSpec& spec : e.make()->settings_schema())
      settings.append(py::dict(py::arg("name") = spec.name, py::arg("default") = spec.default_value,
                               py::arg("takes") = sim::allowed_values(spec),
                               py::arg("what") = spec.doc, py::arg("reported") = spec.reported));
    out.append(py::dict(py::arg("name") = e.name, py::arg("description") = e.description,
                        py::arg("settings") = settings));
  }
  return out;
}

}  // namespace
}  // namespace crosslink::python

PYBIND11_MODULE(crosslink, module) {
  using namespace crosslink;
  using namespace crosslink::python;
  module.doc() =
      "crosslink: exact kinematics of planar linkages, cross-validated against physics engines "
      "(docs/python.md)";

  // A definition's problems, each "file:line:col: error: message" as the command prints them.
  py::register_exception<DefinitionError>(module, "DefinitionError", PyExc_ValueError);

  py::class_<PyMechanism>(module, "Mechanism", "A definition, loaded and assembled")
      .def_property_readonly("name", [](const PyMechanism& p) { return p.m->name; })
      .def_property_readonly("file", [](const PyMechanism& p) { return p.m->file; })
      .def_property_readonly("links",
                             [](const PyMechanism& p) {
                               std::vector<std::string> names;
                               for (const Link& l : p.m->links) names.push_back(l.name);
                               return names;
                             })
      .def_property_readonly("joints",
                             [](const PyMechanism& p) {
                               std::vector<std::string> names;
                               for (const Joint& j : p.m->joints) names.push_back(j.name);
                               return names;
                             })
      .def_property_readonly("mobility",
                             [](const PyMechanism& p) { return mobility(*p.m).mobility; })
      .def_property_readonly("mobility_text",
                             [](const PyMechanism& p) { return mobility(*p.m).explain(); })
      .def("__repr__", [](const PyMechanism& p) {
        return "<crosslink.Mechanism '" + p.m->name + "' from " + p.m->file + ">";
      });

  py::class_<PySolution>(module, "Solution",
                         "The exact solution: every channel as a masked numpy array (SI)")
      .def_property_readonly("method", [](const PySolution& s) { return s.method; })
      .def_property_readonly("channels", [](const PySolution& s) { return s.t().channel_names(); })
      .def("__getitem__", &channel, py::arg("channel"))
      .def("__contains__",
           [](const PySolution& s, const std::string& name) {
             return s.t().stored(name) != nullptr || s.t().channel(name).has_value();
           })
      .def("__len__", [](const PySolution& s) { return s.t().samples(); })
      .def_static(
          "unit", [](const std::string& name) { return std::string(Trajectory::si_unit(name)); },
          py::arg("channel"), "The SI unit of a channel's values")
      .def_property_readonly("status",
                             [](const PySolution& s) {
                               std::vector<std::string> out;
                               for (PoseStatus status : s.t().status)
                                 out.emplace_back(to_string(status));
                               return out;
                             })
      // Each sample's time, and its position along the sweep (the CSV's `driver`).
      .def_property_readonly("time",
                             [](const PySolution& s) {
                               return py::array_t<double>(s.t().samples(), s.t().time.data());
                             })
      .def_property_readonly("driver",
                             [](const PySolution& s) {
                               const Trajectory& t = s.t();
                               py::array_t<double> out(t.samples());
                               for (int r = 0; r < t.samples(); ++r)
                                 out.mutable_at(r) = t.driver_field(r);
                               return out;
                             })
      .def_property_readonly(
          "events",
          [](const PySolution& s) {
            py::list out;
            for (const Trajectory::Event& e : s.t().events)
              out.append(py::dict(py::arg("kind") = std::string(to_string(e.kind)),
                                  py::arg("at") = e.driver, py::arg("message") = e.message));
            return out;
          })
      .def_property_readonly("derived", [](const PySolution& s) { return from_json(s.derived); })
      .def_property_readonly("energy", [](const PySolution& s) {
        py::dict out;
        for (const auto& [name, values] : s.energy)
          out[py::str(name)] =
              masked(s.t(), py::array_t<double>(values.size(), values.data()), Quantity::energy);
        return out;
      });

  py::class_<PyComparison>(module, "Comparison",
                           "Every method against the exact reference, as `crosslink compare`")
      .def_property_readonly(
          "json", [](const PyComparison& c) { return from_json(compare::to_json(*c.comparison)); })
      .def_property_readonly("passed", [](const PyComparison& c) { return c.comparison->pass(); })
      .def_property_readonly("nothing_compared",
                             [](const PyComparison& c) { return c.comparison->nothing_compared(); })
      .def_property_readonly("methods",
                             [](const PyComparison& c) {
                               std::vector<std::string> names;
                               for (const compare::MethodRun& r : c.comparison->methods)
                                 names.push_back(r.name);
                               return names;
                             })
      .def("__getitem__", [](const PyComparison& c, const std::string& method) {
        const compare::MethodRun* run = c.comparison->method(method);
        if (!run) throw py::key_error(method);
        return PySolution{c.comparison, &run->trajectory, run->name, nullptr, {}};
      });

  module.def("load", &load, py::arg("path"),
             "Loads and assembles a definition file; raises DefinitionError with every problem");
  module.def("loads", &loads, py::arg("text"), py::arg("name") = "<string>",
             "The same from text; `name` stands for the file in messages");
  module.def("check", &check, py::arg("mechanism"),
             py::arg("max_samples") = WorkLimits{}.max_samples,
             "`crosslink check`'s report: {exit_code, report, errors}");
  module.def("solve", &solve, py::arg("mechanism"), py::arg("step") = py::none(),
             py::arg("at") = py::none(), py::arg("method") = "auto", py::arg("at_limit") = "stop",
             py::arg("max_samples") = WorkLimits{}.max_samples,
             "The exact sweep (or one pose at `at`), as `crosslink solve`: step and at in the "
             "file's units of the driver");
  module.def("simulate", &simulate_case, py::arg("mechanism"), py::arg("duration") = py::none(),
             py::arg("integrator") = "rkf78", py::arg("tolerance") = 1e-13,
             py::arg("max_solves") = SimulationOptions::kDefaultMaxSolves,
             "A dynamics case's exact forward dynamics, as `crosslink simulate`");
  module.def("compare", &compare_methods, py::arg("mechanism"), py::arg("methods") = py::none(),
             py::arg("tolerances") = std::vector<std::string>{},
             py::arg("settings") = std::vector<std::string>{}, py::arg("accuracy") = py::none(),
             py::arg("step") = py::none(), py::arg("at") = py::none(), py::arg("jobs") = 1,
             py::arg("max_steps") = sim::kDefaultMaxSteps,
             "Every method against the exact reference, as `crosslink compare`: methods, "
             "tolerances and settings as its --engines, --tolerance and --set texts");
  module.def("sweep", &sweep_definitions, py::arg("paths"), py::arg("engines") = py::none(),
             py::arg("dts") = std::vector<double>{}, py::arg("step") = 0.0, py::arg("repeat") = 3,
             py::arg("accuracy") = "", py::arg("shard") = "", py::arg("jobs") = 1,
             py::arg("max_steps") = sim::kDefaultMaxSteps,
             py::arg("max_samples") = WorkLimits{}.max_samples,
             "Every engine over a grid of its settings, as `crosslink sweep --json`: the "
             "document of the definitions (files or folders), or of shard \"I/N\" of them");
  module.def("merge", &merge_parts, py::arg("parts"),
             "Sweep documents of every shard joined into one run's, as `crosslink merge --json`");
  module.def("engines", &engines, "Every engine and its settings, as `crosslink engines`");
}
