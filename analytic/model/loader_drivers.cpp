#include "analytic/model/loader_reader.h"

namespace crosslink::loading {

namespace {

// A polynomial or table law must stay within the magnitudes of a driver, its rates and
// accelerations too, at every time the solvers evaluate it: the sweep's 361 samples and the
// 3601-point grid `solve --at` searches (both equal divisions of the duration).
void check_law(Reader& r, const Driver& d, const Scale& value_scale) {
  const int n = 3600;
  for (int k = 0; k <= n; ++k) {
    const double time = d.law.duration * k / n;
    const DriverState s = d.at_time(time);
    const std::string_view unit = value_scale.unit;
    std::string fault;
    if (!(std::abs(s.value) <= value_scale.largest))
      fault = fmt::format("reaches {:g} {} (the limit is {:g} {})", s.value / value_scale.si, unit,
                          value_scale.largest / value_scale.si, unit);
    else if (!(std::abs(s.rate) <= limits::kRate))
      fault = fmt::format("moves at {:g} {}/s (the limit is {:g} in SI)", s.rate / value_scale.si,
                          unit, limits::kRate);
    else if (!(std::abs(s.accel) <= limits::kAcceleration))
      fault = fmt::format("accelerates at {:g} {}/s^2 (the limit is {:g} in SI)",
                          s.accel / value_scale.si, unit, limits::kAcceleration);
    if (!fault.empty()) {
      r.error(d.law.where,
              fmt::format("[driver] '{}' {} at t = {:g} s", to_string(d.law.kind), fault, time));
      return;
    }
  }
}

// Constant acceleration from the start speed: value = start + speed t + acceleration t^2 / 2.
// Without a duration an angular driver's cycle is the time it takes to turn once.
void read_acceleration(Reader& r, const Mechanism& m, Driver& d, const toml::table& t,
                       const Scale& value_scale, bool duration_given) {
  d.law.kind = MotionLaw::Kind::constant_acceleration;
  d.law.where = r.at(t.get("acceleration"));
  Scale scale{value_scale.si, "", limits::kAcceleration};
  std::string unit_name = m.units.length_name + "/s^2";
  if (d.angular()) {
    unit_name = "rad/s^2";
    if (const auto f = unit_factor(r, t, "[driver]", "acceleration_unit", kAngularAccelerationUnits,
                                   "rad/s^2", &unit_name))
      scale.si = *f;
  } else if (t.get("acceleration_unit")) {
    r.error(r.at(t.get("acceleration_unit")),
            fmt::format("[driver]: a slider's acceleration is in the file's length unit per "
                        "second squared ({}/s^2); remove 'acceleration_unit'",
                        m.units.length_name));
  }
  scale.unit = unit_name;
  d.law.acceleration_unit = {unit_name, scale.si};
  const std::optional<double> acceleration = r.number(t, "acceleration", "[driver]", true, scale);
  if (!acceleration || !r.diagnostics().empty()) return;
  d.law.acceleration = *acceleration;
  if (!duration_given) {
    const auto shown = [&] {
      return fmt::format("speed {:g} {}, acceleration {:g} {}", d.law.speed / d.law.speed_unit.si,
                         d.law.speed_unit.name, *acceleration / scale.si, unit_name);
    };
    if (!d.angular()) {
      r.error(d.law.where, fmt::format("[driver] a slider at constant acceleration ({}) needs "
                                       "'duration' (seconds): it has no turn to complete",
                                       shown()));
      return;
    }
    // The first t > 0 with |speed t + acceleration t^2 / 2| = 2 pi, in the direction of motion.
    const double direction =
        d.law.speed != 0.0 ? std::copysign(1.0, d.law.speed) : std::copysign(1.0, *acceleration);
    const double w = direction * d.law.speed, a = direction * *acceleration;
    const double turn = 2.0 * std::numbers::pi;
    const double discriminant = w * w + 2.0 * a * turn;
    if ((w == 0.0 && a == 0.0) || discriminant < 0.0) {
      r.error(d.law.where,
              fmt::format("[driver] at {} the driver {} before it turns once: give 'duration' "
                          "(seconds)",
                          shown(), w == 0.0 && a == 0.0 ? "does not move" : "stops"));
      return;
    }
    d.law.duration = 2.0 * turn / (w + std::sqrt(discriminant));
  }
  check_law(r, d, value_scale);
}

// One driver's table: [driver], or one of [[driver]] (`named`: it takes a 'name', read before).
void read_driver(Reader& r, const Mechanism& m, Driver& d, const toml::table* t,
                 const toml::table& root, bool named) {
  d.where = r.at(*t);
  std::vector<std::string> keys = {
      "type",       "joint", "link",       "from",         "to",
      "start",      "speed", "speed_unit", "acceleration", "acceleration_unit",
      "polynomial", "table", "duration",   "range"};
  if (named) keys.push_back("name");
  r.known_keys(*t, "[driver]", keys);
  const std::string type = r.string(*t, "type", "[driver]", true).value_or("");
  if (type == "joint_angle") {
    d.type = DriverType::joint_angle;
    const std::optional<std::string> joint = r.string(*t, "joint", "[driver]", true);
    if (joint) {
      d.joint = m.find_joint(*joint);
      if (d.joint < 0) {
        std::vector<std::string> names;
        for (const Joint& j : m.joints)
          if (j.type == JointType::revolute) names.push_back(j.name);
        r.error(
            r.at(t->get("joint")),
            fmt::format("[driver]: unknown joint '{}' (revolute joints: {})", *joint, join(names)));
      } else if (m.joints[d.joint].type != JointType::revolute) {
        r.error(r.at(t->get("joint")),
                fmt::format("[driver]: joint_angle needs a revolute joint; '{}' is {}", *joint,
                            to_string(m.joints[d.joint].type)));
        d.joint = -1;
      }
    }
    if (d.joint >= 0) {
      const Joint& j = m.joints[d.joint];
      d.link = j.link_b;
      d.from = j.point_b;
      if (const auto to = r.string(*t, "to", "[driver] (joint_angle)", true))
        d.to = resolve_point(r, m, d.link, t->get("to"), *to, "[driver] 'to'");
      if (d.to >= 0 && d.to == d.from)
        r.error(r.at(t->get("to")), "[driver]: 'to' must differ from the joint's point");
    }
  } else if (type == "link_angle") {
    d.type = DriverType::link_angle;
    d.link = resolve_link(r, m, *t, "link", "[driver]");
    if (d.link >= 0) {
      const auto from = r.string(*t, "from", "[driver] (link_angle)", true);
      const auto to = r.string(*t, "to", "[driver] (link_angle)", true);
      if (from) d.from = resolve_point(r, m, d.link, t->get("from"), *from, "[driver] 'from'");
      if (to) d.to = resolve_point(r, m, d.link, t->get("to"), *to, "[driver] 'to'");
      if (d.from >= 0 && d.to >= 0 &&
          (m.links[d.link].points[d.to].local - m.links[d.link].points[d.from].local).norm() <
              1e-12)
        r.error(r.at(t->get("to")), "[driver]: 'from' and 'to' are the same place");
      if (m.links[d.link].ground)
        r.error(r.at(t->get("link")), "[driver]: the ground cannot be driven");
    }
  } else if (type == "slider") {
    d.type = DriverType::slider;
    const std::optional<std::string> joint = r.string(*t, "joint", "[driver]", true);
    if (joint) {
      d.joint = m.find_joint(*joint);
      if (d.joint < 0 || !m.joints[d.joint].is_slide()) {
        std::vector<std::string> names;
        for (const Joint& j : m.joints)
          if (j.is_slide()) names.push_back(j.name);
        r.error(r.at(t->get("joint")),
                fmt::format("[driver]: '{}' is not a prismatic or pin_in_slot joint (those: {})",
                            *joint, join(names)));
        d.joint = -1;
      } else {
        d.link = m.joints[d.joint].link_b;
      }
    }
  } else {
    r.error(t->get("type") ? r.at(t->get("type")) : d.where,
            fmt::format("[driver]: unknown type '{}' (valid types: joint_angle, link_angle, "
                        "slider)",
                        type));
  }

  // Driver values are in the file's angle unit, or its length unit for a slider.
  const Scale value_scale = driver_scale(m, d);
  d.start = r.number(*t, "start", "[driver]", true, start_scale(m, d)).value_or(0.0);
  if (const toml::node* range = t->get("range")) {
    d.range_where = r.at(*range);
    if (const auto lr =
            r.numbers(*range, "[driver] 'range' ([low, high])", {value_scale, value_scale})) {
      if ((*lr)[0] >= (*lr)[1])
        r.error(r.at(*range), "[driver] 'range' must be [low, high] with low < high");
      else
        d.range = std::make_pair((*lr)[0], (*lr)[1]);
    }
  }

  // The motion law: exactly one of speed, polynomial, table; none for a dynamics case.
  const int laws =
      (t->get("speed") ? 1 : 0) + (t->get("polynomial") ? 1 : 0) + (t->get("table") ? 1 : 0);
  if (root.get("dynamics")) {
    for (const char* key : {"speed", "acceleration", "polynomial", "table"})
      if (const toml::node* law = t->get(key)) {
        r.error(r.at(law), fmt::format("[driver] of a dynamics case ([dynamics]) takes no motion "
                                       "law: the coordinate moves freely; remove '{}'",
                                       key));
        break;
      }
    return;
  }
  if (t->get("acceleration") && !t->get("speed")) {
    r.error(r.at(t->get("acceleration")),
            "[driver] 'acceleration' needs 'speed', the speed at t = 0 (speed = 0 from rest)");
    return;
  }
  if (laws != 1) {
    r.error(d.where,
            "[driver] needs exactly one motion law: 'speed' (constant, or with 'acceleration' "
            "from that speed), 'polynomial' or 'table'");
    return;
  }
  const Scale time_scale{1.0, "s", limits::kDuration, limits::kShortestDuration};
  // A polynomial's or a table's cycle; optional with a speed (for an acceleration law).
  const std::optional<double> duration =
      r.number(*t, "duration", "[driver]", !t->get("speed"), time_scale);
  if (duration && *duration <= 0.0)
    r.error(r.at(t->get("duration")), "[driver] 'duration' must be positive (seconds)");
  d.law.duration = duration.value_or(0.0);
  if (t->get("speed")) {
    d.law.kind = MotionLaw::Kind::constant_speed;
    d.law.where = r.at(t->get("speed"));
    Scale speed_scale{value_scale.si, "", limits::kRate, limits::kSlowestSpeed};
    std::string unit_name = m.units.length_name + "/s";
    if (d.angular()) {
      unit_name = "rad/s";
      if (const auto f =
              unit_factor(r, *t, "[driver]", "speed_unit", kAngularSpeedUnits, "rad/s", &unit_name))
        speed_scale.si = *f;
    } else if (t->get("speed_unit")) {
      r.error(r.at(t->get("speed_unit")),
              fmt::format("[driver]: a slider's speed is in the file's length unit per second "
                          "({}/s); remove 'speed_unit'",
                          m.units.length_name));
    }
    speed_scale.unit = unit_name;
    d.law.speed_unit = {unit_name, speed_scale.si};
    const std::optional<double> speed = r.number(*t, "speed", "[driver]", true, speed_scale);
    d.law.speed = speed.value_or(0.0);
    if (t->get("acceleration")) read_acceleration(r, m, d, *t, value_scale, duration.has_value());
    return;
  }
  if (const toml::node* poly = t->get("polynomial")) {
    d.law.kind = MotionLaw::Kind::polynomial;
    d.law.where = r.at(*poly);
    const auto* array = poly->as_array();
    if (!array || array->empty()) {
      r.error(r.at(*poly),
              "[driver] 'polynomial' must be [c1, c2, ...]: value = start + c1 t + "
              "c2 t^2 + ... (file units, seconds)");
      return;
    }
    if (array->size() > limits::kPolynomialTerms) {
      r.error(r.at(*poly), fmt::format("[driver] 'polynomial' has {} coefficients: the limit is {}",
                                       array->size(), limits::kPolynomialTerms));
      return;
    }
    // Each coefficient is finite; what the law reaches is checked below.
    for (const toml::node& c : *array)
      d.law.coefficients.push_back(
          r.number(c, "a polynomial coefficient", {value_scale.si, value_scale.unit})
              .value_or(0.0));
  } else {
    d.law.kind = MotionLaw::Kind::table;
    const toml::node* table = t->get("table");
    d.law.where = r.at(*table);
    const auto* rows = table->as_array();
    if (!rows || rows->size() < 3) {
      r.error(r.at(*table), "[driver] 'table' must list at least 3 rows [[t, value], ...]");
      return;
    }
    if (rows->size() > limits::kTableRows) {
      r.error(r.at(*table), fmt::format("[driver] 'table' has {} rows: the limit is {}",
                                        rows->size(), limits::kTableRows));
      return;
    }
    const Scale row_time{1.0, "s", limits::kDuration};
    for (const toml::node& row : *rows) {
      const auto tv = r.numbers(row, "a [driver] table row ([t, value])", {row_time, value_scale});
      if (!tv) return;
      if (!d.law.table_time.empty() && (*tv)[0] <= d.law.table_time.back()) {
        r.error(r.at(row), "[driver] table times must increase strictly");
        return;
      }
      // A shorter step makes the spline's rates overflow.
      if (!d.law.table_time.empty() && (*tv)[0] - d.law.table_time.back() < time_scale.smallest) {
        r.error(r.at(row), fmt::format("[driver] table times {:g} s and {:g} s are closer than "
                                       "the limit of {:g} s",
                                       d.law.table_time.back(), (*tv)[0], time_scale.smallest));
        return;
      }
      d.law.table_time.push_back((*tv)[0]);
      d.law.table_value.push_back((*tv)[1]);
    }
    // The value at t = 0: knots may start before it (the spline's end condition kept off the
    // cycle); at a first knot at 0 this is its value exactly.
    d.start = d.at_time(0.0).value;
  }
  if (duration && r.diagnostics().empty()) check_law(r, d, value_scale);
}

// What a driver drives, for two drivers on one thing: a joint's coordinate, or a link's absolute
// angle (a link_angle driver's, or a joint_angle driver's on a joint to the ground).
std::string driven_thing(const Mechanism& m, const Driver& d) {
  if (d.type == DriverType::link_angle ||
      (d.type == DriverType::joint_angle && d.joint >= 0 &&
       m.links[static_cast<size_t>(m.joints[static_cast<size_t>(d.joint)].link_a)].ground))
    return d.link >= 0 ? fmt::format("the angle of link '{}'", m.links[d.link].name) : "";
  return d.joint >= 0 ? fmt::format("joint '{}'", m.joints[d.joint].name) : "";
}

}  // namespace

// [driver], or [[driver]] tables: several drivers, each named (docs/mechanism-format.md,
// "Several drivers").
void read_drivers(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::node* node = root.get("driver");
  const toml::array* array = node ? node->as_array() : nullptr;
  if (!array) {  // the one-driver form
    if (const toml::table* t = r.table(root, "driver", "a mechanism", true))
      read_driver(r, m, m.drivers.front(), t, root, false);
    return;
  }
  if (!array->is_array_of_tables() || array->empty()) {
    r.error(r.at(*node), "'driver' must be a table ([driver]) or tables ([[driver]])");
    return;
  }
  if (array->size() > kMostDrivers) {
    r.error(r.at((*array)[kMostDrivers]),
            fmt::format("{} [[driver]] tables: the limit is {}", array->size(), kMostDrivers));
    return;
  }
  const bool several = array->size() > 1;
  m.drivers.assign(array->size(), Driver{});
  std::vector<std::string> taken;  // names a driver's channels would share
  for (const Link& l : m.links) taken.push_back(l.name);
  for (const Joint& j : m.joints) taken.push_back(j.name);
  for (const Mechanism::NamedPoint& p : m.named_points()) taken.push_back(p.name);
  for (size_t i = 0; i < array->size(); ++i) {
    const toml::table* t = (*array)[i].as_table();
    Driver& d = m.drivers[i];
    const toml::node* name = t->get("name");
    if (name) {
      d.name = r.string(*t, "name", "[[driver]]", true).value_or("");
      if (name->is_string() && d.name.empty())
        r.error(r.at(*name), "[[driver]] 'name' must not be empty");
    } else if (several) {
      r.error(r.at(*t), fmt::format("[[driver]] needs a 'name' when there are several drivers "
                                    "({} here): its channels are named after it "
                                    "(torque.<name>, angle.<name>)",
                                    array->size()));
    }
    const size_t first = r.diagnostics().size();
    read_driver(r, m, d, t, root, true);
    r.relabel(first, "[driver]",
              d.name.empty() ? std::string("[[driver]]") : fmt::format("[[driver]] '{}'", d.name));
    if (!several || d.name.empty()) continue;
    if (std::find(taken.begin(), taken.end(), d.name) != taken.end())
      r.error(r.at(*name), fmt::format("[[driver]] name '{0}' is already a link's, joint's or "
                                       "point's name: its channels (angle.{0}, torque.{0}) "
                                       "would be ambiguous; choose another",
                                       d.name));
    for (size_t k = 0; k < i; ++k)
      if (m.drivers[k].name == d.name)
        r.error(r.at(*name), fmt::format("duplicate driver name '{}' (first at line {}); driver "
                                         "names must be unique",
                                         d.name, m.drivers[k].where.line));
  }
  if (!several) return;
  for (size_t i = 0; i < m.drivers.size(); ++i) {
    const Driver& d = m.drivers[i];
    const toml::table& t = *(*array)[i].as_table();
    const std::string thing = driven_thing(m, d);
    for (size_t k = 0; k < i && !thing.empty(); ++k)
      if (driven_thing(m, m.drivers[k]) == thing) {
        r.error(r.at(t.get("joint")  ? t.get("joint")
                     : t.get("link") ? t.get("link")
                                     : &t),
                fmt::format("drivers '{}' and '{}' both drive {}: one coordinate takes one "
                            "driver (drive another joint or link)",
                            m.drivers[k].name, d.name, thing));
        break;
      }
    if (d.range)
      r.error(d.range_where,
              fmt::format("[[driver]] '{}': 'range' sweeps one driver's values; with several "
                          "drivers the sweep runs in time over the longest cycle (remove "
                          "'range', or give 'duration')",
                          d.name));
    if (!root.get("dynamics") && d.law.kind == MotionLaw::Kind::constant_speed && !d.at_rest() &&
        d.cycle() == 0.0)
      r.error(d.law.where,
              fmt::format("[[driver]] '{}': a slider at constant speed has no turn to set the "
                          "sweep's time: give 'duration' (seconds)",
                          d.name));
  }
}

namespace {

// With several drivers the sweep runs in time: what reads a sweep over one driver's values is
// refused at its key.
// The first driver whose row of the constraint Jacobian at q is a combination of the joints'
// rows and the drivers' before it (the joints then hold its coordinate still, to first order),
// or -1. Each link turns about the centroid of its points here, not its frame's origin (the
// chain rule: d/dtheta less d/dr times A'(theta) c), so that points drawn far from that origin
// do not make its columns nearly parallel; then every column and row has unit length.
int first_locked_driver(const Mechanism& m, const ConstraintLayout& layout,
                        const Eigen::VectorXd& q) {
  Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(layout.rows(), q.size());
  layout.jacobian(LinkFrames{q}, jac);
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k < 0 || m.links[l].points.empty()) continue;
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const Point& p : m.links[l].points) c += p.local;
    c /= static_cast<double>(m.links[l].points.size());
    const double th = q(3 * k + 2), cs = std::cos(th), sn = std::sin(th);
    const Eigen::Vector2d turned(-sn * c.x() - cs * c.y(), cs * c.x() - sn * c.y());  // A'(th) c
    jac.col(3 * k + 2) -= jac.col(3 * k) * turned.x() + jac.col(3 * k + 1) * turned.y();
  }
  for (Eigen::Index c = 0; c < jac.cols(); ++c)
    if (const double norm = jac.col(c).norm(); norm > 0.0) jac.col(c) /= norm;
  for (int row = 0; row < layout.rows(); ++row)
    if (const double norm = jac.row(row).norm(); norm > 0.0) jac.row(row) /= norm;
  // Cheap first (a dense QR of IFToMM A02 at N = 160 took 7 s): a square Jacobian whose sparse
  // LU solves two fixed right-hand sides with bounded solutions is far from singular, so no
  // row depends on the others.
  if (jac.rows() == jac.cols()) {
    const Eigen::SparseMatrix<double> sparse = jac.sparseView();
    Eigen::SparseLU<Eigen::SparseMatrix<double>, Eigen::COLAMDOrdering<int>> lu;
    lu.compute(sparse);
    if (lu.info() == Eigen::Success) {
      bool bounded = true;
      for (const double phase : {1.0, 2.0}) {
        Eigen::VectorXd b(jac.rows());
        for (Eigen::Index i = 0; i < b.size(); ++i) b(i) = std::sin(phase + 1.618034 * i);
        const Eigen::VectorXd x = lu.solve(b);
        bounded =
            bounded && lu.info() == Eigen::Success && x.allFinite() && x.norm() <= 1e8 * b.norm();
      }
      if (bounded) return -1;
    }
  }
  auto rank = [&](int rows) {
    if (rows == 0) return Eigen::Index{0};
    Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(jac.topRows(rows));
    qr.setThreshold(1e-9);
    return qr.rank();
  };
  Eigen::Index before = rank(layout.joint_row_count());
  for (int d = 0; d < layout.driver_count(); ++d) {
    const Eigen::Index with = rank(layout.driver_row(d) + 1);
    if (with == before) return d;
    before = with;
  }
  return -1;
}

}  // namespace

