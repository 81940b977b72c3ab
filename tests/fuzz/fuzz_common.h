// Shared by the libFuzzer targets: the bytes under test as a file the real loaders read
// (they take paths, as the command line gives them), and the one rule every target checks:
// bad input ends in a ConfigError (a clean, named error), never another exception, a crash
// or a sanitizer report.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>

#include "lander/core/params_io.h"

namespace lander::fuzz {

// A per-process scratch file holding the input.
inline std::string write_input(const uint8_t* data, size_t size, const char* suffix) {
  static const std::string path =
      "/tmp/lander_fuzz_" + std::to_string(getpid()) + suffix;
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

// Runs `f`; a ConfigError is the expected answer to bad input, anything else escaping is a
// finding: abort so libFuzzer saves the input.
template <class F>
void expect_clean(F f) {
  try {
    f();
  } catch (const ConfigError&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz: unexpected exception (not a ConfigError): %s\n", e.what());
    std::abort();
  }
}

}  // namespace lander::fuzz
