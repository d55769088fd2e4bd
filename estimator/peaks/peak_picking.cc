#include "estimator/peaks/peak_picking.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <string>

#include <Eigen/Dense>

#include "absl/status/status.h"
#include "estimator/stats/smooth.h"
#include "estimator/stats/golden_section.h"
#include "estimator/stats/median.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Background-subtracted mean per bin from row blocks weighted by `weights`
// (1 each for the plain profile, multiplicities for a bootstrap resample).
// Empty bins are filled by linear interpolation from their neighbours.
// With a range [from, to], only those bins are computed (and filled from
// neighbours inside it); the others are 0.
std::vector<double> MeanFromBlocks(const Profile& p, const std::vector<int>& weights,
                                   int from = 0, int to = -1) {
  const int all = p.NumBins();
  if (to < 0 || to >= all) to = all - 1;
  from = std::max(from, 0);
  std::vector<double> whole(all, 0.0);
  if (to < from) return whole;
  const int n = to - from + 1;
  std::vector<double> mean(n, 0.0);
  std::vector<bool> have(n, false);
  for (int i = 0; i < n; ++i) {
    double sum = 0.0;
    double count = 0.0;
    for (int b = 0; b < p.num_blocks; ++b) {
      if (weights[b] == 0) continue;
      const std::size_t at = static_cast<std::size_t>(b) * all + from + i;
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
  std::copy(mean.begin(), mean.end(), whole.begin() + from);
  return whole;
}

// Sub-bin position of a maximum at index i, by a parabola through i−1..i+1;
// on a flat top (bins read at one clip level: ReadLevels), its middle.
double RefineMaximum(const std::vector<double>& s, int i) {
  const int n = static_cast<int>(s.size());
  if (i <= 0 || i + 1 >= n) return i;
  int a = i, b = i;
  while (a > 0 && s[a - 1] == s[i]) --a;
  while (b + 1 < n && s[b + 1] == s[i]) ++b;
  if (b > a) return 0.5 * (a + b);
  const double denom = s[i - 1] - 2.0 * s[i] + s[i + 1];
  if (!(denom < 0.0)) return i;
  return i + std::clamp(0.5 * (s[i - 1] - s[i + 1]) / denom, -0.5, 0.5);
}

// Topographic prominence of the maximum at i within [lo, hi]: its height
// above the higher of the two lowest points reached before a higher
// sample (or the window's edge) on each side.
double Prominence(const std::vector<double>& s, int i, int lo, int hi) {
  double left_min = s[i];
  for (int k = i - 1; k >= lo && s[k] <= s[i]; --k) left_min = std::min(left_min, s[k]);
  double right_min = s[i];
  for (int k = i + 1; k <= hi && s[k] <= s[i]; ++k) right_min = std::min(right_min, s[k]);
  return s[i] - std::max(left_min, right_min);
}

// Maxima of s in [lo, hi] above `baseline` whose prominence exceeds
// min_dip_sigmas standard errors and min_dip_fraction of their height above
// the baseline, keeping those at least min_peak_ratio of the highest.
std::vector<int> SignificantMaxima(const std::vector<double>& s,
                                   const std::vector<double>& se, int lo,
                                   int hi, double baseline,
                                   const PeakPickingOptions& options) {
  std::vector<int> maxima;
  double highest = 0.0;
  for (int i = std::max(lo, 1); i <= std::min(hi, static_cast<int>(s.size()) - 2); ++i) {
    if (!(s[i] >= s[i - 1] && s[i] > s[i + 1])) continue;
    const double height = s[i] - baseline;
    const double prominence = Prominence(s, i, lo, hi);
    if (height <= 0.0 || prominence < options.min_dip_sigmas * se[i] ||
        prominence < options.min_dip_fraction * height) {
      continue;
    }
    maxima.push_back(i);
    highest = std::max(highest, height);
  }
  maxima.erase(std::remove_if(maxima.begin(), maxima.end(),
                              [&](int i) { return s[i] - baseline < options.min_peak_ratio * highest; }),
               maxima.end());
  return maxima;
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

// The least height, as a share of the lower caustic peak's excess, of a
// maximum between the peaks that counts as a glint of a comb (the teeth in PickPeaks).
constexpr double kMinToothShare = 0.05;
// An outside point closer than this to the limb (px) lies on its edge.
constexpr double kLimbEdgePx = 4.0;
// The valley's chord is fitted to the profile this far outside the two
// peaks' outside points, from at least this many bins on each side.
constexpr double kChordReachDeg = 20.0;
constexpr int kChordMinBinsPerSide = 4;
// The caustic asymmetry (PickPeaks) from which both peaks read as a
// sinusoid's, whatever the level between them.
constexpr double kSinusoidShoulder = 0.2;
// On a comb of glints smoothed over its teeth, the share of the way from
// a sawtooth's valley level to a sinusoid's from which the lobe is a
// sinusoid (PickPeaks).
constexpr double kCombSinusoidShare = 0.5;
// Within this of the terminator and of the limb, threads shadow and mask
// each other and the grazing scatter departs from its 1/cos φ (PickPeaks).
constexpr double kGrazingMarginDeg = 8.0;
// The widest single peak read as a smooth glossy lobe (PickPeaks), deg.
constexpr double kMaxSinglePeakFwhmDeg = 30.0;
// The valley's chord is a dome of free centre where its sum of squares
// outside the peaks is at most this share of the other shapes' (PickPeaks).
constexpr double kDomeRssShare = 0.5;
// Where the lobe is isolated only in the window trimmed to the scatter's
// lawful range (PickPeaks), a comb's share this close to kCombSinusoidShare,
// or any share short of its far side with the scatter's glint lines beside
// the lobe, does not decide the model: the lobe is refused.
constexpr double kCombTrimmedAmbiguity = 0.25;

double Stddev(const std::vector<double>& v) {
  if (v.size() < 2) return 0.0;
  double mean = 0.0;
  for (double x : v) mean += x;
  mean /= v.size();
  double ss = 0.0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / (v.size() - 1));
}

// The mean of level(k) over the middle half of [left, right]: the valley
// between two peaks at those indices.
template <typename Level>
double MiddleHalfMean(int left, int right, Level&& level) {
  const int q = (right - left) / 4;
  double sum = 0.0;
  for (int k = left + q; k <= right - q; ++k) sum += level(k);
  return sum / (right - left - 2 * q + 1);
}

// The model's specular radiance (DESIGN.md §3) blurred by a Gaussian of
// sigma_rad, at mirror azimuth mirror_rad, sampled in facet tilt β every
// `step`, and its highest maximum on each side of β = 0.
struct SmoothedLobe {
  std::vector<double> f;
  double step = 0.0;
  int left = 0;
  int right = 0;
};
SmoothedLobe SampleSmoothedLobe(ProfileModel model, double max_slope, double sigma_rad,
                                double mirror_rad) {
  RadianceParams<double> p;
  p.model = model;
  p.max_slope = max_slope;
  p.mirror_rad = mirror_rad;
  p.blur_rad = sigma_rad;
  const double reach = std::atan(max_slope) + 5.0 * sigma_rad;
  SmoothedLobe lobe;
  lobe.step = std::min(sigma_rad, std::atan(max_slope)) / 10.0;
  const int n = static_cast<int>(std::ceil(2.0 * reach / lobe.step)) + 1;
  lobe.f.resize(n);
  for (int i = 0; i < n; ++i) {
    const double beta = -reach + i * lobe.step;
    lobe.f[i] = SpecularRadiance(p, mirror_rad - beta);
  }
  const int mid = n / 2;
  for (int i = 1; i <= mid; ++i) if (lobe.f[i] > lobe.f[lobe.left]) lobe.left = i;
  lobe.right = n - 1;
  for (int i = n - 2; i >= mid; --i) if (lobe.f[i] > lobe.f[lobe.right]) lobe.right = i;
  return lobe;
}

// Distance in facet tilt between the outermost maxima of the smoothed lobe
// (SampleSmoothedLobe): what peak picking on a profile smoothed by
// sigma_rad would read for max slope m.
double SmoothedSpacing(ProfileModel model, double max_slope, double sigma_rad,
                       double mirror_rad) {
  const SmoothedLobe lobe = SampleSmoothedLobe(model, max_slope, sigma_rad, mirror_rad);
  // Sub-step positions by a parabola through each maximum and its
  // neighbours: without them the spacing moves in whole steps and the
  // inversion below cannot settle.
  return (RefineMaximum(lobe.f, lobe.right) - RefineMaximum(lobe.f, lobe.left)) * lobe.step;
}

// The level over the middle half between the two outermost maxima of the
// smoothed lobe (SampleSmoothedLobe), over the lower of the two: what peak
// picking's valley ratio reads on a lobe smoothed by sigma_rad, for max
// slope m.
double SmoothedValleyRatio(ProfileModel model, double max_slope, double sigma_rad,
                           double mirror_rad) {
  const SmoothedLobe lobe = SampleSmoothedLobe(model, max_slope, sigma_rad, mirror_rad);
  const int left = lobe.left;
  const int right = lobe.right;
  if (right - left < 3) return 1.0;
  const double middle = MiddleHalfMean(left, right, [&](int i) { return lobe.f[i]; });
  return middle / std::min(lobe.f[left], lobe.f[right]);
}

// The max slope whose smoothed lobe (of the model) shows `spacing_rad`
// between its maxima. Smoothing shifts the maxima inward by an amount that
// barely depends on m, so the fixed-point iteration g ← g + (target − S(g))
// on the true spacing g converges in a few steps.
double InvertSmoothedSpacing(ProfileModel model, double spacing_rad, double sigma_rad,
                             double mirror_rad) {
  double g = spacing_rad;
  for (int it = 0; it < 20; ++it) {
    const double m = std::tan(0.5 * std::clamp(g, 1e-4, 2.8));
    const double miss = spacing_rad - SmoothedSpacing(model, m, sigma_rad, mirror_rad);
    g += miss;
    if (std::fabs(miss) < 1e-6) break;
  }
  return std::tan(0.5 * std::clamp(g, 1e-4, 2.8));
}

// Blur pulls a sinusoid's caustic maxima inward (DESIGN.md §3). For tilt
// amplitude a = arctan m the facet tilts are ≈ a·sin θ, an arcsine density;
// blurred by a Gaussian σ its shape depends on ρ = a/σ alone: outer maxima
// at ±σ·P(ρ) and outer half-maximum points at ±σ·H(ρ). Tabulated once over
// ρ from 1.5 to 300 (σ = 1, 2048 phase nodes; golden-section and bisection
// searches, ≈ 20 ms).
struct BlurPullTable {
  std::vector<double> rho;
  std::vector<double> peak;  // P(ρ)
  std::vector<double> half;  // H(ρ)
};

const BlurPullTable& PullTable() {
  static const BlurPullTable table = [] {
    BlurPullTable t;
    constexpr int kNodes = 2048;
    std::vector<double> sines(kNodes);
    for (int i = 0; i < kNodes; ++i) sines[i] = std::sin(2.0 * M_PI * (i + 0.5) / kNodes);
    for (int k = 0; k < 96; ++k) {
      const double rho = 1.5 * std::pow(200.0, k / 95.0);
      auto f = [&](double x) {
        double sum = 0.0;
        for (double sn : sines) {
          const double d = x - rho * sn;
          if (std::fabs(d) < 9.0) sum += std::exp(-0.5 * d * d);
        }
        return sum;
      };
      // f rises from the valley at 0 to the outer maximum, then falls.
      const double peak = GoldenSectionMinimum([&](double x) { return -f(x); }, 0.0, rho + 4.0,
                                               1e-10 * (rho + 4.0));
      if (peak < 0.05) continue;  // no split at this ρ
      const double target = 0.5 * f(peak);
      double a = peak;
      double b = rho + 12.0;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (a + b);
        if (f(mid) > target) a = mid; else b = mid;
      }
      t.rho.push_back(rho);
      t.peak.push_back(peak);
      t.half.push_back(0.5 * (a + b));
    }
    return t;
  }();
  return table;
}

// The tilt amplitude a (rad) of a blurred sinusoid lobe whose outer maxima
// are `spacing` apart and whose outer half-maximum points are `width`
// apart, both in tilt; NaN when the pair lies outside the table.
double UnpullSinusoidSpacing(double spacing, double width) {
  const BlurPullTable& t = PullTable();
  if (!(spacing > 0.0) || !(width > spacing) || t.rho.size() < 2) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const double ratio = width / spacing;  // H/P: falls toward 1 as ρ grows
  for (std::size_t k = 1; k < t.rho.size(); ++k) {
    const double r0 = t.half[k - 1] / t.peak[k - 1];
    const double r1 = t.half[k] / t.peak[k];
    if ((ratio - r0) * (ratio - r1) > 0.0) continue;
    const double u = (ratio - r0) / (r1 - r0);
    const double rho = t.rho[k - 1] + u * (t.rho[k] - t.rho[k - 1]);
    const double peak = t.peak[k - 1] + u * (t.peak[k] - t.peak[k - 1]);
    const double sigma = 0.5 * spacing / peak;
    return rho * sigma;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Position (bin index) of the highest local maximum of s in [a, b], refined.
double HighestMaximum(const std::vector<double>& s, int a, int b) {
  int best = -1;
  for (int i = std::max(a, 1); i <= std::min(b, static_cast<int>(s.size()) - 2); ++i) {
    if (s[i] >= s[i - 1] && s[i] > s[i + 1] && (best < 0 || s[i] > s[best])) best = i;
  }
  return best < 0 ? -1.0 : RefineMaximum(s, best);
}

// What every stage of PickPeaks reads: the profile, the geometry and the
// options, with the azimuth of each bin and the small readings the stages
// share.
struct PickInputs {
  const Profile& profile;
  double phase_angle_rad = 0.0;
  const Projection& projection;
  const PeakPickingOptions& options;
  int n = 0;           // bins
  double bin = 0.0;    // bin width, rad
  double first = 0.0;  // azimuth of bin 0, rad

  double IndexOf(double phi) const { return (phi - first) / bin; }
  double AzimuthOf(double index) const { return first + index * bin; }

  // A bin more than 5 % saturated.
  bool Clipped(int i) const {
    const double total = profile.count[i] + profile.saturated[i];
    return total > 0 && profile.saturated[i] > 0.05 * total;
  }

  // A bin closer than kLimbEdgePx to the limb lies on its edge.
  bool AtLimbEdge(int i) const {
    return profile.radius_px > 0.0 &&
           profile.radius_px * (1.0 - std::fabs(std::sin(AzimuthOf(i)))) < kLimbEdgePx;
  }

  double SpacingOf(double left_rad, double right_rad) const {
    // β at each peak (DESIGN.md §2 with the perspective view angle v); the
    // facet tilts there are ±arctan m, so their difference is 2·arctan m.
    const double beta_left =
        0.5 * (phase_angle_rad + ViewAngleRad(left_rad, projection)) - left_rad;
    const double beta_right =
        0.5 * (phase_angle_rad + ViewAngleRad(right_rad, projection)) - right_rad;
    return beta_left - beta_right;
  }

  // Position quantisation: a bin, or a pixel's footprint in azimuth where
  // that is wider (toward the limbs), as a uniform error.
  double QuantisationAt(double phi) const {
    const double footprint =
        profile.radius_px > 0 ? 1.0 / (profile.radius_px * std::max(std::cos(phi), 0.05)) : 0.0;
    return std::max(bin, footprint) / std::sqrt(12.0);
  }
};

// Stage 1 of PickPeaks: the profile's levels and the window searched.
struct Levels {
  // Background-subtracted mean per bin, a clipped bin's raised to the bound
  // its clipped pixels give.
  std::vector<double> raw;
  // What that bound added to each bin (0 where nothing clipped).
  std::vector<double> clip_lift;
  // raw with the bins more than 5 % saturated raised to their neighbours'.
  std::vector<double> filled;
  int clipped_bins = 0;
  // The search window around half the phase angle (bin indices).
  int lo = 0;
  int hi = 0;
};

absl::StatusOr<Levels> ReadLevels(const PickInputs& in) {
  const Profile& profile = in.profile;
  const int n = in.n;
  Levels v;
  const std::vector<int> ones(profile.num_blocks, 1);
  v.raw = MeanFromBlocks(profile, ones);
  // A bin with clipped pixels: its clipped pixels at their clipped values
  // give a lower bound on its mean (Profile::saturated_sum). The mean of its
  // unclipped pixels alone leaves out the brightest glints, and most where
  // they crowd, at the caustics: an overexposed lobe then read 5-16 deg
  // short. The bound, taken as the level, is still low, but by far less.
  // A bin with every pixel clipped (the top of an overexposed smooth lobe)
  // is at least at the clip level, not the flanks' level its neighbours
  // would interpolate.
  v.clip_lift.assign(n, 0.0);
  if (profile.saturated_sum.size() == static_cast<std::size_t>(n)) {
    for (int i = 0; i < n; ++i) {
      const double count = std::max(profile.count[i], 0.0);
      const double clipped_px = profile.saturated[i];
      if (!(clipped_px > 0.0)) continue;
      const double sum = (v.raw[i] + profile.background) * count + profile.saturated_sum[i];
      v.clip_lift[i] = std::max(0.0, sum / (count + clipped_px) - profile.background - v.raw[i]);
      v.raw[i] += v.clip_lift[i];
    }
  }
  const double center = in.IndexOf(in.phase_angle_rad / 2.0);
  const double half = in.options.search_half_width_deg * kDeg / in.bin;
  v.lo = std::max(1, static_cast<int>(std::floor(center - half)));
  v.hi = std::min(n - 2, static_cast<int>(std::ceil(center + half)));
  if (v.hi - v.lo < 8) {
    return absl::InvalidArgumentError(
        absl::StrFormat("the mirror azimuth %.1f deg (half the phase angle) is outside the "
                        "visible part of the cylinder",
                        in.phase_angle_rad / 2.0 / kDeg));
  }

  // Bins dominated by saturated pixels carry no level: raise them to their
  // neighbours' maximum so that a clipped peak reads as one plateau rather
  // than a dip between two false peaks.
  v.filled = v.raw;
  for (int i = 0; i < n; ++i) {
    if (in.Clipped(i)) {
      ++v.clipped_bins;
      double level = v.raw[i];
      for (int k = std::max(0, i - 3); k <= std::min(n - 1, i + 3); ++k) {
        level = std::max(level, v.raw[k]);
      }
      v.filled[i] = level;
    }
  }
  return v;
}

// Stage 2 of PickPeaks, at work: the baseline drawn under the heavily
// smoothed profile across the search window [lo, hi], and the lobe it
// leaves standing above it.
struct BaselineFit {
  std::vector<double> heavy;
  double lobe_fraction = 0.0;
  int lo = 0;
  int hi = 0;
  // The medians of the window's two ends, and where they stand.
  double base_lo = 0.0;
  double base_hi = 0.0;
  double at_lo = 0.0;
  double at_hi = 0.0;
  std::vector<double> baseline;
  // The straight baseline over the whole window, to go back to.
  std::vector<double> straight;
  double lobe_max = 0.0;
  int lobe_lo = -1;
  int lobe_hi = -1;
  // Whether the lobe stood out only in the window trimmed to the scatter's
  // lawful range.
  bool trimmed = false;

  // Baseline: a straight line between the medians of the window's two ends,
  // which takes out the background and, to first order, the slow rise of
  // the grazing scatter toward a limb.
  void DrawStraight() {
    const int n = static_cast<int>(baseline.size());
    const int edge = std::max(3, (hi - lo) / 10);
    base_lo = Median(std::vector<double>(heavy.begin() + lo, heavy.begin() + lo + edge));
    base_hi = Median(std::vector<double>(heavy.begin() + hi - edge + 1, heavy.begin() + hi + 1));
    at_lo = lo + 0.5 * (edge - 1);
    at_hi = hi - 0.5 * (edge - 1);
    for (int i = 0; i < n; ++i) {
      baseline[i] = base_lo + (base_hi - base_lo) * (i - at_lo) / (at_hi - at_lo);
    }
  }

  // The lobe spans from the first to the last bin where the heavily
  // smoothed profile rises above lobe_fraction of its highest excess.
  void FindLobe() {
    lobe_max = 0.0;
    for (int i = lo; i <= hi; ++i) lobe_max = std::max(lobe_max, heavy[i] - baseline[i]);
    lobe_lo = lobe_hi = -1;
    for (int i = lo; i <= hi; ++i) {
      if (heavy[i] - baseline[i] > lobe_fraction * lobe_max) {
        if (lobe_lo < 0) lobe_lo = i;
        lobe_hi = i;
      }
    }
  }

  // The baseline a + b·shape(φ) through the window's two ends, kept (true)
  // where it isolates the lobe with nothing far below it; otherwise the
  // straight one is restored.
  template <typename Shape>
  bool TryShape(Shape&& shape) {
    const int n = static_cast<int>(baseline.size());
    const double c_lo = shape(at_lo);
    const double c_hi = shape(at_hi);
    const double b = std::fabs(c_hi - c_lo) > 0.1 ? (base_hi - base_lo) / (c_hi - c_lo) : 0.0;
    if (!(b > 0.0)) return false;
    for (int i = 0; i < n; ++i) baseline[i] = base_lo + b * (shape(i) - c_lo);
    FindLobe();
    double deepest = 0.0;
    for (int i = lo; i <= hi; ++i) {
      if (i < lobe_lo || i > lobe_hi) deepest = std::min(deepest, heavy[i] - baseline[i]);
    }
    if (lobe_lo >= 0 && lobe_lo > lo && lobe_hi < hi && deepest >= -lobe_fraction * lobe_max) {
      return true;
    }
    baseline = straight;
    FindLobe();
    return false;
  }
};

// The profile under the heavy smoothing, which reads no bin within
// kLimbEdgePx of either limb (those keep their own levels).
std::vector<double> SmoothOffTheLimbEdge(const PickInputs& in, const std::vector<double>& level) {
  int first = 0, last = in.n - 1;
  while (first < last && in.AtLimbEdge(first)) ++first;
  while (last > first && in.AtLimbEdge(last)) --last;
  std::vector<double> out = level;
  const std::vector<double> inside(level.begin() + first, level.begin() + last + 1);
  const std::vector<double> smoothed =
      Smooth(inside, in.options.lobe_smoothing_deg * kDeg / in.bin);
  std::copy(smoothed.begin(), smoothed.end(), out.begin() + first);
  return out;
}

BaselineFit FitBaseline(const PickInputs& in, const Levels& levels) {
  const PeakPickingOptions& options = in.options;
  const double phase_angle_rad = in.phase_angle_rad;
  // One photograph samples only the weave phases of the threads in view, so
  // its profile is a comb of glints around the analytic lobe (DESIGN.md §3).
  // The lobe is found on a heavily smoothed profile; the split peaks are the
  // outermost significant maxima of the lightly smoothed profile inside it
  // (the caustic glints bound the lobe).
  BaselineFit f;
  f.heavy = Smooth(levels.filled, options.lobe_smoothing_deg * kDeg / in.bin);
  f.lobe_fraction = options.lobe_fraction;
  f.lo = levels.lo;
  f.hi = levels.hi;
  f.baseline.resize(in.n);
  f.DrawStraight();
  f.FindLobe();
  // A Lambertian term (a coloured cloth) is a dome, cos(φ − α), that bulges
  // above the straight baseline; at large phase angles the window runs from
  // beyond the terminator to the lit limb and the dome filled it, so the
  // lobe was "not isolated" (random scenes at 112°-119° with diffuse
  // 0.1-0.2). The grazing scatter rises as 1/cos φ toward the limb, and
  // where it is strong it did the same (independently rendered photographs
  // at 60°-110°). Where the straight baseline leaves the lobe at an end of
  // the window, a + b·f(φ) through the two ends is tried for f = max(0,
  // cos(φ − α)), then 1/cos φ, and the first kept that isolates the lobe
  // with nothing far below it.
  if (f.lobe_lo >= 0 && (f.lobe_lo <= f.lo || f.lobe_hi >= f.hi)) {
    f.straight = f.baseline;
    auto lit = [&](double i) { return std::max(0.0, std::cos(in.AzimuthOf(i) - phase_angle_rad)); };
    auto grazing = [&](double i) { return 1.0 / std::max(std::cos(in.AzimuthOf(i)), 0.05); };
    if (!f.TryShape(lit) && !f.TryShape(grazing)) {
      // Within a few degrees of the terminator the threads shadow each
      // other, and within a few of the limb they mask each other: there the
      // scatter leaves its 1/cos φ law (it starts softly, and it levels off
      // before the limb). At α ≈ 110° the window runs from beyond the
      // terminator to the limb, so both its ends lie there, and any shape
      // drawn through them left the lobe running into one (the paper's gauze
      // at 110° under a strong smooth scatter, independently rendered:
      // "deepest" −0.11 against a lobe of 0.08). The window is then cut to
      // where the law holds, kGrazingMarginDeg (plus the heavy smoothing)
      // from both, and the three baselines are tried again there. Nor does
      // it hold within kLimbEdgePx of the limb, where a bin holds the limb's
      // own light spread by the pixel and the lens: on a small cylinder that
      // is more than the margin (227 px: the last 10.8 deg), and the heavy
      // smoothing is then taken without those bins (the shared photographs
      // at half their size: the lobe ran into the window's limb end).
      const int window_lo = f.lo;
      const int window_hi = f.hi;
      const double margin = std::sin(kGrazingMarginDeg * kDeg + options.lobe_smoothing_deg * kDeg);
      auto trusted = [&](int i) {
        const double phi = in.AzimuthOf(i);
        return std::cos(phi - phase_angle_rad) > margin && std::cos(phi) > margin &&
               !in.AtLimbEdge(i);
      };
      while (f.lo < f.hi && !trusted(f.lo)) ++f.lo;
      while (f.hi > f.lo && !trusted(f.hi)) --f.hi;
      bool isolated = false;
      const std::vector<double> heavy = f.heavy;
      if ((f.lo != window_lo || f.hi != window_hi) && f.hi - f.lo >= 8) {
        f.heavy = SmoothOffTheLimbEdge(in, levels.filled);
        f.DrawStraight();
        f.FindLobe();
        isolated = f.lobe_lo > f.lo && f.lobe_hi < f.hi;  // lobe_lo < 0 fails too
        if (!isolated) isolated = f.TryShape(lit) || f.TryShape(grazing);
      }
      f.trimmed = isolated;
      if (!isolated) {
        f.heavy = heavy;
        f.lo = window_lo;
        f.hi = window_hi;
        f.DrawStraight();
        f.FindLobe();
      }
    }
  }
  return f;
}

// Stage 2 of PickPeaks: the lobe, isolated above its baseline.
struct Lobe {
  std::vector<double> baseline;
  // The search window, cut to the scatter's lawful range where `trimmed`.
  int lo = 0;
  int hi = 0;
  bool trimmed = false;
  // The lobe's bins, widened by `margin` on each side (within the window).
  int lobe_lo = 0;
  int lobe_hi = 0;
  int margin = 0;
  // Share of the lobe's bins (before widening) more than 5 % saturated.
  double clipped_share = 0.0;
};

absl::StatusOr<Lobe> IsolateLobe(const PickInputs& in, const Levels& levels) {
  const int n = in.n;
  BaselineFit f = FitBaseline(in, levels);
  if (f.lobe_lo < 0) {
    return absl::InvalidArgumentError(
        "no specular lobe near half the phase angle: check the phase angle "
        "and that the cylinder is lit");
  }
  // A lobe that runs to an end of the search window is not isolated: its
  // baseline is lobe, and at the limb end its outer caustic may be cut. At
  // α = 140° the lobe (70° ± 13.5° for m = 0.24) meets the limb: peak picking
  // read it as a 23.7° sawtooth for a 27.0° sinusoid, 4 stated errors off.
  if (f.lobe_lo <= f.lo || f.lobe_hi >= f.hi) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the specular lobe is not isolated: it runs from %.1f to %.1f deg, to the end of the "
        "%.1f-%.1f deg searched around half the phase angle%s; its caustic peaks cannot be read",
        in.AzimuthOf(f.lobe_lo) / kDeg, in.AzimuthOf(f.lobe_hi) / kDeg, in.AzimuthOf(f.lo) / kDeg,
        in.AzimuthOf(f.hi) / kDeg,
        f.lo <= 1 || f.hi >= n - 2
            ? ", which the limb cuts short (photograph at a smaller phase angle)"
            : ""));
  }
  Lobe lobe;
  int clipped_in_lobe = 0;
  for (int i = f.lobe_lo; i <= f.lobe_hi; ++i) clipped_in_lobe += in.Clipped(i);
  lobe.clipped_share = static_cast<double>(clipped_in_lobe) / (f.lobe_hi - f.lobe_lo + 1);
  lobe.margin =
      static_cast<int>(std::ceil(2.0 * in.options.lobe_smoothing_deg * kDeg / in.bin)) + 2;
  lobe.lobe_lo = std::max(f.lo, f.lobe_lo - lobe.margin);
  lobe.lobe_hi = std::min(f.hi, f.lobe_hi + lobe.margin);
  lobe.lo = f.lo;
  lobe.hi = f.hi;
  lobe.trimmed = f.trimmed;
  lobe.baseline = std::move(f.baseline);
  return lobe;
}

