#include "estimator/stats/normal_table.h"

#include <gtest/gtest.h>

#include <cmath>

namespace weavefit {
namespace {

TEST(StandardNormalTest, MatchesLibmEverywhere) {
  double worst_cdf = 0.0, worst_pdf = 0.0;
  for (double z = -9.0; z <= 9.0; z += 1.0 / 4099.0) {
    const NormalAt at = StandardNormal(z);
    worst_cdf = std::max(worst_cdf, std::fabs(at.cdf - 0.5 * std::erfc(-z * M_SQRT1_2)));
    worst_pdf =
        std::max(worst_pdf, std::fabs(at.pdf - 0.3989422804014327 * std::exp(-0.5 * z * z)));
  }
  EXPECT_LT(worst_cdf, 2e-10);
  EXPECT_LT(worst_pdf, 2e-10);
}

// Difference quotients of Φ over steps far below the table's spacing stay
// close to φ (the comb fit's glints integrate over such steps).
TEST(StandardNormalTest, SmallStepsOfTheCdfFollowTheDensity) {
  for (double z : {-3.1, -0.7, 0.0, 0.013, 1.9, 5.2}) {
    for (double h : {1e-2, 1e-3}) {
      const double quotient = (StandardNormal(z + h).cdf - StandardNormal(z).cdf) / h;
      const double mid = StandardNormal(z + 0.5 * h).pdf;
      EXPECT_NEAR(quotient, mid, 1e-7 + 0.2 * h * h * (1.0 + z * z) * mid) << z << " " << h;
    }
  }
}

TEST(StandardNormalTest, BeyondTheTableIsTheTail) {
  EXPECT_EQ(StandardNormal(-20.0).cdf, 0.0);
  EXPECT_EQ(StandardNormal(20.0).cdf, 1.0);
  EXPECT_EQ(StandardNormal(20.0).pdf, 0.0);
  EXPECT_NEAR(StandardNormal(0.0).cdf, 0.5, 1e-15);
}

}  // namespace
}  // namespace weavefit
