// Statistics for campaign results: binomial intervals, quantiles, bootstrap intervals, rank
// correlation. Deterministic: the resampling streams are seeded, so a report is reproducible.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

namespace lander::campaign {

struct Interval {
  double lo{0.0};
  double hi{0.0};
};

// Wilson score interval of a proportion k/n at 95 % (z = 1.96); [0, 1] when n = 0.
Interval wilson95(int k, int n);

// Quantile q in [0, 1] of the values, linear interpolation between order statistics
// (Hyndman & Fan type 7, numpy's default). NaN for an empty set.
double quantile(std::vector<double> x, double q);

double mean(const std::vector<double>& x);

// Percentile bootstrap 95 % interval of stat(x): `resamples` resamples drawn with a seeded
// generator. NaN bounds for an empty set.
Interval bootstrap95(const std::vector<double>& x,
                     const std::function<double(const std::vector<double>&)>& stat,
                     int resamples = 2000, std::uint64_t seed = 1);

// Paired bootstrap 95 % interval of stat(b) - stat(a) over pairs (a_i, b_i) resampled together.
Interval paired_bootstrap95(const std::vector<double>& a, const std::vector<double>& b,
                            const std::function<double(const std::vector<double>&)>& stat,
                            int resamples = 2000, std::uint64_t seed = 1);

// 95 % interval of p_b - p_a for two binary outcomes observed on the same n units (paired
// proportions, e.g. landed in campaign a and in campaign b, run by run), from the 2x2 counts:
// `both` (1 in a and b), `only_a`, `only_b`, `neither`. Newcombe (1998), "Improved confidence
// intervals for the difference between binomial proportions based on paired data", Stat. Med.
// 17:2635, method 10 (square-and-add of the two Wilson intervals with the continuity-corrected
// correlation); [-1, 1] when n = 0.
Interval paired_proportion_difference95(int both, int only_a, int only_b, int neither);

// Ranks 1..n with ties given their average rank.
std::vector<double> ranks(const std::vector<double>& x);

struct Correlation {
  double rho{0.0};  ///< Spearman's rank correlation (NaN when undefined: n < 3 or no spread)
  double p{1.0};    ///< two-sided permutation p-value (seeded, `permutations` shuffles)
  int n{0};
};

Correlation spearman(const std::vector<double>& x, const std::vector<double>& y,
                     int permutations = 2000, std::uint64_t seed = 1);

}  // namespace lander::campaign
