// The `crosslink` command line run as a user would, for the app's tests: its exit code, stdout
// and stderr. CROSSLINK_BINARY is the built executable.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace crosslink::test {

struct CommandRun {
  int exit_code = -1;
  std::string out, err;
};

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A folder of this test process's own.
inline std::filesystem::path scratch_dir() {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("crosslink_test_cli_" + std::to_string(static_cast<long>(::getpid())));
  std::filesystem::create_directories(dir);
  return dir;
}

// Runs `crosslink ARGS` (from the source root, or from `in` when given), capturing stdout and
// stderr.
inline CommandRun crosslink(const std::string& args, const std::filesystem::path& in = {}) {
  const std::filesystem::path err = scratch_dir() / "stderr.txt";
  const std::string command = (in.empty() ? "" : "cd \"" + in.string() + "\" && ") + "\"" +
                              CROSSLINK_BINARY + "\" " + args + " 2>\"" + err.string() + "\"";
  CommandRun run;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) {
    ADD_FAILURE() << "cannot run " << command;
    return run;
  }
  char buffer[4096];
  for (size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) run.out.append(buffer, n);
  const int status = ::pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.err = read_file(err);
  return run;
}

}  // namespace crosslink::test
