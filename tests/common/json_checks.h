// Reading JSON in tests with nlohmann::json: a missing key, a null where a number is
// expected or text that is not JSON throws with the path named, so the test fails instead of
// reading 0 (the string searches these replace read a missing value as 0).
#pragma once

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

namespace lander::test {

// Parses `text`; throws std::runtime_error quoting the text when it is not JSON.
inline nlohmann::json parse_json(const std::string& text) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw std::runtime_error(std::string("not JSON (") + e.what() + "): " + text);
  }
}

// Parses the file at `path`; throws naming the file when it is missing or not JSON.
inline nlohmann::json read_json_file(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot read");
  std::stringstream ss;
  ss << f.rdbuf();
  return parse_json(ss.str());
}

// The value at a dotted path ("vision.frames"; for a key that holds a dot, use at()). Throws
// naming the path when a key is missing.
inline const nlohmann::json& at_path(const nlohmann::json& j, const std::string& dotted) {
  const nlohmann::json* cur = &j;
  std::size_t start = 0;
  while (start <= dotted.size()) {
    const std::size_t dot = dotted.find('.', start);
    const std::string key = dotted.substr(start, dot == std::string::npos ? std::string::npos
                                                                          : dot - start);
    if (!cur->is_object() || !cur->contains(key)) {
      throw std::runtime_error("JSON has no '" + dotted + "' (missing '" + key + "')");
    }
    cur = &(*cur)[key];
    if (dot == std::string::npos) break;
    start = dot + 1;
  }
  return *cur;
}

// The number at a dotted path; throws when it is missing, null or not a number.
inline double number_at(const nlohmann::json& j, const std::string& dotted) {
  const nlohmann::json& v = at_path(j, dotted);
  if (!v.is_number()) {
    throw std::runtime_error("JSON '" + dotted + "' is " + v.dump() + ", not a number");
  }
  return v.get<double>();
}

// The string at a dotted path; throws when it is missing or not a string.
inline std::string string_at(const nlohmann::json& j, const std::string& dotted) {
  const nlohmann::json& v = at_path(j, dotted);
  if (!v.is_string()) {
    throw std::runtime_error("JSON '" + dotted + "' is " + v.dump() + ", not a string");
  }
  return v.get<std::string>();
}

// The boolean at a dotted path; throws when it is missing or not a boolean.
inline bool bool_at(const nlohmann::json& j, const std::string& dotted) {
  const nlohmann::json& v = at_path(j, dotted);
  if (!v.is_boolean()) {
    throw std::runtime_error("JSON '" + dotted + "' is " + v.dump() + ", not a boolean");
  }
  return v.get<bool>();
}

}  // namespace lander::test
