#include "lander/campaign/stats.h"

#include "lander/sim/util/stats.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace lander::campaign {

namespace {

// SplitMix64; the same resamples on every machine.
struct Rng {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  std::size_t below(std::size_t n) { return static_cast<std::size_t>(next() % n); }
};

double pearson(const std::vector<double>& a, const std::vector<double>& b) {
  const double ma = mean(a), mb = mean(b);
  double sab = 0, saa = 0, sbb = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  if (saa <= 0 || sbb <= 0) return NAN;
  return sab / std::sqrt(saa * sbb);
}

Interval percentile_interval(std::vector<double> stats) {
  stats.erase(std::remove_if(stats.begin(), stats.end(), [](double v) { return !std::isfinite(v); }),
              stats.end());
  if (stats.empty()) return {NAN, NAN};
  return {quantile(stats, 0.025), quantile(stats, 0.975)};
}

}  // namespace

// Wilson (1927): centre (p + z^2/2n) / (1 + z^2/n), half-width
// z sqrt(p(1-p)/n + z^2/4n^2) / (1 + z^2/n).
Interval wilson95(int k, int n) {
  if (n <= 0) return {0.0, 1.0};
  const double z = 1.959963984540054, nn = n, p = k / nn;
  const double d = 1 + z * z / nn;
  const double c = (p + z * z / (2 * nn)) / d;
  const double h = z * std::sqrt(p * (1 - p) / nn + z * z / (4 * nn * nn)) / d;
  return {std::max(0.0, c - h), std::min(1.0, c + h)};
}

double quantile(std::vector<double> x, double q) {
  std::sort(x.begin(), x.end());
  return sim::quantile_sorted(x, q);  // the project's one quantile (type 7)
}

double mean(const std::vector<double>& x) {
  if (x.empty()) return NAN;
  return std::accumulate(x.begin(), x.end(), 0.0) / static_cast<double>(x.size());
}

Interval bootstrap95(const std::vector<double>& x,
                     const std::function<double(const std::vector<double>&)>& stat, int resamples,
                     std::uint64_t seed) {
  if (x.empty()) return {NAN, NAN};
  Rng rng{seed};
  std::vector<double> stats, s(x.size());
  stats.reserve(resamples);
  for (int b = 0; b < resamples; ++b) {
    for (double& v : s) v = x[rng.below(x.size())];
    stats.push_back(stat(s));
  }
  return percentile_interval(stats);
}

Interval paired_bootstrap95(const std::vector<double>& a, const std::vector<double>& b,
                            const std::function<double(const std::vector<double>&)>& stat,
                            int resamples, std::uint64_t seed) {
  if (a.empty() || a.size() != b.size()) return {NAN, NAN};
  Rng rng{seed};
  std::vector<double> stats, sa(a.size()), sb(b.size());
  for (int r = 0; r < resamples; ++r) {
    for (std::size_t i = 0; i < a.size(); ++i) {
      const std::size_t k = rng.below(a.size());
      sa[i] = a[k];
      sb[i] = b[k];
    }
    stats.push_back(stat(sb) - stat(sa));
  }
  return percentile_interval(stats);
}

// Newcombe (1998) method 10, with sample 1 = b and sample 2 = a. Counts: a11 = both,
// a10 = 1 in b only, a01 = 1 in a only, a00 = neither; p1 = (a11 + a10)/n, p2 = (a11 + a01)/n.
//   Wilson intervals (l1, u1) of p1 and (l2, u2) of p2;
//   A = a11 a00 - a10 a01; phi = (A - n/2)/sqrt(...) if A > n/2, 0 if 0 <= A <= n/2, A/sqrt(...)
//   if A < 0, with sqrt(...) = sqrt((a11 + a10)(a01 + a00)(a11 + a01)(a10 + a00)), phi = 0 when
//   a margin is empty;
//   L = (p1 - p2) - sqrt((p1 - l1)^2 - 2 phi (p1 - l1)(u2 - p2) + (u2 - p2)^2)
//   U = (p1 - p2) + sqrt((u1 - p1)^2 - 2 phi (u1 - p1)(p2 - l2) + (p2 - l2)^2)
Interval paired_proportion_difference95(int both, int only_a, int only_b, int neither) {
  const int n = both + only_a + only_b + neither;
  if (n <= 0) return {-1.0, 1.0};
  const double nn = n, p1 = (both + only_b) / nn, p2 = (both + only_a) / nn;
  const Interval w1 = wilson95(both + only_b, n), w2 = wilson95(both + only_a, n);
  const double margins = static_cast<double>(both + only_b) * (only_a + neither) *
                         static_cast<double>(both + only_a) * (only_b + neither);
  double phi = 0.0;
  if (margins > 0) {
    const double a = static_cast<double>(both) * neither - static_cast<double>(only_b) * only_a;
    if (a > nn / 2) {
      phi = (a - nn / 2) / std::sqrt(margins);
    } else if (a < 0) {
      phi = a / std::sqrt(margins);
    }
  }
  const double dl1 = p1 - w1.lo, du1 = w1.hi - p1, dl2 = p2 - w2.lo, du2 = w2.hi - p2;
  const double lower = std::sqrt(std::max(0.0, dl1 * dl1 - 2 * phi * dl1 * du2 + du2 * du2));
  const double upper = std::sqrt(std::max(0.0, du1 * du1 - 2 * phi * du1 * dl2 + dl2 * dl2));
  return {std::max(-1.0, p1 - p2 - lower), std::min(1.0, p1 - p2 + upper)};
}

std::vector<double> ranks(const std::vector<double>& x) {
  std::vector<std::size_t> idx(x.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::stable_sort(idx.begin(), idx.end(), [&](std::size_t i, std::size_t j) { return x[i] < x[j]; });
  std::vector<double> r(x.size());
  for (std::size_t i = 0; i < idx.size();) {
    std::size_t j = i;
    while (j + 1 < idx.size() && x[idx[j + 1]] == x[idx[i]]) ++j;
    const double avg = (static_cast<double>(i) + static_cast<double>(j)) / 2.0 + 1.0;
    for (std::size_t k = i; k <= j; ++k) r[idx[k]] = avg;
    i = j + 1;
  }
  return r;
}

// Spearman's rho: Pearson's correlation of the ranks. The p-value counts the shuffles of y's
// ranks whose |rho| reaches the observed one: (1 + count) / (1 + permutations).
Correlation spearman(const std::vector<double>& x, const std::vector<double>& y, int permutations,
                     std::uint64_t seed) {
  Correlation c;
  c.n = static_cast<int>(std::min(x.size(), y.size()));
  c.rho = NAN;
  if (c.n < 3 || x.size() != y.size()) return c;
  const std::vector<double> rx = ranks(x);
  std::vector<double> ry = ranks(y);
  c.rho = pearson(rx, ry);
  if (!std::isfinite(c.rho)) return c;
  Rng rng{seed};
  int hits = 0;
  for (int p = 0; p < permutations; ++p) {
    for (std::size_t i = ry.size() - 1; i > 0; --i) std::swap(ry[i], ry[rng.below(i + 1)]);
    const double r = pearson(rx, ry);
    if (std::isfinite(r) && std::abs(r) >= std::abs(c.rho) - 1e-12) ++hits;
  }
  c.p = (1.0 + hits) / (1.0 + permutations);
  return c;
}

}  // namespace lander::campaign
