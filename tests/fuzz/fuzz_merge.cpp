// Fuzz target for `crosslink merge` (app/merge.cpp, docs/robustness.md): the JSON part of a
// sharded sweep is the one input the definition loader does not check (it carries the
// definitions' texts, which merge loads, and each definition's sweep, which methods/sweep_json
// reads back). Any bytes given as a part must be merged or refused with an exception that the
// command turns into exit code 2; a crash, a sanitizer report or a hang is a finding. Built with
// libFuzzer by -DCROSSLINK_FUZZ=ON (clang); replay.cpp runs kept inputs with any compiler.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <exception>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "app/commands.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // merge reads its parts from files: one file per process, rewritten for each input.
  static const std::string path = "/tmp/fuzz_merge_" + std::to_string(getpid()) + ".json";
  std::string text(reinterpret_cast<const char*>(data), size);
  // A part names the version that wrote it and merge refuses another: the seeds' parts are
  // taken as this version's, so that a new version still fuzzes past that check.
  nlohmann::json part = nlohmann::json::parse(text, nullptr, false);
  if (part.is_object() && part.contains("crosslink") && part["crosslink"].is_string() &&
      part["crosslink"] != CROSSLINK_VERSION) {
    part["crosslink"] = CROSSLINK_VERSION;
    text = part.dump();
  }
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
  try {
    crosslink::app::MergeArgs args;
    args.parts = {path};
    crosslink::app::run_merge(args);
  } catch (const std::exception&) {
    // Refused: exit code 2 (run_command_line, app/options.cpp), with its message.
  }
  return 0;
}
