// Unit tests of stats/smooth.h: the Gaussian smoothing of profiles.
#include "estimator/stats/smooth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>
#include <vector>

namespace weavefit {
namespace {

std::vector<double> Noise(int n) {
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<double> v(n);
  for (double& x : v) x = g(rng);
  return v;
}

TEST(SmoothTest, ConstantStaysConstantUpToTheEnds) {
  const std::vector<double> v(50, 2.5);
  for (double x : Smooth(v, 3.0)) EXPECT_NEAR(x, 2.5, 1e-12);
}

TEST(SmoothTest, BelowAThirdOfASampleReturnsTheInput) {
  const std::vector<double> v = Noise(20);
  EXPECT_EQ(Smooth(v, 0.2), v);
}

TEST(SmoothTest, AverageOfNoiseShrinksItsSpread) {
  const std::vector<double> v = Noise(4000);
  const std::vector<double> s = Smooth(v, 4.0);
  double ss = 0.0;
  for (std::size_t i = 100; i + 100 < s.size(); ++i) ss += s[i] * s[i];
  const double sd = std::sqrt(ss / (s.size() - 200));
  // A Gaussian of σ samples averages about 2·sqrt(π)·σ of them.
  EXPECT_NEAR(sd, 1.0 / std::sqrt(2.0 * std::sqrt(M_PI) * 4.0), 0.03);
}

TEST(SmoothTest, ARangeComputesExactlyThoseOutputs) {
  const std::vector<double> v = Noise(300);
  const std::vector<double> whole = Smooth(v, 2.7);
  for (auto [from, to] : {std::pair{0, 20}, std::pair{100, 180}, std::pair{280, 299},
                          std::pair{250, 1000}}) {
    const std::vector<double> part = Smooth(v, 2.7, from, to);
    ASSERT_EQ(part.size(), v.size());
    for (int i = 0; i < static_cast<int>(v.size()); ++i) {
      if (i >= from && i <= to) {
        EXPECT_EQ(part[i], whole[i]) << i;  // the same sums, bit for bit
      } else {
        EXPECT_EQ(part[i], v[i]) << i;
      }
    }
  }
}

}  // namespace
}  // namespace weavefit