// A chain that Grübler–Kutzbach counts as mobile can still be locked: a planetary train whose
// sun mesh is moved onto the ground meshes the planet with two fixed gears that disagree, which
// holds the arm (the driver) still and leaves the sun free; the count sees 1 and the sweep
// wrote thousands of samples all at t = 0. Locked means the driver's row of the constraint
// Jacobian depends on the joints' rows, tested at the drawn pose and at a perturbation of it: a
// structural lock (gear rows are constant, a rigid sub-chain is rigid everywhere) holds at both;
// a drawing that happens to sit at a dead point or a limit of the assembling range does not.
void check_locked(Reader& r, const Mechanism& m) {
  if (!r.diagnostics().empty() || m.ground() < 0 || m.moving_count() == 0) return;
  const ConstraintLayout layout(m);
  const int n = 3 * m.moving_count();
  Eigen::VectorXd drawn = Eigen::VectorXd::Zero(n);
  for (size_t l = 0; l < m.links.size(); ++l) {
    const int k = m.moving_index(static_cast<int>(l));
    if (k >= 0 && m.links[l].pose) drawn.segment<3>(3 * k) = *m.links[l].pose;
  }
  const int locked = first_locked_driver(m, layout, drawn);
  if (locked < 0) return;
  // A fixed, irregular perturbation: a tenth of the size and of a radian at most.
  Eigen::VectorXd moved = drawn;
  for (int i = 0; i < n; ++i)
    moved(i) += (i % 3 == 2 ? 0.1 : 0.1 * m.size()) * std::sin(1.0 + 2.399963 * i);
  if (first_locked_driver(m, layout, moved) != locked) return;
  const Driver& d = m.drivers[static_cast<size_t>(locked)];
  r.error(d.where,
          fmt::format("the chain is locked: its joints hold the driven coordinate{} still, "
                      "though Grübler–Kutzbach counts a mobility of {} (its count cannot see "
                      "constraints that repeat or contradict each other, such as two gear meshes "
                      "fixing one gear's turn). The driver's row of the constraint Jacobian is a "
                      "combination of the joints' rows at the drawn pose and near it; free the "
                      "chain (a gear on the wrong link, a joint too many) or drive a coordinate "
                      "that moves",
                      d.name.empty() ? "" : " '" + d.name + "'", mobility(m).mobility));
}