// Stage 3 of PickPeaks: the significant maxima of the lobe, at the finest
// smoothing that shows any.
struct Maxima {
  // The smoothing (σ) in degrees and in bins.
  double light_deg = 0.0;
  double light_bins = 0.0;
  // The profile so smoothed, its standard errors, and its excess above the
  // baseline.
  std::vector<double> s;
  std::vector<double> se;
  std::vector<double> excess;
  // The outermost maxima, and the highest.
  int left = 0;
  int right = 0;
  int top = 0;
};

// The weave's texture: the relief under stray and diffuse light ripples the
// whole lit body's profile with the thread period, inside the lobe and out,
// and on a large photograph those ripples stand far out of the pixel noise.
// Their typical size beside the lobe (the median prominence of the maxima
// in a stretch half the lobe's width on each side of it) tells a ripple from
// a glint within it. 0 where fewer than kMinTextureMaxima maxima stand out
// there (no texture the pixels resolve).
constexpr int kMinTextureMaxima = 5;
// The fewest bins between the outermost maxima that make a split.
constexpr int kMinSplitBins = 3;
// The fewest glints above the texture that make a comb it can be cut from
// (TrimTexture): the two caustics and a tooth between them.
constexpr int kMinGlintsOverTexture = 3;
// A maximum in the lobe is a glint when its prominence exceeds this many
// times the texture's typical ripple beside the lobe: the ripples'
// prominences spread by a factor of two to three about their median, and
// they grow with the body's level toward the lobe, while a glint is a
// specular highlight on top of that texture. On 800x600 renders at 2.5
// times a lab scene's size, the ripples beside the lobe stood 0.0008-0.0043
// (median 0.0017-0.0021), those within it up to 0.0036, the lobe's
// outermost glints 0.011-0.046: taken for the caustics, the outermost
// ripples read the spacing twice too wide.
constexpr double kGlintOverTexture = 3.0;
// ... where the lobe's highest maximum stands this many times that cut
// above the texture, so that the ripples and the glints that matter lie
// on clearly different scales. Beside independently rendered lobes
// (scripts/independent_scenes.py) the axial threads' glint lines made the
// "texture", and the lobe's highest maximum stood 1.0-91 times their
// median: with every maximum under the cut dropped wherever a texture
// showed, the glints went with the lines, and of the 64 scenes 17 more
// were refused and 2 more answered wrong.
constexpr double kTextureApart = 3.0;

