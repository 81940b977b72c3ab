// Checking configuration errors in tests: the call must throw ConfigError, and its message
// must name what it is about (the key, the file, the line).
#pragma once

#include <initializer_list>
#include <string>

#include <gtest/gtest.h>

#include "lander/core/params_io.h"

namespace lander::test {

// Expects `fn` to throw ConfigError whose message contains every string in `needles`.
template <class Fn>
void expect_config_error(Fn fn, std::initializer_list<std::string> needles) {
  try {
    fn();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    for (const std::string& n : needles) {
      EXPECT_NE(std::string(e.what()).find(n), std::string::npos)
          << "message '" << e.what() << "' lacks '" << n << "'";
    }
  }
}

}  // namespace lander::test
