#include "estimator/pipeline/estimate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <map>
#include <optional>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "estimator/fit/profile_fit.h"
#include "estimator/glints/comb_fit.h"
#include "estimator/glints/glint_period.h"
#include "estimator/init/profile_bank.h"
#include "estimator/profile/arc_signals.h"
#include "estimator/select/model_selection.h"
#include "estimator/stats/smooth.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;
// Beyond this the lobe read is not the one the stated acquisition makes
// (the phase-angle check refuses the estimate rather than warn).
constexpr double kMaxMirrorMissRad = 20.0 * kDeg;
// Beyond 3 standard errors and this, peak picking's numbers are reported
// unresolved (issue 5: a mirror azimuth inconsistent with the phase angle).
constexpr double kMirrorMissUnresolvedRad = 5.0 * kDeg;
// A caustic closer than this to the limb (px) is not read (see its use).
constexpr double kMinCausticToLimbPx = 4.0;

// Wall time per stage, appended in order. Each lap also asks the caller's
// interrupt (EstimateOptions::interrupt) whether to go on.
class StageClock {
 public:
  explicit StageClock(const std::function<absl::Status()>& interrupt) : interrupt_(interrupt) {}
  [[nodiscard]] absl::Status Lap(const char* stage) {
    const auto now = std::chrono::steady_clock::now();
    double ms = std::chrono::duration<double, std::milli>(now - last_).count() - moving_ms_;
    moving_ms_ = 0.0;
    if (const auto it = moved_ms_.find(stage); it != moved_ms_.end()) {
      ms += it->second;
      moved_ms_.erase(it);
    }
    laps_.push_back({stage, ms});
    last_ = now;
    return interrupt_ ? interrupt_() : absl::OkStatus();
  }
  // Counts the time since the last lap toward the later lap `stage`, not the
  // next: work of that stage done while another ran beside it.
  void MoveToLater(const char* stage) {
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - last_)
            .count() -
        moving_ms_;
    moved_ms_[stage] += ms;
    moving_ms_ += ms;
  }
  const std::vector<StageTime>& laps() const { return laps_; }

 private:
  const std::function<absl::Status()>& interrupt_;
  std::vector<StageTime> laps_;
  std::map<std::string, double> moved_ms_;  // MoveToLater's, by stage
  double moving_ms_ = 0.0;                  // of them, since the last lap
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// One channel of an image, with the image's saturation mask.
Image Channel(const Image& image, int c) {
  Image out;
  out.width = image.width;
  out.height = image.height;
  out.channels = 1;
  out.format = image.format;
  out.bit_depth = image.bit_depth;
  out.srgb = image.srgb;
  out.saturated = image.saturated;
  out.pixels.resize(static_cast<std::size_t>(image.width) * image.height);
  for (std::size_t i = 0; i < out.pixels.size(); ++i) {
    out.pixels[i] = image.pixels[i * image.channels + c];
  }
  return out;
}

// Where each colour's features are (issue 4): the peaks of each channel's
// own profile, its lobe level and its grazing scatter near the lit limb.
std::vector<ChannelSummary> SummariseChannels(const Image& image,
                                              const CylinderGeometry& cylinder,
                                              const Acquisition& acquisition,
                                              const EstimateOptions& options,
                                              std::vector<std::string>* warnings) {
  std::vector<ChannelSummary> out;
  const char* names[] = {"R", "G", "B"};
  const Projection projection = acquisition.GetProjection();
  const double alpha = acquisition.phase_angle_rad;
  for (int c = 0; c < 3; ++c) {
    ChannelSummary summary;
    summary.channel = names[c];
    absl::StatusOr<Profile> profile =
        ExtractProfile(Channel(image, c), cylinder, projection, options.profile);
    if (!profile.ok()) continue;
    absl::StatusOr<PeakPickingResult> peaks = PickPeaks(*profile, alpha, projection, options.peaks);
    if (peaks.ok()) {
      summary.model = peaks->model;
      summary.specular_azimuth_rad = {peaks->mirror_rad, peaks->mirror_stderr_rad, true, 0.0,
                                      peaks->mirror_systematic_rad};
      if (peaks->split_resolved) {
        summary.peak_spacing_rad = {peaks->spacing_rad, peaks->spacing_stderr_rad, true, 0.0,
                                    peaks->spacing_systematic_rad, peaks->spacing_common_rad};
      }
    }
    // The body beside the lobe, lit bins only: a + b/cos φ + d·cos(φ − α)
    // (ambient, the axial threads' grazing scatter, a Lambertian term), by
    // linear least squares; b/cos φ at 77° is the grazing level.
    const double lobe_half = peaks.ok() ? 0.5 * peaks->spacing_rad + 6.0 * kDeg : 45.0 * kDeg;
    double ata[3][3] = {{0}};
    double atb[3] = {0};
    for (int i = 0; i < profile->NumBins(); ++i) {
      const double phi = profile->azimuth_rad[i];
      if (profile->count[i] <= 0 || std::cos(phi - alpha) <= 0.05 ||
          std::fabs(phi - alpha / 2.0) < lobe_half) {
        continue;
      }
      const double f[3] = {1.0, 1.0 / std::cos(phi), std::cos(phi - alpha)};
      const double w = profile->count[i];
      for (int r = 0; r < 3; ++r) {
        atb[r] += w * f[r] * profile->mean[i];
        for (int k = 0; k < 3; ++k) ata[r][k] += w * f[r] * f[k];
      }
    }
    // Solve the 3×3 system (Cramer's rule; the terms are well apart).
    auto det3 = [](const double m[3][3]) {
      return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
             m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
             m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    };
    const double d = det3(ata);
    double coef[3] = {0.0, 0.0, 0.0};
    if (std::fabs(d) > 1e-30) {
      for (int k = 0; k < 3; ++k) {
        double m[3][3];
        for (int r = 0; r < 3; ++r) {
          for (int q = 0; q < 3; ++q) m[r][q] = q == k ? atb[r] : ata[r][q];
        }
        coef[k] = det3(m) / d;
      }
    }
    auto body = [&](double phi) {
      return coef[0] + coef[1] / std::cos(phi) + coef[2] * std::max(std::cos(phi - alpha), 0.0);
    };
    for (int i = 0; i < profile->NumBins(); ++i) {
      const double phi = profile->azimuth_rad[i];
      if (profile->count[i] > 0 && std::fabs(phi - alpha / 2.0) < lobe_half) {
        summary.lobe_level = std::max(summary.lobe_level, profile->mean[i] - body(phi));
      }
    }
    summary.grazing_level = std::max(coef[1], 0.0) / std::cos(77.0 * kDeg);
    out.push_back(summary);
  }
  if (out.size() == 3) {
    double lobe_total = 0.0;
    double grazing_total = 0.0;
    int lobe_best = 0;
    int grazing_best = 0;
    for (int c = 0; c < 3; ++c) {
      lobe_total += std::max(out[c].lobe_level, 0.0);
      grazing_total += std::max(out[c].grazing_level, 0.0);
      if (out[c].lobe_level > out[lobe_best].lobe_level) lobe_best = c;
      if (out[c].grazing_level > out[grazing_best].grazing_level) grazing_best = c;
    }
    if (lobe_best != grazing_best && lobe_total > 0 && grazing_total > 0 &&
        out[lobe_best].lobe_level > 0.4 * lobe_total &&
        out[grazing_best].grazing_level > 0.4 * grazing_total) {
      warnings->push_back(absl::StrCat(
          "colour: the specular lobe is strongest in ", out[lobe_best].channel,
          ", the grazing scatter in ", out[grazing_best].channel,
          " (a shot fabric: the two thread families differ in colour)"));
    }
  }
  return out;
}

// An upper bound on the max slope of a lobe whose split is not resolved:
// the lobe's variance in facet tilt is the blur's plus the facets' own, and
// the facets' is m²/2 for a sinusoid (tan β = m·sin θ) and arctan²(m) for a
// sawtooth, so arctan(m) ≤ √2·σ_lobe for either. σ_lobe is the second moment
// about the mirror azimuth of the lobe within ±20° in tilt, a straight
// baseline through the window's ends taken off and the geometric factor
// cos(α/2)/(cos φ·cos β) divided out (DESIGN.md §3); noise in the tails only
// widens it, loosening the bound. 0 when there is no lobe to measure.
double MaxSlopeUpperBound(const Profile& profile, double mirror_rad, double phase_angle_rad) {
  constexpr double kWindow = 20.0 * kDeg;
  constexpr double kEnds = 2.0 * kDeg;
  std::vector<double> beta;
  std::vector<double> value;
  for (int i = 0; i < profile.NumBins(); ++i) {
    const double b = mirror_rad - profile.azimuth_rad[i];
    if (std::fabs(b) > kWindow || profile.count[i] <= 0.0) continue;
    beta.push_back(b);
    value.push_back(profile.mean[i]);
  }
  if (beta.size() < 10) return 0.0;
  double lo_sum = 0.0, lo_beta = 0.0, hi_sum = 0.0, hi_beta = 0.0;
  int lo_n = 0, hi_n = 0;
  const double b_min = *std::min_element(beta.begin(), beta.end());
  const double b_max = *std::max_element(beta.begin(), beta.end());
  for (std::size_t i = 0; i < beta.size(); ++i) {
    if (beta[i] < b_min + kEnds) {
      lo_sum += value[i];
      lo_beta += beta[i];
      ++lo_n;
    } else if (beta[i] > b_max - kEnds) {
      hi_sum += value[i];
      hi_beta += beta[i];
      ++hi_n;
    }
  }
  if (lo_n == 0 || hi_n == 0) return 0.0;
  const double b0 = lo_beta / lo_n, v0 = lo_sum / lo_n, b1 = hi_beta / hi_n, v1 = hi_sum / hi_n;
  double w_sum = 0.0, w_b2 = 0.0;
  for (std::size_t i = 0; i < beta.size(); ++i) {
    const double base = v0 + (v1 - v0) * (beta[i] - b0) / (b1 - b0);
    const double phi = mirror_rad - beta[i];
    const double w = std::max(0.0, value[i] - base) * std::cos(phi) * std::cos(beta[i]) /
                     std::max(std::cos(0.5 * phase_angle_rad), 0.05);
    w_sum += w;
    w_b2 += w * beta[i] * beta[i];
  }
  if (!(w_sum > 0.0)) return 0.0;
  const double sigma = std::sqrt(w_b2 / w_sum);
  // A lobe still high at the window's ends is cut by the baseline and its
  // width underestimated: no bound then.
  if (sigma > 0.3 * kWindow) return 0.0;
  return std::tan(std::min(std::sqrt(2.0) * sigma, 80.0 * kDeg));
}

// The comb of glints fitted row by row (glints/comb_fit.h) over the whole
// lobe and a margin beyond the peaks read (which a comb pulls inward): the
// range of `wide` (WideArcRange), signals along the rows the period search
// chose (ReadWavelength).
ArcSignalOptions WideArcRange(const PeakPickingResult& peaks, const Projection& projection) {
  const double half = 0.5 * peaks.spacing_rad;
  const double limit = projection.VisibleLimbRad() - 3.0 * kDeg;
  const double reach = half + std::max(4.0 * kDeg, 0.25 * half);
  ArcSignalOptions wide;
  wide.from_rad = std::max(peaks.mirror_rad - reach, -limit);
  wide.to_rad = std::min(peaks.mirror_rad + reach, limit);
  return wide;
}

// The comb fit over the lobe from `wavelength_mm` and model.max_slope: on
// `chosen`'s rows when it holds any (their phases read again there), else
// on rows chosen for that start, which `chosen` then holds.
absl::StatusOr<CombFitResult> FitCombOverLobe(
    const Image& luminance, const CylinderGeometry& cylinder, const Projection& projection,
    const ArcSignalOptions& wide, const ArcSignals& signals, const GlintModel& model,
    double wavelength_mm, const CombFitOptions& options, CombRows* chosen) {
  absl::StatusOr<CombRows> rows =
      chosen->rows.empty() ? ChooseCombRows(signals, model, wavelength_mm, options.max_rows)
                           : RephaseCombRows(signals, model, wavelength_mm, *chosen);
  if (!rows.ok()) return rows.status();
  *chosen = *rows;
  // Neighbouring columns binned so that a row holds at most
  // max_samples_per_row bins.
  const double columns = (OffsetFromAzimuth(wide.to_rad, projection) -
                          OffsetFromAzimuth(wide.from_rad, projection)) *
                         cylinder.radius_px / std::cos(cylinder.axis_angle_rad);
  const int bin = std::max(1, static_cast<int>(std::ceil(columns / options.max_samples_per_row)));
  absl::StatusOr<ArcPixels> pixels =
      ExtractArcPixels(luminance, cylinder, projection, rows->rows, wide.from_rad, wide.to_rad, bin);
  if (!pixels.ok()) return pixels.status();
  return FitGlintComb(*pixels, *rows, model, wavelength_mm, options);
}