double TextureRipple(const std::vector<double>& s, const std::vector<double>& se,
                     const PickInputs& in, const Lobe& lobe) {
  std::vector<double> ripples;
  auto stretch = [&](int lo, int hi) {
    lo = std::max(lo, 1);
    hi = std::min(hi, in.n - 2);
    for (int i = lo; i <= hi; ++i) {
      if (!(s[i] >= s[i - 1] && s[i] > s[i + 1])) continue;
      if (in.AtLimbEdge(i) || in.Clipped(i)) continue;
      const double prominence = Prominence(s, i, lo, hi);
      if (prominence >= in.options.min_dip_sigmas * se[i]) ripples.push_back(prominence);
    }
  };
  const int half = (lobe.lobe_hi - lobe.lobe_lo) / 2;
  stretch(lobe.lobe_lo - half, lobe.lobe_lo - 1);
  stretch(lobe.lobe_hi + 1, lobe.lobe_hi + half);
  if (static_cast<int>(ripples.size()) < kMinTextureMaxima) return 0.0;
  return Median(ripples);
}

// The outermost maxima (bin order) that are the texture's ripples, not
// glints, dropped from each side inward: on a diffuse dome the ripples
// beyond the caustics rise above the window's baseline as the lobe's teeth
// do. Only where the lobe's highest maximum stands clear of the texture
// (kTextureApart), and only where a comb of kMinGlintsOverTexture glints
// or more, spanning a split, stands above it: a lobe with fewer, its
// teeth of the texture's size, cannot be told from the texture, and its
// maxima are kept as they are (a steep sinusoid's weak teeth beside a
// textured body, one caustic above the cut: trimmed, the lobe collapsed
// onto that caustic and was refused, where its split read right before).
void TrimTexture(const PickInputs& in, const Lobe& lobe, const Maxima& mx,
                 std::vector<int>* maxima) {
  const double ripple = TextureRipple(mx.s, mx.se, in, lobe);
  if (!(ripple > 0.0)) return;
  std::vector<double> prominence;
  double highest = 0.0;
  for (int k : *maxima) {
    prominence.push_back(Prominence(mx.excess, k, lobe.lobe_lo, lobe.lobe_hi));
    highest = std::max(highest, prominence.back());
  }
  const double cut = kGlintOverTexture * ripple;
  if (!(highest > kTextureApart * cut)) return;
  std::size_t first = 0;
  std::size_t last = maxima->size();
  while (first < last && prominence[first] < cut) ++first;
  while (last > first && prominence[last - 1] < cut) --last;
  if (last >= first + kMinGlintsOverTexture &&
      (*maxima)[last - 1] - (*maxima)[first] >= kMinSplitBins) {
    *maxima = std::vector<int>(maxima->begin() + first, maxima->begin() + last);
  }
}

