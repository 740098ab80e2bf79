#include "methods/sweep_parts.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "analytic/model/limits.h"
#include "analytic/model/loader.h"
#include "analytic/model/units_text.h"
#include "methods/engines.h"
#include "methods/study.h"
#include "methods/sweep_json.h"

namespace crosslink::methods {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A part's "format": what merge reads.
constexpr const char* kPartFormat = "crosslink sweep 1";

// The grid's size multiplies the work: bounded like every other input.
constexpr size_t kMaxTimeSteps = 50;

// FNV-1a, 64 bits: tells two contents apart (a changed definition), not a secure digest.
std::string fnv1a64(std::string_view text) {
  uint64_t h = 14695981039346656037ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  return fmt::format("{:016x}", h);
}

// At most the loader's limit and one byte more (the loader refuses it; /dev/zero ends).
std::string read_definition(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string text(static_cast<size_t>(limits::kDefinitionBytes) + 1, '\0');
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(in.gcount()));
  return text;
}

// One definition's sweep options, checked. `several`: one of many, where --step applies to the
// kinematic cases and a dynamics case keeps its interval.
SettingsSweepOptions sweep_options(const Mechanism& m, const SweepRun& run, bool several) {
  // A dynamics case: against its exact simulation, over its duration (docs/sweep.md).
  const bool dynamics = m.dynamics.has_value();
  if (dynamics && run.step != 0.0 && !several)
    throw std::invalid_argument(
        "--step: a dynamics case is sampled at its [dynamics] interval, not swept");
  SettingsSweepOptions options;
  options.engines = run.engines;
  for (const std::string& e : options.engines)
    if (!find_engine(e))
      throw std::invalid_argument(
          fmt::format("--engines: '{}' has no settings to sweep (engines: {})", e,
                      fmt::join(engine_names(), ", ")));
  if (!run.dts.empty()) options.dts = run.dts;
  if (options.dts.size() > kMaxTimeSteps)
    throw std::invalid_argument(
        fmt::format("--dt: {} time steps: the limit is {}", options.dts.size(), kMaxTimeSteps));
  for (double dt : options.dts) {
    // The reference covers at most one cycle (a dynamics case: its duration); the defaults are
    // left to the engines' own check.
    const double span = dynamics ? m.dynamics->duration : m.cycle_period();
    if (!run.dts.empty() && span > 0.0)
      check_time_step(span, dt, run.max_steps, fmt::format("--dt {:g}", dt));
  }
  if (run.step != 0.0 && !dynamics)  // 0: the default
    options.sweep.step = run.step * axis_unit_of(m).scale;
  if (!dynamics) check_sweep_work(m, options.sweep, run.limits);
  options.base = {{"max_steps", std::to_string(run.max_steps)}};
  options.repeat = run.repeat;
  options.jobs = run.jobs;
  options.accuracy_pct = parse_accuracy(run.accuracy);
  return options;
}