// Marks the split and what leans on it (max slope, amplitude, and the
// wavelength unless `keep_wavelength`: a period read from a lattice, not
// from the glints between the caustics) unresolved, their values kept, and
// says why.
void LeaveSplitUnresolved(const std::string& why, Estimate* estimate,
                          bool keep_wavelength = false) {
  for (Quantity* q : {&estimate->peak_spacing_rad, &estimate->max_slope,
                      &estimate->wavelength_mm, &estimate->amplitude_mm}) {
    if (q == &estimate->wavelength_mm && keep_wavelength) continue;
    q->resolved = false;
  }
  estimate->warnings.push_back(absl::StrCat(
      keep_wavelength && estimate->wavelength_mm.resolved
          ? "split, max slope and amplitude not resolved (the wavelength, read from the weave's "
            "lattice, stands): "
          : "split, max slope, wavelength and amplitude not resolved: ",
      why));
}

// What the limbs' placement adds to the errors of the peak spacing, the
// mirror azimuth and the wavelength, all and the allowances' share, for
// peaks at the mirror ∓ half the spacing: a limb moved by its error moves
// both peaks, the one beside it most (AzimuthPerLimbPx). A sawtooth at
// 98.6° (640×480, lens blur 2 px) had its lit limb 2 px out, within its
// stated 4 px, and its spacing 1.5° short, 4.3 times the peaks' own error.
// The limbs' independent errors add in quadrature, their moves through the
// lens blur's error (CylinderGeometry::left_limb_blur_px) coherently.
//
// The glints between the peaks time the wavelength: the arc between them
// stretches by the spacing's relative move (the wavelength in mm is the
// radius in mm times the period in azimuth). Near the centre that is the
// radius's relative error; off it a limb moved stretches one side of the
// arc more than the other. Over 32 draws of the copper gauze at −110° the
// wavelength's error followed the centre's at 3.3 % per px (correlation
// 0.74) and spread 2.4 times the error the radius alone gave it.
struct LimbErrors {
  double spacing_rad = 0.0;
  double spacing_systematic_rad = 0.0;
  double mirror_rad = 0.0;
  double mirror_systematic_rad = 0.0;
  double wavelength_relative = 0.0;
  double wavelength_relative_systematic = 0.0;
};

LimbErrors LimbErrorsAt(const CylinderGeometry& cylinder, const Projection& projection,
                        double mirror_rad, double spacing_rad) {
  const double half = cylinder.radius_px / std::cos(cylinder.axis_angle_rad);
  const AzimuthPerLimb l = AzimuthPerLimbPx(mirror_rad - 0.5 * spacing_rad, half, projection);
  const AzimuthPerLimb r = AzimuthPerLimbPx(mirror_rad + 0.5 * spacing_rad, half, projection);
  // Each limb's error without its move through the blur.
  auto independent = [](double all, double blur) {
    return std::sqrt(std::max(0.0, all * all - blur * blur));
  };
  const double left_px = independent(cylinder.left_limb_stderr_px, cylinder.left_limb_blur_px);
  const double right_px = independent(cylinder.right_limb_stderr_px, cylinder.right_limb_blur_px);
  // The error of a φ combination with per-px weights (per_left, per_right).
  auto error = [&](double per_left, double per_right) {
    const double coherent =
        per_left * cylinder.left_limb_blur_px + per_right * cylinder.right_limb_blur_px;
    return std::hypot(std::hypot(per_left * left_px, per_right * right_px), coherent);
  };
  auto systematic = [&](double per_left, double per_right) {
    return std::hypot(per_left * cylinder.left_limb_systematic_px,
                      per_right * cylinder.right_limb_systematic_px);
  };
  // The spacing is φ_right − φ_left to first order (the view angle's share
  // is R/D of it), the mirror their mean.
  LimbErrors e;
  e.spacing_rad = error(r.left - l.left, r.right - l.right);
  e.spacing_systematic_rad = systematic(r.left - l.left, r.right - l.right);
  e.mirror_rad = error(0.5 * (r.left + l.left), 0.5 * (r.right + l.right));
  e.mirror_systematic_rad = systematic(0.5 * (r.left + l.left), 0.5 * (r.right + l.right));
  if (spacing_rad > 0.0) {
    e.wavelength_relative = e.spacing_rad / spacing_rad;
    e.wavelength_relative_systematic = e.spacing_systematic_rad / spacing_rad;
  } else {
    // No arc between peaks: the radius's share, as at the centre.
    e.wavelength_relative = cylinder.RelativeRadiusError();
    e.wavelength_relative_systematic = cylinder.RelativeRadiusSystematic();
  }
  return e;
}

// A quantity with an error added in quadrature, its allowances' share too
// (and that share counted common to all photographs of the set-up).
Quantity WithLimbError(Quantity q, double error, double systematic) {
  q.stderr_value = std::hypot(q.stderr_value, error);
  q.systematic = std::hypot(q.systematic, systematic);
  q.common = std::hypot(q.common, systematic);
  return q;
}

// The comb fit's period with its errors: the fit's own (scaled up by its
// misfit), the floor and the glint model's mismatch, and the limbs' stretch
// of the arc (their share and the floors systematic).
Quantity CombWavelength(const CombFitResult& comb, const CombFitOptions& options,
                        const LimbErrors& limbs) {
  const double misfit = std::sqrt(std::max(1.0, comb.reduced_chi2));
  const double lambda = comb.wavelength_mm;
  const double sys = std::hypot(misfit * options.wavelength_floor * lambda,
                                limbs.wavelength_relative_systematic * lambda,
                                options.wavelength_mismatch * lambda);
  const double se = std::hypot(
      misfit * std::hypot(comb.wavelength_stderr_mm, options.wavelength_floor * lambda),
      limbs.wavelength_relative * lambda, options.wavelength_mismatch * lambda);
  return {lambda, se, true, 0.0, sys, sys};
}

// The comb fit's max slope, spacing, wavelength and amplitude replace the
// profile's, with its cluster-robust errors and the model floors (the
// model, a sinusoid's, is the caller's: ModelWithConfirmedComb).
void ApplyCombFit(const CombFitResult& comb, const CombFitOptions& options,
                  const Acquisition& acquisition, double mirror_start_rad, Estimate* estimate) {
  // A fit that leaves residuals larger than the start's noise scale (a
  // reduced chi-square above 1: e.g. a tilted axis whose threads the rows
  // cross) misses something the errors must own: they grow by its root.
  // (The threads' scores see misfit that varies from thread to thread, not the
  // tilt's, which every thread shares: unscaled, one draw in three of the
  // bench sweep's 1° tilt fell outside 3 stated errors.)
  const double misfit = std::sqrt(std::max(1.0, comb.reduced_chi2));
  {
    // The mirror azimuth: φ = (α + v(φ))/2 + δ, by fixed point.
    const Projection projection = acquisition.GetProjection();
    double phi = mirror_start_rad;
    for (int i = 0; i < 8; ++i) {
      phi = 0.5 * (acquisition.phase_angle_rad + ViewAngleRad(phi, projection)) +
            comb.mirror_offset_rad;
    }
    const double se =
        misfit * std::hypot(comb.mirror_offset_stderr_rad, options.mirror_floor_rad);
    const double floor = misfit * options.mirror_floor_rad;
    estimate->specular_azimuth_rad = {phi, se, true, 0.0, floor, floor};
    // The phase-angle check from the glints (peak picking's is made only
    // when there is no comb fit).
    if (std::fabs(comb.mirror_offset_rad) > 3.0 * se + options.mirror_tolerance_rad) {
      estimate->warnings.push_back(absl::StrFormat(
          "the mirror azimuth %.2f deg is %.2f deg from half the stated phase angle, more than "
          "its error (%.2f deg) explains: the glints say the phase angle is %.2f deg, not %.2f; "
          "check the phase angle and its sign (positive = light on the image's right)",
          phi / kDeg, comb.mirror_offset_rad / kDeg, se / kDeg,
          (acquisition.phase_angle_rad + 2.0 * comb.mirror_offset_rad) / kDeg,
          acquisition.phase_angle_rad / kDeg));
    }
  }
  // The limbs set the scale from pixels to azimuth: they move the glints'
  // azimuths, the outer caustics' most, and stretch the arc between them
  // (LimbErrorsAt): that is the max slope's and the wavelength's share.
  // The floors and the limbs' allowances are the systematic share.
  const double m = comb.max_slope;
  const LimbErrors limbs = LimbErrorsAt(estimate->cylinder, acquisition.GetProjection(),
                                        estimate->specular_azimuth_rad.value, PeakSpacingRad(m));
  const double per_spacing = 0.5 * (1.0 + m * m);  // dm/d(spacing)
  // The glint model's mismatch with threads of another make is systematic
  // too, and taken as common: its sign changed from scene to scene on
  // independent renders, but nothing says it changes with the phase angle
  // for one sample, and as a per-photograph share it would weight a joint
  // estimate's photographs alike (the gauze's −110° as much as its 10°: the
  // joint's error 0.0079° rms against 0.0049° at 10° alone, 16 draws).
  const double m_sys = std::hypot(misfit * options.slope_floor * m,
                                  per_spacing * limbs.spacing_systematic_rad,
                                  options.slope_mismatch * m);
  const double m_se = std::hypot(misfit * std::hypot(comb.max_slope_stderr, options.slope_floor * m),
                                 per_spacing * limbs.spacing_rad, options.slope_mismatch * m);
  estimate->specular_azimuth_rad = WithLimbError(estimate->specular_azimuth_rad, limbs.mirror_rad,
                                                 limbs.mirror_systematic_rad);
  estimate->max_slope = {m, m_se, true, 0.0, m_sys, m_sys};
  estimate->peak_spacing_rad = SpacingFromSlope(estimate->max_slope);
  estimate->wavelength_mm = CombWavelength(comb, options, limbs);
  estimate->amplitude_mm = AmplitudeFrom(ProfileModel::kSinusoid, estimate->max_slope,
                                         estimate->wavelength_mm);
  estimate->method = "comb-fit";
  for (CandidateScore& c : estimate->candidates) c.selected = false;
  estimate->candidates.push_back(
      {ProfileModel::kSinusoid, "comb fit (glints row by row)", -comb.explained, true});
  estimate->warnings.push_back(absl::StrFormat(
      "max slope and wavelength from the comb of glints fitted pixel by pixel over %d rows "
      "of %d threads (the model explains %.1f%% of their variance; source blur %.2f deg, "
      "lens blur %.2f px%s%s)",
      comb.rows_used, comb.threads_used, 100.0 * comb.explained, comb.blur_rad / kDeg, comb.psf_px,
      comb.relief_parallax ? "; each glint seen where its facet stands on the threads' relief" : "",
      comb.hidden_share > 0.0
          ? absl::StrFormat("; where the axial threads float over the circumferential ones, "
                            "%.0f%% of each period, their glints hidden",
                            100.0 * comb.hidden_share)
          : std::string()));
}

// A comb fit started from the lattice that explains this share of its rows
// but less than min_explained gives the period and not the slope. The rows
// also carry the axial lines, which the comb does not model; the lattice's
// independent measurement of the period rules out the false optima a
// quarter off that min_explained guards against. Its slope is not so
// backed: on independently rendered photographs such fits (70-80 %) gave
// periods within 0.4 %, but one read the max slope 4 % long at 8 stated
// errors.
constexpr double kLatticePeriodExplained = 0.7;

// The axial threads' glint lines are looked for up to this azimuth: beyond
// it foreshortening more than halves their pitch in pixels.
constexpr double kLatticeMaxAzimuth = 60.0 * kDeg;
// ... and where the direct light falls at least 10° above grazing.
constexpr double kLatticeLitReach = 80.0 * kDeg;
// Rows taken along each stretch of arc: at most kLatticeRows, evenly spaced
// over a band of at most kLatticeBandRows about the cylinder's middle (the
// band must span several threads for AxialPitch::aligned).
constexpr int kLatticeRows = 128;
constexpr int kLatticeBandRows = 384;
// Half the width of a caustic's column of glints left out of a lattice read
// across the lobe, before the lens blur: under a source of up to 1° (σ),
// facets within 3σ/2 = 1.5° of the caustic's tilt still mirror it, and
// their glints stand as far from it in azimuth; 2° leaves a margin.
constexpr double kCausticHalfWidth = 2.0 * kDeg;
// How far a comb fit started from the lattice may end from its start and
// still stand on the lattice's evidence: 3 stated errors of the threads'
// pitch (glints/round_threads.h), and at least 3 %. The pitch from many lines
// is good to a few tenths of a percent, and 3 % leaves room for the comb's
// own period error (its optimum moves by tenths of a percent with its
// start) without taking a comb that has moved to another period; from a
// few lines, or a correction the prior decides, the pitch is less sure.
constexpr double kLatticeCombReach = 0.03;

double LatticeCombReach(const ThreadPitch& threads) {
  return std::max(kLatticeCombReach, 3.0 * threads.pitch_stderr_mm / threads.pitch_mm);
}

// A comb that overturns a sawtooth read must agree with the lattice within
// 3 of its stated errors as well (the comb's own period moves by a few
// tenths of a percent with its start, kCombPeriodFloor), since both readings
// must then say the glints repeat with that period: a "sinusoid" fitted to
// a sawtooth's caustics and relief ended 2.9 % from a lattice known to
// better than 1 % and explained 93 % of the rows.
constexpr double kCombPeriodFloor = 0.005;

double OverturnReach(const ThreadPitch& threads) {
  return std::clamp(3.0 * threads.pitch_stderr_mm / threads.pitch_mm, kCombPeriodFloor,
                    kLatticeCombReach);
}

