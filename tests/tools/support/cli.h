// Helpers for tests that run the `lander` binary (LANDER_BINARY) as a user would.
#pragma once

#include <string>

namespace lander::test {

struct CliResult {
  int code;            ///< exit code (-1 if the process did not exit normally)
  std::string output;  ///< stdout + stderr
};

// Runs `lander ARGS`, capturing its output.
CliResult run_lander(const std::string& args);

// A fresh directory under /tmp whose name starts with `prefix`.
std::string make_temp_dir(const std::string& prefix);

// The whole file as a string ("" if it cannot be read).
std::string slurp(const std::string& path);

}  // namespace lander::test
