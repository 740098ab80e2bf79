#include "app/files.h"

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace crosslink::app {

namespace fs = std::filesystem;

void write_file(const std::string& path, const std::string& text) {
  const fs::path folder = fs::path(path).parent_path();
  std::error_code error;
  if (!folder.empty()) fs::create_directories(folder, error);
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::invalid_argument(fmt::format("cannot write '{}'", path));
  out << text;
  if (!out) throw std::invalid_argument(fmt::format("error writing '{}'", path));
}

std::optional<std::filesystem::path> installed_share() {
  std::error_code error;
  const fs::path exe = fs::read_symlink("/proc/self/exe", error);
  if (error) return std::nullopt;
  return exe.parent_path().parent_path() / "share" / "crosslink";
}

std::vector<std::string> installed_asset_dirs() {
  const auto share = installed_share();
  if (!share) return {};
  return {(*share / "report").string()};
}

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  for (std::string part; std::getline(in, part, separator);)
    if (!part.empty()) parts.push_back(part);
  return parts;
}

}  // namespace crosslink::app
