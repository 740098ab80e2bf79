// Small file and text helpers shared by the subcommands.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "analytic/model/mechanism.h"

namespace crosslink::app {

// Writes `text` to `path`, creating its folder; throws std::invalid_argument on failure.
void write_file(const std::string& path, const std::string& text);

// <prefix>/share/crosslink next to the running <prefix>/bin/crosslink (nullopt if unknown).
std::optional<std::filesystem::path> installed_share();

// The installed chart scripts: <prefix>/share/crosslink/report next to <prefix>/bin.
std::vector<std::string> installed_asset_dirs();

// "a,b,,c" -> {"a", "b", "c"}.
std::vector<std::string> split(const std::string& text, char separator = ',');

}  // namespace crosslink::app
