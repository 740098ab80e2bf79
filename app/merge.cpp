// `crosslink merge PART... [--csv OUT] [--report OUT.html] [--json OUT]`: joins the JSON parts of a
// sweep split into shards (`crosslink sweep ... --shard I/N --json PART`) into the outputs a
// single run over every definition writes, after checking that the parts fit together: the same
// crosslink version, settings and definitions (path and hash of each), and every shard of N
// exactly once. Exit 0; 1 when a pick found no setting; 2 on parts that do not fit. Also the
// helpers `sweep` shares with it (app/sweep_parts.h). See docs/sweep.md.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "analytic/model/limits.h"
#include "analytic/model/loader.h"
#include "app/commands.h"
#include "app/files.h"
#include "app/sweep_parts.h"
#include "methods/engines.h"
#include "methods/sweep_json.h"

namespace crosslink::app {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A part's "format": what merge reads.
constexpr const char* kPartFormat = "crosslink sweep 1";

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

json sweep_document(const Shard& shard, const json& settings,
                    const std::vector<DefinitionFile>& definitions,
                    const std::vector<size_t>& swept,
                    const std::vector<methods::SettingsSweep>& sweeps) {
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
    json one = methods::sweep_to_json(sweeps[i]);
    one["definition"] = swept[i];
    j["sweeps"].push_back(std::move(one));
  }
  return j;
}

int write_sweep_outputs(const SweepOutputs& outputs, const methods::HtmlOptions& html,
                        const json& document, const std::vector<DefinitionFile>& definitions,
                        const std::vector<size_t>& swept,
                        const std::vector<methods::SettingsSweep>& sweeps) {
  const bool several = definitions.size() > 1;
  std::vector<methods::SweptDefinition> set;
  for (size_t i = 0; i < sweeps.size(); ++i) {
    if (i > 0) fmt::print("\n");
    if (several) fmt::print("{}\n", definitions[swept[i]].path);
    methods::print_sweep(sweeps[i], stdout);
    set.push_back({definitions[swept[i]].path, &sweeps[i]});
  }
  // One definition: its own CSV and page, as a sweep of one file has always written them.
  if (!outputs.csv.empty()) {
    std::ostringstream text;
    if (several)
      methods::write_sweeps_csv(set, text);
    else if (!sweeps.empty())
      methods::write_sweep_csv(sweeps.front(), text);
    write_file(outputs.csv, text.str());
    fmt::print("csv: {}\n", outputs.csv);
  }
  if (!outputs.report.empty()) {
    std::ostringstream page;
    if (several)
      methods::write_sweeps_html(set, html, page);
    else if (!sweeps.empty())
      methods::write_sweep_html(sweeps.front(), html, page);
    write_file(outputs.report, page.str());
    fmt::print("report: {}\n", outputs.report);
  }
  if (!outputs.json.empty()) {
    write_file(outputs.json, document.dump(1) + "\n");
    fmt::print("json: {}\n", outputs.json);
  }
  for (const methods::SettingsSweep& sweep : sweeps)
    for (const methods::Selection& s : sweep.selections)
      if (!s.found) return kExitFail;
  return kExitOk;
}

namespace {

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
  const std::vector<std::string> known = methods::engine_names();
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

json read_part(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::invalid_argument(fmt::format("{}: cannot open the part", path));
  json j = json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object() || j.value("format", "") != kPartFormat)
    throw std::invalid_argument(fmt::format(
        "{}: not a part of a sweep (the JSON of `crosslink sweep --json`, \"format\": \"{}\")",
        path, kPartFormat));
  validate_part(path, j);
  return j;
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

int run_merge(const MergeArgs& args) {
  std::vector<json> parts;
  for (const std::string& path : args.parts) parts.push_back(read_part(path));
  const json& first = parts.front();
  const std::string& first_path = args.parts.front();
  // The parts must be of one run: what makes a row (version, settings, definitions) the same.
  for (size_t i = 0; i < parts.size(); ++i) {
    const json& p = parts[i];
    const std::string& path = args.parts[i];
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
      throw std::invalid_argument(fmt::format("{}: shard {}/{} is no shard (I/N with 0 <= I < N)",
                                              args.parts[i], index, n));
    if (n != count)
      throw std::invalid_argument(fmt::format("{}: shard {}/{}, but {} is a shard of {}",
                                              args.parts[i], index, n, first_path, count));
    if (const auto it = seen.find(index); it != seen.end())
      throw std::invalid_argument(fmt::format("shard {}/{} given twice: {} and {}", index, count,
                                              it->second, args.parts[i]));
    seen[index] = args.parts[i];
  }
  for (int index = 0; index < count; ++index)
    if (!seen.count(index))
      throw std::invalid_argument(
          fmt::format("shard {}/{} is missing: {} part{} given, each shard's needed once", index,
                      count, parts.size(), parts.size() == 1 ? "" : "s"));

  // The definitions, read from the parts' own texts (the hash checked against them), and each
  // definition's sweep from the part of its shard.
  const json& listed = first.at("definitions");
  std::vector<DefinitionFile> definitions;
  for (const json& d : listed) {
    DefinitionFile f{d.at("path"), d.at("text"), d.at("fnv1a64")};
    if (fnv1a64(f.text) != f.hash)
      throw std::invalid_argument(
          fmt::format("{}: the text of {} does not match its hash", first_path, f.path));
    definitions.push_back(std::move(f));
  }
  std::vector<const json*> by_definition(definitions.size(), nullptr);
  std::vector<std::string> part_of(definitions.size());  // the part holding each sweep
  const Shard whole;
  for (size_t i = 0; i < parts.size(); ++i) {
    const Shard shard{parts[i].at("shard").at("index").get<int>(), count};
    for (const json& s : parts[i].at("sweeps")) {
      const size_t k = s.at("definition").get<size_t>();
      if (k >= definitions.size() || !shard.holds(k) || by_definition[k])
        throw std::invalid_argument(
            fmt::format("{}: holds a sweep of definition {}, which is not shard {}/{}'s",
                        args.parts[i], k + 1, shard.index, count));
      by_definition[k] = &s;
      part_of[k] = args.parts[i];
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
  std::vector<Mechanism> mechanisms;
  mechanisms.reserve(definitions.size());
  std::vector<methods::SettingsSweep> sweeps;
  std::vector<size_t> swept;
  for (size_t k = 0; k < definitions.size(); ++k) {
    mechanisms.push_back(parse_mechanism(definitions[k].text, definitions[k].path));
    try {
      sweeps.push_back(
          methods::sweep_from_json(*by_definition[k], mechanisms.back(), engines, accuracy));
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(
          fmt::format("{}: the sweep of {}: {}", part_of[k], definitions[k].path, e.what()));
    }
    swept.push_back(k);
  }
  compare::HtmlOptions html;
  html.asset_dirs = installed_asset_dirs();
  return write_sweep_outputs({args.csv, args.report, args.json}, html,
                             sweep_document(whole, settings, definitions, swept, sweeps),
                             definitions, swept, sweeps);
}

}  // namespace crosslink::app
