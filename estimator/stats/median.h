// Robust location for the stages: the median by partial sort.
#ifndef WEAVEFIT_ESTIMATOR_STATS_MEDIAN_H_
#define WEAVEFIT_ESTIMATOR_STATS_MEDIAN_H_

#include <algorithm>
#include <vector>

namespace weavefit {

// The median of v (the upper one for an even count); 0 for an empty v.
inline double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + v.size() / 2;
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_STATS_MEDIAN_H_
