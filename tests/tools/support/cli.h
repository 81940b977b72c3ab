// Helpers for tests that run the `lander` binary (LANDER_BINARY) as a user would. The binary
// is started from an argument vector (ChildProcess, no shell), so any byte may appear in an
// argument.
#pragma once

#include <string>
#include <vector>

namespace lander::test {

struct CliResult {
  int code;            ///< exit code (-1 if the process did not exit normally, -2 if killed at kCommandLimit_s, common/run_binary.h)
  int signal;          ///< the signal that ended it, 0 if it exited
  std::string out;     ///< stdout
  std::string err;     ///< stderr
  std::string output;  ///< stdout + stderr
};

// Runs `lander ARGV...`, capturing its output.
CliResult run_lander(const std::vector<std::string>& argv);
// Runs `lander ARGS` with ARGS split at spaces (arguments without spaces only).
CliResult run_lander(const std::string& args);

// A fresh directory under /tmp whose name starts with `prefix`.
std::string make_temp_dir(const std::string& prefix);

// The whole file as a string ("" if it cannot be read).
std::string slurp(const std::string& path);

}  // namespace lander::test