// A table read over one driver's value, in a definition whose sweep runs in time (several
// drivers): refused where it is written, its values not read (docs/mechanism-format.md,
// "Several drivers"). `message` has one {}: "N drivers".
bool refused_in_time(Reader& r, const Mechanism& m, const SourceLocation& where,
                     std::string_view message) {
  if (!m.axis().timed()) return false;
  r.error(where, fmt::format(fmt::runtime(message), fmt::format("{} drivers", m.drivers.size())));
  return true;
}
// Each of an array's tables, so refused.
bool refused_in_time(Reader& r, const Mechanism& m, const toml::array& tables,
                     std::string_view message) {
  if (!m.axis().timed()) return false;
  for (const toml::node& entry : tables) refused_in_time(r, m, r.at(*entry.as_table()), message);
  return true;
}

namespace {

// One driver's free coordinate in [dynamics] (the one-driver form) or [dynamics.<name>] (`what`):
// its initial rate and applied effort. The coordinate's kinematic view (check, solve, compare) is
// a constant speed equal to its initial rate, or 1 unit/s when that is 0.
FreeCoordinate read_free_coordinate(Reader& r, const Mechanism& m, Driver& d, const toml::table& t,
                                    const std::string& what) {
  FreeCoordinate c;
  double rate_unit = d.angular() ? 1.0 : m.units.length;
  std::string rate_name = d.angular() ? "rad/s" : m.units.length_name + "/s";
  if (d.angular()) {
    if (const auto f =
            unit_factor(r, t, what, "rate_unit", kAngularSpeedUnits, "rad/s", &rate_name))
      rate_unit = *f;
  } else if (t.get("rate_unit")) {
    r.error(r.at(t.get("rate_unit")),
            fmt::format("{}: a slider's rate is in the file's length unit per second "
                        "({}/s); remove 'rate_unit'",
                        what, m.units.length_name));
  }
  // The initial rate is the kinematic view's speed: the same limits as a driver's speed.
  c.rate =
      r.number(t, "rate", what, false, {rate_unit, rate_name, limits::kRate, limits::kSlowestSpeed})
          .value_or(0.0);
  const Scale effort_scale = d.angular()
                                 ? Scale{m.units.force * m.units.length, "", limits::kTorque}
                                 : Scale{m.units.force, m.units.force_name, limits::kForce};
  if (t.get("effort") && t.get("effort_table"))
    r.error(r.at(t.get("effort_table")),
            fmt::format("{} takes 'effort' (constant) or 'effort_table' ([[t, value], ...]), not "
                        "both",
                        what));
  if (const auto e = r.number(t, "effort", what, false, effort_scale))
    c.effort.emplace_back(0.0, *e);
  const toml::node* table = t.get("effort") ? nullptr : t.get("effort_table");
  if (table) {
    const auto* rows = table->as_array();
    if (!rows || rows->size() < 2)
      r.error(r.at(*table),
              fmt::format("{} 'effort_table' must list at least 2 rows [[t, value], ...]", what));
    else
      for (const toml::node& row : *rows) {
        const auto tv = r.numbers(row, "an 'effort_table' row ([t, value])",
                                  {Scale{1.0, "s", limits::kDuration}, effort_scale});
        if (!tv) break;
        if (!c.effort.empty() && (*tv)[0] <= c.effort.back().first) {
          r.error(r.at(row), fmt::format("{} 'effort_table' times must increase strictly", what));
          break;
        }
        c.effort.emplace_back((*tv)[0], (*tv)[1]);
      }
  }
  d.law.kind = MotionLaw::Kind::constant_speed;
  d.law.speed = c.rate != 0.0 ? c.rate : 1.0;
  return c;
}

}  // namespace