absl::StatusOr<Maxima> FindMaxima(const PickInputs& in, const Levels& levels, const Lobe& lobe) {
  const Profile& profile = in.profile;
  const PeakPickingOptions& options = in.options;
  const int n = in.n;
  // The finest smoothing at which the lobe shows significant maxima: a
  // noisy photograph needs more than a clean one. Significance is judged
  // against pixel noise at the bin's level (Profile::PixelNoise: the shot
  // noise grows with it), not against the spread over rows: that spread is
  // mostly the weave's own structure, signal here.
  Maxima mx;
  mx.light_deg = options.smoothing_deg;
  mx.se.resize(n);
  mx.excess.resize(n);
  std::vector<int> maxima;
  for (;;) {
    mx.light_bins = mx.light_deg * kDeg / in.bin;
    mx.s = Smooth(levels.filled, mx.light_bins);
    // Smoothing averages about 2·sqrt(π)·σ bins: the standard errors shrink.
    const double gain =
        mx.light_bins >= 0.3 ? 1.0 / std::sqrt(2.0 * std::sqrt(M_PI) * mx.light_bins) : 1.0;
    for (int i = 0; i < n; ++i) {
      // Clipped pixels count: their bound (the clip level) is read exactly.
      const double pixels = profile.count[i] + profile.saturated[i];
      mx.se[i] = pixels <= 0.0
                     ? 1e30  // no data: never significant
                     : gain * std::max(profile.PixelNoise(i), 1e-6) / std::sqrt(pixels);
      mx.excess[i] = mx.s[i] - lobe.baseline[i];
    }
    maxima = SignificantMaxima(mx.excess, mx.se, lobe.lobe_lo, lobe.lobe_hi, 0.0, options);
    if (!maxima.empty() || mx.light_deg >= options.lobe_smoothing_deg) break;
    mx.light_deg = std::min(2.0 * mx.light_deg, options.lobe_smoothing_deg);
  }
  TrimTexture(in, lobe, mx, &maxima);
  if (maxima.empty()) {
    return absl::InvalidArgumentError(
        "no specular peak stands out of the noise near half the phase angle: "
        "check the phase angle, the exposure and that the cylinder is lit");
  }
  mx.left = *std::min_element(maxima.begin(), maxima.end());
  mx.right = *std::max_element(maxima.begin(), maxima.end());
  const std::vector<double>& s = mx.s;
  mx.top =
      *std::max_element(maxima.begin(), maxima.end(), [&](int a, int b) { return s[a] < s[b]; });
  return mx;
}

// Stage 4 of PickPeaks, the split lobe's valley: the chord under it, drawn
// through the profile outside the two peaks, of the first shape that
// applies (in the order At tries them).
struct Chord {
  // The two peaks' outside points, the profile there, and cos(φ − α) at
  // the left one.
  int out_l = 0;
  int out_r = 0;
  double s_l = 0.0;
  double s_r = 0.0;
  double c_l = 0.0;
  // One outside point on the limb's edge: dark + dark_lambert·max(0, cos(φ − α)).
  bool one_sided = false;
  double dark = 0.0;
  double dark_lambert = 0.0;
  // Fitted to the bins outside both: a dome of free centre
  // dome_a + dome_p·cos φ + dome_q·sin φ, or fit_a + fit_b·x for x = 1/cos φ
  // (grazing), max(0, cos(φ − α)) (Lambertian) or the bin (straight).
  bool fitted = false;
  bool fitted_lambert = false;
  bool fitted_grazing = false;
  bool fitted_dome = false;
  double dome_a = 0.0, dome_p = 0.0, dome_q = 0.0;
  double fit_a = 0.0;
  double fit_b = 0.0;
  // Otherwise through the two outside points: a Lambertian term of this b
  // where it fits one, else the straight line.
  double lambert = 0.0;

  double At(const PickInputs& in, int k) const {
    const double phase_angle_rad = in.phase_angle_rad;
    if (one_sided) {
      return dark + dark_lambert * std::max(0.0, std::cos(in.AzimuthOf(k) - phase_angle_rad));
    }
    if (fitted_dome) {
      return dome_a + dome_p * std::cos(in.AzimuthOf(k)) + dome_q * std::sin(in.AzimuthOf(k));
    }
    if (fitted_grazing) return fit_a + fit_b / std::max(std::cos(in.AzimuthOf(k)), 0.05);
    if (fitted_lambert) {
      return fit_a + fit_b * std::max(0.0, std::cos(in.AzimuthOf(k) - phase_angle_rad));
    }
    if (fitted) return fit_a + fit_b * k;
    if (lambert > 0.0) return s_l + lambert * (std::cos(in.AzimuthOf(k) - phase_angle_rad) - c_l);
    return s_l + (s_r - s_l) * (k - out_l) / std::max(out_r - out_l, 1);
  }
};

// Ordinary least squares of s on (1, x) over `bins`: returns {a, b, rss}.
template <typename XOf>
std::array<double, 3> LineFit(const std::vector<int>& bins, const std::vector<double>& s,
                              XOf&& x_of) {
  double sx = 0.0, sy = 0.0, sxx = 0.0, sxy = 0.0;
  const double m = static_cast<double>(bins.size());
  for (int k : bins) {
    const double x = x_of(k);
    sx += x;
    sy += s[k];
    sxx += x * x;
    sxy += x * s[k];
  }
  const double det = m * sxx - sx * sx;
  std::array<double, 3> r = {sy / m, 0.0, std::numeric_limits<double>::infinity()};
  if (det <= 1e-12 * m * m) return r;
  r[1] = (m * sxy - sx * sy) / det;
  r[0] = (sy - r[1] * sx) / m;
  double rss = 0.0;
  for (int k : bins) rss += std::pow(s[k] - r[0] - r[1] * x_of(k), 2);
  r[2] = rss;
  return r;
}

