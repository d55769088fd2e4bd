// Golden-section search for the minimum of a unimodal function on [lo, hi].
#ifndef WEAVEFIT_ESTIMATOR_STATS_GOLDEN_SECTION_H_
#define WEAVEFIT_ESTIMATOR_STATS_GOLDEN_SECTION_H_

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace weavefit {

// The abscissa of the minimum of `f` on [lo, hi], narrowed until the bracket
// is shorter than `tolerance`; f(x) must return something comparable with <.
template <typename F>
double GoldenSectionMinimum(F&& f, double lo, double hi, double tolerance) {
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = hi - g * (hi - lo);
  double x2 = lo + g * (hi - lo);
  auto f1 = f(x1);
  auto f2 = f(x2);
  while (hi - lo > tolerance) {
    if (f1 < f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - g * (hi - lo);
      f1 = f(x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + g * (hi - lo);
      f2 = f(x2);
    }
  }
  return f1 < f2 ? x1 : x2;
}

// The index of the least of `f` over the integers lo..hi, f unimodal there:
// a golden section on the integers (its two inner points placed
// symmetrically, so that one is kept each step), each f(k) computed at most
// once, and the last few compared outright. It returns what a scan of every
// index returns, in 10 evaluations for 21 indices and 13 for 41.
template <typename F>
int LatticeMinimum(F&& f, int lo, int hi) {
  const int first = lo;
  std::vector<double> seen(hi - lo + 1, std::numeric_limits<double>::quiet_NaN());
  auto at = [&](int k) {
    double& v = seen[k - first];
    if (std::isnan(v)) v = f(k);
    return v;
  };
  const double g = 0.5 * (3.0 - std::sqrt(5.0));  // 1 − 1/φ
  int a = lo + std::max(1, static_cast<int>(std::lround(g * (hi - lo))));
  int b = lo + hi - a;
  if (a > b) std::swap(a, b);
  while (hi - lo > 2 && a < b) {
    // Unimodal: the least lies in [lo, b] when f(a) ≤ f(b), else in [a, hi].
    if (at(a) <= at(b)) {
      hi = b;
      b = a;
      a = lo + hi - b;
    } else {
      lo = a;
      a = b;
      b = lo + hi - a;
    }
    if (a > b) std::swap(a, b);
  }
  int best = lo;
  for (int k = lo + 1; k <= hi; ++k) {
    if (at(k) < at(best)) best = k;
  }
  return best;
}

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_STATS_GOLDEN_SECTION_H_
