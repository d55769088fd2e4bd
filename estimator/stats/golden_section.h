// Golden-section search for the minimum of a unimodal function on [lo, hi].
#ifndef WEAVEFIT_ESTIMATOR_STATS_GOLDEN_SECTION_H_
#define WEAVEFIT_ESTIMATOR_STATS_GOLDEN_SECTION_H_

#include <cmath>

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

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_STATS_GOLDEN_SECTION_H_