// Whether a lattice is the lines of threads running along the axis, λ/2
// apart (AxialPitchOptions::min_aligned_share).
bool LinesAlongTheAxis(const AxialPitch& pitch) { return pitch.lines; }
// Read across the lobe, a lattice holds the lobe's glints too, and a
// sawtooth's two caustic columns stand at fixed azimuths in every other
// thread: aligned power that is not the axial threads'. There it must hold
// twice the share to give the period alone. (On independently rendered
// photographs, lattices across the lobe: the axial lines 0.21-0.97; one
// sawtooth's caustics and relief, 0.11, at λ itself.)
constexpr double kMinAlignedAcrossLobe = 0.2;
// At half the lattice's frequency a plain weave shows its period λ: the
// lobe's circumferential glints and the relief under stray light repeat
// with it, neighbouring threads half a period out of step, so that power
// lies in a checkerboard and not in lines along the axis (on independently
// rendered photographs read across the lobe: 6-75 % of the lattice's power
// at half its frequency, 0.3-3 % of that in lines along the axis). Lines
// along the axis at twice the spacing, though, say the lattice found may be
// a harmonic of a coarser pattern of lines, and then nothing says which is
// the threads' pitch. CoarserLines compares the two patterns' power in
// lines along the axis; the lattice alone gives the period below
// kLatticeMaxHalf.
constexpr double kLatticeMaxHalf = 0.25;

double CoarserLines(const AxialPitch& pitch) {
  return pitch.half_contrast * pitch.half_aligned /
         std::max(pitch.contrast * pitch.aligned, 1e-12);
}

// Whether a lattice is a plain weave's pattern repeating with λ itself:
// rows that alternate from one circumferential thread to the next
// (AxialPitchOptions::min_checker_share).
bool RowsAlternate(const AxialPitch& pitch) { return pitch.found && pitch.alternating; }

// The axial threads' pitch (glints/weave_lattice.h) over the lit and visible
// surface beside the lobe, whose circumferential glints repeat with λ and
// not with the pitch; where the lobe leaves too little beside it, over the
// whole lit surface, lobe included (beside_lobe false: then the lattice's
// fundamental may be λ itself).
// For lines along the axis, `threads` is the threads' own pitch from the
// lines' (glints/round_threads.h); for any other lattice, the lattice's.
struct LatticeReading {
  AxialPitch pitch;
  bool beside_lobe = false;
  ThreadPitch threads;
};

LatticeReading ReadAxialLattice(const Image& luminance, const CylinderGeometry& cylinder,
                                const Projection& projection, double phase_angle_rad,
                                const PeakPickingResult& peaks, const GlintModel& model,
                                const EstimateOptions& options) {
  const double limit = std::min(projection.VisibleLimbRad() - 3.0 * kDeg, kLatticeMaxAzimuth);
  const double lo = std::max(phase_angle_rad - kLatticeLitReach, -limit);
  const double hi = std::min(phase_angle_rad + kLatticeLitReach, limit);
  const ArcSignalOptions lobe = WideArcRange(peaks, projection);
  // Evenly spaced rows of a band about the cylinder's middle, in image order
  // (the lattice's spread over the rows is read along them).
  std::vector<int> band;
  const int usable = cylinder.bottom_row - cylinder.top_row + 1;
  const int span = std::min(usable, kLatticeBandRows);
  const int stride = std::max(1, span / kLatticeRows);
  const int first = cylinder.top_row + (usable - span) / 2;
  for (int y = first; y < first + span; y += stride) band.push_back(y);
  auto arc = [&](double from, double to) -> std::optional<ArcSignals> {
    if (!(to - from > kDeg)) return std::nullopt;
    ArcSignalOptions o;
    o.from_rad = from;
    o.to_rad = to;
    o.rows = band;
    absl::StatusOr<ArcSignals> s = ExtractArcSignals(luminance, cylinder, projection, o);
    return s.ok() ? std::optional<ArcSignals>(*std::move(s)) : std::nullopt;
  };
  auto read = [&](const std::vector<ArcSignals>& arcs,
                  const std::vector<std::pair<double, double>>& leave_out) {
    AxialPitch none;
    none.reason = absl::StrFormat(
        "no stretch of the lit surface within %.0f deg of the line of sight to count glint lines "
        "along",
        kLatticeMaxAzimuth / kDeg);
    if (arcs.empty()) return none;
    absl::StatusOr<AxialPitch> p = EstimateAxialPitch(
        arcs, arcs[0].StepMm() / model.mm_per_px, model.pixel_noise, options.lattice, leave_out);
    return p.ok() ? *p : none;
  };
  LatticeReading reading;
  std::vector<ArcSignals> beside;
  for (auto [from, to] : {std::pair(lo, std::min(hi, lobe.from_rad)),
                          std::pair(std::max(lo, lobe.to_rad), hi)}) {
    if (std::optional<ArcSignals> s = arc(from, to)) beside.push_back(*std::move(s));
  }
  reading.pitch = read(beside, {});
  reading.beside_lobe = reading.pitch.found;
  std::vector<ArcSignals> whole;
  if (!reading.pitch.found) {
    // Across the lobe, less its two caustics: there every thread glints at
    // the same azimuths (a sawtooth's facets, a sinusoid's steepest slope),
    // in columns along the axis that are not axial threads. A caustic
    // spreads over kCausticHalfWidth and 3 lens-blur sigmas either side.
    const double gap = kCausticHalfWidth + 3.0 * cylinder.lens_blur_px / cylinder.radius_px;
    std::vector<std::pair<double, double>> caustics;
    for (double side : {-0.5, 0.5}) {
      const double c = peaks.mirror_rad + side * peaks.spacing_rad;
      caustics.push_back({c - gap, c + gap});
    }
    if (std::optional<ArcSignals> s = arc(lo, hi)) whole.push_back(*std::move(s));
    const AxialPitch p = read(whole, caustics);
    if (p.found || beside.empty()) reading.pitch = p;
  }
  reading.threads.pitch_mm = reading.pitch.pitch_mm;
  reading.threads.pitch_stderr_mm = reading.pitch.pitch_stderr_mm;
  if (reading.pitch.found && LinesAlongTheAxis(reading.pitch)) {
    // Read across the lobe, the stretches between its caustics may hold the
    // lobe's own glints, which stand where the undulation mirrors and not
    // on the axial threads' tops: the threads' roundness is fitted beside it.
    AxialPitch lines = reading.pitch;
    lines.local.erase(std::remove_if(lines.local.begin(), lines.local.end(),
                                     [&](const LocalPitch& l) {
                                       return l.azimuth_rad > lobe.from_rad &&
                                              l.azimuth_rad < lobe.to_rad;
                                     }),
                      lines.local.end());
    reading.threads = ThreadPitchFromGlints(lines, reading.beside_lobe ? beside : whole,
                                            peaks.mirror_rad, options.round_threads);
  }
  return reading;
}

// What one photograph's glints gave, kept between its readings
// (ReadWavelength) from one set of peaks, which differ only in how the
// split was called (sawtooth or not): the lattice of glint lines and every
// comb fit, each a pure function of the photograph, the peaks and its
// start, so that a second reading reuses them rather than fitting anew.
struct GlintMemo {
  struct Fit {
    double start_mm = 0.0, max_slope = 0.0;
    CombFitOptions::Relief relief = CombFitOptions::Relief::kCompare;
    CombRows rows_in, rows_out;  // the rows it was given (none: chosen), and fitted
    absl::StatusOr<CombFitResult> result;
  };
  std::optional<LatticeReading> lattice;
  std::vector<Fit> fits;
};

bool SameRows(const CombRows& a, const CombRows& b) {
  return a.rows == b.rows && a.phase_mm == b.phase_mm && a.thread == b.thread;
}

// Comb fits (glints/comb_fit.h) from starting periods in turn, the first
// the fit confirms kept: it converged, explains `needed` of the rows'
// variance, stays within `reach` of its start and 30 % of the profile's max
// slope, and needs a lens blur the limbs could show.
class CombFitter {
 public:
  CombFitter(const Image& luminance, const CylinderGeometry& cylinder, const Projection& projection,
             const ArcSignalOptions& wide, const ArcSignals& wide_signals, const GlintModel& model,
             const CombFitOptions& options, GlintMemo* memo)
      : luminance_(luminance),
        cylinder_(cylinder),
        projection_(projection),
        wide_(wide),
        wide_signals_(wide_signals),
        model_(model),
        options_(options),
        memo_(memo) {}

  // `period_needed` (at most `needed`): a fit that meets every test but
  // explains only this share is kept as period_only().
  std::optional<CombFitResult> First(const std::vector<double>& starts, double needed,
                                     double reach = 0.05, double period_needed = 1.0);
  const std::optional<CombFitResult>& period_only() const { return period_only_; }
  // Why the last call's first start was not taken (empty if none was tried).
  const std::string& failure() const { return failure_; }

 private:
  // On `rows` when it holds any (phased anew at `start`), else on rows
  // chosen for `start`, which it then holds, with the glints placed as
  // `placed` says (else as the options do); as the memo kept it, if it
  // holds this fit.
  absl::StatusOr<CombFitResult> Fit(
      const GlintModel& model, double start, CombRows* rows,
      std::optional<CombFitOptions::Relief> placed = std::nullopt) const {
    const CombFitOptions::Relief relief = placed.value_or(options_.relief);
    for (const GlintMemo::Fit& f : memo_->fits) {
      if (f.start_mm == start && f.max_slope == model.max_slope && f.relief == relief &&
          SameRows(f.rows_in, *rows)) {
        *rows = f.rows_out;
        return f.result;
      }
    }
    GlintMemo::Fit f;
    f.start_mm = start;
    f.max_slope = model.max_slope;
    f.relief = relief;
    f.rows_in = *rows;
    CombFitOptions options = options_;
    options.relief = relief;
    f.result = FitCombOverLobe(luminance_, cylinder_, projection_, wide_, wide_signals_, model,
                               start, options, rows);
    f.rows_out = *rows;
    memo_->fits.push_back(f);
    return f.result;
  }
  // The lens PSF the comb fit needs must be one the limbs could show
  // (CombPsfPlausible).
  bool PsfPlausible(const CombFitResult& fit) const {
    return CombPsfPlausible(fit.psf_px, cylinder_.lens_blur_px);
  }
  static bool Near(const CombFitResult& fit, double start, double reach, double max_slope) {
    return std::fabs(fit.wavelength_mm / start - 1.0) < reach &&
           std::fabs(fit.max_slope / max_slope - 1.0) < 0.3;
  }

  const Image& luminance_;
  const CylinderGeometry& cylinder_;
  const Projection& projection_;
  const ArcSignalOptions& wide_;
  const ArcSignals& wide_signals_;
  const GlintModel& model_;
  const CombFitOptions& options_;
  GlintMemo* memo_;
  std::string failure_;
  std::optional<CombFitResult> period_only_;
};

std::optional<CombFitResult> CombFitter::First(const std::vector<double>& starts,
                                               double needed, double reach,
                                               double period_needed) {
  failure_.clear();
  period_only_.reset();
  for (double start : starts) {
    CombRows rows;
    absl::StatusOr<CombFitResult> comb = Fit(model_, start, &rows);
    if (comb.ok() && comb->converged && comb->explained >= std::min(needed, period_needed) &&
        Near(*comb, start, reach, model_.max_slope) && PsfPlausible(*comb)) {
      const bool whole = comb->explained >= needed;
      CombFitResult best = *comb;
      if (best.reduced_chi2 > 1.0) {
        // Residuals above the start's noise scale: a false optimum, or
        // structure the comb does not model. A second fit started from this
        // one's max slope and period, on the same rows and with its glints
        // placed as this one's, tells them apart: the one that explains
        // more of those rows is kept.
        GlintModel again = model_;
        again.max_slope = best.max_slope;
        using Relief = CombFitOptions::Relief;
        const Relief placed = options_.relief != Relief::kCompare ? options_.relief
                              : best.relief_parallax              ? Relief::kOnFacets
                                                                  : Relief::kMeanCylinder;
        absl::StatusOr<CombFitResult> second = Fit(again, best.wavelength_mm, &rows, placed);
        if (second.ok() && second->converged && second->explained > best.explained &&
            PsfPlausible(*second) && Near(*second, start, reach, model_.max_slope)) {
          best = *second;
        }
      }
      if (whole) return best;
      if (!period_only_) period_only_ = best;
    }
    if (failure_.empty()) {
      failure_ = !comb.ok()         ? std::string(comb.status().message())
                 : !comb->converged ? comb->message
                 : !PsfPlausible(*comb)
                     ? absl::StrFormat("at %.3f mm it needs a lens blur of %.2f px where the "
                                       "limbs show %.2f px",
                                       comb->wavelength_mm, comb->psf_px, cylinder_.lens_blur_px)
                     : absl::StrFormat("it explains %.0f%% of the rows' variance at %.3f mm",
                                       100.0 * comb->explained, comb->wavelength_mm);
    }
  }
  return std::nullopt;
}

// Where a lattice was read, in a warning's words.
const char* LatticeWhere(const LatticeReading& lattice) {
  return lattice.beside_lobe ? "beside the lobe" : "across the lobe";
}

