#include "estimator/cylinder/terminator.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Dense>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "estimator/stats/golden_section.h"
#include "estimator/stats/median.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kBinPx = 0.25;     // profile bins across the terminator
constexpr int kSubSamples = 8;      // per pixel width, for its footprint
// The fit window: this far into the dark side of the terminator, and toward
// the light at most kLitWindowMaxRad and not beyond the mirror azimuth,
// ending a pixel short of the first glints, and at least kMinLitWindowPx
// past the edge.
constexpr double kDarkWindowRad = 15.0 * kDeg;
constexpr double kLitWindowMaxRad = 20.0 * kDeg;
constexpr double kGlintRoughness = 0.15;
constexpr double kMinLitWindowPx = 2.0;
// The window by the lit limb (see InferDarkLimb) stops this far short of the
// limb, where the limb's sub-pixel position and 1/cos φ matter most, and is
// used only when at least kMinLimbWindowPx wide.
constexpr double kLimbGapPx = 3.0;
constexpr double kMinLimbWindowPx = 3.0;
constexpr double kGlintSpreadFactor = 3.0;
// Acceptance: the lit term must rise this many noise sigmas of a bin across
// the window, and the fit's reduced chi-square stay below this.
constexpr double kMinRiseSigmas = 10.0;
constexpr double kMaxReducedChi2 = 6.0;
constexpr double kSharpRadiusPx = 0.25;
constexpr double kSharpRadiusFraction = 2e-3;
constexpr double kMinStepChi2 = 9.0;  // least chi-square gain for a second lit term

// One bin of the tilt-corrected profile across the terminator.
struct Bin {
  double t = 0.0;       // mean perpendicular distance from the lit limb, px (< 0 inside)
  double mean = 0.0;
  double weight = 0.0;  // 1 / variance of the mean
  bool near_limb = false;  // in the window by the lit limb, which has its own offset
};

struct Fit {
  double chi2 = std::numeric_limits<double>::infinity();
  double rise = 0.0;  // model's lit contribution at the lit end of the window
};

// The two lit terms at perpendicular distance t from the lit limb, for a
// cylinder of radius r: averaged over the pixel's width (`sub` samples).
std::array<double, 2> LitTerms(double t, double r, int side, double alpha,
                               const Projection& projection, int sub) {
  std::array<double, 2> terms{0.0, 0.0};
  for (int k = 0; k < sub; ++k) {
    const double tk = t + (k + 0.5) / sub - 0.5;
    const double u = side * (1.0 + tk / r);
    const double phi = AzimuthFromOffset(u, projection);
    if (!std::isfinite(phi)) continue;  // beyond a limb: background only
    const double lit = std::cos(phi - alpha);
    if (lit <= 0.0) continue;
    terms[0] += lit;
    terms[1] += std::cos(alpha / 2.0) / std::max(std::cos(phi), 0.05);
  }
  terms[0] /= sub;
  terms[1] /= sub;
  return terms;
}

using Terms = std::vector<std::array<double, 2>>;

// The lit terms of every bin at radius r.
Terms TermsAt(const std::vector<Bin>& bins, double r, int side, double alpha,
              const Projection& projection, int sub) {
  Terms terms(bins.size());
  for (std::size_t i = 0; i < bins.size(); ++i) {
    terms[i] = LitTerms(bins[i].t, r, side, alpha, projection, sub);
  }
  return terms;
}

