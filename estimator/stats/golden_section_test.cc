// Unit tests of stats/golden_section.h: minima of unimodal functions, on a
// line and on the integers.
#include "estimator/stats/golden_section.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace weavefit {
namespace {

TEST(GoldenSectionTest, FindsTheMinimumOfAParabola) {
  const double x = GoldenSectionMinimum([](double t) { return (t - 0.37) * (t - 0.37); }, -1.0,
                                        2.0, 1e-6);
  EXPECT_NEAR(x, 0.37, 1e-6);
}

// On every unimodal shape (|k − c|^p, its least anywhere in or beyond the
// range, flat-bottomed or sharp) it returns the index a scan of every index
// returns, evaluating each index at most once and far fewer than all.
TEST(LatticeMinimumTest, AgreesWithAFullScanInFewerEvaluations) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> centre(-14.0, 14.0);
  std::uniform_real_distribution<double> power(0.2, 3.0);
  for (int lo_hi : {1, 2, 3, 10, 20}) {
    int most = 0;
    for (int trial = 0; trial < 2000; ++trial) {
      const double c = centre(rng);
      const double p = power(rng);
      auto f = [&](int k) { return std::pow(std::fabs(k - c), p); };
      int scan = -lo_hi;
      for (int k = -lo_hi; k <= lo_hi; ++k) {
        if (f(k) < f(scan)) scan = k;
      }
      std::vector<int> calls(2 * lo_hi + 1, 0);
      const int found = LatticeMinimum(
          [&](int k) {
            ++calls[k + lo_hi];
            return f(k);
          },
          -lo_hi, lo_hi);
      ASSERT_EQ(found, scan) << "centre " << c << ", power " << p << ", range ±" << lo_hi;
      int total = 0;
      for (int n : calls) {
        EXPECT_LE(n, 1);
        total += n;
      }
      most = std::max(most, total);
    }
    if (lo_hi == 10) {
      EXPECT_LE(most, 10);
    } else if (lo_hi == 20) {
      EXPECT_LE(most, 13);
    }
  }
}

}  // namespace
}  // namespace weavefit