// What the lattice of glint lines said, for a wavelength left unresolved.
std::string LatticeWords(const LatticeReading& lattice, const AxialPitchOptions& options) {
  const AxialPitch& p = lattice.pitch;
  if (!p.found) return p.reason;
  const char* where = LatticeWhere(lattice);
  if (!LinesAlongTheAxis(p)) {
    return absl::StrFormat(
        "%s a pattern repeats every %.3f mm, but neither in lines along the axis (%.0f%% of "
        "its power in them) nor in rows alternating from one circumferential thread to the "
        "next, as a plain weave's relief would (%.0f%%, %.0f%% needed), so nothing tells the "
        "period from half of it, and the comb of glints confirmed neither it nor twice it",
        where, p.pitch_mm, 100.0 * p.aligned, 100.0 * p.checker, 100.0 * options.min_checker_share);
  }
  if (!lattice.beside_lobe && p.aligned < kMinAlignedAcrossLobe) {
    return absl::StrFormat(
        "glint lines %.3f mm apart were seen only across the lobe, with too little of their "
        "power in lines along the axis (%.0f%%) to tell them from the lobe's own glints, and "
        "the comb of glints confirmed neither their spacing nor twice it",
        p.pitch_mm, 100.0 * p.aligned);
  }
  return absl::StrFormat(
      "%s glint lines stand %.3f mm apart, but lines along the axis at twice that spacing are "
      "%.0f%% as strong, so the lines may be a harmonic of a coarser pattern, and the comb of "
      "glints confirmed neither twice nor once their spacing",
      where, p.pitch_mm, 100.0 * CoarserLines(p));
}

// Without the axial threads' lines: the glints counted along the lobe's
// rows (glints/glint_period.h) propose periods, and the first the comb fit
// confirms is kept. Otherwise `why` says, after "wavelength and amplitude
// unresolved: ", why not.
std::optional<CombFitResult> WavelengthFromGlintCount(
    const absl::StatusOr<ArcSignals>& signals, const GlintModel& model, bool sawtooth_read,
    const EstimateOptions& options, CombFitter* comb, const std::string& comb_unavailable,
    std::string* why) {
  const std::string sawtooth_unresolved =
      "a sawtooth mirrors only at the two caustic azimuths, so its glints do not repeat along "
      "the arc";
  absl::StatusOr<GlintPeriodResult> period =
      signals.ok() ? EstimateGlintPeriod(*signals, model, options.glints)
                   : absl::StatusOr<GlintPeriodResult>(signals.status());
  if (!period.ok()) {
    *why = sawtooth_read ? sawtooth_unresolved : std::string(period.status().message());
    return std::nullopt;
  }
  // The comb fit, from the period found or, when the glint count found it
  // too weak to call, from its best candidates in turn (the fit is the
  // stronger test: a wrong period explains little of the rows).
  std::vector<double> starts;
  if (period->resolved) {
    starts.push_back(period->wavelength_mm);
  } else {
    if (period->candidate_mm > 0.0) starts.push_back(period->candidate_mm);
    for (double c : period->candidates_mm) {
      bool near = false;
      for (double s : starts) near |= std::fabs(c / s - 1.0) < 0.05;
      if (!near && starts.size() < 3) starts.push_back(c);
    }
  }
  const double needed = period->resolved && !sawtooth_read ? options.comb.min_explained
                                                           : options.comb.min_explained_alone;
  if (comb) {
    if (std::optional<CombFitResult> best = comb->First(starts, needed)) return best;
  }
  const std::string failure = comb ? comb->failure() : comb_unavailable;
  if (sawtooth_read) {
    *why = sawtooth_unresolved;
  } else if (!period->resolved) {
    *why = absl::StrCat(period->reason,
                        failure.empty() ? "" : "; the comb fit does not confirm it: ", failure);
  } else {
    // A period the glint count calls but the comb fit, the model of the
    // glints row by row, does not confirm is not reported: on photographs
    // rendered independently of weavefit, whose threads along the axis add
    // glint lines λ/2 apart, the count read λ/2, λ/4 or a period the image
    // does not resolve, 5 times with 1 % errors (5 of 5 wrong), where on 560
    // of weavefit's own random renders it answered 3 times, all right.
    *why = absl::StrFormat(
        "the glints' count suggests %.3f mm, but the comb fit, which models the glints row by "
        "row, does not confirm it (%s)",
        period->wavelength_mm, failure.empty() ? std::string("no fit") : failure);
  }
  return std::nullopt;
}

// The limbs' errors where the profile put the mirror and the split.
LimbErrors ProfileLimbErrors(const Estimate& estimate, const Acquisition& acquisition) {
  return LimbErrorsAt(estimate.cylinder, acquisition.GetProjection(),
                      estimate.specular_azimuth_rad.value, estimate.peak_spacing_rad.value);
}

// A wavelength without the comb's max slope: it and the amplitude from it
// and the profile's max slope.
void SetWavelength(const Quantity& lambda, Estimate* estimate) {
  estimate->wavelength_mm = lambda;
  estimate->amplitude_mm =
      AmplitudeFrom(estimate->model, estimate->max_slope, estimate->wavelength_mm);
}

// The comb fit's period alone (CombWavelength, its error counting
// ComparePeriods' difference), the max slope and spacing left as the
// profile read them, and the amplitude from both.
void ApplyCombPeriod(const CombFitResult& comb, const CombFitOptions& options,
                     const ThreadPitch& threads, const Acquisition& acquisition,
                     Estimate* estimate) {
  Quantity lambda = CombWavelength(comb, options, ProfileLimbErrors(*estimate, acquisition));
  const PeriodReadings readings =
      ComparePeriods(comb, options, threads.pitch_mm, threads.pitch_stderr_mm);
  lambda.stderr_value = std::hypot(lambda.stderr_value, readings.counted_mm);
  lambda.systematic = std::hypot(lambda.systematic, readings.counted_mm);
  SetWavelength(lambda, estimate);
  estimate->warnings.push_back(absl::StrFormat(
      "wavelength from the comb of glints fitted over %d rows, started from the axial threads' "
      "glint lines; it explains %.0f%% of the rows' variance, enough for the period the lines "
      "confirm but not for its max slope, which stays the profile's%s",
      comb.rows_used, 100.0 * comb.explained,
      readings.counted_mm > 0.0
          ? absl::StrFormat("; the lines give %.3f mm, %.1f%% apart, beyond both readings' "
                            "errors, and the period's error counts the difference",
                            readings.lattice_mm, 100.0 * readings.counted_mm / comb.wavelength_mm)
          : std::string()));
}

// A comb fit started from the lattice and taken whole: where the lattice's
// reading of the period differs from the comb's beyond both their errors
// (ComparePeriods), one of the two is wrong, and the period's error counts
// the difference, as ApplyCombPeriod does. A comb that explains most of its
// rows can still sit in a false optimum between its start and the truth:
// at 38 px per period in strong stray light a comb with the floats modelled
// explained 86 % at 1.6 % long (the lines 3.4 % long, the truth between).
void CountLatticeDifference(const CombFitResult& comb, const CombFitOptions& options,
                            const ThreadPitch& threads, Estimate* estimate) {
  const PeriodReadings readings =
      ComparePeriods(comb, options, threads.pitch_mm, threads.pitch_stderr_mm);
  if (!(readings.counted_mm > 0.0)) return;
  Quantity lambda = estimate->wavelength_mm;
  lambda.stderr_value = std::hypot(lambda.stderr_value, readings.counted_mm);
  lambda.systematic = std::hypot(lambda.systematic, readings.counted_mm);
  SetWavelength(lambda, estimate);
  estimate->warnings.push_back(absl::StrFormat(
      "the axial threads' glint lines give a period of %.3f mm, %.1f%% from the comb's, beyond "
      "both readings' errors; the wavelength's error counts the difference",
      readings.lattice_mm, 100.0 * readings.counted_mm / comb.wavelength_mm));
}

// The wavelength as twice the axial threads' pitch, when the comb of
// circumferential glints did not confirm a period: its error is the threads'
// pitch's (the lines' and ρ's, glints/round_threads.h) and the limbs' scale.
void ApplyLatticePeriod(const LatticeReading& lattice, const Acquisition& acquisition,
                        const std::string& comb_failure, Estimate* estimate) {
  const LimbErrors limbs = ProfileLimbErrors(*estimate, acquisition);
  const ThreadPitch& t = lattice.threads;
  const double lambda = 2.0 * t.pitch_mm;
  const double sys =
      std::hypot(2.0 * t.model_stderr_mm, limbs.wavelength_relative_systematic * lambda);
  const double se = std::hypot(2.0 * t.pitch_stderr_mm, limbs.wavelength_relative * lambda);
  SetWavelength({lambda, se, true, 0.0, sys, sys}, estimate);
  estimate->warnings.push_back(absl::StrFormat(
      "wavelength from the axial threads' glint lines: %.0f lines over %d rows, %.3f mm apart "
      "as seen; each glint slides over its round thread with the mirror azimuth, and threads "
      "whose tops curve with a radius of %.2f ± %.2f mm (%s) stand %.3f mm apart; a plain "
      "weave's period is twice that, and the comb of circumferential glints did not confirm it%s",
      lattice.pitch.pitches_in_arc, lattice.pitch.rows_used, lattice.pitch.pitch_mm,
      t.glint_radius_mm, t.glint_radius_stderr_mm,
      t.stretches > 0 ? absl::StrFormat("fitted to the lines' pitch along %d stretch%s of arc, "
                                        "with a plain weave's prior",
                                        t.stretches, t.stretches == 1 ? "" : "es")
                      : std::string("a plain weave's prior: no stretch of arc beside the lobe "
                                    "showed the slide"),
      t.pitch_mm,
      comb_failure.empty() ? std::string() : absl::StrCat(" (", comb_failure, ")")));
}

// The period from a plain weave's relief alone (RowsAlternate): the
// lattice's pitch itself. Besides the jackknife's error and the limbs', the
// pattern's phase may drift across the arc read: the relief shades a facet
// by its height (crests lit, troughs shaded) and by its tilt to the line of
// sight, a quarter period out of step with the height, whose share changes
// sign across the line of sight, so the pattern's phase turns by less than
// half a period from one end of the arc to the other, and its pitch over N
// pitches of arc may be off by up to 1/(2N), taken as uniform
// (σ = 1/(2√3·N)). On weavefit's renders of stray-lit plain weaves (lab
// random scenes) the drift came to −0.74 to +0.27 of a period, mostly
// within ±0.2; the pitch short in most. It depends on the photograph's geometry, not the sample's.
void ApplyReliefPeriod(const LatticeReading& lattice, const Acquisition& acquisition,
                       const std::string& comb_failure, Estimate* estimate) {
  const LimbErrors limbs = ProfileLimbErrors(*estimate, acquisition);
  const AxialPitch& p = lattice.pitch;
  const double lambda = p.pitch_mm;
  const double drift = lambda / (2.0 * std::sqrt(3.0) * p.pitches_in_arc);
  const double common = limbs.wavelength_relative_systematic * lambda;
  const double sys = std::hypot(common, drift);
  const double se =
      std::hypot(std::hypot(p.pitch_stderr_mm, drift), limbs.wavelength_relative * lambda);
  SetWavelength({lambda, se, true, 0.0, sys, common}, estimate);
  estimate->warnings.push_back(absl::StrFormat(
      "wavelength from the weave's relief: %s a pattern repeats every %.3f mm over %d rows, "
      "alternating from one circumferential thread to the next (%.0f%% of its power), as a "
      "plain weave's relief does, whose neighbouring threads stand half a period out of step, "
      "so the period is the pattern's own; its error counts a drift of the pattern's phase of "
      "up to half a period over the %.1f periods read, as the relief's shading turns from its "
      "height's to its tilt's; the comb of glints did not confirm it%s",
      LatticeWhere(lattice), p.pitch_mm, p.rows_used, 100.0 * p.checker, p.pitches_in_arc,
      comb_failure.empty() ? std::string() : absl::StrCat(" (", comb_failure, ")")));
}

// The wavelength from the glints, and the amplitude from it and the max
// slope (DESIGN.md §3). The axial threads' lines give the period's first
// word (twice their pitch); the comb of circumferential glints in the lobe,
// fitted row by row from it, the last. Without lines, the glints counted in
// the lobe propose the periods the comb fit tries.
// What the glints say of the period (ReadWavelength), before it is applied
// to an estimate (ApplyWavelength).
struct WavelengthReading {
  LatticeReading lattice;
  bool lattice_alone = false;  // the lattice alone gives the period
  // A comb fit taken whole, and whether it started from the lattice.
  std::optional<CombFitResult> best;
  bool from_lattice = false;
  // A comb fit from the lattice that gives the period only.
  std::optional<CombFitResult> period_only;
  std::string comb_failure, period_failure;
};