// Both outside points in view: the chord is fitted to every bin outside
// them within kChordReachDeg (not at the limbs' edges, not clipped), as
// the best of a straight line, a + b·max(0, cos(φ − α)) and a + b/cos φ
// with b > 0, and a dome of free centre (below), by the sum of squares.
// Two points alone let one bin set it: a steep fine sinusoid at −73°,
// its left outside point still on the grazing scatter's
// rise toward the limb, drew a Lambertian chord through its filled
// valley (a ratio of 0.01: a sawtooth, wrongly).
void FitChordOutside(const PickInputs& in, const std::vector<double>& s, Chord* chord) {
  const Profile& profile = in.profile;
  const int n = in.n;
  const double phase_angle_rad = in.phase_angle_rad;
  const int out_l = chord->out_l;
  const int out_r = chord->out_r;
  const int reach = static_cast<int>(std::lround(kChordReachDeg * kDeg / in.bin));
  std::vector<int> bins;
  int left_count = 0;
  for (int k = std::max(0, out_l - reach); k <= std::min(n - 1, out_r + reach); ++k) {
    if (k > out_l && k < out_r) continue;
    if (!(profile.count[k] > 0.0) || in.Clipped(k) || in.AtLimbEdge(k)) continue;
    bins.push_back(k);
    if (k <= out_l) ++left_count;
  }
  const int right_count = static_cast<int>(bins.size()) - left_count;
  if (left_count < kChordMinBinsPerSide || right_count < kChordMinBinsPerSide) return;
  const auto straight = LineFit(bins, s, [&](int k) { return static_cast<double>(k); });
  const auto lit = LineFit(
      bins, s, [&](int k) { return std::max(0.0, std::cos(in.AzimuthOf(k) - phase_angle_rad)); });
  const auto graze =
      LineFit(bins, s, [&](int k) { return 1.0 / std::max(std::cos(in.AzimuthOf(k)), 0.05); });
  // A dome of free centre, a + p·cos φ + q·sin φ = a + b·cos(φ − φ0):
  // a Lambertian term seen through vignetting is brightest toward the
  // image's centre, not at α, and neither the straight chord nor the
  // Lambertian one at α follows it between peaks far apart (a
  // sawtooth 54° wide on a dome centred at −34° for
  // α = −40.7°, 8-bit, vignetting 0.26, read a valley ratio of 0.28,
  // a sinusoid), nor stray light's dome about the line of sight. Kept
  // only where it fits the bins outside the peaks at least twice as well
  // as the other shapes (a dome bulges into the valley, and a dome the
  // data do not ask for would empty a sinusoid's), and where its centre
  // lies on the visible surface, as light's must (beyond, it is a bowl).
  // Its centre may lie beyond an outside point: stray light's dome about
  // the line of sight, 0.9° beyond a steep sawtooth's inner caustic (lab
  // scene, m = 0.39 at −48.7°), was refused for it and the straight chord
  // left the valley 0.59 of the way to a sinusoid's.
  Eigen::MatrixXd design(bins.size(), 3);
  Eigen::VectorXd level(bins.size());
  for (std::size_t r = 0; r < bins.size(); ++r) {
    design(r, 0) = 1.0;
    design(r, 1) = std::cos(in.AzimuthOf(bins[r]));
    design(r, 2) = std::sin(in.AzimuthOf(bins[r]));
    level(r) = s[bins[r]];
  }
  const Eigen::Vector3d dome = design.colPivHouseholderQr().solve(level);
  const double dome_rss = (design * dome - level).squaredNorm();
  const double dome_at = std::atan2(dome(2), dome(1));
  double other_rss = straight[2];
  if (lit[1] > 0.0) other_rss = std::min(other_rss, lit[2]);
  if (graze[1] > 0.0) other_rss = std::min(other_rss, graze[2]);
  const bool dome_kept = std::hypot(dome(1), dome(2)) > 0.0 && std::fabs(dome_at) < 0.5 * M_PI &&
                         dome_rss < kDomeRssShare * other_rss;
  if (dome_kept) {
    chord->fitted = chord->fitted_dome = true;
    chord->dome_a = dome(0);
    chord->dome_p = dome(1);
    chord->dome_q = dome(2);
  } else if (graze[1] > 0.0 && graze[2] < straight[2] && !(lit[1] > 0.0 && lit[2] < graze[2])) {
    chord->fitted = chord->fitted_grazing = true;
    chord->fit_a = graze[0];
    chord->fit_b = graze[1];
  } else if (lit[1] > 0.0 && lit[2] < straight[2]) {
    chord->fitted = chord->fitted_lambert = true;
    chord->fit_a = lit[0];
    chord->fit_b = lit[1];
  } else if (std::isfinite(straight[2])) {
    chord->fitted = true;
    chord->fit_a = straight[0];
    chord->fit_b = straight[1];
  }
}

Chord DrawChord(const PickInputs& in, const Lobe& lobe, const Maxima& mx) {
  const Profile& profile = in.profile;
  const int n = in.n;
  const double phase_angle_rad = in.phase_angle_rad;
  const std::vector<double>& s = mx.s;
  const std::vector<double>& excess = mx.excess;
  // Each peak's outside point: where it has fallen to a tenth of its
  // height, two bins on (ReadValley says why the chord is drawn there).
  auto outside = [&](int peak, int step) {
    const double tenth = 0.1 * excess[peak];
    int i = peak;
    while (i + step >= lobe.lo && i + step <= lobe.hi && excess[i] > tenth) i += step;
    return std::clamp(i + 2 * step, lobe.lo, lobe.hi);
  };
  Chord chord;
  const int out_l = chord.out_l = outside(mx.left, -1);
  const int out_r = chord.out_r = outside(mx.right, +1);
  chord.s_l = s[out_l];
  chord.s_r = s[out_r];
  // Where too few bins lie outside the peaks to fit it (below), the chord
  // is a + b·cos(φ − α) through the two points where that
  // fits a Lambertian term (b ≥ 0, and a no lower than the background
  // outside the cylinder), and the straight line otherwise. A Lambertian
  // term bulges above the straight chord between peaks far apart: a
  // sawtooth m = 0.47 at −95° with diffuse 0.15 read a ratio of 0.14 above
  // the straight chord (a sinusoid, wrongly), 0.02 above this one.
  const double c_l = chord.c_l = std::cos(in.AzimuthOf(out_l) - phase_angle_rad);
  const double c_r = std::cos(in.AzimuthOf(out_r) - phase_angle_rad);
  if (c_l > 0.0 && c_r > 0.0 && std::fabs(c_l - c_r) > 1e-6) {
    const double b = (s[out_l] - s[out_r]) / (c_l - c_r);
    const double most =
        std::min((s[out_l] - profile.background) / c_l, (s[out_r] - profile.background) / c_r);
    if (b > 0.0 && b <= most) chord.lambert = b;
  }
  // A peak whose outside point lies on the limb's edge (an outer caustic
  // at the limb) has no outside there: the chord is then a + b·cos(φ − α)
  // through the other peak's outside point alone, with a the level where
  // the Lambertian term is dark (cos(φ − α) < 0, beyond the terminator).
  // Through the limb's edge, the straight chord and the Lambertian one
  // through it lay below the diffuse dome, which then filled a sawtooth's
  // valley (m = 0.58 at 100°, diffuse 0.19, the outside point 2.5 px
  // inside the limb: a ratio of 0.27, read as a sinusoid), and a straight
  // chord down the limb's edge lay below an empty valley (m = 0.67 at
  // 112°, no diffuse term).
  const bool cut_l = in.AtLimbEdge(out_l);
  const bool cut_r = in.AtLimbEdge(out_r);
  if (cut_l != cut_r) {
    std::vector<double> unlit;
    for (int k = 0; k < n; ++k) {
      if (k >= lobe.lobe_lo && k <= lobe.lobe_hi) continue;
      if (profile.count[k] > 0.0 && std::cos(in.AzimuthOf(k) - phase_angle_rad) < -0.05) {
        unlit.push_back(s[k]);
      }
    }
    const int inner = cut_l ? out_r : out_l;
    const double c_in = std::cos(in.AzimuthOf(inner) - phase_angle_rad);
    chord.one_sided = true;
    chord.dark = unlit.size() >= 5 ? Median(unlit) : s[inner];
    // b only from a point the Lambertian term lights measurably: at the
    // terminator (cos(φ − α) → 0) the noise would set it (a sinusoid at
    // 107°, its inner outside point 0.02 % of full scale above the dark
    // level at cos 0.065, drew a chord above its filled valley).
    if (c_in > 0.05 && s[inner] - chord.dark > 3.0 * mx.se[inner]) {
      chord.dark_lambert = (s[inner] - chord.dark) / c_in;
    }
  } else {
    FitChordOutside(in, s, &chord);
  }
  return chord;
}

