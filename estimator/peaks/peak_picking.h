// The split-peak spacing by peak picking on the azimuthal profile: the
// simplest estimator, and the one later methods are compared against.
#ifndef WEAVEFIT_ESTIMATOR_PEAKS_PEAK_PICKING_H_
#define WEAVEFIT_ESTIMATOR_PEAKS_PEAK_PICKING_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/optics/radiance.h"
#include "estimator/profile/profile_extraction.h"

namespace weavefit {

struct PeakPickingOptions {
  // Gaussian smoothing of the profile before peaks are located (σ, degrees).
  // Smoothing pulls caustic peaks inward, so keep it near the bin width.
  double smoothing_deg = 0.25;
  // Smoothing (σ, degrees) of the profile on which the lobe is delimited;
  // about half a thread period in azimuth hides the comb of glints.
  double lobe_smoothing_deg = 2.0;
  // The lobe extends where the heavily smoothed profile exceeds this
  // fraction of its peak above the baseline.
  double lobe_fraction = 0.2;
  // Peaks are sought within this azimuth of the mirror point α/2.
  double search_half_width_deg = 40.0;
  // A peak must stand out from its surroundings (topographic prominence)
  // by this many standard errors...
  double min_dip_sigmas = 5.0;
  // ...and by at least this fraction of its height above the baseline.
  double min_dip_fraction = 0.08;
  // A tooth of the comb between two peaks found (a glint of the threads in
  // view) needs fewer standard errors. The errors are the pixel noise at
  // each bin's level (Profile::PixelNoise); judged against the background's
  // noise, 2-4 times smaller on a lobe at 20,000 photons, 5 had let the
  // teeth of the 5.6 px-per-period silk through, and with the noise at the
  // level only 3 keeps them (the comb fit needs its period).
  double min_tooth_sigmas = 3.0;
  // Maxima lower than this fraction of the highest are ignored (comb teeth
  // in the middle of the lobe, noise).
  double min_peak_ratio = 0.15;
  // Valley-to-peak ratio below which the split reads as a sawtooth (nothing
  // between the peaks) rather than a sinusoid (a filled lobe).
  double sawtooth_valley_ratio = 0.1;
  // A lobe with more than this share of its bins over 5 % saturated is
  // clipped over most of its width: its peaks are not read (the pipeline
  // reports the split unresolved unless the comb fit reads the glints). In
  // the bench sweep's overexposure axis, 4–5 of the lobe's bins clip at 10×
  // the default exposure (answers right) and 62–66 at 30× (peak picking took
  // inner glints for the caustics: 8.5° for 27°). On 320×240 renders of the
  // coarse gauze, 21–26 % of the lobe's bins clip at 25–30×, where the comb
  // fit may fail and peak picking read 13.9° short on one of four.
  double max_clipped_lobe_share = 0.2;
  // Resamples of row blocks for the standard errors (0 disables them).
  int bootstrap_samples = 50;
  std::uint32_t seed = 20030301;

  absl::Status Validate() const;
};

struct PeakPickingResult {
  ProfileModel model = ProfileModel::kSmooth;
  bool split_resolved = false;
  // Azimuths of the two peaks (split) or both equal to the single peak.
  double left_peak_rad = 0.0;
  double right_peak_rad = 0.0;
  // Spacing on the cylinder, corrected for perspective: 2·arctan(m).
  double spacing_rad = 0.0;
  double spacing_stderr_rad = 0.0;
  double max_slope = 0.0;
  double max_slope_stderr = 0.0;
  // Mirror azimuth: midpoint of the peaks, or the single peak.
  double mirror_rad = 0.0;
  double mirror_stderr_rad = 0.0;
  // The allowances' share of the three errors above (peaks located on the
  // profile's bins, the comb of glints, the blur's pull); the rest is the
  // bootstrap's scatter.
  double spacing_systematic_rad = 0.0;
  double max_slope_systematic = 0.0;
  double mirror_systematic_rad = 0.0;
  // Of those, the blur's pull (always inward, so shared by photographs at
  // other phase angles); the bins and the comb move with the geometry.
  double spacing_common_rad = 0.0;
  double max_slope_common = 0.0;
  // Significance of the split: the smaller of the two peaks' prominences,
  // in pixel-noise standard errors (0 for a single peak).
  double dip_sigmas = 0.0;
  // Full width at half maximum of the single peak (SMOOTH only): a split
  // narrower than this could not be seen.
  double single_peak_fwhm_rad = 0.0;
  // Smoothing (σ) at which the peaks were located.
  double smoothing_rad = 0.0;
  // Where the lobe is a comb of glints, the median spacing of its maxima
  // (rad); 0 where it is not.
  double comb_gap_rad = 0.0;
  // Mean level between the peaks over the lower peak's height.
  double valley_ratio = 0.0;
  // The lower of the two caustic peaks' asymmetries: the excess 2.5 outer
  // half-widths inside a peak less that as far outside, over the peak's
  // excess (a sinusoid's caustic keeps an inner shoulder, a sawtooth's is
  // symmetric); 0 where a peak's outside is not in view.
  double caustic_asymmetry = 0.0;
  // Share of the lobe's bins more than 5 % saturated.
  double clipped_lobe_share = 0.0;
  std::vector<std::string> warnings;
  // What a split read by peak picking leaves out, for the warnings only
  // where its numbers are the ones reported (a lobe fit or a comb fit that
  // replaces them has its own account).
  std::string caveat;
};

// Locates the specular peak(s) near α/2 in the profile. INVALID_ARGUMENT when
// the profile holds no usable lobe.
absl::StatusOr<PeakPickingResult> PickPeaks(const Profile& profile,
                                            double phase_angle_rad,
                                            const Projection& projection,
                                            const PeakPickingOptions& options);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_PEAKS_PEAK_PICKING_H_
