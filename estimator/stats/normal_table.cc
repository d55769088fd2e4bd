#include "estimator/stats/normal_table.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace weavefit {
namespace {

constexpr double kStep = 1.0 / 64.0;
constexpr int kNodes = static_cast<int>(2.0 * kNormalTableReach / kStep) + 1;

struct Table {
  std::vector<double> cdf, pdf;
  Table() : cdf(kNodes), pdf(kNodes) {
    for (int i = 0; i < kNodes; ++i) {
      const double z = -kNormalTableReach + i * kStep;
      cdf[i] = 0.5 * std::erfc(-z * M_SQRT1_2);
      pdf[i] = 0.3989422804014327 * std::exp(-0.5 * z * z);
    }
  }
};

const Table& NormalNodes() {
  static const Table table;
  return table;
}

}  // namespace

NormalAt StandardNormal(double z) {
  if (!(z > -kNormalTableReach)) return {0.0, 0.0};
  if (!(z < kNormalTableReach)) return {1.0, 0.0};
  const Table& t = NormalNodes();
  const double x = (z + kNormalTableReach) / kStep;
  const int i = std::min(static_cast<int>(x), kNodes - 2);
  const double u = x - i;
  const double z0 = -kNormalTableReach + i * kStep;
  const double c0 = t.cdf[i], c1 = t.cdf[i + 1];
  const double p0 = t.pdf[i], p1 = t.pdf[i + 1];
  // Hermite basis on [0, 1]; the derivatives by u are the slopes times kStep.
  const double u2 = u * u, u3 = u2 * u;
  const double h00 = 2.0 * u3 - 3.0 * u2 + 1.0, h10 = u3 - 2.0 * u2 + u;
  const double h01 = -2.0 * u3 + 3.0 * u2, h11 = u3 - u2;
  NormalAt at;
  at.cdf = h00 * c0 + h01 * c1 + kStep * (h10 * p0 + h11 * p1);
  at.pdf = h00 * p0 + h01 * p1 - kStep * (h10 * z0 * p0 + h11 * (z0 + kStep) * p1);
  return at;
}

}  // namespace weavefit
