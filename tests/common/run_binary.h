// Runs a binary from an argument vector (ChildProcess: no shell) for the tests that run
// `lander` as a user would, bounded below ctest's 1500 s timeout so that a command that never
// ends fails its test with its output instead of a bare ctest timeout.
#pragma once

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "lander/sim/util/output_files.h"
#include "lander/sim/util/process.h"

namespace lander::test {

// The longest a command of a test may take (s): ctest's timeout is 1500 s.
constexpr double kCommandLimit_s = 1200.0;

struct BinaryRun {
  int code{-1};    ///< exit code; -1 when ended by a signal, -2 when killed at kCommandLimit_s
  int signal{0};   ///< the signal that ended it, 0 if it exited
  std::string out, err;  ///< stdout, stderr (stderr starts with a note when it was killed)
};

// Runs `argv` with stdout and stderr in files under `io_dir` (removed afterwards).
inline BinaryRun run_binary(const std::vector<std::string>& argv, const std::string& io_dir) {
  sim::SpawnOptions o;
  o.stdout_path = io_dir + "/stdout";
  o.stderr_path = io_dir + "/stderr";
  sim::ChildProcess p = sim::ChildProcess::spawn(argv, o);
  const std::optional<sim::ExitStatus> st = p.wait_or_kill(kCommandLimit_s);
  BinaryRun r;
  r.code = !st ? -2 : st->signaled ? -1 : st->code;
  r.signal = st && st->signaled ? st->signal : 0;
  r.out = sim::read_file_text(o.stdout_path, /*missing_ok=*/true);
  r.err = sim::read_file_text(o.stderr_path, /*missing_ok=*/true);
  if (!st) {
    char note[64];
    std::snprintf(note, sizeof note, "[still running after %g s: killed]\n", kCommandLimit_s);
    r.err = note + r.err;
  }
  std::remove(o.stdout_path.c_str());
  std::remove(o.stderr_path.c_str());
  return r;
}

}  // namespace lander::test
