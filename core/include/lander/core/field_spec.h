// What one params field is: its allowed range, its unit and a short description, written once
// in the struct's visit_fields next to its key,
//
//   v("mass_kg", p.mass_kg, range::positive, "kg", "total mass");
//   v("exposure_ms", p.exposure_s, range::positive, "ms", "exposure time", 1e-3);
//
// and used three ways: check_fields() (called first by every validate()) throws
// ConfigError::invalid(key, "must be > 0") for a value outside its range, so validate() keeps
// only the rules across fields; FieldLister collects key, unit, range and description for the
// generated reference (`lander docs keys`); YamlReader and YamlWriter ignore all but the scale.
// The range, unit and description apply to the value as written in YAML (the field divided by
// the scale: "must be > 0" for exposure_ms is about milliseconds).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include <Eigen/Core>

namespace lander {

// The allowed values of a numeric field: an interval whose ends are each open or closed
// (infinite ends are open). The unbounded interval (range::any) checks nothing, not even NaN;
// any bounded one refuses NaN.
struct Range {
  double lo{-std::numeric_limits<double>::infinity()};
  double hi{std::numeric_limits<double>::infinity()};
  bool lo_open{true};
  bool hi_open{true};
  const char* why{nullptr};  ///< a reason the message gives after the bound, or none

  // The same range with a reason: "must be >= 4 (planar PnP needs four points)".
  constexpr Range because(const char* reason) const {
    Range r = *this;
    r.why = reason;
    return r;
  }

  constexpr bool bounded() const {
    return lo != -std::numeric_limits<double>::infinity() ||
           hi != std::numeric_limits<double>::infinity();
  }
  bool contains(double x) const {
    if (!bounded()) return true;
    const bool above = lo_open ? x > lo : x >= lo;  // false for NaN
    const bool below = hi_open ? x < hi : x <= hi;
    return above && below;
  }
  // "must be > 0", "must be >= 1", "must be <= 5", "must be in [0, 1)", then " (why)" when
  // a reason is given; "" when unbounded.
  std::string problem() const;

 private:
  std::string bound_text() const;
};

namespace range {
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr Range any{};
constexpr Range positive{0.0, kInf, true, true};       ///< > 0
constexpr Range non_negative{0.0, kInf, false, true};  ///< >= 0
constexpr Range at_least(double lo) { return {lo, kInf, false, true}; }      ///< >= lo
constexpr Range greater_than(double lo) { return {lo, kInf, true, true}; }   ///< > lo
constexpr Range at_most(double hi) { return {-kInf, hi, true, false}; }      ///< <= hi
constexpr Range closed(double lo, double hi) { return {lo, hi, false, false}; }       ///< [lo, hi]
constexpr Range open(double lo, double hi) { return {lo, hi, true, true}; }           ///< (lo, hi)
constexpr Range open_closed(double lo, double hi) { return {lo, hi, true, false}; }   ///< (lo, hi]
constexpr Range closed_open(double lo, double hi) { return {lo, hi, false, true}; }   ///< [lo, hi)
}  // namespace range

// One field's spec as the visitor call gives it.
struct FieldSpec {
  Range range{};
  const char* unit{""};  ///< of the YAML value ("ms" for exposure_ms); "" for counts, flags
  const char* doc{""};   ///< a short description
  double scale{1.0};     ///< stored value = YAML value * scale
};

// Checks every field of one params struct against its range (nested structs and lists are
// left to validate_nested / validate_item, which call their own validate()). Throws
// ConfigError::invalid(key, range.problem()) for the first field outside its range.
class FieldChecker {
 public:
  template <class T>
  void operator()(const char*, T&, double = 1.0) {}  // no spec: nothing to check
  template <class T>
  void operator()(const char* key, T& field, const Range& r, const char*, const char*,
                  double scale = 1.0) {
    check(key, field, r, scale);
  }
  template <class P>
  void nested(const char*, P&) {}
  template <class P>
  void list(const char*, std::vector<P>&) {}
  bool has(const char*) const { return false; }

 private:
  void check(const char* key, double x, const Range& r, double scale);
  void check(const char* key, int x, const Range& r, double) { check(key, double(x), r, 1.0); }
  void check(const char* key, std::uint64_t x, const Range& r, double) {
    check(key, double(x), r, 1.0);
  }
  void check(const char* key, const std::vector<double>& x, const Range& r, double scale);
  template <int N>
  void check(const char* key, const Eigen::Matrix<double, N, 1>& x, const Range& r,
             double scale) {
    check(key, std::vector<double>(x.data(), x.data() + N), r, scale);
  }
  // A flag, a string or a mapping with a spec: only its unit and description apply.
  template <class T>
  void check(const char* key, const T&, const Range& r, double) {
    if (r.bounded()) throw std::logic_error(std::string("a range on a non-numeric field: ") + key);
  }
};

// Throws ConfigError::invalid naming the first field of `p` outside the range its
// visit_fields gives (the struct's own fields; see FieldChecker).
template <class P>
void check_fields(const P& p) {
  FieldChecker c;
  visit_fields(c, const_cast<P&>(p));  // FieldChecker only reads
}

// Every key of a params struct, nested ones and list items ("vehicle.waypoints[].t_s")
// included, with its spec: for `lander docs keys` and the generated reference.
struct FieldInfo {
  std::string key;    ///< dotted path
  std::string type;   ///< "number", "integer", "flag", "text", "vector", "mapping"
  std::string unit;   ///< "" when none is given
  std::string allowed;  ///< range.problem(), "" when the visitor gives no range
  std::string doc;    ///< "" when the visitor gives none
  Range range{};      ///< as the visitor gives it (in the YAML unit)
  double scale{1.0};  ///< stored value = YAML value * scale
};

class FieldLister {
 public:
  explicit FieldLister(std::vector<FieldInfo>* out, std::string prefix = "")
      : out_(out), prefix_(std::move(prefix)) {}
  template <class T>
  void operator()(const char* key, T& field, double = 1.0) {
    add(key, type_of(field), FieldSpec{});
  }
  template <class T>
  void operator()(const char* key, T& field, const Range& r, const char* unit, const char* doc,
                  double scale = 1.0) {
    add(key, type_of(field), FieldSpec{r, unit, doc, scale});
  }
  template <class P>
  void nested(const char* key, P& sub) {
    FieldLister l(out_, prefix_ + key + ".");
    visit_fields(l, sub);
  }
  template <class P>
  void list(const char* key, std::vector<P>&) {
    P item;
    FieldLister l(out_, prefix_ + key + "[].");
    visit_fields(l, item);
  }
  bool has(const char*) const { return false; }

 private:
  void add(const char* key, const char* type, const FieldSpec& s);
  static const char* type_of(const double&) { return "number"; }
  static const char* type_of(const int&) { return "integer"; }
  static const char* type_of(const std::uint64_t&) { return "integer"; }
  static const char* type_of(const bool&) { return "flag"; }
  static const char* type_of(const std::string&) { return "text"; }
  template <class T>
  static const char* type_of(const T&) {
    return std::is_same_v<T, std::vector<double>> || std::is_base_of_v<Eigen::MatrixBase<T>, T>
               ? "vector"
               : "mapping";
  }
  std::vector<FieldInfo>* out_;
  std::string prefix_;
};

}  // namespace lander
