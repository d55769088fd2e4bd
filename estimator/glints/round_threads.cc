#include "estimator/glints/round_threads.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "absl/status/status.h"

namespace weavefit {
namespace {

// The lattice's spectrum weighs each sample by its Hann weight squared (its
// power), every row alike: the mean of cos(μ − φ) under that weight.
double MeanCos(const std::vector<ArcSignals>& arcs, double mirror_rad) {
  double sum = 0.0;
  double weight = 0.0;
  for (const ArcSignals& a : arcs) {
    const double rows = static_cast<double>(a.rows.size());
    for (int k = 0; k < a.num_samples; ++k) {
      const double hann = HannWeight(k, a.num_samples);
      const double w = rows * hann * hann;
      sum += w * std::cos(mirror_rad - (a.first_azimuth_rad + k * a.step_rad));
      weight += w;
    }
  }
  return weight > 0.0 ? sum / weight : 0.0;
}

// The largest ρ, in pitches (ThreadPitchFromGlints).
constexpr double kMaxRadiusPitches = 0.5;

// The weighted least-squares fit of the local pitches, p_i = a − b·c_i (a
// the threads' pitch, b = a·κ, c_i = cos(μ − φ_i)), with the prior on b as
// one more observation, over the stretches `use` marks.
struct LineFit {
  double a = 0.0;
  double b = 0.0;
  double b_var = 0.0;
  bool ok = false;
};

LineFit FitLocalPitches(const std::vector<LocalPitch>& local, const std::vector<double>& cosines,
                        const std::vector<double>& weights, const std::vector<bool>& use,
                        double b_prior, double b_sd) {
  double aa = 0.0, ab = 0.0, bb = 1.0 / (b_sd * b_sd), ya = 0.0, yb = b_prior / (b_sd * b_sd);
  for (std::size_t i = 0; i < local.size(); ++i) {
    if (!use[i]) continue;
    const double w = weights[i];
    const double c = cosines[i];
    aa += w;
    ab -= w * c;
    bb += w * c * c;
    ya += w * local[i].pitch_mm;
    yb -= w * c * local[i].pitch_mm;
  }
  LineFit f;
  const double det = aa * bb - ab * ab;
  if (!(aa > 0.0) || !(det > 0.0)) return f;
  f.a = (ya * bb - ab * yb) / det;
  f.b = (aa * yb - ab * ya) / det;
  f.b_var = aa / det;
  f.ok = f.a > 0.0;
  return f;
}

// A stretch whose pitch lies further than this many of its errors from the
// fit is not the lattice's lines sliding over round threads (a stretch
// that followed other structure): it is left out and the fit redone.
constexpr double kLocalOutlier = 3.0;

}  // namespace

absl::Status RoundThreadOptions::Validate() const {
  if (!(radius_pitches >= 0.0) || !(radius_pitches_sd > 0.0) || !(local_scatter >= 0.0)) {
    return absl::InvalidArgumentError(
        "round thread options: radius_pitches and local_scatter must not be negative, "
        "radius_pitches_sd must be positive");
  }
  return absl::OkStatus();
}

ThreadPitch ThreadPitchFromGlints(const AxialPitch& apparent, const std::vector<ArcSignals>& arcs,
                                  double mirror_rad, const RoundThreadOptions& options) {
  ThreadPitch t;
  const double p = apparent.pitch_mm;
  const double radius_mm = arcs.empty() ? 0.0 : arcs[0].radius_mm;
  if (!(p > 0.0) || !(radius_mm > 0.0)) return t;
  const std::vector<LocalPitch>& local = apparent.local;
  std::vector<double> cosines(local.size());
  std::vector<double> weights(local.size());
  const double scatter = options.local_scatter * p;
  for (std::size_t i = 0; i < local.size(); ++i) {
    cosines[i] = std::cos(mirror_rad - local[i].azimuth_rad);
    weights[i] = 1.0 / std::max(local[i].stderr_mm * local[i].stderr_mm + scatter * scatter,
                                1e-12 * p * p);
  }
  const double b_prior = p * p * options.radius_pitches / radius_mm;
  const double b_sd = p * p * options.radius_pitches_sd / radius_mm;
  std::vector<bool> use(local.size(), true);
  LineFit fit = FitLocalPitches(local, cosines, weights, use, b_prior, b_sd);
  // The worst outlier out, while one stands beyond kLocalOutlier errors.
  while (fit.ok) {
    int worst = -1;
    double worst_z = kLocalOutlier;
    for (std::size_t i = 0; i < local.size(); ++i) {
      const double z = std::fabs(local[i].pitch_mm - (fit.a - fit.b * cosines[i])) *
                       std::sqrt(weights[i]);
      if (use[i] && z > worst_z) {
        worst = static_cast<int>(i);
        worst_z = z;
      }
    }
    if (worst < 0) break;
    use[worst] = false;
    fit = FitLocalPitches(local, cosines, weights, use, b_prior, b_sd);
  }
  t.stretches = static_cast<int>(std::count(use.begin(), use.end(), true));
  t.mean_cos = MeanCos(arcs, mirror_rad);
  double kappa = options.radius_pitches * p / radius_mm;
  double kappa_sd = options.radius_pitches_sd * p / radius_mm;
  if (fit.ok) {
    // κ = b/a of the fit, bounded: a glint on a convex thread trails the
    // mirror azimuth (κ ≥ 0), and cannot leave its thread: ρ·|sin(μ − φ)|
    // stays within the thread's half-width, at most half a pitch, over the
    // 60-80° from μ a lattice is read at, so ρ ≤ p/2. (The fit's intercept
    // is not taken for the pitch: the lattice's own reading is, from all its
    // samples.)
    kappa = std::clamp(fit.b / fit.a, 0.0, kMaxRadiusPitches * p / radius_mm);
    kappa_sd = std::sqrt(fit.b_var) / fit.a;
  }
  // The lattice's spectrum weighs the local pitches' frequencies,
  // (1 + κ·cos(μ − φ))/p, by its samples' power: p = P·(1 + κ·mean cos).
  const double stretch = 1.0 + kappa * t.mean_cos;
  t.pitch_mm = p * stretch;
  t.model_stderr_mm = p * t.mean_cos * kappa_sd;
  t.pitch_stderr_mm = std::hypot(apparent.pitch_stderr_mm * stretch, t.model_stderr_mm);
  t.glint_radius_mm = kappa * radius_mm;
  t.glint_radius_stderr_mm = kappa_sd * radius_mm;
  return t;
}

}  // namespace weavefit