// Weighted least squares of bins ≈ b + D·lambert + S·scatter with D, S ≥ 0,
// the terms in `terms_mask` only (bit 0 Lambertian, bit 1 scatter), from
// the bins' lit terms at one radius; bins by the lit limb have an offset of
// their own (an uneven ambient or vignetting must not pass for a term). An
// infeasible fit (a negative term) scores infinity.
Fit FitTerms(const std::vector<Bin>& bins, const Terms& all_terms, int terms_mask) {
  std::vector<int> cols;  // which lit terms, after the offsets
  for (int j = 0; j < 2; ++j) {
    if (terms_mask & (1 << j)) cols.push_back(j);
  }
  const bool limb = std::any_of(bins.begin(), bins.end(), [](const Bin& b) { return b.near_limb; });
  const int offsets = limb ? 2 : 1;
  const int n = static_cast<int>(bins.size());
  const int p = offsets + static_cast<int>(cols.size());
  Eigen::MatrixXd design = Eigen::MatrixXd::Zero(n, p);
  Eigen::VectorXd values(n);
  for (int i = 0; i < n; ++i) {
    const std::array<double, 2>& terms = all_terms[i];
    const double w = std::sqrt(bins[i].weight);
    design(i, limb && bins[i].near_limb ? 1 : 0) = w;
    for (std::size_t j = 0; j < cols.size(); ++j) design(i, offsets + j) = w * terms[cols[j]];
    values(i) = w * bins[i].mean;
  }
  const Eigen::VectorXd x = design.colPivHouseholderQr().solve(values);
  const int q = p - offsets;
  Fit fit;
  if (!x.allFinite() || (x.tail(q).array() < 0.0).any()) return fit;
  const Eigen::VectorXd residual = values - design * x;
  fit.chi2 = residual.squaredNorm();
  for (int i = 0; i < n; ++i) {
    if (bins[i].near_limb) continue;
    const double lit = (design.row(i).tail(q) * x.tail(q)).value() / std::sqrt(bins[i].weight);
    fit.rise = std::max(fit.rise, lit);
  }
  return fit;
}

// Pixel-wide steps of a profile: their mean position, mean and its noise.
struct PixelSteps {
  std::vector<double> t, mean, sigma;
  std::vector<double> spread;  // standard deviation of the step's samples
};

// A profile across the limb-parallel lines t = const (t: perpendicular
// distance from the lit limb, px, < 0 inside) in kBinPx bins, over the rows
// between the edges' top_row and bottom_row.
struct TiltedProfile {
  std::vector<double> sum, sum_sq, sum_t;
  std::vector<int> count;

  int size() const { return static_cast<int>(count.size()); }

  PixelSteps PixelMeans(double pixel_noise) const {
    const int per_px = static_cast<int>(std::lround(1.0 / kBinPx));
    PixelSteps steps;
    for (int b0 = 0; b0 + per_px <= size(); b0 += per_px) {
      double s_sum = 0.0;
      double sq_sum = 0.0;
      double t_sum = 0.0;
      int n = 0;
      for (int b = b0; b < b0 + per_px; ++b) {
        s_sum += sum[b];
        sq_sum += sum_sq[b];
        t_sum += sum_t[b];
        n += count[b];
      }
      if (n == 0) continue;
      const double mean = s_sum / n;
      steps.mean.push_back(mean);
      steps.spread.push_back(std::sqrt(std::max(0.0, sq_sum / n - mean * mean)));
      steps.t.push_back(t_sum / n);
      steps.sigma.push_back(pixel_noise / std::sqrt(static_cast<double>(n)));
    }
    return steps;
  }

  // The bins with t_from ≤ t ≤ t_to and at least 3 samples, as fit bins
  // weighted by their spread over the rows (at least the pixel noise).
  void AppendBins(double pixel_noise, double t_from, double t_to, bool near_limb,
                  std::vector<Bin>* bins) const {
    for (int b = 0; b < size(); ++b) {
      if (count[b] < 3) continue;
      const double t = sum_t[b] / count[b];
      if (t < t_from || t > t_to) continue;
      const double mean = sum[b] / count[b];
      const double var = std::max(sum_sq[b] / count[b] - mean * mean, pixel_noise * pixel_noise);
      bins->push_back({t, mean, (count[b] - 1) / var, near_limb});
    }
  }
};

TiltedProfile AccumulateProfile(const Image& luminance, const CylinderGeometry& edges, int side,
                                double t_lo, double t_hi) {
  const double cos_tilt = std::cos(edges.axis_angle_rad);
  const double half = edges.radius_px / cos_tilt;
  TiltedProfile p;
  const int nbins = std::max(0, static_cast<int>(std::ceil((t_hi - t_lo) / kBinPx)));
  p.sum.assign(nbins, 0.0);
  p.sum_sq.assign(nbins, 0.0);
  p.sum_t.assign(nbins, 0.0);
  p.count.assign(nbins, 0);
  for (int y = std::max(edges.top_row, 0); y <= std::min(edges.bottom_row, luminance.height - 1); ++y) {
    const double lit_x = edges.AxisColumn(y) + side * half;
    // t = side·(x − lit_x)·cos tilt, so x = lit_x + side·t / cos tilt.
    const double xa = lit_x + side * t_lo / cos_tilt;
    const double xb = lit_x + side * t_hi / cos_tilt;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min(xa, xb))));
    const int x1 = std::min(luminance.width - 1, static_cast<int>(std::ceil(std::max(xa, xb))));
    for (int x = x0; x <= x1; ++x) {
      const double t = side * (x - lit_x) * cos_tilt;
      const int b = static_cast<int>(std::floor((t - t_lo) / kBinPx));
      if (b < 0 || b >= nbins) continue;
      const double v = luminance.At(x, y);
      p.sum[b] += v;
      p.sum_sq[b] += v * v;
      p.sum_t[b] += t;
      ++p.count[b];
    }
  }
  return p;
}