// Every field merge reads, checked before any is used, each refusal naming the part: a shard
// index that is a whole number in [0, N), a count from 1, the definitions' texts and hashes, each
// sweep's definition an index into them (its rows: methods/sweep_json.cpp).
void validate_part(const std::string& path, const json& j) {
  const auto refuse = [&](const std::string& what) {
    throw std::invalid_argument(fmt::format("{}: {}", path, what));
  };
  const auto whole = [&](const json& object, const char* key, long long least,
                         long long below) -> long long {
    if (!object.is_object() || !object.contains(key)) refuse(fmt::format("missing \"{}\"", key));
    const json& v = object.at(key);
    if (!v.is_number_integer() || v.get<long long>() < least || v.get<long long>() >= below)
      refuse(fmt::format("\"{}\": expected a whole number from {} to {}, got {}", key, least,
                         below - 1, v.dump()));
    return v.get<long long>();
  };
  if (!j.contains("crosslink") || !j.at("crosslink").is_string())
    refuse("\"crosslink\": expected the version that wrote the part");
  if (!j.contains("settings") || !j.at("settings").is_object())
    refuse("\"settings\": expected an object");
  const json& settings = j.at("settings");
  if (!settings.contains("engines") || !settings.at("engines").is_array())
    refuse("\"settings\": \"engines\": expected an array of engine names");
  const std::vector<std::string> known = engine_names();
  for (const json& e : settings.at("engines"))
    if (!e.is_string() ||
        std::find(known.begin(), known.end(), e.get<std::string>()) == known.end())
      refuse(fmt::format("\"settings\": \"engines\": unknown engine {} (known: {})", e.dump(),
                         fmt::join(known, ", ")));
  if (!settings.contains("accuracy")) refuse("\"settings\": missing \"accuracy\"");
  if (!j.contains("shard")) refuse("missing \"shard\"");
  const long long count = whole(j.at("shard"), "count", 1, std::numeric_limits<int>::max());
  whole(j.at("shard"), "index", 0, count);
  if (!j.contains("definitions") || !j.at("definitions").is_array())
    refuse("\"definitions\": expected an array");
  for (const json& d : j.at("definitions"))
    for (const char* key : {"path", "fnv1a64", "text"})
      if (!d.is_object() || !d.contains(key) || !d.at(key).is_string())
        refuse(fmt::format("\"definitions\": each needs a string \"{}\"", key));
  if (!j.contains("sweeps") || !j.at("sweeps").is_array()) refuse("\"sweeps\": expected an array");
  const auto definitions = static_cast<long long>(j.at("definitions").size());
  for (const json& sweep : j.at("sweeps")) whole(sweep, "definition", 0, definitions);
}

// The definitions' list without their texts (the hash stands for them), for messages.
std::string definitions_text(const json& definitions) {
  std::string text;
  for (const json& d : definitions)
    text += fmt::format("{}{} ({})", text.empty() ? "" : ", ", d.at("path").get<std::string>(),
                        d.at("fnv1a64").get<std::string>());
  return text;
}

}  // namespace

std::vector<DefinitionFile> definition_files(const std::vector<std::string>& paths) {
  std::vector<DefinitionFile> out;
  for (const std::string& path : paths) {
    std::error_code error;
    if (!fs::is_directory(path, error)) {
      // One file that cannot be read is the loader's to report (file:line:col).
      if (paths.size() > 1 && !fs::exists(path, error))
        throw std::invalid_argument(fmt::format("'{}': no such file or folder", path));
      out.push_back({path, "", ""});
      continue;
    }
    std::vector<std::string> found;
    for (const auto& entry : fs::recursive_directory_iterator(path))
      if (entry.is_regular_file() && entry.path().extension() == ".toml")
        found.push_back(entry.path().string());
    if (found.empty())
      throw std::invalid_argument(fmt::format("'{}': a folder with no .toml definition", path));
    std::sort(found.begin(), found.end());
    for (std::string& f : found) out.push_back({std::move(f), "", ""});
  }
  for (DefinitionFile& d : out) {
    d.text = read_definition(d.path);
    d.hash = fnv1a64(d.text);
  }
  return out;
}

Shard parse_shard(const std::string& text) {
  if (text.empty()) return {};
  Shard s;
  char slash = 0;
  std::istringstream in(text);
  in >> s.index >> slash >> s.count;
  if (!in || slash != '/' || in.peek() != EOF || s.count < 1 || s.index < 0 || s.index >= s.count)
    throw std::invalid_argument(
        fmt::format("--shard: expected I/N with 0 <= I < N, such as 0/4 (Slurm: "
                    "$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT with --array=0-3), got '{}'",
                    text));
  return s;
}

