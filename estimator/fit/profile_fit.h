// Least-squares fits of the optical models (DESIGN.md §3) to the azimuthal
// profile with Ceres: the whole lobe, not only its peaks, so that the band
// between the peaks tells a sinusoid from a sawtooth. One fit per candidate
// model; the candidates are compared by BIC. Bins near clipped pixels are
// censored (a lower bound). Ceres types stay in the .cc.
#ifndef WEAVEFIT_ESTIMATOR_FIT_PROFILE_FIT_H_
#define WEAVEFIT_ESTIMATOR_FIT_PROFILE_FIT_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/optics/radiance.h"
#include "estimator/profile/profile_extraction.h"

namespace weavefit {

struct ProfileFitOptions {
  // Gaussian smoothing (σ, rad) applied to the profile before the fit and,
  // in quadrature with the fitted blur, to the model: set it to about half a
  // thread period when the lobe is a comb of glints (0 = none).
  double smoothing_rad = 0.0;
  // The lens PSF (Gaussian σ, px; CylinderGeometry::lens_blur_px) and the
  // limbs' half-width (px) that turn pixels into azimuth: with a half-width,
  // the PSF and the pixel's footprint blur the model by their width in
  // azimuth at each bin, 1/cos φ times their width at the middle
  // (orthographic). A half-width of 0: a blur constant in azimuth only.
  double lens_blur_px = 0.0;
  double half_width_px = 0.0;
  // The fitted window reaches this far beyond the starting caustics (rad).
  double margin_rad = 6.0 * 3.14159265358979323846 / 180.0;
  // ... or beyond the caustics of this max slope, where larger than the
  // start's: fits from several starts must share one window for their BICs
  // to compare (a start of 0.2 fitted only the dome between a sawtooth's
  // peaks at ±35° and won on the BIC of its fewer bins).
  double window_max_slope = 0.0;
  int max_iterations = 100;
  // Run the fits (three models from two starting blurs) on threads of their
  // own; the answer is the same either way.
  bool parallel = true;

  absl::Status Validate() const;
};

// The largest share of its arc a fitted sawtooth may give to its rounded
// corners (ModelFit::corner_share). Beyond a quarter the corners are no
// longer a detail of flat facets: a fit that wants more is filling a level
// between the peaks fuller than a sawtooth's (a sinusoid's, or glints a
// comb leaves there), and the fitted corners already took up to 0.43 on a
// sinusoid.
constexpr double kMaxCornerShare = 0.25;

// One candidate model fitted to the profile, in library units.
struct ModelFit {
  ProfileModel model = ProfileModel::kSmooth;
  bool converged = false;
  double max_slope = 0.0;
  double max_slope_stderr = 0.0;
  double mirror_rad = 0.0;
  double mirror_stderr_rad = 0.0;
  double blur_rad = 0.0;
  // A sawtooth's share of arc in its rounded corners (SawtoothTiltDensity);
  // 0 for the other models.
  double corner_share = 0.0;
  double chi2 = 0.0;            // weighted sum of squared residuals
  int num_residuals = 0;
  int num_censored = 0;         // of them, bins known only from below (clipped)
  int num_params = 0;
  double bic = 0.0;             // chi2 + num_params·ln(num_residuals)
  // The residuals' integrated autocorrelation (bins): the covariance is
  // scaled by it, as the residuals carry num_residuals/correlation_bins
  // independent pieces of information.
  double correlation_bins = 1.0;
  std::string message;          // the solver's word when not converged
  // The fitted model at the bins it was fitted to, for plots: azimuth (rad)
  // and level (the profile's units; the model is smoothed like the data).
  std::vector<double> curve_azimuth_rad;
  std::vector<double> curve;
};

struct ProfileFitResult {
  std::vector<ModelFit> fits;   // SMOOTH, SINUSOID, SAWTOOTH
  int best = -1;                // index of the lowest BIC among converged fits
};

// Fits SMOOTH, SINUSOID and SAWTOOTH to the profile around α/2, starting
// from max_slope0 (e.g. peak picking's). Bins near clipped pixels are
// censored: their clipped pixels at the clip level give a lower bound the
// model must reach. The standard errors come from the covariance scaled by
// the reduced chi-square and by the residuals' integrated correlation
// (correlation_bins); what the models leave out (a comb of glints from few
// weave phases, a sawtooth's real shape), callers must count.
// INVALID_ARGUMENT for a profile that cannot be fitted (over half the
// window clipped, too few bins).
absl::StatusOr<ProfileFitResult> FitProfileModels(const Profile& profile,
                                                  double phase_angle_rad,
                                                  const Projection& projection,
                                                  double max_slope0,
                                                  const ProfileFitOptions& options);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_FIT_PROFILE_FIT_H_
