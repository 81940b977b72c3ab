// Campaign statistics against values computed by hand or by reference formulas.
#include <gtest/gtest.h>

#include <cmath>

#include "lander/campaign/stats.h"

namespace lander::campaign {
namespace {

// Published values are given to 4 decimals.
constexpr double kTableTol = 5e-5;

TEST(Wilson, MatchesPublishedIntervals) {
  // Wilson 95 % for 8/10: [0.4902, 0.9433]; for 0/20: [0, 0.1611]; for 20/20: [0.8389, 1].
  Interval a = wilson95(8, 10);
  EXPECT_NEAR(a.lo, 0.4902, kTableTol);
  EXPECT_NEAR(a.hi, 0.9433, kTableTol);
  Interval b = wilson95(0, 20);
  EXPECT_NEAR(b.lo, 0.0, kTableTol);
  EXPECT_NEAR(b.hi, 0.1611, kTableTol);
  Interval c = wilson95(20, 20);
  EXPECT_NEAR(c.lo, 0.8389, kTableTol);
  EXPECT_NEAR(c.hi, 1.0, kTableTol);
  Interval none = wilson95(0, 0);
  EXPECT_EQ(none.lo, 0.0);
  EXPECT_EQ(none.hi, 1.0);
}

TEST(Quantile, LinearInterpolationLikeNumpy) {
  // numpy.quantile([1, 2, 3, 4, 10], q) = 3 (0.5), 8.8 (0.95), 1 (0), 10 (1).
  const std::vector<double> x{10, 2, 4, 1, 3};
  EXPECT_DOUBLE_EQ(quantile(x, 0.5), 3.0);
  EXPECT_NEAR(quantile(x, 0.95), 8.8, 1e-12);
  EXPECT_DOUBLE_EQ(quantile(x, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(quantile(x, 1.0), 10.0);
  EXPECT_TRUE(std::isnan(quantile({}, 0.5)));
}

TEST(Ranks, TiesGetTheirAverageRank) {
  const std::vector<double> r = ranks({5, 1, 5, 3});
  EXPECT_DOUBLE_EQ(r[0], 3.5);
  EXPECT_DOUBLE_EQ(r[1], 1.0);
  EXPECT_DOUBLE_EQ(r[2], 3.5);
  EXPECT_DOUBLE_EQ(r[3], 2.0);
}

TEST(Spearman, MonotoneIsOneAndSignificant) {
  std::vector<double> x, y;
  for (int i = 0; i < 30; ++i) {
    x.push_back(i);
    y.push_back(std::exp(0.1 * i));  // monotone, not linear
  }
  const Correlation c = spearman(x, y);
  EXPECT_NEAR(c.rho, 1.0, 1e-12);
  // No shuffle of 30 ranks reaches |rho| = 1 in 2000 tries: p is the floor 1/2001.
  EXPECT_LT(c.p, 0.001);
  EXPECT_EQ(c.n, 30);
}

TEST(Spearman, UnrelatedIsNotSignificant) {
  // y is a fixed pseudo-random permutation unrelated to x.
  std::vector<double> x, y;
  for (int i = 0; i < 40; ++i) {
    x.push_back(i);
    y.push_back((i * 17 + 5) % 40);
  }
  const Correlation c = spearman(x, y);
  EXPECT_LT(std::abs(c.rho), 0.4);
  EXPECT_GT(c.p, 0.01);
}

TEST(Spearman, UndefinedWithoutSpreadOrSamples) {
  EXPECT_TRUE(std::isnan(spearman({1, 2}, {3, 4}).rho));
  EXPECT_TRUE(std::isnan(spearman({1, 1, 1, 1}, {1, 2, 3, 4}).rho));
}

TEST(Bootstrap, IntervalCoversTheSampleStatisticAndIsReproducible) {
  std::vector<double> x;
  for (int i = 0; i < 200; ++i) x.push_back(0.01 * ((i * 37) % 100));
  auto p95 = [](const std::vector<double>& s) { return quantile(s, 0.95); };
  const Interval a = bootstrap95(x, p95);
  const Interval b = bootstrap95(x, p95);
  EXPECT_EQ(a.lo, b.lo);  // seeded: the same interval every time
  EXPECT_EQ(a.hi, b.hi);
  EXPECT_LE(a.lo, p95(x));
  EXPECT_GE(a.hi, p95(x));
  EXPECT_LT(a.hi - a.lo, 0.2);  // 200 samples of a spread of 1: the p95 is known to +-0.1
}

TEST(Bootstrap, PairedDifferenceSeesAShift) {
  std::vector<double> a, b;
  for (int i = 0; i < 100; ++i) {
    a.push_back(0.01 * ((i * 13) % 50));
    b.push_back(a.back() + 0.05);  // every pair worse by 5 cm
  }
  auto med = [](const std::vector<double>& s) { return quantile(s, 0.5); };
  const Interval d = paired_bootstrap95(a, b, med);
  EXPECT_NEAR(d.lo, 0.05, 1e-9);
  EXPECT_NEAR(d.hi, 0.05, 1e-9);
}

}  // namespace
}  // namespace lander::campaign
