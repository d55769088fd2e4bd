#include "estimator/peaks/peak_picking.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Background-subtracted mean per bin from row blocks weighted by `weights`
// (1 each for the plain profile, multiplicities for a bootstrap resample).
// Empty bins are filled by linear interpolation from their neighbours.
std::vector<double> MeanFromBlocks(const Profile& p,
                                   const std::vector<int>& weights) {
  const int n = p.NumBins();
  std::vector<double> mean(n, 0.0);
  std::vector<bool> have(n, false);
  for (int i = 0; i < n; ++i) {
    double sum = 0.0;
    double count = 0.0;
    for (int b = 0; b < p.num_blocks; ++b) {
      if (weights[b] == 0) continue;
      const std::size_t at = static_cast<std::size_t>(b) * n + i;
      sum += weights[b] * p.block_sum[at];
      count += weights[b] * p.block_count[at];
    }
    if (count > 0) {
      mean[i] = sum / count - p.background;
      have[i] = true;
    }
  }
  int last = -1;
  for (int i = 0; i < n; ++i) {
    if (!have[i]) continue;
    if (last < 0) {
      for (int k = 0; k < i; ++k) mean[k] = mean[i];
    } else {
      for (int k = last + 1; k < i; ++k) {
        mean[k] = mean[last] + (mean[i] - mean[last]) * (k - last) / (i - last);
      }
    }
    last = i;
  }
  for (int k = last + 1; k < n && last >= 0; ++k) mean[k] = mean[last];
  return mean;
}

std::vector<double> Smooth(const std::vector<double>& v, double sigma_bins) {
  if (sigma_bins < 0.3) return v;
  const int half = static_cast<int>(std::ceil(3.0 * sigma_bins));
  std::vector<double> kernel(2 * half + 1);
  for (int k = -half; k <= half; ++k) {
    kernel[k + half] = std::exp(-0.5 * k * k / (sigma_bins * sigma_bins));
  }
  const int n = static_cast<int>(v.size());
  std::vector<double> out(n);
  for (int i = 0; i < n; ++i) {
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

// Sub-bin position of a maximum at index i, by a parabola through i−1..i+1.
double RefineMaximum(const std::vector<double>& s, int i) {
  if (i <= 0 || i + 1 >= static_cast<int>(s.size())) return i;
  const double denom = s[i - 1] - 2.0 * s[i] + s[i + 1];
  if (!(denom < 0.0)) return i;
  return i + std::clamp(0.5 * (s[i - 1] - s[i + 1]) / denom, -0.5, 0.5);
}

struct Located {
  bool split = false;
  int top = -1;
  int other = -1;
  double dip_sigmas = 0.0;
  double valley_ratio = 0.0;
};

// Finds the highest peak in [lo, hi] and, if it exists, the second peak that
// forms a significant split with it around index `center`.
Located Locate(const std::vector<double>& s, const std::vector<double>& se,
               int lo, int hi, double center, double straddle_bins,
               const PeakPickingOptions& options) {
  Located out;
  std::vector<int> maxima;
  for (int i = std::max(lo, 1); i <= std::min(hi, static_cast<int>(s.size()) - 2); ++i) {
    if (s[i] >= s[i - 1] && s[i] > s[i + 1]) maxima.push_back(i);
  }
  if (maxima.empty()) return out;
  out.top = *std::max_element(maxima.begin(), maxima.end(),
                              [&](int a, int b) { return s[a] < s[b]; });
  double best_height = -1.0;
  for (int j : maxima) {
    if (j == out.top || std::abs(j - out.top) < 3) continue;
    const int a = std::min(j, out.top);
    const int b = std::max(j, out.top);
    if (a > center + straddle_bins || b < center - straddle_bins) continue;
    const double lower = std::min(s[a], s[b]);
    if (lower < options.min_peak_ratio * s[out.top]) continue;
    int valley = a;
    for (int k = a; k <= b; ++k) {
      if (s[k] < s[valley]) valley = k;
    }
    const int lower_index = s[a] < s[b] ? a : b;
    const double dip = lower - s[valley];
    const double sigma = std::hypot(se[valley], se[lower_index]);
    const double significance = sigma > 0 ? dip / sigma : 1e9;
    out.dip_sigmas = std::max(out.dip_sigmas, std::min(significance, 1e3));
    if (dip < options.min_dip_fraction * lower ||
        significance < options.min_dip_sigmas) {
      continue;
    }
    if (s[j] > best_height) {
      best_height = s[j];
      out.other = j;
      out.split = true;
      out.valley_ratio = std::max(s[valley], 0.0) / lower;
    }
  }
  return out;
}

// The highest local maximum within `radius` bins of `near`, refined.
double NearestPeak(const std::vector<double>& s, double near, double radius) {
  const int n = static_cast<int>(s.size());
  const int lo = std::max(1, static_cast<int>(std::floor(near - radius)));
  const int hi = std::min(n - 2, static_cast<int>(std::ceil(near + radius)));
  int best = -1;
  for (int i = lo; i <= hi; ++i) {
    if (best < 0 || s[i] > s[best]) best = i;
  }
  return best < 0 ? near : RefineMaximum(s, best);
}

double Stddev(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  double mean = 0.0;
  for (double x : v) mean += x;
  mean /= v.size();
  double ss = 0.0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / (v.size() - 1));
}

}  // namespace

