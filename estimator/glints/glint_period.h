// The thread wavelength from the glints along the arc (DESIGN.md §3). The
// far-field profile fixes only the max slope; the wavelength comes from the
// image's fine structure. Along one row of a sinusoidal thread h0·sin(ks),
// a glint stands wherever the facet mirrors the light:
//     φ − (α + v(φ))/2 = arctan(m·cos(k·(R·φ + c))),
// with the row's own weave phase c. Two glints per period, evenly spaced in
// mid-lobe and pairing up toward the caustics, so a spectrum of the row is
// strongest at 2/λ and smeared by the pairing: a trap. Instead, the glints
// of each row are located and λ is the period for which, with the best phase
// per row, the most glints satisfy that equation; λ/2 or 2λ do not, which is
// what tells the fundamental apart. The half-period shift of a plain weave
// between neighbouring threads is absorbed by the per-row phase.
#ifndef WEAVEFIT_ESTIMATOR_GLINTS_GLINT_PERIOD_H_
#define WEAVEFIT_ESTIMATOR_GLINTS_GLINT_PERIOD_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/profile/arc_signals.h"

namespace weavefit {

struct GlintPeriodOptions {
  // Shortest period that counts as resolved, in pixels at the axis.
  double min_px_per_period = 4.0;
  // The analysed arc must hold at least this many periods, and at most
  // max_periods are looked for (finer weaves glint too densely to separate).
  double min_periods = 2.0;
  double max_periods = 60.0;
  // A glint must stand this many pixel-noise sigmas above its row's median.
  double glint_sigmas = 6.0;
  // At least this many glints in all, and a share of them the best period
  // must explain, and how many times better than half or twice it.
  int min_glints = 100;
  double min_explained = 0.3;
  double min_ratio = 1.5;
  // The period found must fit this many times into the analysed arc.
  double min_periods_found = 2.5;
  // Relative standard error always counted for what the model leaves out:
  // over 19 noise draws of one sinusoid scene (λ 2 mm, 11 px per period) the
  // estimates spread by 1.3 %, against 0.8 % reported with a 0.5 % floor.
  double model_floor = 0.01;
  int bootstrap_samples = 40;
  std::uint32_t seed = 20030302;

  absl::Status Validate() const;
};

struct GlintPeriodResult {
  bool resolved = false;
  double wavelength_mm = 0.0;
  double wavelength_stderr_mm = 0.0;
  // Its share from the period grid's step (the rest, model_floor included,
  // is scatter: the floor makes up spread over noise draws that the
  // bootstrap misses).
  double wavelength_systematic_mm = 0.0;
  double px_per_period = 0.0;
  int rows_used = 0;
  int glints_used = 0;
  double explained = 0.0;  // share of glints the period explains
  // The best period searched, kept when it is rejected as unresolved (0
  // when the search did not run), and the coarse scan's best local maxima
  // (up to four, best first): a stronger test (glints/comb_fit.h) may still
  // confirm one.
  double candidate_mm = 0.0;
  std::vector<double> candidates_mm;
  // Why the period is unresolved, in words (empty when resolved).
  std::string reason;
};

// The facet geometry the glints must satisfy.
struct GlintModel {
  double max_slope = 0.0;        // m, from the profile
  double max_slope_stderr = 0.0; // its standard error
  double phase_angle_rad = 0.0;  // α
  Projection projection;         // for v(φ) and the arc radius
  double mm_per_px = 0.0;        // arc length per pixel at the axis
  double pixel_noise = 0.0;      // one pixel's noise sigma, linear units
  double lens_blur_px = 0.0;     // the lens blur the limbs show (σ, px; 0: none)
};

absl::StatusOr<GlintPeriodResult> EstimateGlintPeriod(const ArcSignals& signals,
                                                      const GlintModel& model,
                                                      const GlintPeriodOptions& options);

// Each row's weave phase c (mm) for period λ: the phase at which the row's
// glints best satisfy the mirror equation above with model.max_slope; NaN for
// rows with fewer than three glints. Starts the comb fit (glints/comb_fit.h).
std::vector<double> RowPhasesMm(const ArcSignals& signals, const GlintModel& model,
                                double wavelength_mm, const GlintPeriodOptions& options);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_GLINTS_GLINT_PERIOD_H_