// Each caustic peak's asymmetry: a sinusoid's caustic is an edge, the
// density rising as 1/sqrt toward it from inside and nothing beyond,
// so blurred it keeps a long inner shoulder; a sawtooth's is a delta,
// blurred symmetrically. The excess above the chord 2.5 outer
// half-widths inside the peak less that as far outside, over the
// peak's excess. A smooth trend the chord missed (a dome) adds to both
// sides alike and cancels to first order.
double CausticAsymmetry(const PickInputs& in, const Maxima& mx, const Chord& c, int peak,
                        int inward) {
  const int n = in.n;
  const std::vector<double>& s = mx.s;
  auto chord = [&](int k) { return c.At(in, k); };
  const double height = s[peak] - chord(peak);
  if (!(height > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  int w = 1;
  while (peak - inward * w >= 0 && peak - inward * w < n &&
         s[peak - inward * w] - chord(peak - inward * w) > 0.5 * height && w < n) {
    ++w;
  }
  const int d = std::max(2, static_cast<int>(std::lround(2.5 * w)));
  const int in_bin = peak + inward * d;
  const int out = peak - inward * d;
  const int middle_bin = (mx.left + mx.right) / 2;
  if (out < 0 || out >= n || !(in.profile.count[out] > 0.0) || in.AtLimbEdge(out) ||
      inward * (middle_bin - in_bin) < 0) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return ((s[in_bin] - chord(in_bin)) - (s[out] - chord(out))) / height;
}

// Stage 4 of PickPeaks: the valley's chord over the profile, for the
// comb's smoothed valley too, and whether it was fitted to both sides of
// the lobe.
struct Valley {
  std::vector<double> chord_values;
  bool chord_fitted = false;
};

// Reads the split lobe's valley into `result` (dip_sigmas, valley_ratio,
// caustic_asymmetry).
Valley ReadValley(const PickInputs& in, const Lobe& lobe, const Maxima& mx,
                  PeakPickingResult* result) {
  const std::vector<double>& s = mx.s;
  const std::vector<double>& excess = mx.excess;
  const std::vector<double>& se = mx.se;
  const int left_index = mx.left;
  const int right_index = mx.right;
  const double lower = std::min(excess[left_index], excess[right_index]);
  result->dip_sigmas = std::min(
      {Prominence(excess, left_index, lobe.lobe_lo, lobe.lobe_hi) / se[left_index],
       Prominence(excess, right_index, lobe.lobe_lo, lobe.lobe_hi) / se[right_index], 1e3});
  // Mean level over the middle half between the peaks, against the
  // lower peak: a filled lobe (sinusoid) or an empty one (sawtooth). Both
  // are measured above the chord through the profile just outside the two
  // peaks (where each has fallen to a tenth of its height, two bins on),
  // not the window's: a Lambertian term (a coloured cloth) bulges above
  // the window's chord and filled a sawtooth's valley (α = −16°, 640×480:
  // a ratio of 0.25 above the window's chord, 0.01 above this one).
  const Chord c = DrawChord(in, lobe, mx);
  auto chord = [&](int k) { return c.At(in, k); };
  Valley valley;
  valley.chord_values.assign(in.n, 0.0);
  for (int k = 0; k < in.n; ++k) valley.chord_values[k] = chord(k);
  valley.chord_fitted = c.fitted && !c.one_sided;
  const double lower_local =
      std::min(s[left_index] - chord(left_index), s[right_index] - chord(right_index));
  const double middle =
      MiddleHalfMean(left_index, right_index, [&](int k) { return s[k] - chord(k); });
  result->valley_ratio =
      lower_local > 0.0 ? std::max(middle, 0.0) / lower_local : std::max(middle, 0.0) / lower;
  const double asym_l = CausticAsymmetry(in, mx, c, left_index, +1);
  const double asym_r = CausticAsymmetry(in, mx, c, right_index, -1);
  result->caustic_asymmetry =
      std::isfinite(asym_l) && std::isfinite(asym_r) ? std::min(asym_l, asym_r) : 0.0;
  return valley;
}

// The resamples of the profile for the bootstrap errors (stages 4-6 of
// PickPeaks), drawn from one generator in the order the stages ask.
//
// The resamples draw runs of neighbouring row blocks (a circular moving
// block bootstrap), a quarter of the blocks per run. Single blocks are
// about a thread wide on the fixtures (32 blocks of 7.5 rows, a thread
// 8 px), and a plain weave's neighbouring threads are half a period apart
// (DESIGN.md §3): their profiles alternate, and every photograph holds
// them in equal shares, but a resample of single blocks does not. Over 16
// noise draws of ten sawtooth fixtures the spacings spread 0.08-0.93
// (median 0.60) times the single-block bootstrap's error, 0.08-1.36
// (median 0.77) times this one's.
struct Resampler {
  Resampler(const PickInputs& in, const Levels& levels, const Lobe& lobe)
      : profile(in.profile),
        levels(levels),
        n(in.n),
        run(std::max(1, in.profile.num_blocks / 4)),
        rng(in.options.seed),
        pick(0, in.profile.num_blocks - 1),
        radius(std::max(2.0, 0.5 * kDeg / in.bin)) {
    // A bootstrap resample is read only near the lobe: its maxima are sought
    // inside [lobe_lo, lobe_hi] or within `radius` bins of peaks there, then
    // refined from their neighbours. So it is smoothed over that stretch
    // alone, from the block means within the smoothing's reach of it.
    const int read_margin = static_cast<int>(std::ceil(std::max(radius, 3.0))) + 3;
    read_lo = std::max(0, lobe.lobe_lo - read_margin);
    read_hi = std::min(n - 1, lobe.lobe_hi + read_margin);
  }

  // A resample smoothed by sigma (bins) over [read_lo, read_hi].
  std::vector<double> Smoothed(double sigma) {
    std::vector<int> w(profile.num_blocks, 0);
    for (int k = 0; k < profile.num_blocks; k += run) {
      const int start = pick(rng);
      for (int j = 0; j < run && k + j < profile.num_blocks; ++j) {
        ++w[(start + j) % profile.num_blocks];
      }
    }
    const int reach = static_cast<int>(std::ceil(3.0 * sigma)) + 1;
    const int from = std::max(0, read_lo - reach);
    const int to = std::min(n - 1, read_hi + reach);
    std::vector<double> t = MeanFromBlocks(profile, w, from, to);
    for (int i = from; i <= to; ++i) {
      t[i] += levels.clip_lift[i];
      if (levels.filled[i] != levels.raw[i]) t[i] = levels.filled[i];  // clipped bins as above
    }
    return Smooth(t, sigma, read_lo, read_hi);
  }

  const Profile& profile;
  const Levels& levels;
  int n = 0;
  int run = 1;  // blocks per run
  std::mt19937 rng;
  std::uniform_int_distribution<int> pick;
  // Peaks of a resample are sought within this many bins of the profile's.
  double radius = 0.0;
  int read_lo = 0;
  int read_hi = 0;
};

// Stage 4 of PickPeaks: the teeth of a split lobe's comb of glints.
struct Teeth {
  // The options that find them.
  PeakPickingOptions any_height;
  // The least excess of a tooth.
  double min_tooth = 0.0;
  std::vector<int> at;
};

Teeth FindTeeth(const PeakPickingOptions& options, const Maxima& mx) {
  const std::vector<double>& excess = mx.excess;
  Teeth teeth;
  // Teeth: every prominent maximum of the lobe, however low.
  teeth.any_height = options;
  teeth.any_height.min_peak_ratio = 0.0;
  teeth.any_height.min_dip_sigmas = options.min_tooth_sigmas;
  // ... that stands at least kMinToothShare of the lower caustic peak
  // above the floor: a sinusoid's comb fills the valley to a third of the
  // peaks or more, while the noise and texture on a sawtooth's empty
  // valley (its level 0.4 % of the peaks') showed 3 maxima at 1-2 % of
  // them (800×600, 8.7°, 3,000 photons): read as a comb, so a sinusoid,
  // 3.9° long.
  teeth.min_tooth = kMinToothShare * std::min(excess[mx.left], excess[mx.right]);
  for (int k : SignificantMaxima(excess, mx.se, mx.left, mx.right, 0.0, teeth.any_height)) {
    if (k == mx.left || k == mx.right || excess[k] >= teeth.min_tooth) teeth.at.push_back(k);
  }
  return teeth;
}

// What the split reading's errors are made of (stage 6 of PickPeaks): the
// bootstrap's spacings and mirrors, and the comb's and the blur-pull
// correction's systematic allowances.
struct SplitSpread {
  std::vector<double> spacings;
  std::vector<double> mirrors;
  // Whether the comb's reading drew its own resamples.
  bool comb_bootstrapped = false;
  double comb_rad = 0.0;
  double pull_rad = 0.0;  // systematic error of the blur-pull correction
};

// The highest maximum of h (the profile smoothed over a comb) on each side
// of `mid` within the lobe, into *l and *r; whether they stand apart.
bool HeavyPeaks(const std::vector<double>& h, const Lobe& lobe, double mid, double* l, double* r) {
  *l = HighestMaximum(h, lobe.lobe_lo, static_cast<int>(std::floor(mid)));
  *r = HighestMaximum(h, static_cast<int>(std::ceil(mid)), lobe.lobe_hi);
  return *l >= 0 && *r >= 0 && *r - *l >= 3;
}

// The level between the peaks hl and hr of hs (the profile smoothed by
// sigma_h) above the valley's chord, as the share of the way from a
// sawtooth's to a sinusoid's, each smoothed alike.
double CombValleyShare(const std::vector<double>& hs, double hl, double hr, double measured,
                       double sigma_h, double mirror, const Valley& valley) {
  const std::vector<double>& chord_values = valley.chord_values;
  // The model, from the level between the smoothed peaks above the
  // chord against what each model's lobe, smoothed alike, shows there
  // (SmoothedValleyRatio): the teeth alone do not make a sinusoid.
  // Threads along the axis glinting λ/2 apart (independently rendered
  // photographs) stand between a sawtooth's caustics as a comb of
  // teeth just as they stand outside them; smoothed over the comb,
  // that level is the chord's. On those 12 sawtooths it read at most
  // 0.21 of the way from a sawtooth's level to a sinusoid's (one at
  // 0.80: lines 2.5 times its caustics' height, 5° apart), on their 24
  // sinusoids 0.69-1.23 of the way (a smoothed sinusoid's own level
  // there, 0.25-0.98 of the peaks, is met to within 30 %).
  const int il = static_cast<int>(std::lround(hl));
  const int ir = static_cast<int>(std::lround(hr));
  const double valley_h = MiddleHalfMean(il, ir, [&](int k) { return hs[k] - chord_values[k]; });
  const double low_h = std::min(hs[il] - chord_values[il], hs[ir] - chord_values[ir]);
  const double sin_level = SmoothedValleyRatio(
      ProfileModel::kSinusoid,
      InvertSmoothedSpacing(ProfileModel::kSinusoid, measured, sigma_h, mirror), sigma_h, mirror);
  const double saw_level = SmoothedValleyRatio(
      ProfileModel::kSawtooth,
      InvertSmoothedSpacing(ProfileModel::kSawtooth, measured, sigma_h, mirror), sigma_h, mirror);
  // Only against a chord fitted to both sides: drawn through a point
  // on the limb's rise (an outer caustic 6° from the limb), it lay above
  // a sinusoid's filled valley.
  return valley.chord_fitted && low_h > 0.0 && sin_level > saw_level
             ? (valley_h / low_h - saw_level) / (sin_level - saw_level)
             : 1.0;
}

// A comb of glints (three teeth or more): its peaks, model and spread,
// into *result and *spread. INVALID_ARGUMENT where the lobe stands out
// only in the trimmed window and its comb cannot tell the model.
absl::Status ReadComb(const PickInputs& in, const Levels& levels, const Lobe& lobe,
                      const Maxima& mx, const Valley& valley, const Teeth& teeth,
                      Resampler* resampler, PeakPickingResult* result, SplitSpread* spread) {
  const double bin = in.bin;
  const std::vector<double>& excess = mx.excess;
  // A comb of glints: one photograph samples only the weave phases of
  // the threads in view (DESIGN.md §3). Smooth over about half a thread
  // period (the median tooth spacing), read the two maxima there, and
  // undo the inward pull of that smoothing with the sinusoid's own lobe
  // shape (SmoothedSinusoidSpacing). What smoothing cannot restore is
  // counted as half a tooth spacing per side: with few threads in view
  // one side's caustic glints can be missing altogether (seen on coarse
  // gauze renders: errors up to a tooth spacing, ~4 deg).
  std::vector<int> sorted = teeth.at;
  std::sort(sorted.begin(), sorted.end());
  std::vector<double> gaps;
  for (std::size_t k = 1; k < sorted.size(); ++k) gaps.push_back((sorted[k] - sorted[k - 1]) * bin);
  const double gap = Median(gaps);
  const double sigma_h = std::clamp(gap, 0.5 * kDeg, 3.0 * kDeg);
  const double mid = 0.5 * (mx.left + mx.right);
  double hl = 0;
  double hr = 0;
  const std::vector<double> hs = Smooth(levels.filled, sigma_h / bin);
  if (!HeavyPeaks(hs, lobe, mid, &hl, &hr)) {
    // The smoothed peaks merge: keep the outermost teeth, whose offset
    // from the caustic can reach a tooth spacing.
    spread->comb_rad = 0.75 * gap;
    result->comb_gap_rad = gap;
    result->warnings.push_back(
        absl::StrFormat("the lobe is a comb of glints (%d maxima, median spacing %.2f deg) "
                        "too narrow to smooth: the outermost glints were taken as the "
                        "peaks, half a tooth spacing counted per side in the errors",
                        static_cast<int>(teeth.at.size()), gap / kDeg));
    return absl::OkStatus();
  }
  const double mirror = 0.5 * (in.AzimuthOf(hl) + in.AzimuthOf(hr));
  const double measured = in.SpacingOf(in.AzimuthOf(hl), in.AzimuthOf(hr));
  const double valley_share = CombValleyShare(hs, hl, hr, measured, sigma_h, mirror, valley);
  // The scatter's own glint lines outside the lobe (threads along the
  // axis glinting λ/2 apart) can fill a sawtooth's valley or, above a
  // chord drawn under their crests, empty a sinusoid's. Where the lobe
  // stood out only in the trimmed window, independently rendered
  // sinusoids under such lines read 0.20 and 0.31 of the way (at 110°),
  // a sawtooth 0.19 (at 90°), smooth-scatter sinusoids 1.04-1.12: an
  // ambiguous or line-ridden share is refused, not guessed.
  int outer_teeth = 0;
  if (lobe.trimmed) {
    for (int k : SignificantMaxima(excess, mx.se, lobe.lo, lobe.hi, 0.0, teeth.any_height)) {
      if ((k < lobe.lobe_lo || k > lobe.lobe_hi) && excess[k] >= teeth.min_tooth) ++outer_teeth;
    }
  }
  if (lobe.trimmed &&
      (std::fabs(valley_share - kCombSinusoidShare) < kCombTrimmedAmbiguity ||
       (outer_teeth >= 2 && valley_share < kCombSinusoidShare + kCombTrimmedAmbiguity))) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the specular lobe stands out only from a baseline drawn away from the "
        "terminator and the limb (a strong grazing scatter); its comb of glints (%d "
        "maxima, median spacing %.2f deg) reads %.2f of the way from a sawtooth's level "
        "between the peaks to a sinusoid's, and %d glint lines of the scatter stand "
        "beside the lobe, so the profile cannot be told (they can fill or empty that "
        "level); photograph at a smaller phase angle",
        static_cast<int>(teeth.at.size()), gap / kDeg, valley_share, outer_teeth));
  }
  result->model =
      valley_share >= kCombSinusoidShare ? ProfileModel::kSinusoid : ProfileModel::kSawtooth;
  const double m = InvertSmoothedSpacing(result->model, measured, sigma_h, mirror);
  result->spacing_rad = PeakSpacingRad(m);
  result->mirror_rad = mirror;
  result->left_peak_rad = mirror - 0.5 * result->spacing_rad;
  result->right_peak_rad = mirror + 0.5 * result->spacing_rad;
  // Gain of the correction, for propagating the measured spread.
  const double delta = 0.1 * kDeg;
  const double gain_h =
      (PeakSpacingRad(InvertSmoothedSpacing(result->model, measured + delta, sigma_h, mirror)) -
       result->spacing_rad) / delta;
  spread->comb_bootstrapped = true;
  for (int r = 0; r < in.options.bootstrap_samples; ++r) {
    double bl = 0;
    double br = 0;
    if (!HeavyPeaks(resampler->Smoothed(sigma_h / bin), lobe, mid, &bl, &br)) continue;
    spread->spacings.push_back(gain_h * in.SpacingOf(in.AzimuthOf(bl), in.AzimuthOf(br)));
    spread->mirrors.push_back(0.5 * (in.AzimuthOf(bl) + in.AzimuthOf(br)));
  }
  spread->comb_rad = 0.5 * gap;
  result->comb_gap_rad = gap;
  result->smoothing_rad = sigma_h;
  result->warnings.push_back(absl::StrFormat(
      "the lobe is a comb of glints (%d maxima, median spacing %.2f deg): "
      "peaks read after smoothing by %.2f deg and corrected for that "
      "smoothing with the %s lobe shape (%s); the comb's residue is "
      "counted in the standard errors",
      static_cast<int>(teeth.at.size()), gap / kDeg, sigma_h / kDeg,
      result->model == ProfileModel::kSinusoid ? "sinusoid's" : "sawtooth's",
      valley.chord_fitted ? absl::StrFormat("its level between the peaks is %.2f of the way "
                                            "from a sawtooth's to a sinusoid's",
                                            valley_share)
                          : std::string("no chord fitted on both sides of the lobe to judge "
                                        "the level between the peaks by: the teeth decide")));
  return absl::OkStatus();
}

