// The one statistics helper of the simulator and its tools: summaries of a sample (mean,
// variance, quantiles) and a streaming error accumulator (RMSE, max |error|). Non-finite
// values are counted apart and never enter a figure, so one NaN from the flight side cannot
// poison or abort a metric.
#pragma once

#include <cstddef>
#include <limits>
#include <vector>

#include <nlohmann/json.hpp>

namespace lander::sim {

// Summary of a sample of finite values; every figure is NaN when there is none (variance:
// fewer than two).
struct SampleSummary {
  std::size_t n{0};              ///< finite values
  std::size_t non_finite{0};     ///< values left out (NaN, +-inf)
  double mean{std::numeric_limits<double>::quiet_NaN()};
  double var{std::numeric_limits<double>::quiet_NaN()};  ///< unbiased sample variance (n - 1)
  double min{std::numeric_limits<double>::quiet_NaN()};
  double median{std::numeric_limits<double>::quiet_NaN()};
  double p95{std::numeric_limits<double>::quiet_NaN()};
  double max{std::numeric_limits<double>::quiet_NaN()};
};

// Summarises `values` (any order). Quantiles interpolate linearly between order statistics
// (Hyndman-Fan type 7, numpy's default): the median of an even count is the mean of the two
// middle values.
SampleSummary summarize(std::vector<double> values);

// Quantile q in [0, 1] of ascending-sorted finite values (type 7); NaN when empty.
double quantile_sorted(const std::vector<double>& sorted, double q);

// {"n", "mean", "median", "p95", "max"} of a summary (NaN as null when written).
nlohmann::ordered_json to_json(const SampleSummary& s);

// Streaming RMSE and max |error| of error samples (estimate - truth).
struct ErrorStats {
  std::size_t n{0};            ///< finite samples added
  std::size_t non_finite{0};   ///< NaN / inf samples, skipped
  double sum_sq_m2{0.0};
  double max_abs_m{0.0};
  double rmse_m() const;       ///< NaN when n == 0
  void add(double error_m);    ///< non-finite errors are counted in non_finite, not used
};

}  // namespace lander::sim
