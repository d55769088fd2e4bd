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
// Acceptance: the lit term must rise this many noise sigmas of a bin across
// the window, and the fit's reduced chi-square stay below this.
constexpr double kMinRiseSigmas = 10.0;
constexpr double kMaxReducedChi2 = 6.0;
constexpr double kSharpRadiusPx = 0.25;
constexpr double kSharpRadiusFraction = 2e-3;

// One bin of the tilt-corrected profile across the terminator.
struct Bin {
  double t = 0.0;       // mean perpendicular distance from the lit limb, px (< 0 inside)
  double mean = 0.0;
  double weight = 0.0;  // 1 / variance of the mean
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
// the bins' lit terms at one radius; an infeasible fit (a negative term)
// scores infinity.
Fit FitTerms(const std::vector<Bin>& bins, const Terms& all_terms, int terms_mask) {
  std::vector<int> cols;  // which lit terms, after the constant
  for (int j = 0; j < 2; ++j) {
    if (terms_mask & (1 << j)) cols.push_back(j);
  }
  const int n = static_cast<int>(bins.size());
  const int p = 1 + static_cast<int>(cols.size());
  Eigen::MatrixXd design(n, p);
  Eigen::VectorXd values(n);
  for (int i = 0; i < n; ++i) {
    const std::array<double, 2>& terms = all_terms[i];
    const double w = std::sqrt(bins[i].weight);
    design(i, 0) = w;
    for (int j = 0; j + 1 < p; ++j) design(i, 1 + j) = w * terms[cols[j]];
    values(i) = w * bins[i].mean;
  }
  const Eigen::VectorXd x = design.colPivHouseholderQr().solve(values);
  Fit fit;
  if (!x.allFinite() || (x.tail(p - 1).array() < 0.0).any()) return fit;
  const Eigen::VectorXd residual = values - design * x;
  fit.chi2 = residual.squaredNorm();
  for (int i = 0; i < n; ++i) {
    const double lit = (design.row(i).tail(p - 1) * x.tail(p - 1)).value() / std::sqrt(bins[i].weight);
    fit.rise = std::max(fit.rise, lit);
  }
  return fit;
}

}  // namespace

absl::StatusOr<CylinderGeometry> InferDarkLimb(const Image& luminance,
                                               const CylinderGeometry& edges,
                                               double phase_angle_rad,
                                               const Projection& projection,
                                               const BackgroundLevel& background) {
  const double alpha = phase_angle_rad;
  if (!(std::fabs(alpha) > 20.0 * kDeg && std::fabs(alpha) < 170.0 * kDeg)) {
    return absl::InvalidArgumentError(
        "no terminator to infer a dark limb from: the phase angle must lie between 20 and 170 deg");
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
  const int nbins = static_cast<int>(std::ceil((t_mirror - t_lo) / kBinPx));
  std::vector<double> sum(nbins, 0.0), sum_sq(nbins, 0.0), sum_t(nbins, 0.0);
  std::vector<int> count(nbins, 0);
  for (int y = std::max(edges.top_row, 0); y <= std::min(edges.bottom_row, luminance.height - 1); ++y) {
    const double lit_x = edges.AxisColumn(y) + side * half;
    // t = side·(x − lit_x)·cos tilt, so x = lit_x + side·t / cos tilt.
    const double xa = lit_x + side * t_lo / cos_tilt;
    const double xb = lit_x + side * t_mirror / cos_tilt;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min(xa, xb))));
    const int x1 = std::min(luminance.width - 1, static_cast<int>(std::ceil(std::max(xa, xb))));
    for (int x = x0; x <= x1; ++x) {
      const double t = side * (x - lit_x) * cos_tilt;
      const int b = static_cast<int>(std::floor((t - t_lo) / kBinPx));
      if (b < 0 || b >= nbins) continue;
      const double v = luminance.At(x, y);
      sum[b] += v;
      sum_sq[b] += v * v;
      sum_t[b] += t;
      ++count[b];
    }
  }
  // Glints: where the profile, in pixel-wide steps, turns jagged. Shading
  // (Lambertian, grazing scatter) changes smoothly across a few pixels; the
  // comb of glints of the specular lobe does not. A step is jagged when its
  // second difference exceeds kGlintRoughness of its level above the
  // background and 6 noise sigmas.
  const int per_px = static_cast<int>(std::lround(1.0 / kBinPx));
  std::vector<double> px_mean;
  std::vector<double> px_sigma;
  std::vector<double> px_t;
  for (int b0 = 0; b0 + per_px <= nbins; b0 += per_px) {
    double s_sum = 0.0;
    double t_sum = 0.0;
    int n = 0;
    for (int b = b0; b < b0 + per_px; ++b) {
      s_sum += sum[b];
      t_sum += sum_t[b];
      n += count[b];
    }
    if (n == 0) continue;
    px_mean.push_back(s_sum / n);
    px_t.push_back(t_sum / n);
    px_sigma.push_back(background.noise / std::sqrt(static_cast<double>(n)));
  }
  double t_glints = t_far;
  int run = 0;
  for (std::size_t k = 1; k + 1 < px_mean.size(); ++k) {
    if (px_t[k] < t_edge) continue;
    const double second = std::fabs(px_mean[k] - 0.5 * (px_mean[k - 1] + px_mean[k + 1]));
    const double level = std::fabs(px_mean[k] - background.level);
    const bool jagged = second > std::max(6.0 * px_sigma[k], kGlintRoughness * level);
    run = jagged ? run + 1 : 0;
    if (run == 2) {
      t_glints = px_t[k - 1];
      break;
    }
  }
  const double t_hi = std::min(t_far, t_glints - 1.0);
  if (t_hi - t_edge < kMinLitWindowPx) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "the edge on the unlit side is where the glints start (%.1f px from it), not a "
        "lit terminator",
        std::max(0.0, t_glints - t_edge)));
  }
  std::vector<Bin> bins;
  std::vector<double> dark_noise;  // of the bins in shadow: the scale of a rise
  for (int b = 0; b < nbins; ++b) {
    if (count[b] < 3) continue;
    const double t = sum_t[b] / count[b];
    if (t > t_hi) break;
    const double mean = sum[b] / count[b];
    const double var = std::max(sum_sq[b] / count[b] - mean * mean,
                                background.noise * background.noise);
    const double var_mean = var / (count[b] - 1);
    bins.push_back({t, mean, 1.0 / var_mean});
    if (t < t_edge - 2.0) dark_noise.push_back(std::sqrt(var_mean));
  }
  if (bins.size() < 12 || dark_noise.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "too few samples across the terminator (", bins.size(), " bins)"));
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
  // One lit term, or both when the second pays for itself (BIC: its
  // parameter costs ln n in chi-square). Measured on 320×240 renders, 10
  // noise draws each: a Lambertian-dominated or a scatter-only terminator
  // puts the dark limb within 2 px; where both terms are comparable the
  // choice between one and two terms is uncertain and the limb can be 3.5 px
  // off (the closing note of issue 4 has the figures).
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
    double penalty = mask == 3 ? std::log(static_cast<double>(bins.size())) : 0.0;
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