// Glints: where a profile, in pixel-wide steps, turns jagged. Shading
// (Lambertian, grazing scatter) changes smoothly across a few pixels; the
// comb of glints of the specular lobe does not. A step is jagged when its
// second difference exceeds kGlintRoughness of its level above the
// background and 6 noise sigmas. Walking forward (increasing t, from t_from)
// or backward, this returns the first of the first two jagged steps in a
// row, or −1.
int FirstJaggedStep(const PixelSteps& steps, double background_level, bool forward,
                    double t_from) {
  const int n = static_cast<int>(steps.mean.size());
  int run = 0;
  for (int i = 1; i + 1 < n; ++i) {
    const int k = forward ? i : n - 1 - i;
    if (forward && steps.t[k] < t_from) continue;
    const double second =
        std::fabs(steps.mean[k] - 0.5 * (steps.mean[k - 1] + steps.mean[k + 1]));
    const double level = std::fabs(steps.mean[k] - background_level);
    const bool jagged = second > std::max(6.0 * steps.sigma[k], kGlintRoughness * level);
    run = jagged ? run + 1 : 0;
    if (run == 2) return forward ? k - 1 : k + 1;
  }
  return -1;
}

// Walking from the lit limb inward (decreasing t), the first of the first
// two steps in a row whose spread over the rows exceeds kGlintSpreadFactor
// times the largest spread of the steps before them, or −1. The smooth terms
// by the limb (grazing scatter, Lambertian) spread over the rows no more
// than their level and the noise allow, and both fall or hold inward; the
// comb of glints at the lobe's outer edge spreads many times more (bright
// glints in a few rows), even where its mean over the rows is smooth.
int FirstSpreadStepFromLimb(const PixelSteps& steps) {
  const int n = static_cast<int>(steps.spread.size());
  double largest = 0.0;
  int run = 0;
  for (int k = n - 1; k >= 0; --k) {
    const bool wide = k < n - 1 && steps.spread[k] > kGlintSpreadFactor * largest;
    run = wide ? run + 1 : 0;
    if (run == 2) return k + 1;
    if (!wide) largest = std::max(largest, steps.spread[k]);
  }
  return -1;
}

}  // namespace