// A smooth sinusoid lobe (split, no comb): undo the blur's inward pull on
// the caustic maxima from the lobe's own shape, the outer half-maximum
// points against the maxima (UnpullSinusoidSpacing). Updates *result and
// scales *spacings; returns the correction's systematic error.
double UnpullSmoothSinusoid(const PickInputs& in, const Lobe& lobe, const Maxima& mx,
                            PeakPickingResult* result, std::vector<double>* spacings) {
  const int n = in.n;
  const std::vector<double>& excess = mx.excess;
  const int lobe_lo = lobe.lobe_lo;
  const int lobe_hi = lobe.lobe_hi;
  const int margin = lobe.margin;
  double pull_rad = 0.0;
  auto outer_half = [&](int from, int step) {
    const double level = 0.5 * excess[from];
    for (int i = from; i + step >= lobe_lo - margin && i + step <= lobe_hi + margin &&
                       i + step >= 0 && i + step < n;
         i += step) {
      if (excess[i + step] <= level) {
        const double t = (excess[i] - level) / (excess[i] - excess[i + step]);
        return i + step * t;
      }
    }
    return std::numeric_limits<double>::quiet_NaN();
  };
  const double lh = outer_half(mx.left, -1);
  const double rh = outer_half(mx.right, +1);
  if (!std::isfinite(lh) || !std::isfinite(rh)) return pull_rad;
  const double width = in.SpacingOf(in.AzimuthOf(lh), in.AzimuthOf(rh));
  const double a = UnpullSinusoidSpacing(result->spacing_rad, width);
  const double corrected = 2.0 * a;
  if (std::isfinite(a) && corrected >= 2.0 * result->spacing_rad) {
    // The split barely clears the blur: a correction this large rests
    // on the table's far end. Keep the spacing read, and count the
    // whole correction in its error.
    pull_rad = corrected - result->spacing_rad;
    result->warnings.push_back(absl::StrFormat(
        "the split barely clears the blur: the peaks stand %.2f deg apart, but the "
        "lobe's width allows up to %.2f deg; the difference is counted in the error",
        result->spacing_rad / kDeg, corrected / kDeg));
  } else if (std::isfinite(a) && corrected > result->spacing_rad) {
    const double gain = corrected / result->spacing_rad;
    for (double& sp : *spacings) sp *= gain;
    // The whole correction again for what the table leaves out (the
    // arctangent, the lobe's geometric factor, a non-Gaussian blur):
    // at α = 108° with a 1 px lens blur (800×600, m 0.09) the table
    // corrected 7.87° to 8.67° where the truth was 9.75°, and a
    // quarter of the correction made that 4.3 stated errors.
    pull_rad = corrected - result->spacing_rad;
    result->warnings.push_back(absl::StrFormat(
        "the caustic peaks stand %.2f deg apart; the lobe's width says blur pulled them "
        "inward, and the spacing read is %.2f deg",
        result->spacing_rad / kDeg, corrected / kDeg));
    result->spacing_rad = corrected;
    result->left_peak_rad = result->mirror_rad - 0.5 * corrected;
    result->right_peak_rad = result->mirror_rad + 0.5 * corrected;
  }
  return pull_rad;
}

// Stage 6 of PickPeaks for a split lobe: the bootstrap's scatter and the
// systematic allowances, combined into the stated errors.
void SplitErrors(const PickInputs& in, const SplitSpread& spread, PeakPickingResult* result) {
  const double comb_rad = spread.comb_rad;
  const double pull_rad = spread.pull_rad;
  const double q_left = in.QuantisationAt(result->left_peak_rad);
  const double q_right = in.QuantisationAt(result->right_peak_rad);
  const double q2 = q_left * q_left + q_right * q_right;
  // A real sawtooth's shape, which the model leaves out
  // (kSawtoothShapeFloor), is common to the sample.
  const double shape_rad =
      result->model == ProfileModel::kSawtooth ? kSawtoothShapeFloor * result->spacing_rad : 0.0;
  result->spacing_systematic_rad =
      std::sqrt(q2 + 2.0 * comb_rad * comb_rad + pull_rad * pull_rad + shape_rad * shape_rad);
  result->mirror_systematic_rad = std::sqrt(0.25 * q2 + 0.5 * comb_rad * comb_rad);
  result->spacing_stderr_rad = std::hypot(Stddev(spread.spacings), result->spacing_systematic_rad);
  result->mirror_stderr_rad = std::hypot(Stddev(spread.mirrors), result->mirror_systematic_rad);
  result->max_slope = std::tan(0.5 * result->spacing_rad);
  const double sec = 1.0 / std::cos(0.5 * result->spacing_rad);
  result->max_slope_stderr = 0.5 * sec * sec * result->spacing_stderr_rad;
  result->max_slope_systematic = 0.5 * sec * sec * result->spacing_systematic_rad;
  result->spacing_common_rad = std::hypot(pull_rad, shape_rad);
  result->max_slope_common = 0.5 * sec * sec * result->spacing_common_rad;
}