std::optional<double> parse_accuracy(const std::string& text) {
  if (text.empty()) return std::nullopt;
  std::string number = text;
  if (number.back() == '%') number.pop_back();
  size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(number, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  // It becomes the engines' tolerance: the same limit.
  if (used == 0 || used != number.size() || !(value > 0.0) || !(value <= limits::kTolerance))
    throw std::invalid_argument(
        fmt::format("--accuracy: expected a positive percentage of peak up to {:g} such as 1 or "
                    "0.5%, got '{}'",
                    limits::kTolerance, text));
  return value;
}

json sweep_settings(const SweepRun& run) {
  json j;
  j["engines"] = run.engines;
  j["dt"] = run.dts.empty() ? default_time_steps() : run.dts;
  j["step"] = run.step;
  j["repeat"] = run.repeat;
  j["accuracy"] = run.accuracy;
  j["max_steps"] = run.max_steps;
  j["max_samples"] = run.limits.max_samples;
  return j;
}

ShardSweeps prepare_shard(const std::vector<DefinitionFile>& definitions, const Shard& shard,
                          const SweepRun& run) {
  const bool several = definitions.size() > 1;
  ShardSweeps out;
  for (size_t k = 0; k < definitions.size(); ++k)
    if (shard.holds(k)) out.swept.push_back(k);
  // Reserved, so that the sweeps' pointers to them hold.
  out.mechanisms.reserve(out.swept.size());
  for (size_t k : out.swept) {
    out.mechanisms.push_back(load_mechanism(definitions[k].path));
    out.options.push_back(sweep_options(out.mechanisms.back(), run, several));
  }
  return out;
}

void sweep_shard(ShardSweeps& shard,
                 const std::function<void(size_t, SettingsSweepOptions&)>& starting,
                 const std::function<void()>& finished) {
  for (size_t i = 0; i < shard.swept.size(); ++i) {
    if (starting) starting(shard.swept[i], shard.options[i]);
    shard.sweeps.push_back(run_settings_sweep(shard.mechanisms[i], shard.options[i]));
    if (finished) finished();
  }
}

json sweep_document(const Shard& shard, const json& settings,
                    const std::vector<DefinitionFile>& definitions,
                    const std::vector<size_t>& swept, const std::vector<SettingsSweep>& sweeps) {
  json j;
  j["format"] = kPartFormat;
  j["crosslink"] = CROSSLINK_VERSION;
  j["shard"] = {{"index", shard.index}, {"count", shard.count}};
  j["settings"] = settings;
  j["definitions"] = json::array();
  for (const DefinitionFile& d : definitions)
    j["definitions"].push_back({{"path", d.path}, {"fnv1a64", d.hash}, {"text", d.text}});
  j["sweeps"] = json::array();
  for (size_t i = 0; i < sweeps.size(); ++i) {
    json one = sweep_to_json(sweeps[i]);
    one["definition"] = swept[i];
    j["sweeps"].push_back(std::move(one));
  }
  return j;
}

json part_of(const json& document, const std::string& name) {
  if (!document.is_object() || document.value("format", "") != kPartFormat)
    throw std::invalid_argument(fmt::format(
        "{}: not a part of a sweep (the JSON of `crosslink sweep --json`, \"format\": \"{}\")",
        name, kPartFormat));
  validate_part(name, document);
  return document;
}

json read_part(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(fmt::format("{}: cannot open the part", path));
  const json j = json::parse(in, nullptr, false);
  return part_of(j.is_discarded() ? json() : j, path);
}

MergedSweep merge_parts(const std::vector<std::pair<std::string, json>>& given) {
  if (given.empty()) throw std::invalid_argument("no part to merge");
  std::vector<json> parts;
  for (const auto& [name, document] : given) parts.push_back(part_of(document, name));
  const auto name_of = [&](size_t i) -> const std::string& { return given[i].first; };
  const json& first = parts.front();
  const std::string& first_path = name_of(0);
  // The parts must be of one run: what makes a row (version, settings, definitions) the same.
  for (size_t i = 0; i < parts.size(); ++i) {
    const json& p = parts[i];
    const std::string& path = name_of(i);
    if (p.at("crosslink") != CROSSLINK_VERSION)
      throw std::invalid_argument(
          fmt::format("{}: written by crosslink {}, this is crosslink {}: run every shard and the "
                      "merge with one version",
                      path, p.at("crosslink").dump(), CROSSLINK_VERSION));
    if (p.at("settings") != first.at("settings"))
      throw std::invalid_argument(
          fmt::format("{}: its settings {} differ from {}'s {}: the shards of one sweep run with "
                      "the same options",
                      path, p.at("settings").dump(), first_path, first.at("settings").dump()));
    const json& d = p.at("definitions");
    const json& d0 = first.at("definitions");
    for (size_t k = 0; k < std::max(d.size(), d0.size()); ++k)
      if (k >= d.size() || k >= d0.size() || d[k].at("path") != d0[k].at("path") ||
          d[k].at("fnv1a64") != d0[k].at("fnv1a64"))
        throw std::invalid_argument(fmt::format(
            "{}: its definitions differ from {}'s at definition {}: {} against {} (a definition "
            "changed, or the shards were given different files)",
            path, first_path, k + 1, definitions_text(d), definitions_text(d0)));
  }
  // Every shard of N exactly once.
  const int count = first.at("shard").at("count").get<int>();
  std::map<int, std::string> seen;
  for (size_t i = 0; i < parts.size(); ++i) {
    const json& shard = parts[i].at("shard");
    const int n = shard.at("count").get<int>(), index = shard.at("index").get<int>();
    // A count of 0 would divide by zero in Shard::holds (SIGFPE).
    if (n < 1 || index < 0 || index >= n)
      throw std::invalid_argument(
          fmt::format("{}: shard {}/{} is no shard (I/N with 0 <= I < N)", name_of(i), index, n));
    if (n != count)
      throw std::invalid_argument(fmt::format("{}: shard {}/{}, but {} is a shard of {}",
                                              name_of(i), index, n, first_path, count));
    if (const auto it = seen.find(index); it != seen.end())
      throw std::invalid_argument(
          fmt::format("shard {}/{} given twice: {} and {}", index, count, it->second, name_of(i)));
    seen[index] = name_of(i);
  }
  for (int index = 0; index < count; ++index)
    if (!seen.count(index))
      throw std::invalid_argument(
          fmt::format("shard {}/{} is missing: {} part{} given, each shard's needed once", index,
                      count, parts.size(), parts.size() == 1 ? "" : "s"));

  // The definitions, read from the parts' own texts (the hash checked against them), and each
  // definition's sweep from the part of its shard.
  MergedSweep out;
  for (const json& d : first.at("definitions")) {
    DefinitionFile f{d.at("path"), d.at("text"), d.at("fnv1a64")};
    if (fnv1a64(f.text) != f.hash)
      throw std::invalid_argument(
          fmt::format("{}: the text of {} does not match its hash", first_path, f.path));
    out.definitions.push_back(std::move(f));
  }
  const std::vector<DefinitionFile>& definitions = out.definitions;
  std::vector<const json*> by_definition(definitions.size(), nullptr);
  std::vector<std::string> part_of_definition(definitions.size());  // the part holding each
  for (size_t i = 0; i < parts.size(); ++i) {
    const Shard shard{parts[i].at("shard").at("index").get<int>(), count};
    for (const json& s : parts[i].at("sweeps")) {
      const size_t k = s.at("definition").get<size_t>();
      if (k >= definitions.size() || !shard.holds(k) || by_definition[k])
        throw std::invalid_argument(
            fmt::format("{}: holds a sweep of definition {}, which is not shard {}/{}'s",
                        name_of(i), k + 1, shard.index, count));
      by_definition[k] = &s;
      part_of_definition[k] = name_of(i);
    }
  }
  for (size_t k = 0; k < definitions.size(); ++k)
    if (!by_definition[k])
      throw std::invalid_argument(fmt::format("no part holds the sweep of {} (shard {}/{})",
                                              definitions[k].path, k % static_cast<size_t>(count),
                                              count));

  const json& settings = first.at("settings");
  const std::vector<std::string> engines = settings.at("engines");
  const std::optional<double> accuracy = parse_accuracy(settings.at("accuracy"));
  ShardSweeps& all = out.shards;
  all.mechanisms.reserve(definitions.size());
  for (size_t k = 0; k < definitions.size(); ++k) {
    all.mechanisms.push_back(parse_mechanism(definitions[k].text, definitions[k].path));
    try {
      all.sweeps.push_back(
          sweep_from_json(*by_definition[k], all.mechanisms.back(), engines, accuracy));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(fmt::format("{}: the sweep of {}: {}", part_of_definition[k],
                                              definitions[k].path, e.what()));
    }
    all.swept.push_back(k);
  }
  out.document = sweep_document(Shard{}, settings, definitions, all.swept, all.sweeps);
  return out;
}

}  // namespace crosslink::methods
