// A small ordered JSON value for the run outputs (summary.json, bench files). Keys keep their
// insertion order so files diff cleanly; numbers are written with round-trip precision, and
// non-finite numbers become null (JSON has no NaN).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace lander::sim {

class Json {
 public:
  enum class Type { Null, Bool, Number, String, Array, Object, Raw };

  Json() = default;                       // null
  Json(bool b) : type_(Type::Bool), bool_(b) {}
  Json(double x) : type_(Type::Number), num_(x) {}
  Json(int x) : type_(Type::Number), num_(x), is_int_(true), int_(x) {}
  Json(long x) : type_(Type::Number), num_(static_cast<double>(x)), is_int_(true), int_(x) {}
  Json(long long x) : type_(Type::Number), num_(static_cast<double>(x)), is_int_(true), int_(x) {}
  Json(unsigned long x) : Json(static_cast<long long>(x)) {}
  Json(const char* s) : type_(Type::String), str_(s) {}
  Json(std::string s) : type_(Type::String), str_(std::move(s)) {}

  static Json object() { Json j; j.type_ = Type::Object; return j; }
  static Json array() { Json j; j.type_ = Type::Array; return j; }
  // Already-serialised JSON text, written verbatim (e.g. a helper's to_json()).
  static Json raw(std::string text) { Json j; j.type_ = Type::Raw; j.str_ = std::move(text); return j; }

  // Object access: inserts the key (in order) if absent.
  Json& operator[](const std::string& key);
  const Json* find(const std::string& key) const;
  // Array append.
  Json& push(Json v);

  Type type() const { return type_; }
  double number() const { return num_; }
  bool boolean() const { return bool_; }
  const std::string& string() const { return str_; }
  std::size_t size() const { return type_ == Type::Array ? items_.size() : keys_.size(); }
  const Json& at(std::size_t i) const { return items_.at(i); }

  std::string dump(int indent = 2) const;

 private:
  void dump_to(std::string& out, int indent, int depth) const;

  Type type_ = Type::Null;
  bool bool_ = false;
  double num_ = 0.0;
  bool is_int_ = false;
  long long int_ = 0;
  std::string str_;
  std::vector<Json> items_;                 // array items, or object values (with keys_)
  std::vector<std::string> keys_;
};

// Writes text to a file atomically (temp file + rename); throws std::runtime_error naming
// the path on failure.
void write_text_file(const std::string& path, const std::string& text);

}  // namespace lander::sim