// The glints' reading of the period for a split read as a sawtooth or not
// (`sawtooth_read`): the lattice of glint lines, then comb fits from its
// pitch or from the glints' count. A pure function of the photograph and
// the peaks, so that it can run beside the lobe fits; `memo` (kept for one
// photograph and its peaks) spares a second reading the lattice and the
// fits the first made.
//
// A sawtooth mirrors only at the two caustic azimuths, so its glints do
// not repeat along the arc. A split is called a sawtooth from the low
// level between its peaks (peak picking, the lobe fits), which a steep
// sinusoid shares (m = 0.79: 0.04-0.06 of the peaks' height, read as a
// sawtooth 1.2° short, 3-4 stated errors). So the glints are still timed:
// a period the comb fit confirms as strictly as one the glint count could
// not call makes it a sinusoid after all.
WavelengthReading ReadWavelength(const Image& luminance, const CylinderGeometry& cylinder,
                                 const Acquisition& acquisition, const PeakPickingResult& peaks,
                                 double pixel_noise, const EstimateOptions& options,
                                 bool sawtooth_read, GlintMemo* memo) {
  WavelengthReading reading;
  const Projection projection = acquisition.GetProjection();
  GlintModel model;
  model.max_slope = peaks.max_slope;
  model.max_slope_stderr = peaks.max_slope_stderr;
  model.phase_angle_rad = acquisition.phase_angle_rad;
  model.projection = projection;
  model.mm_per_px = projection.radius_mm / cylinder.radius_px;
  model.pixel_noise = pixel_noise;
  model.lens_blur_px = cylinder.lens_blur_px;
  if (!memo->lattice) {
    memo->lattice = ReadAxialLattice(luminance, cylinder, projection, acquisition.phase_angle_rad,
                                     peaks, model, options);
  }
  reading.lattice = *memo->lattice;
  const LatticeReading& lattice = reading.lattice;
  const double half = 0.5 * peaks.spacing_rad;
  const double limit = projection.VisibleLimbRad() - 3.0 * kDeg;
  ArcSignalOptions arc;
  arc.from_rad = std::max(peaks.mirror_rad - 0.9 * half, -limit);
  arc.to_rad = std::min(peaks.mirror_rad + 0.9 * half, limit);
  // The period search uses at most 96 rows with glints; twice as many
  // candidates is plenty and keeps large images cheap.
  arc.max_rows = 192;
  absl::StatusOr<ArcSignals> signals = ExtractArcSignals(luminance, cylinder, projection, arc);
  // The signals over the comb's wider range, along the rows ranked in the
  // lobe (its glints rank them the same way).
  ArcSignalOptions wide = WideArcRange(peaks, projection);
  if (signals.ok()) wide.rows = signals->rows;
  const absl::StatusOr<ArcSignals> wide_signals =
      signals.ok() ? ExtractArcSignals(luminance, cylinder, projection, wide)
                   : absl::StatusOr<ArcSignals>(signals.status());
  std::optional<CombFitter> comb;
  if (wide_signals.ok()) {
    comb.emplace(luminance, cylinder, projection, wide, *wide_signals, model, options.comb, memo);
  }
  // The lattice alone gives the period when it is made of lines along the
  // axis (the axial threads, λ/2 apart; across the lobe, more clearly so)
  // and no coarser pattern of lines along the axis rivals them.
  reading.lattice_alone = lattice.pitch.found && LinesAlongTheAxis(lattice.pitch) &&
                          (lattice.beside_lobe || lattice.pitch.aligned >= kMinAlignedAcrossLobe) &&
                          CoarserLines(lattice.pitch) < kLatticeMaxHalf;
  const bool lattice_alone = reading.lattice_alone;
  std::optional<CombFitResult>& best = reading.best;
  if (comb && lattice.pitch.found) {
    // Lines along the axis are the axial threads, λ/2 apart: the comb starts
    // from twice their spacing (and, read across the lobe, whose glints may
    // have made the lattice's fundamental λ, from the spacing too, unless
    // the lines alone give the period). A lattice not in lines along the
    // axis is a plain weave's relief, which repeats with λ: its spacing
    // first, then twice it. The comb must land within LatticeCombReach of
    // its start; one that explains less of the rows than min_explained, but
    // kLatticePeriodExplained, gives the period only (the lattice stands
    // behind it; the slope stays the profile's).
    std::vector<double> starts = {2.0 * lattice.threads.pitch_mm, lattice.threads.pitch_mm};
    if (!LinesAlongTheAxis(lattice.pitch)) std::swap(starts[0], starts[1]);
    // A comb that overturns a sawtooth read (whose own glints do not repeat)
    // must stand on the lattice's first reading of λ (OverturnReach): from a
    // second guess at twice it, a "sinusoid" of twice the period explained a
    // sawtooth's caustics and relief to 90 %.
    if (lattice_alone || sawtooth_read ||
        (lattice.beside_lobe && LinesAlongTheAxis(lattice.pitch))) {
      starts.pop_back();
    }
    best = comb->First(starts,
                       sawtooth_read ? options.comb.min_explained_alone
                                     : options.comb.min_explained,
                       sawtooth_read ? OverturnReach(lattice.threads)
                                     : LatticeCombReach(lattice.threads),
                       sawtooth_read ? 1.0 : kLatticePeriodExplained);
    if (!best) reading.period_only = comb->period_only();
  }
  reading.from_lattice = best.has_value();
  if (!best && !lattice_alone) {
    best = WavelengthFromGlintCount(signals, model, sawtooth_read, options, comb ? &*comb : nullptr,
                                    std::string(wide_signals.status().message()),
                                    &reading.period_failure);
  }
  // A whole comb from the glints' count stands over a comb from the
  // lattice that gave the period alone: it passed the stricter test. On a
  // lens-blurred render (17 px per period) a comb at twice the period of
  // the weave's relief explained 57 % or 71 % of the rows, as its start
  // moved by rounding, where the count's period gave a comb that explained
  // 95 %.
  if (best) reading.period_only.reset();
  if (!best) {
    reading.comb_failure = comb ? comb->failure() : std::string(wide_signals.status().message());
  }
  return reading;
}

// The glints' reading applied: the comb's numbers, or its period alone, or
// the lattice's, or why the wavelength is unresolved. True where the period
// came from the lattice alone (lines along the axis or a plain weave's
// relief), which stands without the caustics.
bool ApplyWavelength(const WavelengthReading& reading, const Acquisition& acquisition,
                     const PeakPickingResult& peaks, const EstimateOptions& options,
                     bool sawtooth_read, Estimate* estimate) {
  const LatticeReading& lattice = reading.lattice;
  if (reading.period_only) {
    ApplyCombPeriod(*reading.period_only, options.comb, lattice.threads, acquisition, estimate);
    return false;
  }
  if (const std::optional<CombFitResult>& best = reading.best) {
    // The model a confirmed comb names (select/): a sinusoid, unless the
    // lobe's shape decides a sawtooth.
    const ProfileModel model = ModelWithConfirmedComb(estimate->model, estimate->model_evidence);
    if (model != ProfileModel::kSinusoid) {
      estimate->warnings.push_back(absl::StrFormat(
          "wavelength and amplitude unresolved: the glints fit a sinusoid's comb of a %.3f mm "
          "period, but the lobe's shape is a sawtooth's (its fit beats the sinusoid's by %.0f "
          "BIC per independent bin), and a sawtooth's glints do not repeat along the arc",
          best->wavelength_mm, estimate->model_evidence));
      return false;
    }
    estimate->model = model;
    ApplyCombFit(*best, options.comb, acquisition, peaks.mirror_rad, estimate);
    if (reading.from_lattice) {
      CountLatticeDifference(*best, options.comb, lattice.threads, estimate);
    }
    if (sawtooth_read) {
      estimate->warnings.push_back(absl::StrFormat(
          "SINUSOID, not the SAWTOOTH the level between the peaks suggested: the glints repeat "
          "along the arc with a %.3f mm period, which a sawtooth's do not",
          best->wavelength_mm));
    }
    return false;
  }
  if (reading.lattice_alone) {
    ApplyLatticePeriod(lattice, acquisition, reading.comb_failure, estimate);
    return true;
  }
  if (RowsAlternate(lattice.pitch)) {
    ApplyReliefPeriod(lattice, acquisition, reading.comb_failure, estimate);
    return true;
  }
  estimate->warnings.push_back(
      absl::StrCat("wavelength and amplitude unresolved: ", LatticeWords(lattice, options.lattice),
                   "; ", reading.period_failure));
  return false;
}

// Whether the glints can time the period at all: a split whose max slope
// stands (else a warning says why not).
bool HasGlintsToTime(const PeakPickingResult& peaks, Estimate* estimate) {
  if (peaks.split_resolved && estimate->max_slope.resolved) return true;
  estimate->warnings.push_back(
      "wavelength and amplitude unresolved: with no split there are no "
      "glints along the arc to time the thread period by");
  return false;
}

// The lens blur (σ, px) the limbs must show for `balanced` to fit the models
// to the profile too.
constexpr double kFitsFromLensBlurPx = 1.0;

// The profile fits' options: the profile smoothed as peak picking read it,
// the model seen through the lens blur the limbs show.
ProfileFitOptions FitOptionsFor(const PeakPickingResult& peaks, const EstimateOptions& options,
                                const CylinderGeometry& cylinder) {
  ProfileFitOptions fit_options;
  fit_options.smoothing_rad = peaks.smoothing_rad;
  fit_options.max_iterations = options.fit_max_iterations;
  fit_options.lens_blur_px = cylinder.lens_blur_px;
  fit_options.half_width_px = cylinder.radius_px / std::cos(cylinder.axis_angle_rad);
  return fit_options;
}

// `accurate` mode: least-squares fits of every candidate model to the
// profile (smoothed as peak picking found necessary), the lowest BIC wins.
// The curves of a fit plot (EstimateOptions::include_curves): the profile
// smoothed as peak picking read it, and each model fitted to it. Runs the
// profile fits afresh, so it changes nothing in the estimate.
void AddCurves(const PeakPickingResult& peaks, const Acquisition& acquisition,
               const EstimateOptions& options, Estimate* estimate) {
  const Profile& profile = estimate->profile;
  if (profile.NumBins() == 0) return;
  ModelCurve smoothed;
  smoothed.label = "smoothed profile";
  smoothed.model = estimate->model;
  smoothed.azimuth_rad = profile.azimuth_rad;
  smoothed.value = Smooth(profile.mean, peaks.smoothing_rad / std::max(profile.bin_width_rad, 1e-9));
  estimate->curves.push_back(std::move(smoothed));
  const ProfileFitOptions fit_options = FitOptionsFor(peaks, options, estimate->cylinder);
  const double start = estimate->max_slope.resolved ? estimate->max_slope.value
                                                     : (peaks.split_resolved ? peaks.max_slope : 0.2);
  absl::StatusOr<ProfileFitResult> fits = FitProfileModels(
      profile, acquisition.phase_angle_rad, acquisition.GetProjection(), start, fit_options);
  if (!fits.ok()) return;
  for (const ModelFit& fit : fits->fits) {
    if (fit.curve.empty()) continue;
    estimate->curves.push_back({absl::StrCat(ProfileModelName(fit.model), " fit"), fit.model,
                                fit.model == estimate->model, fit.curve_azimuth_rad, fit.curve});
  }
}

// The split and mirror azimuth from the chosen model's fit to the whole
// lobe. Its errors are the fit's covariance, scaled by the reduced
// chi-square and by the residuals' correlation (FitProfileModels), and what
// the model leaves out:
// - a sawtooth: the real shape its fitted corners leave out
//   (kSawtoothShapeFloor of the spacing, common to the sample); a sinusoid:
//   the comb fit's floor and mismatch for threads of another make, relative
//   to m, common too (on renders with a 2 px lens blur the fits read 0.3 %
//   short where the covariance said 0.04 %);
// - a sinusoid whose lobe is a comb of glints: the fitted lobe is the limit
//   of every weave phase in view, and the caustic's outermost glint stands
//   anywhere within a tooth gap g inside the caustic, as the threads' phase
//   there falls. Uniform over [0, g] on each side independently, that is
//   g/√12 per caustic: g/√6 on the spacing.
// Either shares the two caustics independently, so the mirror azimuth, their
// midpoint, has half the spacing's allowance (g/√24 for the comb).
void ApplyLobeFit(const ModelFit& fit, const PeakPickingResult& peaks,
                  const CombFitOptions& thread_model, Estimate* estimate) {
  estimate->method = "least-squares";
  if (fit.model == ProfileModel::kSmooth) {
    estimate->specular_azimuth_rad = {fit.mirror_rad, fit.mirror_stderr_rad, true};
    // Keep peak picking's upper bound, when it set one.
    estimate->peak_spacing_rad = {0.0, 0.0, false, estimate->peak_spacing_rad.upper_bound};
    estimate->max_slope = {0.0, 0.0, false, estimate->max_slope.upper_bound};
    return;
  }
  const double spacing = PeakSpacingRad(fit.max_slope);
  const double statistical = 2.0 * fit.max_slope_stderr / (1.0 + fit.max_slope * fit.max_slope);
  const bool sawtooth = fit.model == ProfileModel::kSawtooth;
  // A sinusoid's shape floor is the comb fit's for the same model: its max
  // slope's floor and its mismatch with threads of another make, relative
  // to m (CombFitOptions), which the spacing 2·arctan m carries as
  // 2·m/(1 + m²) times.
  const double m = fit.max_slope;
  const double common =
      sawtooth ? kSawtoothShapeFloor * spacing
               : std::hypot(thread_model.slope_floor, thread_model.slope_mismatch) * 2.0 * m /
                     (1.0 + m * m);
  const double gap = sawtooth ? 0.0 : peaks.comb_gap_rad;
  const double sys = std::hypot(common, gap / std::sqrt(6.0));
  // Each caustic's own share: the spacing's over √2; their midpoint's, half
  // the spacing's.
  const double mirror_sys = 0.5 * sys;
  const double sec = 1.0 / std::cos(0.5 * spacing);
  const double per_spacing = 0.5 * sec * sec;
  const double dspacing = std::hypot(statistical, sys);
  estimate->peak_spacing_rad = {spacing, dspacing, true, 0.0, sys, common};
  estimate->max_slope = {fit.max_slope, per_spacing * dspacing, true, 0.0, per_spacing * sys,
                         per_spacing * common};
  estimate->specular_azimuth_rad = {fit.mirror_rad, std::hypot(fit.mirror_stderr_rad, mirror_sys),
                                    true, 0.0, mirror_sys};
  estimate->warnings.push_back(absl::StrFormat(
      "split from a least-squares fit of the %s lobe to the profile (residuals correlated over "
      "%.0f bins, counted in the errors)%s%s",
      ProfileModelName(fit.model), fit.correlation_bins,
      sawtooth ? absl::StrFormat("; rounded corners fitted (%.0f %% of the arc), the shape "
                                 "they leave out counted as 1 %% of the spacing",
                                 100.0 * fit.corner_share)
               : std::string("; the sinusoid's mismatch with real threads counted as the comb "
                             "fit counts it"),
      gap > 0.0 ? absl::StrFormat("; the comb's outermost glints, up to a tooth gap (%.2f deg) "
                                  "inside each caustic, counted",
                                  gap / kDeg)
                : std::string()));
}

