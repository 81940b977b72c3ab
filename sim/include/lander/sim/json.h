// LEGACY: the tree API of the former hand-written JSON writer, kept only so that
// tools/lander/cmd_batch.cpp (being replaced by `lander campaign` on main) still compiles.
// Delete this header and json.cpp together with cmd_batch.cpp. Serialisation goes through
// nlohmann::ordered_json (json_text in output_files.h); new code uses nlohmann::ordered_json
// and write_json_file directly.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "lander/sim/output_files.h"

namespace lander::sim {

class Json {
 public:
  enum class Type { Null, Bool, Number, String, Array, Object };

  Json() = default;  // null
  Json(bool b) : type_(Type::Bool), bool_(b) {}
  Json(double x) : type_(Type::Number), num_(x) {}
  Json(int x) : Json(static_cast<long long>(x)) {}
  Json(long x) : Json(static_cast<long long>(x)) {}
  Json(long long x) : type_(Type::Number), num_(static_cast<double>(x)), is_int_(true), int_(x) {}
  Json(unsigned long x) : Json(static_cast<long long>(x)) {}
  Json(const char* s) : type_(Type::String), str_(s) {}
  Json(std::string s) : type_(Type::String), str_(std::move(s)) {}
  Json(const nlohmann::ordered_json& j);  // NOLINT: converts run_scenario()'s summary

  static Json object() { Json j; j.type_ = Type::Object; return j; }
  static Json array() { Json j; j.type_ = Type::Array; return j; }

  Json& operator[](const std::string& key);  // inserts the key (in order) if absent
  const Json* find(const std::string& key) const;
  Json& push(Json v);

  Type type() const { return type_; }
  double number() const { return num_; }
  bool boolean() const { return bool_; }
  const std::string& string() const { return str_; }

  nlohmann::ordered_json to_nlohmann() const;
  std::string dump() const { return json_text(to_nlohmann()); }

 private:
  Type type_ = Type::Null;
  bool bool_ = false;
  double num_ = 0.0;
  bool is_int_ = false;
  long long int_ = 0;
  std::string str_;
  std::vector<Json> items_;  // array items, or object values (with keys_)
  std::vector<std::string> keys_;
};

// write_file_atomic under its former name.
inline void write_text_file(const std::string& path, const std::string& text) {
  write_file_atomic(path, text);
}

}  // namespace lander::sim
