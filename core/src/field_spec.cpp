#include "lander/core/field_spec.h"

#include <sstream>

#include "lander/core/params_io.h"

namespace lander {
namespace {
// A bound as the messages write it: 0, 1, 0.5, 1e-06.
std::string number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}
}  // namespace

std::string Range::problem() const {
  const std::string bound = bound_text();
  return why == nullptr || bound.empty() ? bound : bound + " (" + why + ")";
}

std::string Range::bound_text() const {
  const bool has_lo = lo != -range::kInf, has_hi = hi != range::kInf;
  if (has_lo && has_hi) {
    return "must be in " + std::string(lo_open ? "(" : "[") + number(lo) + ", " + number(hi) +
           (hi_open ? ")" : "]");
  }
  if (has_lo) return std::string("must be ") + (lo_open ? "> " : ">= ") + number(lo);
  if (has_hi) return std::string("must be ") + (hi_open ? "< " : "<= ") + number(hi);
  return "";
}

namespace {
// The range in the stored unit: the bounds times the scale, so that the value read as
// YAML value * scale is compared exactly (5 ms is 5 * 1e-3 both sides).
Range stored(const Range& r, double scale) {
  Range s = r;
  s.lo = r.lo * scale;
  s.hi = r.hi * scale;
  return s;
}
}  // namespace

void FieldChecker::check(const char* key, double x, const Range& r, double scale) {
  if (!stored(r, scale).contains(x)) throw ConfigError::invalid(key, r.problem());
}

void FieldChecker::check(const char* key, const std::vector<double>& x, const Range& r,
                         double scale) {
  for (double e : x) {
    if (!stored(r, scale).contains(e)) throw ConfigError::invalid(key, "all entries " + r.problem());
  }
}

void FieldLister::add(const char* key, const char* type, const FieldSpec& s) {
  out_->push_back({prefix_ + key, type, s.unit, s.range.problem(), s.doc, s.range, s.scale});
}

}  // namespace lander
