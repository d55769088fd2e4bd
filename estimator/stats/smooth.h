// Gaussian smoothing of a uniformly sampled series (profiles in azimuth).
#ifndef WEAVEFIT_ESTIMATOR_STATS_SMOOTH_H_
#define WEAVEFIT_ESTIMATOR_STATS_SMOOTH_H_

#include <cmath>
#include <vector>

namespace weavefit {

// Convolves v with a Gaussian of sigma_bins samples (truncated at 3 σ),
// renormalised at the ends; below 0.3 samples v is returned as it is.
// With a range [from, to], only the outputs there are computed (each exactly
// as without one; they read v within 3 σ of the range); the others are v's.
inline std::vector<double> Smooth(const std::vector<double>& v, double sigma_bins,
                                  int from = 0, int to = -1) {
  if (sigma_bins < 0.3) return v;
  const int half = static_cast<int>(std::ceil(3.0 * sigma_bins));
  std::vector<double> kernel(2 * half + 1);
  for (int k = -half; k <= half; ++k) {
    kernel[k + half] = std::exp(-0.5 * k * k / (sigma_bins * sigma_bins));
  }
  const int n = static_cast<int>(v.size());
  if (to < 0 || to >= n) to = n - 1;
  if (from < 0) from = 0;
  std::vector<double> out = from == 0 && to == n - 1 ? std::vector<double>(n) : v;
  double whole = 0.0;  // the kernel's sum, summed in the same order as below
  for (int k = -half; k <= half; ++k) whole += kernel[k + half];
  for (int i = from; i <= to; ++i) {
    if (i >= half && i + half < n) {
      // Inside: the whole kernel, no bounds to check (the hot path).
      const double* x = &v[i - half];
      double s = 0.0;
      for (int k = 0; k <= 2 * half; ++k) s += kernel[k] * x[k];
      out[i] = s / whole;
      continue;
    }
    double s = 0.0;
    double w = 0.0;
    for (int k = -half; k <= half; ++k) {
      const int j = i + k;
      if (j < 0 || j >= n) continue;
      s += kernel[k + half] * v[j];
      w += kernel[k + half];
    }
    out[i] = s / w;
  }
  return out;
}

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_STATS_SMOOTH_H_