absl::Status PeakPickingOptions::Validate() const {
  if (!(smoothing_deg >= 0.0 && smoothing_deg <= 5.0)) {
    return absl::InvalidArgumentError("smoothing_deg must be in [0, 5]");
  }
  if (!(search_half_width_deg > 1.0 && search_half_width_deg <= 80.0)) {
    return absl::InvalidArgumentError("search_half_width_deg must be in (1, 80]");
  }
  if (!(min_dip_sigmas > 0.0)) return absl::InvalidArgumentError("min_dip_sigmas must be > 0");
  if (bootstrap_samples < 0) return absl::InvalidArgumentError("bootstrap_samples must be >= 0");
  return absl::OkStatus();
}

absl::StatusOr<PeakPickingResult> PickPeaks(const Profile& profile,
                                            double phase_angle_rad,
                                            const Projection& projection,
                                            const PeakPickingOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  const int n = profile.NumBins();
  if (n < 8 || profile.num_blocks < 2 ||
      profile.block_sum.size() != static_cast<std::size_t>(n) * profile.num_blocks) {
    return absl::InvalidArgumentError("profile too short or inconsistent for peak picking");
  }
  const double bin = profile.bin_width_rad;
  const double first = profile.azimuth_rad.front();
  auto index_of = [&](double phi) { return (phi - first) / bin; };
  auto azimuth_of = [&](double index) { return first + index * bin; };

  const std::vector<int> ones(profile.num_blocks, 1);
  const double sigma_bins = options.smoothing_deg * kDeg / bin;
  const std::vector<double> s = Smooth(MeanFromBlocks(profile, ones), sigma_bins);
  // Smoothing averages about 2·sqrt(π)·σ bins: the standard errors shrink.
  const double se_gain = sigma_bins >= 0.3 ? 1.0 / std::sqrt(2.0 * std::sqrt(M_PI) * sigma_bins) : 1.0;
  std::vector<double> se(n);
  for (int i = 0; i < n; ++i) se[i] = profile.stderr_mean[i] * se_gain;

  const double center = index_of(phase_angle_rad / 2.0);
  const double half = options.search_half_width_deg * kDeg / bin;
  const int lo = std::max(1, static_cast<int>(std::floor(center - half)));
  const int hi = std::min(n - 2, static_cast<int>(std::ceil(center + half)));
  if (hi - lo < 8) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the mirror azimuth %.1f deg (half the phase angle) is outside the "
        "visible part of the cylinder",
        phase_angle_rad / 2.0 / kDeg));
  }
  const Located found = Locate(s, se, lo, hi, center, 3.0 * kDeg / bin, options);
  if (found.top < 0 || s[found.top] <= 0.0) {
    return absl::InvalidArgumentError(
        "no specular peak near half the phase angle: check the phase angle "
        "and that the cylinder is lit");
  }

  PeakPickingResult result;
  result.dip_sigmas = found.dip_sigmas;
  auto spacing_of = [&](double left_rad, double right_rad) {
    // β at each peak (DESIGN.md §2 with the perspective view angle v); the
    // facet tilts there are ±arctan m, so their difference is 2·arctan m.
    const double beta_left = 0.5 * (phase_angle_rad + ViewAngleRad(left_rad, projection)) - left_rad;
    const double beta_right = 0.5 * (phase_angle_rad + ViewAngleRad(right_rad, projection)) - right_rad;
    return beta_left - beta_right;
  };

  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, profile.num_blocks - 1);
  auto resample = [&]() {
    std::vector<int> w(profile.num_blocks, 0);
    for (int k = 0; k < profile.num_blocks; ++k) ++w[pick(rng)];
    return Smooth(MeanFromBlocks(profile, w), sigma_bins);
  };
  const double quantisation = bin / std::sqrt(12.0);

  if (found.split) {
    const int a = std::min(found.top, found.other);
    const int b = std::max(found.top, found.other);
    const double left = RefineMaximum(s, a);
    const double right = RefineMaximum(s, b);
    result.split_resolved = true;
    result.model = found.valley_ratio < options.sawtooth_valley_ratio
                       ? ProfileModel::kSawtooth
                       : ProfileModel::kSinusoid;
    result.left_peak_rad = azimuth_of(left);
    result.right_peak_rad = azimuth_of(right);
    result.spacing_rad = spacing_of(result.left_peak_rad, result.right_peak_rad);
    result.mirror_rad = 0.5 * (result.left_peak_rad + result.right_peak_rad);
    std::vector<double> spacings;
    std::vector<double> mirrors;
    const double radius = std::max(3.0, 0.25 * (right - left));
    for (int r = 0; r < options.bootstrap_samples; ++r) {
      const std::vector<double> t = resample();
      const double l = azimuth_of(NearestPeak(t, left, radius));
      const double rr = azimuth_of(NearestPeak(t, right, radius));
      spacings.push_back(spacing_of(l, rr));
      mirrors.push_back(0.5 * (l + rr));
    }
    result.spacing_stderr_rad = std::hypot(Stddev(spacings), std::sqrt(2.0) * quantisation);
    result.mirror_stderr_rad = std::hypot(Stddev(mirrors), quantisation / std::sqrt(2.0));
    result.max_slope = std::tan(0.5 * result.spacing_rad);
    const double sec = 1.0 / std::cos(0.5 * result.spacing_rad);
    result.max_slope_stderr = 0.5 * sec * sec * result.spacing_stderr_rad;
    result.warnings.push_back(
        "peak picking: blur pulls each caustic peak inward, so the spacing "
        "and max slope are biased low by up to about the peak width; "
        "SINUSOID vs SAWTOOTH is judged from the valley between the peaks only");
  } else {
    const double peak = RefineMaximum(s, found.top);
    result.model = ProfileModel::kSmooth;
    result.left_peak_rad = result.right_peak_rad = result.mirror_rad = azimuth_of(peak);
    // Full width at half maximum above the window's floor.
    double floor_level = s[found.top];
    for (int i = lo; i <= hi; ++i) floor_level = std::min(floor_level, s[i]);
    const double half_level = 0.5 * (s[found.top] + floor_level);
    int l = found.top;
    while (l > lo && s[l] > half_level) --l;
    int r = found.top;
    while (r < hi && s[r] > half_level) ++r;
    result.single_peak_fwhm_rad = (r - l) * bin;
    std::vector<double> mirrors;
    for (int k = 0; k < options.bootstrap_samples; ++k) {
      mirrors.push_back(azimuth_of(NearestPeak(resample(), peak, 3.0)));
    }
    result.mirror_stderr_rad = std::hypot(Stddev(mirrors), quantisation);
    result.warnings.push_back(absl::StrFormat(
        "a single specular peak (FWHM %.2f deg): any split narrower than "
        "about that is not resolved, so peak spacing and max slope are "
        "reported unresolved",
        result.single_peak_fwhm_rad / kDeg));
  }
  return result;
}

}  // namespace weavefit