void FitModels(const PeakPickingResult& peaks, const Acquisition& acquisition,
               const EstimateOptions& options, Estimate* estimate) {
  const ProfileFitOptions fit_options = FitOptionsFor(peaks, options, estimate->cylinder);
  // Starting slopes: peak picking's, and in `accurate` those of the nearest
  // model shapes in the FLANN bank (estimator/init), which are also reported
  // as candidates. Per model the fit with the lowest BIC over the starts is
  // kept. (`balanced` starts from peak picking's alone: a second start
  // doubles the fits' time, and the fits' numbers stand only where their
  // caustics meet peak picking's peaks anyway, ChooseProfileModel.)
  std::vector<double> starts = {peaks.split_resolved ? peaks.max_slope : 0.2};
  absl::StatusOr<std::vector<BankMatch>> near =
      options.mode == Mode::kAccurate
          ? ProfileBank::Default().NearestPerModel(estimate->profile, peaks.mirror_rad,
                                                   acquisition.phase_angle_rad)
          : absl::StatusOr<std::vector<BankMatch>>(std::vector<BankMatch>{});
  if (near.ok() && !near->empty()) {
    const BankMatch* nearest = &near->front();
    for (const BankMatch& m : *near) {
      estimate->candidates.push_back({m.entry.model, "flann (nearest model shape)", m.distance, false});
      if (m.distance < nearest->distance) nearest = &m;
    }
    // The nearest shape's slope, when it has a split, starts the fits too.
    if (nearest->entry.model != ProfileModel::kSmooth &&
        std::fabs(nearest->entry.max_slope / starts.front() - 1.0) > 0.05) {
      starts.push_back(nearest->entry.max_slope);
    }
  } else if (!near.ok()) {
    estimate->warnings.push_back(absl::StrCat("model-shape bank not searched: ",
                                              near.status().message()));
  }
  // One window for all starts, the widest: the best BIC per model is kept
  // over the starts.
  ProfileFitOptions shared_window = fit_options;
  shared_window.window_max_slope = *std::max_element(starts.begin(), starts.end());
  absl::StatusOr<ProfileFitResult> fits;
  for (double start : starts) {
    absl::StatusOr<ProfileFitResult> f = FitProfileModels(
        estimate->profile, acquisition.phase_angle_rad, acquisition.GetProjection(), start,
        shared_window);
    if (!f.ok()) {
      if (!fits.ok() || fits->fits.empty()) fits = f;
      continue;
    }
    if (!fits.ok() || fits->fits.empty()) {
      fits = f;
      continue;
    }
    for (std::size_t i = 0; i < f->fits.size() && i < fits->fits.size(); ++i) {
      const ModelFit& candidate = f->fits[i];
      ModelFit& kept = fits->fits[i];
      if (candidate.converged && (!kept.converged || candidate.bic < kept.bic)) kept = candidate;
    }
  }
  if (!fits.ok() || fits->fits.empty()) {
    estimate->warnings.push_back(
        absl::StrCat("model fit failed, peak picking kept: ", fits.status().message()));
    return;
  }
  fits->best = -1;
  for (std::size_t i = 0; i < fits->fits.size(); ++i) {
    if (!fits->fits[i].converged) continue;
    if (fits->best < 0 || fits->fits[i].bic < fits->fits[fits->best].bic) {
      fits->best = static_cast<int>(i);
    }
  }
  if (fits->best < 0) {
    estimate->warnings.push_back("model fit failed, peak picking kept: no fit converged");
    return;
  }
  estimate->lobe_fits = *fits;
  const std::size_t first_fit = estimate->candidates.size();
  for (const ModelFit& f : fits->fits) {
    estimate->candidates.push_back({f.model, "least-squares (BIC)", f.converged ? f.bic : 1e300, false});
  }
  const ModelChoice choice = ChooseProfileModel(
      {peaks.split_resolved, peaks.model, peaks.spacing_rad, peaks.spacing_stderr_rad,
       peaks.smoothing_rad, peaks.comb_gap_rad,
       0.5 * (acquisition.phase_angle_rad +
              ViewAngleRad(peaks.mirror_rad, acquisition.GetProjection()))},
      *fits);
  if (!choice.reason.empty()) estimate->warnings.push_back("model: " + choice.reason);
  estimate->model = choice.model;
  if (choice.fit < 0) return;
  estimate->model_evidence = choice.evidence;
  estimate->candidates[first_fit + choice.fit].selected = true;
  for (CandidateScore& c : estimate->candidates) {
    if (c.method == "peak-picking") c.selected = false;
  }
  ApplyLobeFit(fits->fits[choice.fit], peaks, options.comb, estimate);
}

// The cylinder the photograph is read through: the given one
// (GeometryFromGiven) when the acquisition has one, else detected on the
// photograph. Sets estimate->cylinder and ->cylinder_source, and the
// warning that says where it came from.
absl::StatusOr<CylinderGeometry> CylinderFor(const Image& luminance,
                                             const Acquisition& acquisition,
                                             const EstimateOptions& options, Estimate* estimate,
                                             DetectionTrace* trace = nullptr) {
  if (acquisition.given_cylinder) {
    absl::StatusOr<CylinderGeometry> given =
        GeometryFromGiven(*acquisition.given_cylinder, luminance.width, luminance.height,
                          acquisition.region);
    if (!given.ok()) return given.status();
    estimate->cylinder = *given;
    estimate->cylinder_source = acquisition.given_cylinder->source;
    estimate->warnings.push_back(GivenCylinderWarning(*acquisition.given_cylinder));
    return given;
  }
  CylinderDetectionOptions detection = options.detection;
  detection.region = acquisition.region;
  detection.phase_angle_rad = acquisition.phase_angle_rad;
  detection.projection = acquisition.GetProjection();
  absl::StatusOr<CylinderGeometry> cylinder = DetectCylinder(luminance, detection, trace);
  if (!cylinder.ok()) return cylinder.status();
  estimate->cylinder = *cylinder;
  estimate->cylinder_source = CylinderSource::kDetected;
  if (!cylinder->left_observed || !cylinder->right_observed) {
    estimate->warnings.push_back(absl::StrCat(
        "the ", cylinder->left_observed ? "right" : "left",
        " limb is lost in darkness and was inferred from the lit limb and the terminator "
        "(expect it within about 2 px); light the body or darken the background to see it"));
  }
  return cylinder;
}

// Without the cylinder's diameter a length on it is known in its radius
// only. The pipeline runs at a nominal diameter, and the wavelength and
// amplitude are then reported unresolved, their values in cylinder radii in
// the reason: a guessed diameter would scale every wavelength silently.
// The nominal diameter is a typical lab cylinder's, the one assumed before
// the diameter was required: nothing in the pipeline decides on
// millimetres (its priors are in thread pitches), so any would do.
constexpr double kNominalDiameterMm = 46.0;

void WithoutDiameter(Estimate* estimate) {
  const double radius_mm = kNominalDiameterMm / 2.0;
  auto in_radii = [&](const char* name, const Quantity& q) {
    return q.resolved ? absl::StrFormat("the %s is %.5g ± %.2g cylinder radii", name,
                                        q.value / radius_mm, q.stderr_value / radius_mm)
                      : std::string();
  };
  const std::string wavelength = in_radii("wavelength", estimate->wavelength_mm);
  const std::string amplitude = in_radii("amplitude", estimate->amplitude_mm);
  if (!wavelength.empty()) {
    estimate->warnings.push_back(absl::StrCat(
        "wavelength and amplitude unresolved in mm: no cylinder diameter was given (--diameter-mm, "
        "a manifest's diameter_mm or a sidecar's acquisition.cylinderDiameterMm); ",
        wavelength, amplitude.empty() ? "" : absl::StrCat(" and ", amplitude),
        "; multiply by the radius in mm"));
  }
  estimate->wavelength_mm = Quantity{};
  estimate->amplitude_mm = Quantity{};
}

absl::StatusOr<Estimate> EstimateWithDiameter(const Image& image, const Acquisition& acquisition,
                                              const EstimateOptions& options, Estimate estimate,
                                              StageClock& clock);

absl::StatusOr<Estimate> EstimateFromLuminance(const Image& image,
                                               const Acquisition& acquisition,
                                               const EstimateOptions& options,
                                               Estimate estimate,
                                               StageClock& clock) {
  estimate.acquisition = acquisition;
  estimate.mode = options.mode;
  if (acquisition.HasDiameter()) {
    return EstimateWithDiameter(image, acquisition, options, std::move(estimate), clock);
  }
  Acquisition nominal = acquisition;
  nominal.cylinder_diameter_mm = kNominalDiameterMm;
  absl::StatusOr<Estimate> e =
      EstimateWithDiameter(image, nominal, options, std::move(estimate), clock);
  if (e.ok()) WithoutDiameter(&*e);
  return e;
}

