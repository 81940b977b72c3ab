// Helpers for the campaign tests: run `lander` from an argument vector (no shell) and read
// CSV files with a real (RFC 4180) parser.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "common/run_binary.h"

namespace lander::test {

struct Result {
  int code{-1};        ///< exit code; -1 when ended by a signal, -2 when killed at kCommandLimit_s
  std::string output;  ///< stdout + stderr
};

// Runs LANDER_BINARY with `args`, waits (up to kCommandLimit_s), returns the exit code and output.
Result lander(const std::vector<std::string>& args);

// A fresh directory under /tmp.
std::string temp_dir(const std::string& prefix);

std::string read_text(const std::string& path);

// A CSV file as a header and rows of cells (quoted fields, doubled quotes, line breaks inside
// quotes). Throws std::runtime_error for a malformed file.
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  // Rows as "col=value;" strings without the named columns, sorted (order-free comparison).
  std::vector<std::string> canonical_rows(const std::vector<std::string>& drop) const;
};
Csv read_csv(const std::string& path);

}  // namespace lander::test