absl::StatusOr<CylinderGeometry> InferDarkLimb(const Image& luminance,
                                               const CylinderGeometry& edges,
                                               double phase_angle_rad,
                                               const Projection& projection,
                                               const BackgroundLevel& background) {
  const double alpha = phase_angle_rad;
  if (!(std::fabs(alpha) > 10.0 * kDeg && std::fabs(alpha) < 170.0 * kDeg)) {
    return absl::InvalidArgumentError(
        "no terminator to infer a dark limb from: the phase angle must lie between 10 and 170 deg");
  }
  if (luminance.channels != 1 || !(edges.radius_px > 0.0)) {
    return absl::InvalidArgumentError("InferDarkLimb needs a one-channel image and two edges");
  }
  const int side = alpha > 0.0 ? 1 : -1;  // the lit limb: +1 right, −1 left
  const double cos_tilt = std::cos(edges.axis_angle_rad);
  const double half = edges.radius_px / cos_tilt;
  const double limb = projection.VisibleLimbRad();
  const double phi_t = alpha - side * M_PI / 2.0;
  const double u_t = OffsetFromAzimuth(phi_t, projection);
  // The edges are 2·radius_px apart; the lit limb (offset side) and the
  // terminator (offset u_t) are r·(1 − side·u_t) apart.
  const double r0 = 2.0 * edges.radius_px / (1.0 - side * u_t);

  // Bins from well inside the shadow up to the mirror azimuth (at r0); the
  // fit window ends short of where the glints start.
  const double phi_dark = std::clamp(phi_t - side * kDarkWindowRad, -limb, limb);
  const double t_lo = r0 * (side * OffsetFromAzimuth(phi_dark, projection) - 1.0);
  const double t_edge = r0 * (side * u_t - 1.0);
  const double t_mirror = r0 * (side * OffsetFromAzimuth(alpha / 2.0, projection) - 1.0);
  const double t_far = std::min(t_mirror, r0 * (side * OffsetFromAzimuth(phi_t + side * kLitWindowMaxRad, projection) - 1.0));
  if (!(t_far - t_lo > 4.0)) {
    return absl::InvalidArgumentError("the terminator window is too narrow to fit");
  }

  // Tilt-corrected profile across the terminator over the usable rows.
  const TiltedProfile across = AccumulateProfile(luminance, edges, side, t_lo, t_mirror);
  const PixelSteps steps = across.PixelMeans(background.noise);
  // Glints: where the profile, in pixel-wide steps, turns jagged, walking
  // from the terminator toward the light.
  double t_glints = t_far;
  const int first_glint = FirstJaggedStep(steps, background.level, /*forward=*/true, t_edge);
  if (first_glint >= 0) t_glints = steps.t[first_glint];
  const double t_hi = std::min(t_far, t_glints - 1.0);
  if (t_hi - t_edge < kMinLitWindowPx) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the edge on the unlit side is where the glints start (%.1f px from it), not a "
        "lit terminator",
        std::max(0.0, t_glints - t_edge)));
  }
  std::vector<Bin> bins;
  std::vector<double> dark_noise;  // of the bins in shadow: the scale of a rise
  across.AppendBins(background.noise, -std::numeric_limits<double>::infinity(), t_hi,
                    /*near_limb=*/false, &bins);
  for (const Bin& bin : bins) {
    if (bin.t < t_edge - 2.0) dark_noise.push_back(1.0 / std::sqrt(bin.weight));
  }
  if (bins.size() < 12 || dark_noise.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "too few samples across the terminator (", bins.size(), " bins)"));
  }
  // The window by the lit limb, from kLimbGapPx inside it inward up to the
  // glints (walking from the limb) or the mirror azimuth: the grazing
  // scatter, S·cos(α/2)/cos φ, rises there several-fold over a few pixels
  // while the Lambertian term hardly changes, so these bins pin S. At the
  // terminator S is only a step at the edge, which a shifted Lambertian
  // ramp mimics: fitted there alone, S and the radius trade off by pixels.
  {
    const TiltedProfile by_limb = AccumulateProfile(luminance, edges, side, t_mirror, -kLimbGapPx);
    const PixelSteps limb_steps = by_limb.PixelMeans(background.noise);
    const int jagged = FirstJaggedStep(limb_steps, background.level, /*forward=*/false,
                                       -std::numeric_limits<double>::infinity());
    const int spread = FirstSpreadStepFromLimb(limb_steps);
    const int glint = std::max(jagged, spread);  // the nearer the limb
    const double t_from = glint >= 0 ? limb_steps.t[glint] + 1.0 : t_mirror;
    if (-kLimbGapPx - t_from >= kMinLimbWindowPx) {
      by_limb.AppendBins(background.noise, t_from, -kLimbGapPx, /*near_limb=*/true, &bins);
    }
  }
  const double bin_noise = Median(dark_noise);

  // Radius: a coarse scan over 0.85–1.2 r0 (steps of 0.4 % of r0, at least
  // 0.5 px; the lit terms of all bins computed once per radius for the three
  // choices of terms), then a golden-section search to 0.01 px around each
  // choice's best. Pixel footprints are sampled 8 times at r0 ≤ 128 px,
  // fewer on larger cylinders (down to 2), where they matter less.
  const int sub = std::clamp(static_cast<int>(1024.0 / r0), 2, kSubSamples);
  const double r_min = 0.85 * r0;
  const double r_max = 1.2 * r0;
  const double step = std::max(0.5, 0.004 * r0);
  std::array<Fit, 3> coarse;
  std::array<double, 3> r_coarse = {r0, r0, r0};
  for (double r = r_min; r <= r_max + 1e-9; r += step) {
    const Terms terms = TermsAt(bins, r, side, alpha, projection, sub);
    for (int mask = 1; mask <= 3; ++mask) {
      const Fit f = FitTerms(bins, terms, mask);
      if (f.chi2 < coarse[mask - 1].chi2) {
        coarse[mask - 1] = f;
        r_coarse[mask - 1] = r;
      }
    }
  }
  Fit fit;
  double r_hat = r0;
  double best_chi2 = std::numeric_limits<double>::infinity();
  // One lit term, or both when the second pays for itself: its parameter
  // costs ln n in chi-square (BIC), and at least kMinStepChi2 (a 3-sigma
  // term). With BIC alone a noise-made scatter step at the terminator was
  // taken on one 320×240 render in 60 and put the dark limb 4 px off; the
  // window by the limb, when the lobe leaves room for one, pins a real
  // scatter term far above that. Measured over 125 renders of 19 scenes
  // (320×240 to 1600×1200, |α| 90-120°, tilt, perspective, sawtooth, smooth,
  // scatter-dominated): every inferred limb within 2 px (the closing note of
  // issue 4 has the figures).
  for (int mask = 1; mask <= 3; ++mask) {
    if (!std::isfinite(coarse[mask - 1].chi2)) continue;
    const double rc = r_coarse[mask - 1];
    if (rc <= r_min + 0.5 * step || rc >= r_max - 0.5 * step) continue;
    auto chi2_at = [&](double r) {
      return FitTerms(bins, TermsAt(bins, r, side, alpha, projection, sub), mask);
    };
    const double r_fine = GoldenSectionMinimum([&](double r) { return chi2_at(r).chi2; },
                                               rc - step, rc + step, 0.01);
    const Fit f = chi2_at(r_fine);
    double penalty =
        mask == 3 ? std::max(kMinStepChi2, std::log(static_cast<double>(bins.size()))) : 0.0;
    if (mask == 3) {
      // Both terms are the physics (axial threads always scatter); they
      // are left to BIC only while the data cannot tell them apart. When the
      // two-term fit places the radius to better than kSharpRadiusPx or
      // kSharpRadiusFraction of it (its chi-square curvature, scaled by the
      // reduced chi-square), it is kept without a penalty: a single-term fit
      // is biased by the step it leaves out by more than that, by pixels on
      // large images (12 Mpx render: 4 px in the radius; 1600×1200, R 640: 1 px).
      const double h = 0.5;
      const double d2 = chi2_at(r_fine + h).chi2 + chi2_at(r_fine - h).chi2 - 2.0 * f.chi2;
      const double reduced = std::max(1.0, f.chi2 / std::max<double>(1.0, bins.size() - 5.0));
      const double sharp = std::max(kSharpRadiusPx, kSharpRadiusFraction * r_fine);
      if (std::isfinite(d2) && d2 > 0.0 && h * std::sqrt(2.0 / d2) * std::sqrt(reduced) < sharp) {
        penalty = 0.0;  // nested: its chi-square is never above a single term's
      }
    }
    if (f.chi2 + penalty < best_chi2) {
      best_chi2 = f.chi2 + penalty;
      fit = f;
      r_hat = r_fine;
    }
  }
  if (!std::isfinite(best_chi2)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "no terminator fits the edge on the unlit side: no radius within %.0f-%.0f px does",
        r_min, r_max));
  }
  const double reduced_chi2 = fit.chi2 / std::max<double>(1.0, bins.size() - 4.0);
  if (fit.rise < kMinRiseSigmas * bin_noise) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "no lit terminator on the unlit side: the surface rises only %.1f noise sigmas there",
        fit.rise / bin_noise));
  }
  if (reduced_chi2 > kMaxReducedChi2) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the edge on the unlit side is not a terminator: the lit-surface model leaves a reduced "
        "chi-square of %.1f (glints or texture, not the start of the lit surface)",
        reduced_chi2));
  }

  CylinderGeometry g = edges;
  const double lit_at_center = edges.center_x_px + side * half;
  g.radius_px = r_hat;
  g.center_x_px = lit_at_center - side * r_hat / cos_tilt;
  g.left_observed = side < 0;
  g.right_observed = side > 0;
  return g;
}

}  // namespace weavefit