absl::StatusOr<Estimate> EstimateWithDiameter(const Image& image, const Acquisition& acquisition,
                                              const EstimateOptions& options, Estimate estimate,
                                              StageClock& clock) {
  // One channel is used as it is; three are reduced to luminance (a copy).
  Image converted;
  if (image.channels != 1) converted = Luminance(image);
  const Image& luminance = image.channels != 1 ? converted : image;
  absl::StatusOr<CylinderGeometry> cylinder =
      CylinderFor(luminance, acquisition, options, &estimate);
  if (!cylinder.ok()) return cylinder.status();
  if (absl::Status s = clock.Lap("detect"); !s.ok()) return s;

  const Projection projection = acquisition.GetProjection();
  // Fast mode reads at most 384 rows: plenty for the profile's peaks (on a
  // 12 Mpx photograph still over a thousand pixels per bin, and its peak
  // picking's error is the blur's bias, not noise), and it keeps that
  // photograph's profile about 2 ms. The other modes read every row: their comb
  // fit starts from these peaks, and a 12 Mpx render whose fit sat at the
  // acceptance threshold fell below it from a 1024-row start.
  ProfileOptions profile_options = options.profile;
  if (profile_options.max_rows == 0 && options.mode == Mode::kFast) {
    profile_options.max_rows = 384;
  }
  absl::StatusOr<Profile> profile =
      ExtractProfile(luminance, *cylinder, projection, profile_options);
  if (!profile.ok()) return profile.status();
  if (absl::Status s = clock.Lap("profile"); !s.ok()) return s;

  absl::StatusOr<PeakPickingResult> peaks =
      PickPeaks(*profile, acquisition.phase_angle_rad, projection, options.peaks);
  if (!peaks.ok()) return peaks.status();
  if (absl::Status s = clock.Lap("peaks"); !s.ok()) return s;
  if (image.channels == 3) {
    estimate.channels =
        SummariseChannels(image, *cylinder, acquisition, options, &estimate.warnings);
    if (absl::Status s = clock.Lap("channels"); !s.ok()) return s;
  }
  estimate.method = "peak-picking";
  estimate.profile = *std::move(profile);
  estimate.smoothing_rad = peaks->smoothing_rad;
  estimate.model = peaks->model;
  estimate.specular_azimuth_rad = {peaks->mirror_rad, peaks->mirror_stderr_rad, true, 0.0,
                                   peaks->mirror_systematic_rad};
  if (peaks->split_resolved) {
    estimate.peak_spacing_rad = {peaks->spacing_rad, peaks->spacing_stderr_rad, true, 0.0,
                                 peaks->spacing_systematic_rad, peaks->spacing_common_rad};
    estimate.max_slope = {peaks->max_slope, peaks->max_slope_stderr, true, 0.0,
                          peaks->max_slope_systematic, peaks->max_slope_common};
  } else if (const double bound = MaxSlopeUpperBound(estimate.profile, peaks->mirror_rad,
                                                      acquisition.phase_angle_rad);
             bound > 0.0) {
    estimate.max_slope.upper_bound = bound;
    estimate.peak_spacing_rad.upper_bound = PeakSpacingRad(bound);
    estimate.warnings.push_back(absl::StrFormat(
        "split unresolved: the lobe is one peak, so any split hides in its width; "
        "that width bounds the max slope to at most %.3f (peak spacing at most %.1f deg)",
        bound, PeakSpacingRad(bound) / kDeg));
  }
  // Scores: minus the significance of the dip between the peaks for a
  // split, minus the decision threshold for a single peak; lower is better.
  const double split_score = -peaks->dip_sigmas;
  const double smooth_score = -options.peaks.min_dip_sigmas;
  const ProfileModel split_model =
      peaks->split_resolved ? peaks->model : ProfileModel::kSinusoid;
  estimate.candidates.push_back({ProfileModel::kSmooth, "peak-picking",
                                 smooth_score, !peaks->split_resolved});
  estimate.candidates.push_back({split_model, "peak-picking", split_score,
                                 peaks->split_resolved});
  estimate.warnings.insert(estimate.warnings.end(), peaks->warnings.begin(),
                           peaks->warnings.end());
  if (estimate.profile.saturated_samples > 0) {
    estimate.warnings.push_back(absl::StrCat(
        estimate.profile.saturated_samples,
        " saturated pixels on the cylinder were left out of the profile; "
        "lower the exposure if they fall on the peaks"));
  }
  // The glints' reading of the period needs only the peaks: it runs beside
  // the lobe fits, for the split as peak picking called it (a sawtooth or
  // not), and is read again below where the fits call it otherwise (2 of the
  // 23 shared photographs with both, 12 of 75 lab scenes). Either way the
  // answer is the one read in turn. The fits go to another thread and the
  // reading stays on this one, whose memory is already in use: on a
  // 4096×3072 photograph the reading took 35 ms longer in a thread of its
  // own, the pages of its large buffers new to it. The reading's time is
  // counted in the "glints" lap, the fits' beyond it in the "fit" lap.
  const bool predicted_sawtooth = estimate.model == ProfileModel::kSawtooth;
  const double pixel_noise = estimate.profile.background_noise;
  std::optional<WavelengthReading> early_glints;
  GlintMemo memo;
  auto read_glints = [&luminance, &cylinder, &acquisition, &peaks, pixel_noise, &options,
                      &memo](bool sawtooth_read) {
    return ReadWavelength(luminance, *cylinder, acquisition, *peaks, pixel_noise, options,
                          sawtooth_read, &memo);
  };
  // `accurate` fits the models to the profile always; `balanced` where peak
  // picking read a split, whose model and numbers the fits of the whole lobe
  // then give (FitModels), or where the limbs show a lens blur of a pixel or
  // more, which widens each caustic by its own width in azimuth (1/cos φ)
  // where peak picking sees one blur.
  if (options.mode == Mode::kAccurate ||
      (options.mode == Mode::kBalanced &&
       (peaks->split_resolved || cylinder->lens_blur_px >= kFitsFromLensBlurPx))) {
    std::future<void> fits =
        std::async(std::launch::async, [&peaks, &acquisition, &options, &estimate] {
          FitModels(*peaks, acquisition, options, &estimate);
        });
    if (peaks->split_resolved) {
      early_glints = read_glints(predicted_sawtooth);
      clock.MoveToLater("glints");
    }
    fits.get();
    if (absl::Status s = clock.Lap("fit"); !s.ok()) return s;
  }
  {
    // The peaks were read through the limbs: their errors are the limbs'
    // too (a comb fit, below, counts them in its own).
    const LimbErrors limbs = LimbErrorsAt(
        estimate.cylinder, projection, estimate.specular_azimuth_rad.value,
        estimate.peak_spacing_rad.resolved ? estimate.peak_spacing_rad.value : 0.0);
    estimate.specular_azimuth_rad = WithLimbError(estimate.specular_azimuth_rad,
                                                  limbs.mirror_rad, limbs.mirror_systematic_rad);
    if (estimate.peak_spacing_rad.resolved) {
      estimate.peak_spacing_rad = WithLimbError(estimate.peak_spacing_rad, limbs.spacing_rad,
                                                limbs.spacing_systematic_rad);
      const double m = estimate.max_slope.value;
      const double per_spacing = 0.5 * (1.0 + m * m);
      estimate.max_slope = WithLimbError(estimate.max_slope, per_spacing * limbs.spacing_rad,
                                         per_spacing * limbs.spacing_systematic_rad);
    }
  }
  bool period_from_lattice = false;
  if (options.mode == Mode::kFast) {
    estimate.warnings.push_back(
        "wavelength and amplitude not analysed: fast mode reads the profile's peaks only "
        "(use balanced or accurate for the thread period)");
  } else {
    if (HasGlintsToTime(*peaks, &estimate)) {
      const bool sawtooth_read = estimate.model == ProfileModel::kSawtooth;
      const WavelengthReading reading = early_glints && sawtooth_read == predicted_sawtooth
                                            ? *std::move(early_glints)
                                            : read_glints(sawtooth_read);
      period_from_lattice =
          ApplyWavelength(reading, acquisition, *peaks, options, sawtooth_read, &estimate);
    }
    if (absl::Status s = clock.Lap("glints"); !s.ok()) return s;
  }
  if (peaks->split_resolved && estimate.peak_spacing_rad.resolved) {
    // A caustic within kMinCausticToLimbPx of the limb lies inside the
    // pixels the limb's edge fit always keeps (two either side of the
    // edge): the peak draws the limb out and the limb cuts the peak, and
    // a pixel there spans degrees of azimuth. A sawtooth with m = 0.49 at
    // α = −118° (R = 256 px, the outer caustic 2.5 px inside the limb) read
    // the limb 2.2 px out and the spacing 3.4° short at 7.7 stated errors.
    const Projection projection = acquisition.GetProjection();
    const double half = estimate.cylinder.radius_px / std::cos(estimate.cylinder.axis_angle_rad);
    const double outer = std::max(std::fabs(OffsetFromAzimuth(peaks->left_peak_rad, projection)),
                                  std::fabs(OffsetFromAzimuth(peaks->right_peak_rad, projection)));
    const double inside = half * (1.0 - outer);
    if (inside < kMinCausticToLimbPx) {
      // The model, too, rests there on the level between the peaks beside
      // the limb, unless the comb of glints confirmed it: on random scenes
      // with the outer caustic at 72-100° and a 1 px lens blur, 5 of 40
      // such readings named the wrong profile (README, Known limits).
      LeaveSplitUnresolved(
          absl::StrFormat(
              "the outer caustic lies %.1f px inside the limb, where the limb's edge and the "
              "peak cannot be told apart; photograph at a smaller phase angle%s",
              inside,
              estimate.method == "comb-fit"
                  ? ""
                  : absl::StrCat("; the profile (", ProfileModelName(estimate.model),
                                 ") is judged from the level between the peaks beside the limb, "
                                 "where a Lambertian term can fill a sawtooth's valley and faint "
                                 "glints leave a sinusoid's looking empty: treat it as uncertain")),
          &estimate, period_from_lattice);
      if (period_from_lattice) {
        // A lattice's period stands apart from the caustics, but its scale
        // is the radius's, and the limb the caustic drew out by up to
        // kMinCausticToLimbPx moves the radius by half that: counted as
        // uniform within it, systematic but not common to the sample's
        // photographs (the caustic's place depends on the phase angle).
        Quantity& lambda = estimate.wavelength_mm;
        const double pull = lambda.value * kMinCausticToLimbPx /
                            (2.0 * std::sqrt(3.0) * estimate.cylinder.radius_px);
        lambda.systematic = std::hypot(lambda.systematic, pull);
        lambda.stderr_value = std::hypot(lambda.stderr_value, pull);
      }
    }
  }
  if (estimate.method != "comb-fit" && estimate.peak_spacing_rad.resolved &&
      peaks->clipped_lobe_share > options.peaks.max_clipped_lobe_share) {
    // Clipped over most of its width, the lobe is a plateau whose inner
    // glints peak picking takes for the caustics (the bench sweep's
    // overexposure axis: 8.5° read for 27°, outside its error): no number
    // rather than a wrong one. The comb fit, which reads the glints
    // themselves, is kept when it ran.
    estimate.peak_spacing_rad = {};
    estimate.max_slope = {};
    estimate.wavelength_mm = {};
    estimate.amplitude_mm = {};
    estimate.warnings.push_back(absl::StrFormat(
        "split unresolved: %.0f%% of the lobe's azimuth bins are clipped at the sensor's maximum, "
        "so its caustic peaks cannot be read (the wavelength and amplitude, which lean on them, "
        "neither); lower the exposure until the lobe is mostly unclipped",
        100.0 * peaks->clipped_lobe_share));
  }
  if (estimate.method != "comb-fit") {
    // The mirror azimuth should be half the phase angle (a smooth cylinder's
    // brightest column sits a little off it; allow a degree besides 3 σ).
    // The comb fit makes its own check from the glints (ApplyCombFit).
    const double expected = 0.5 * (acquisition.phase_angle_rad +
                                    ViewAngleRad(peaks->mirror_rad, projection));
    const double miss = std::fabs(peaks->mirror_rad - expected);
    // So far off, the lobe read is not the one the stated acquisition makes:
    // a wrong phase angle, or a "cylinder" that is only the lobe's own
    // stripe of glints on a body as dark as the background (α = −29°,
    // 320×240: a 27 px cylinder, the lobe 28° off and a 26° sinusoid read
    // as a 13° sawtooth). No number is better than that one.
    if (miss > kMaxMirrorMissRad) {
      return absl::InvalidArgumentError(absl::StrFormat(
          "the brightest lobe stands at %.1f deg, %.1f deg from half the stated phase angle "
          "(%.1f deg), so it is not the specular lobe the acquisition makes: check the phase "
          "angle and its sign (positive = light on the image's right); if it is right, either "
          "the specular lobe is too dim beside the grazing scatter at the limb (expose more, "
          "or photograph at a smaller phase angle) or the cylinder found (axis at column %.1f, "
          "radius %.1f px) is not the cylinder (a body as dark as the background shows only "
          "its glints: light it, or lighten the background)",
          peaks->mirror_rad / kDeg, miss / kDeg, expected / kDeg, estimate.cylinder.center_x_px,
          estimate.cylinder.radius_px));
    }
    // The mirror azimuth reported (a lobe fit's where one replaced peak
    // picking's reading) against α/2.
    Quantity& mirror = estimate.specular_azimuth_rad;
    const double disagreement = std::fabs(mirror.value - expected);
    if (disagreement > 3.0 * mirror.stderr_value + 1.0 * kDeg) {
      // Either the reading or the stated geometry is that far off, and this
      // photograph cannot tell which (a clipped smooth lobe's plateau read
      // 3.8° from α/2 with an error of 0.19°): the mirror azimuth is
      // reported as read, with the disagreement counted in its error.
      const double sys = std::hypot(mirror.systematic, disagreement);
      mirror = {mirror.value, std::hypot(mirror.Statistical(), sys), true, 0.0, sys,
                mirror.common};
      estimate.warnings.push_back(absl::StrFormat(
          "the mirror azimuth %.2f deg is %.2f deg from half the stated phase "
          "angle (%.2f deg), more than its error explains, and its error counts that "
          "difference: check the phase angle and its sign (positive = light on the image's "
          "right)",
          mirror.value / kDeg, disagreement / kDeg, expected / kDeg));
    }
    // Several degrees beyond its error the lobe read is not what the stated
    // geometry makes, and its peaks cannot be trusted either: α = −90°,
    // m = 0.47, where the unlit limb was taken for the terminator and the
    // cylinder came out twice its size, read the lobe 14° off and the
    // spacing 16° short at 12 stated errors. The numbers stay, unresolved.
    if (miss > 3.0 * peaks->mirror_stderr_rad + kMirrorMissUnresolvedRad) {
      LeaveSplitUnresolved(
          absl::StrFormat("the lobe stands %.1f deg from where the stated phase angle and the "
                          "cylinder found put it, so the geometry it was read with is wrong (the "
                          "phase angle, or the cylinder: axis at column %.1f, radius %.1f px)",
                          miss / kDeg, estimate.cylinder.center_x_px, estimate.cylinder.radius_px),
          &estimate);
      // Nor is the split itself, where one peak explains the profile far
      // better (ChooseModelOffTheGeometry).
      const ProfileModel model = ChooseModelOffTheGeometry(estimate.model, estimate.lobe_fits);
      if (model != estimate.model) {
        double split_bic = 0.0, smooth_bic = 0.0;
        for (const ModelFit& f : estimate.lobe_fits.fits) {
          if (!f.converged) continue;
          if (f.model == ProfileModel::kSmooth) {
            smooth_bic = f.bic;
          } else if (split_bic == 0.0 || f.bic < split_bic) {
            split_bic = f.bic;
          }
        }
        estimate.warnings.push_back(absl::StrFormat(
            "model: the %s read is not where the geometry puts a split, and one peak explains "
            "the profile with a BIC %.1f times lower than a split's: SMOOTH",
            ProfileModelName(estimate.model), split_bic / smooth_bic));
        estimate.model = model;
        for (CandidateScore& c : estimate.candidates) {
          c.selected = c.method == "least-squares (BIC)" && c.model == ProfileModel::kSmooth;
        }
      }
    }
  }
  if (estimate.method == "peak-picking" && estimate.peak_spacing_rad.resolved &&
      !peaks->caveat.empty()) {
    estimate.warnings.push_back(peaks->caveat);
  }
  estimate.max_inclination_rad = MaxInclinationFromSlope(estimate.max_slope);
  if (options.include_curves) AddCurves(*peaks, acquisition, options, &estimate);
  estimate.timings = clock.laps();
  return estimate;
}