// Stages 4 and 6 of PickPeaks for a split lobe: the valley, the comb of
// glints, the model, the peaks, and their errors, into *result.
absl::Status ReadSplit(const PickInputs& in, const Levels& levels, const Lobe& lobe,
                       const Maxima& mx, PeakPickingResult* result) {
  const Valley valley = ReadValley(in, lobe, mx, result);
  Resampler resampler(in, levels, lobe);
  const Teeth teeth = FindTeeth(in.options, mx);
  const double left = RefineMaximum(mx.s, mx.left);
  const double right = RefineMaximum(mx.s, mx.right);
  result->split_resolved = true;
  // A sawtooth mirrors only at ±arctan m: glints between the peaks (a
  // comb of teeth) or a filled valley mean a smooth slope distribution.
  // ... or both caustics with a sinusoid's inner shoulder: a steep fine
  // sinusoid (m = 0.70, 2.4 px per period: no comb), its caustics sharp,
  // fills its valley to 0.095 of the peaks only, but its
  // peaks' asymmetry reads 0.36-0.40; over 249 random sawtooth scenes the
  // lower of the two reads at most 0.045, over the fixtures' at most 0.03.
  result->model = teeth.at.size() < 3 && result->valley_ratio < in.options.sawtooth_valley_ratio &&
                          result->caustic_asymmetry < kSinusoidShoulder
                      ? ProfileModel::kSawtooth
                      : ProfileModel::kSinusoid;
  result->left_peak_rad = in.AzimuthOf(left);
  result->right_peak_rad = in.AzimuthOf(right);
  result->spacing_rad = in.SpacingOf(result->left_peak_rad, result->right_peak_rad);
  result->mirror_rad = 0.5 * (result->left_peak_rad + result->right_peak_rad);
  SplitSpread spread;
  if (teeth.at.size() >= 3) {
    if (absl::Status comb =
            ReadComb(in, levels, lobe, mx, valley, teeth, &resampler, result, &spread);
        !comb.ok()) {
      return comb;
    }
  }
  if (!spread.comb_bootstrapped) {
    // The spread of the peaks read as above over resamples of the row
    // blocks (unless the comb was read after heavier smoothing, which has
    // its own).
    for (int r = 0; r < in.options.bootstrap_samples; ++r) {
      const std::vector<double> t = resampler.Smoothed(mx.light_bins);
      const double l = in.AzimuthOf(NearestPeak(t, left, resampler.radius));
      const double rr = in.AzimuthOf(NearestPeak(t, right, resampler.radius));
      spread.spacings.push_back(in.SpacingOf(l, rr));
      spread.mirrors.push_back(0.5 * (l + rr));
    }
  }
  if (teeth.at.size() < 3 && result->model == ProfileModel::kSinusoid) {
    spread.pull_rad = UnpullSmoothSinusoid(in, lobe, mx, result, &spread.spacings);
  }
  SplitErrors(in, spread, result);
  result->caveat =
      "peak picking: blur pulls each caustic peak inward, so the spacing "
      "and max slope are biased low by up to about the peak width; "
      "SINUSOID vs SAWTOOTH is judged from the glints and the level between "
      "the peaks only (no model was fitted)";
  return absl::OkStatus();
}

// Stage 5 of PickPeaks: one peak, read as a smooth glossy lobe, with its
// errors, into *result. INVALID_ARGUMENT where it is far too wide for one.
absl::Status ReadSinglePeak(const PickInputs& in, const Levels& levels, const Lobe& lobe,
                            const Maxima& mx, PeakPickingResult* result) {
  const std::vector<double>& excess = mx.excess;
  const int top_index = mx.top;
  result->dip_sigmas = 0.0;
  Resampler resampler(in, levels, lobe);
  const double peak = RefineMaximum(mx.s, top_index);
  result->model = ProfileModel::kSmooth;
  result->left_peak_rad = result->right_peak_rad = result->mirror_rad = in.AzimuthOf(peak);
  // Full width at half maximum above the window's floor.
  const double half_level = 0.5 * excess[top_index];
  int l = top_index;
  while (l > lobe.lo && excess[l] > half_level) --l;
  int r = top_index;
  while (r < lobe.hi && excess[r] > half_level) ++r;
  result->single_peak_fwhm_rad = (r - l) * in.bin;
  // A smooth glossy lobe is narrow (DESIGN.md §3): 1-6.5° wide at half
  // height on weavefit's own smooth renders, 5-15° on independently
  // rendered ones with 2-6° of microfacet roughness. Far wider, the one
  // peak is the body's diffuse dome, and the specular lobe, if any, is
  // lost in it (a sinusoid 64° wide at 300 photons
  // under diffuse 0.12, its glints below the noise, read as a 49° SMOOTH).
  if (result->single_peak_fwhm_rad > kMaxSinglePeakFwhmDeg * kDeg) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "no specular lobe stands out: the one peak near half the phase angle is %.1f deg "
        "wide at half its height, far wider than a smooth glossy lobe, so it is the "
        "body's diffuse light; expose for the specular glints (or check the phase angle)",
        result->single_peak_fwhm_rad / kDeg));
  }
  std::vector<double> mirrors;
  for (int k = 0; k < in.options.bootstrap_samples; ++k) {
    mirrors.push_back(in.AzimuthOf(NearestPeak(resampler.Smoothed(mx.light_bins), peak, 3.0)));
  }
  result->mirror_systematic_rad = in.QuantisationAt(result->mirror_rad);
  result->mirror_stderr_rad = std::hypot(Stddev(mirrors), result->mirror_systematic_rad);
  result->warnings.push_back(
      absl::StrFormat("a single specular peak (FWHM %.2f deg): any split narrower than "
                      "about that is not resolved, so peak spacing and max slope are "
                      "reported unresolved",
                      result->single_peak_fwhm_rad / kDeg));
  return absl::OkStatus();
}

}  // namespace

absl::Status PeakPickingOptions::Validate() const {
  if (!(smoothing_deg >= 0.0 && smoothing_deg <= 5.0)) {
    return absl::InvalidArgumentError("smoothing_deg must be in [0, 5]");
  }
  if (!(search_half_width_deg > 1.0 && search_half_width_deg <= 80.0)) {
    return absl::InvalidArgumentError("search_half_width_deg must be in (1, 80]");
  }
  if (!(max_clipped_lobe_share > 0.0 && max_clipped_lobe_share <= 1.0)) {
    return absl::InvalidArgumentError("max_clipped_lobe_share must be in (0, 1]");
  }
  if (!(lobe_smoothing_deg >= smoothing_deg && lobe_smoothing_deg <= 10.0)) {
    return absl::InvalidArgumentError("lobe_smoothing_deg must be in [smoothing_deg, 10]");
  }
  if (!(lobe_fraction > 0.0 && lobe_fraction < 1.0)) {
    return absl::InvalidArgumentError("lobe_fraction must be in (0, 1)");
  }
  if (!(min_dip_sigmas > 0.0)) return absl::InvalidArgumentError("min_dip_sigmas must be > 0");
  if (!(min_tooth_sigmas > 0.0)) return absl::InvalidArgumentError("min_tooth_sigmas must be > 0");
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
  const PickInputs in{profile, phase_angle_rad, projection, options, n, profile.bin_width_rad,
                      profile.azimuth_rad.front()};
  absl::StatusOr<Levels> levels = ReadLevels(in);
  if (!levels.ok()) return levels.status();
  absl::StatusOr<Lobe> lobe = IsolateLobe(in, *levels);
  if (!lobe.ok()) return lobe.status();
  absl::StatusOr<Maxima> maxima = FindMaxima(in, *levels, *lobe);
  if (!maxima.ok()) return maxima.status();

  PeakPickingResult result;
  result.clipped_lobe_share = lobe->clipped_share;
  result.smoothing_rad = maxima->light_deg * kDeg;
  if (maxima->light_deg > options.smoothing_deg) {
    result.warnings.push_back(absl::StrFormat(
        "noisy profile: peaks located after smoothing by %.2f deg", maxima->light_deg));
  }
  if (levels->clipped_bins > 0) {
    result.warnings.push_back(absl::StrFormat(
        "%d azimuth bins are more than 5%% saturated: their level was "
        "raised to their neighbours' maximum", levels->clipped_bins));
  }
  const bool split = maxima->right - maxima->left >= kMinSplitBins;
  // The window cut to the scatter's lawful range (FitBaseline) also cuts
  // off what lies within 10° of the terminator and of the limb, where a
  // caustic may stand: one peak there is no evidence of a smooth lobe. A
  // sawtooth at −115°, its inner caustic 1° inside the terminator and
  // its outer beyond the limb, read in the cut window as the diffuse dome's
  // single peak, SMOOTH.
  if (lobe->trimmed && !split) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the specular lobe is not isolated: it stands out only from a baseline drawn "
        "%.0f deg or more from the terminator and the limb (a strong grazing scatter or a "
        "diffuse dome), and there it is one peak, which a caustic cut off beside the "
        "terminator or the limb would also leave; photograph at a smaller phase angle",
        kGrazingMarginDeg + options.lobe_smoothing_deg));
  }
  const absl::Status read = split ? ReadSplit(in, *levels, *lobe, *maxima, &result)
                                  : ReadSinglePeak(in, *levels, *lobe, *maxima, &result);
  if (!read.ok()) return read;
  return result;
}

}  // namespace weavefit
