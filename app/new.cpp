// `crosslink new fourbar|slider-crank|five-bar [FILE]`: writes a commented starting definition
// (app/templates/, embedded at build time) that `crosslink check` accepts, for a user to edit.
#include <fmt/core.h>

#include <array>
#include <filesystem>
#include <fstream>
#include <string>

#include "app/commands.h"

namespace crosslink::app {

extern const char* const kFourbarTemplate;      // templates/fourbar.toml
extern const char* const kSliderCrankTemplate;  // templates/slider_crank.toml
extern const char* const kFivebarTemplate;      // templates/fivebar.toml

namespace {

struct Template {
  const char* kind;
  const char* const* text;
  const char* what;
};
const std::array<Template, 3> kTemplates{{
    {"fourbar", &kFourbarTemplate,
     "a crank-rocker four-bar with its swing, time ratio and "
     "transmission angle"},
    {"slider-crank", &kSliderCrankTemplate,
     "an offset slider-crank with its stroke and time ratio"},
    {"five-bar", &kFivebarTemplate, "a five-bar with two driven cranks"},
}};

}  // namespace

int run_new(const std::string& kind, const std::string& file) {
  const std::string path = file.empty() ? kind + ".toml" : file;
  if (std::filesystem::exists(path)) {
    fmt::print(stderr, "{}: error: the file exists; crosslink new does not overwrite it\n", path);
    return kExitBadInput;
  }
  for (const Template& t : kTemplates) {
    if (kind != t.kind) continue;
    std::ofstream out(path);
    out << *t.text;
    if (!out.flush()) {
      fmt::print(stderr, "{}: error: cannot write the file\n", path);
      return kExitBadInput;
    }
    fmt::print("wrote {}: {}. Edit it, then: crosslink check {}\n", path, t.what, path);
  }
  return kExitOk;
}

}  // namespace crosslink::app
