#include "lander/sim/util/stats.h"

#include <algorithm>
#include <cmath>

namespace lander::sim {

double quantile_sorted(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  // Type 7: h = (n - 1) q, linear between the order statistics floor(h) and floor(h) + 1.
  const double h = (static_cast<double>(sorted.size()) - 1.0) * std::clamp(q, 0.0, 1.0);
  const auto lo = static_cast<std::size_t>(std::floor(h));
  const std::size_t hi = std::min(lo + 1, sorted.size() - 1);
  return sorted[lo] + (h - static_cast<double>(lo)) * (sorted[hi] - sorted[lo]);
}

SampleSummary summarize(std::vector<double> values) {
  SampleSummary s;
  const auto finite_end = std::partition(values.begin(), values.end(),
                                         [](double v) { return std::isfinite(v); });
  s.non_finite = static_cast<std::size_t>(values.end() - finite_end);
  values.erase(finite_end, values.end());
  s.n = values.size();
  if (values.empty()) return s;
  std::sort(values.begin(), values.end());
  double sum = 0.0;
  for (double v : values) sum += v;
  s.mean = sum / static_cast<double>(s.n);
  if (s.n >= 2) {
    double ss = 0.0;
    for (double v : values) ss += (v - s.mean) * (v - s.mean);
    s.var = ss / static_cast<double>(s.n - 1);
  }
  s.min = values.front();
  s.max = values.back();
  s.median = quantile_sorted(values, 0.5);
  s.p95 = quantile_sorted(values, 0.95);
  return s;
}

nlohmann::ordered_json to_json(const SampleSummary& s) {
  nlohmann::ordered_json j;
  j["n"] = s.n;
  j["mean"] = s.mean;
  j["median"] = s.median;
  j["p95"] = s.p95;
  j["max"] = s.max;
  return j;
}

double ErrorStats::rmse_m() const {
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(sum_sq_m2 / static_cast<double>(n));
}

void ErrorStats::add(double error_m) {
  if (!std::isfinite(error_m)) {
    ++non_finite;
    return;
  }
  ++n;
  sum_sq_m2 += error_m * error_m;
  max_abs_m = std::max(max_abs_m, std::abs(error_m));
}

}  // namespace lander::sim