// The region's own consistency, before any image is seen: every field >= 0,
// and width and height given together. PixelRegion::IsEmpty needs both 0, so
// one alone would be read as a region 0 pixels wide or high; an offset
// without a size would be silently ignored.
absl::Status CheckRegionFields(const PixelRegion& r) {
  const std::pair<const char*, int> fields[] = {
      {"roi.x_px", r.x}, {"roi.y_px", r.y}, {"roi.width_px", r.width}, {"roi.height_px", r.height}};
  for (const auto& [name, value] : fields) {
    if (value < 0) {
      return absl::InvalidArgumentError(absl::StrFormat("%s must be >= 0, got %d", name, value));
    }
  }
  if ((r.width == 0) != (r.height == 0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "roi.width_px %d with roi.height_px %d: give both (> 0), or neither for the whole image",
        r.width, r.height));
  }
  if (r.IsEmpty() && (r.x != 0 || r.y != 0)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "roi.x_px %d, roi.y_px %d given without roi.width_px and roi.height_px", r.x, r.y));
  }
  return absl::OkStatus();
}

// One axis of CheckRegion: [start, start + size) within [0, extent).
absl::Status CheckSpan(const char* start_name, int start, const char* size_name, int size,
                       const char* dimension, int extent) {
  // 64 bits: x_px = 2147483547 with width_px = 200 wrapped round to a
  // negative sum in int, passed, and DetectCylinder read far outside the
  // image (SIGSEGV in weavefitd, issue 30).
  const std::int64_t end = std::int64_t{start} + size;
  if (end > extent) {
    return absl::InvalidArgumentError(absl::StrFormat("%s + %s = %d exceeds the image %s %d",
                                                      start_name, size_name, end, dimension,
                                                      extent));
  }
  if (start < 0 || size <= 0) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "%s %d with %s %d is not a span inside the image %s %d", start_name, start, size_name,
        size, dimension, extent));
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status CheckRegion(const PixelRegion& region, int width, int height) {
  if (region.IsEmpty()) return absl::OkStatus();
  if (absl::Status s = CheckSpan("roi.x_px", region.x, "roi.width_px", region.width, "width",
                                 width);
      !s.ok()) {
    return s;
  }
  return CheckSpan("roi.y_px", region.y, "roi.height_px", region.height, "height", height);
}

// Numbers are printed with %g: a value 300 digits long helps nobody.
absl::Status Acquisition::Validate() const {
  if (!(phase_angle_rad > -M_PI && phase_angle_rad < M_PI)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "phase_angle_deg must be in (-180, 180), got %g", phase_angle_rad / kDeg));
  }
  if (HasDiameter() &&
      !(cylinder_diameter_mm >= kMinDiameterMm && cylinder_diameter_mm <= kMaxDiameterMm)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "cylinder_diameter_mm must be 0 (not given) or in [%g, %g] (a lab cylinder), got %g",
        kMinDiameterMm, kMaxDiameterMm, cylinder_diameter_mm));
  }
  if (!HasDiameter() && camera_distance_mm != 0.0) {
    return absl::InvalidArgumentError(
        "camera_distance_mm needs cylinder_diameter_mm: the perspective is set by their ratio; "
        "give the cylinder's diameter too, or 0 for the distance (orthographic)");
  }
  const double radius_mm = cylinder_diameter_mm / 2.0;
  if (camera_distance_mm != 0.0 &&
      !(camera_distance_mm > radius_mm && camera_distance_mm <= kMaxCameraDistanceMm)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "camera_distance_mm must be 0 (orthographic) or beyond the cylinder radius %g and at "
        "most %g, got %g",
        radius_mm, kMaxCameraDistanceMm, camera_distance_mm));
  }
  if (!(saturation_level >= 0.0) || !std::isfinite(saturation_level)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "saturation_level must be finite and >= 0 (0 = the format's maximum), got %g",
        saturation_level));
  }
  if (absl::Status s = CheckRegionFields(region); !s.ok()) return s;
  return given_cylinder ? given_cylinder->Validate() : absl::OkStatus();
}

absl::Status EstimateOptions::Validate() const {
  if (max_pixels <= 0) return absl::InvalidArgumentError("max_pixels must be > 0");
  if (max_working_bytes < 0) {
    return absl::InvalidArgumentError("max_working_bytes must be >= 0 (0 = no limit)");
  }
  if (absl::Status s = detection.Validate(); !s.ok()) return s;
  if (absl::Status s = profile.Validate(); !s.ok()) return s;
  if (absl::Status s = lattice.Validate(); !s.ok()) return s;
  if (absl::Status s = round_threads.Validate(); !s.ok()) return s;
  if (absl::Status s = glints.Validate(); !s.ok()) return s;
  if (absl::Status s = comb.Validate(); !s.ok()) return s;
  return peaks.Validate();
}

Quantity MaxInclinationFromSlope(const Quantity& max_slope) {
  if (!max_slope.resolved) {
    return {0.0, 0.0, false, max_slope.upper_bound > 0.0 ? std::atan(max_slope.upper_bound) : 0.0};
  }
  const double m = max_slope.value;
  const double d = 1.0 / (1.0 + m * m);
  return {std::atan(m), max_slope.stderr_value * d, true, 0.0, max_slope.systematic * d,
          max_slope.common * d};
}

Quantity SpacingFromSlope(const Quantity& max_slope) {
  if (!max_slope.resolved) {
    return {0.0, 0.0, false,
            max_slope.upper_bound > 0.0 ? PeakSpacingRad(max_slope.upper_bound) : 0.0};
  }
  const double m = max_slope.value;
  const double d = 2.0 / (1.0 + m * m);
  return {PeakSpacingRad(m), max_slope.stderr_value * d, true, 0.0, max_slope.systematic * d,
          max_slope.common * d};
}

Quantity AmplitudeFrom(ProfileModel model, const Quantity& max_slope,
                       const Quantity& wavelength_mm) {
  if (!max_slope.resolved || !wavelength_mm.resolved || !(max_slope.value > 0.0) ||
      !(wavelength_mm.value > 0.0) || model == ProfileModel::kSmooth) {
    return {};
  }
  const double factor = model == ProfileModel::kSinusoid ? 1.0 / (2.0 * M_PI) : 0.25;
  const double h0 = factor * max_slope.value * wavelength_mm.value;
  const double rel = std::hypot(max_slope.stderr_value / max_slope.value,
                                wavelength_mm.stderr_value / wavelength_mm.value);
  const double rel_sys = std::hypot(max_slope.systematic / max_slope.value,
                                    wavelength_mm.systematic / wavelength_mm.value);
  const double rel_common = std::hypot(max_slope.common / max_slope.value,
                                       wavelength_mm.common / wavelength_mm.value);
  return {h0, h0 * rel, true, 0.0, h0 * rel_sys, h0 * rel_common};
}

std::string Estimate::BriefReport() const {
  if (!peak_spacing_rad.resolved) {
    return absl::StrFormat("%s, mirror %.2f±%.2f deg, split unresolved",
                           ProfileModelName(model), specular_azimuth_rad.value / kDeg,
                           specular_azimuth_rad.stderr_value / kDeg);
  }
  return absl::StrFormat("%s, spacing %.2f±%.2f deg, max slope %.4f±%.4f",
                         ProfileModelName(model), peak_spacing_rad.value / kDeg,
                         peak_spacing_rad.stderr_value / kDeg, max_slope.value,
                         max_slope.stderr_value);
}

absl::StatusOr<Estimate> EstimateFromImage(const Image& image,
                                           const Acquisition& acquisition,
                                           const EstimateOptions& options) {
  if (absl::Status s = acquisition.Validate(); !s.ok()) return s;
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (absl::Status s = CheckRegion(acquisition.region, image.width, image.height); !s.ok()) {
    return s;
  }
  Estimate estimate;
  estimate.image = {image.width, image.height, image.channels, image.format,
                    image.bit_depth, image.SaturatedCount()};
  StageClock clock(options.interrupt);
  return EstimateFromLuminance(image, acquisition, options, std::move(estimate), clock);
}

namespace {

// EstimateWorkingBytes from a header: what decoding holds, the luminance
// copy of a colour image (4 bytes a pixel), and a float a pixel for the
// detection's band profiles, the profile and the arc signals (together far
// less; measured on a 7999x7999 16-bit RGBA PNG: 1.25 GiB counted here,
// 1.02 GiB peak resident set of the daemon that estimated it).
std::int64_t WorkingBytes(const ImageHeader& header) {
  const std::int64_t pixels = std::int64_t{header.width} * header.height;
  const bool colour = header.samples == 0 || header.samples >= 3;
  return DecodedBytes(header) + (colour ? 4 : 0) * pixels + 4 * pixels;
}

absl::Status CheckWorkingBytes(const ImageHeader& header, const EstimateOptions& options) {
  if (options.max_working_bytes == 0) return absl::OkStatus();
  const std::int64_t need = WorkingBytes(header);
  if (need <= options.max_working_bytes) return absl::OkStatus();
  return absl::ResourceExhaustedError(absl::StrFormat(
      "estimating this %dx%d %s photograph takes about %.0f MiB, more than the %.0f MiB "
      "allowed (the daemon's --memory-budget-mb)",
      header.width, header.height, header.format, need / 1048576.0,
      options.max_working_bytes / 1048576.0));
}

// Decodes `bytes` and runs the pipeline; `release`, when given, is the
// caller's copy of the bytes, emptied once decoded.
absl::StatusOr<Estimate> DecodeAndEstimate(const std::string& bytes, std::string* release,
                                           const Acquisition& acquisition,
                                           const EstimateOptions& options) {
  if (absl::Status s = acquisition.Validate(); !s.ok()) return s;
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  Estimate estimate;
  StageClock clock(options.interrupt);
  DecodeOptions decode;
  decode.pixels_linear = acquisition.pixels_linear;
  decode.saturation_level = acquisition.saturation_level;
  decode.max_pixels = options.max_pixels;
  // The region and the memory against the header, before DecodeImage
  // allocates the pixels (a region far outside the image, or a
  // decompression bomb, is refused without decoding).
  absl::StatusOr<ImageHeader> header = ReadImageHeader(bytes);
  if (!header.ok()) return header.status();
  if (absl::Status s = CheckRegion(acquisition.region, header->width, header->height); !s.ok()) {
    return s;
  }
  if (acquisition.given_cylinder) {
    if (absl::Status s = GeometryFromGiven(*acquisition.given_cylinder, header->width,
                                           header->height, acquisition.region)
                             .status();
        !s.ok()) {
      return s;
    }
  }
  if (absl::Status s = CheckWorkingBytes(*header, options); !s.ok()) return s;
  absl::StatusOr<Image> image = DecodeImage(bytes, decode);
  if (release != nullptr) std::string().swap(*release);
  if (!image.ok()) return image.status();
  if (absl::Status s = clock.Lap("decode"); !s.ok()) return s;
  estimate.image = {image->width, image->height, image->channels, image->format,
                    image->bit_depth, image->SaturatedCount()};
  return EstimateFromLuminance(*image, acquisition, options, std::move(estimate), clock);
}

}  // namespace

absl::StatusOr<std::int64_t> EstimateWorkingBytes(const std::string& bytes) {
  absl::StatusOr<ImageHeader> header = ReadImageHeader(bytes);
  if (!header.ok()) return header.status();
  return WorkingBytes(*header);
}

absl::StatusOr<DetectedCylinder> DetectCylinderInBytes(const std::string& bytes,
                                                       const Acquisition& acquisition,
                                                       const EstimateOptions& options,
                                                       DetectionTrace* trace) {
  Acquisition detect = acquisition;
  detect.given_cylinder.reset();
  if (absl::Status s = detect.Validate(); !s.ok()) return s;
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  absl::StatusOr<ImageHeader> header = ReadImageHeader(bytes);
  if (!header.ok()) return header.status();
  if (absl::Status s = CheckRegion(detect.region, header->width, header->height); !s.ok()) {
    return s;
  }
  if (absl::Status s = CheckWorkingBytes(*header, options); !s.ok()) return s;
  DecodeOptions decode;
  decode.pixels_linear = detect.pixels_linear;
  decode.saturation_level = detect.saturation_level;
  decode.max_pixels = options.max_pixels;
  absl::StatusOr<Image> image = DecodeImage(bytes, decode);
  if (!image.ok()) return image.status();
  Image converted;
  if (image->channels != 1) converted = Luminance(*image);
  Estimate estimate;
  absl::StatusOr<CylinderGeometry> cylinder =
      CylinderFor(image->channels != 1 ? converted : *image, detect, options, &estimate, trace);
  if (!cylinder.ok()) return cylinder.status();
  return DetectedCylinder{*cylinder, image->width, image->height};
}

absl::StatusOr<Estimate> EstimateFromBytes(const std::string& bytes,
                                           const Acquisition& acquisition,
                                           const EstimateOptions& options) {
  return DecodeAndEstimate(bytes, nullptr, acquisition, options);
}

absl::StatusOr<Estimate> EstimateFromBytes(std::string&& bytes, const Acquisition& acquisition,
                                           const EstimateOptions& options) {
  std::string owned = std::move(bytes);
  return DecodeAndEstimate(owned, &owned, acquisition, options);
}

}  // namespace weavefit
