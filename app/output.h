// The trajectory writers shared by `solve` and `simulate`: one sample as JSON in the documented
// schema (docs/json.md), a whole trajectory as JSON or CSV (SI), one sample as notes-style
// tables in the file's units.
#pragma once

#include <Eigen/Core>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "analytic/model/mechanism.h"
#include "analytic/model/trajectory.h"

namespace crosslink::app {

// Extra per-sample columns (name, values), written after the trajectory's own.
using Columns = std::vector<std::pair<std::string, Eigen::VectorXd>>;

// One sample: time, driver, status, links, points, sliders, forces (null when not usable).
nlohmann::json sample_json(const Mechanism& m, const Trajectory& t, int row);

// The document: mechanism, file, units, method, then either the one sample `single` (its fields
// at the top level) or `status` and `samples`, and `events` (each at `event_key`: "driver" for a
// kinematic sweep, "time" for a simulation). `extra` adds fields to each sample.
nlohmann::json trajectory_json(const Mechanism& m, const Trajectory& t, std::optional<int> single,
                               const std::string& event_key = "driver",
                               const std::function<void(nlohmann::json&, int)>& extra = {});

// trajectory_json(...).dump(2) and a newline on `file`, each sample written as it is made (the
// memory of one sample's JSON, not of the document's).
// `more`: top-level fields added to the document (null: none).
void print_trajectory_json(std::FILE* file, const Mechanism& m, const Trajectory& t,
                           std::optional<int> single, const std::string& event_key = "driver",
                           const std::function<void(nlohmann::json&, int)>& extra = {},
                           const nlohmann::json& more = nullptr);

// One row per sample: sample, time, driver, status, every channel, then `extra`. A value that is
// not usable (a flagged sample) is an empty field.
void print_csv(const Trajectory& t, const Columns& extra = {});

// The channels a table shows for `choice`, a comma-separated list of channel names (x.C) and
// kinds (alpha: every link's alpha), in that order; an empty choice gives each link's angle,
// omega and alpha and each slider's s, sdot and sddot, but for those the definition prescribes
// (compare::prescribed: the driven crank, a link a prismatic joint holds to the ground). Throws
// std::invalid_argument for a name that is neither, listing the kinds.
std::vector<std::string> table_channels(const Mechanism& m, const Trajectory& t,
                                        const std::string& choice);

// One row per sample: the driver (file units) or, with `by_time`, the time [s]; the status;
// each of `channels` in the file's units (a row of units under the names) with `digits`
// decimals; then `extra` (scientific, blank where not finite or the sample is flagged). Values
// that do not exist are blank.
void print_table_rows(const Mechanism& m, const Trajectory& t, bool by_time, int digits,
                      const std::vector<std::string>& channels, const std::string& note,
                      const Columns& extra = {});

// Notes-style tables of links, points and sliders at one sample, in the file's units.
void print_table_at(const Mechanism& m, const Trajectory& t, int row);

}  // namespace crosslink::app