// [dynamics]: a forward-dynamics case. With one driver its coordinate's keys are [dynamics]'s;
// with several, each driver's are in [dynamics.<name>] (a driver without one starts at rest and
// moves freely).
void read_dynamics(Reader& r, Mechanism& m, const toml::table& root) {
  const toml::table* t = r.table(root, "dynamics", "a mechanism", false);
  if (!t) return;
  const std::vector<std::string> coordinate_keys = {"rate", "rate_unit", "effort", "effort_table"};
  std::vector<std::string> keys = {"duration", "interval"};
  if (m.axis().timed())
    for (const Driver& d : m.drivers) keys.push_back(d.name);
  else
    keys.insert(keys.end(), coordinate_keys.begin(), coordinate_keys.end());
  if (m.axis().timed()) {
    // A coordinate's key at the top: whose it is is not said.
    for (const std::string& key : coordinate_keys)
      if (const toml::node* node = t->get(key))
        r.error(r.at(*node),
                fmt::format("[dynamics] '{}' belongs to one driver: with {} drivers give each "
                            "driver's rate and effort in its own table [dynamics.<name>] "
                            "([dynamics.{}])",
                            key, m.drivers.size(), m.drivers.front().name));
    for (auto&& [key, node] : *t)
      if (std::find(keys.begin(), keys.end(), key.str()) == keys.end() &&
          std::find(coordinate_keys.begin(), coordinate_keys.end(), key.str()) ==
              coordinate_keys.end())
        r.error(
            r.at(key.source()),
            fmt::format("unknown key '{}' in [dynamics]: it takes 'duration', 'interval' and "
                        "one table per driver, [dynamics.<name>] (drivers: {})",
                        key.str(), join(std::vector<std::string>(keys.begin() + 2, keys.end()))));
  } else {
    r.known_keys(*t, "[dynamics]", keys);
  }
  DynamicsCase c;
  c.where = r.at(*t);
  const Scale seconds{1.0, "s", limits::kDuration, limits::kShortestDuration};
  const std::optional<double> duration = r.number(*t, "duration", "[dynamics] (s)", true, seconds);
  if (duration && *duration <= 0.0)
    r.error(r.at(t->get("duration")), "[dynamics] 'duration' must be positive (seconds)");
  c.duration = duration.value_or(0.0);
  if (const toml::node* key = t->get("duration")) c.duration_where = r.at(*key);
  const std::optional<double> interval = r.number(*t, "interval", "[dynamics] (s)", true, seconds);
  if (interval && (*interval <= 0.0 || (duration && *interval > *duration)))
    r.error(r.at(t->get("interval")),
            "[dynamics] 'interval' (s between output samples) must be positive and at most "
            "'duration'");
  c.interval = interval.value_or(0.0);
  if (!m.axis().timed()) {
    static_cast<FreeCoordinate&>(c) = read_free_coordinate(
        r, m, m.drivers[static_cast<size_t>(m.axis().driver)], *t, "[dynamics]");
    m.dynamics = c;
    return;
  }
  for (size_t i = 0; i < m.drivers.size(); ++i) {
    Driver& d = m.drivers[i];
    const std::string what = fmt::format("[dynamics.{}]", d.name);
    FreeCoordinate coordinate;
    if (const toml::table* own = r.table(*t, d.name, "[dynamics]", false)) {
      r.known_keys(*own, what, coordinate_keys);
      coordinate = read_free_coordinate(r, m, d, *own, what);
    } else {
      d.law.kind = MotionLaw::Kind::constant_speed;  // at rest: its kinematic view at 1 unit/s
      d.law.speed = 1.0;
    }
    if (i == 0)
      static_cast<FreeCoordinate&>(c) = coordinate;
    else
      c.others.push_back(coordinate);
  }
  m.dynamics = c;
}

}  // namespace crosslink::loading
