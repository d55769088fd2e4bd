// The azimuthal radiance profile I(φ) ± σ(φ) of the cylinder's surface.
#ifndef WEAVEFIT_ESTIMATOR_PROFILE_PROFILE_EXTRACTION_H_
#define WEAVEFIT_ESTIMATOR_PROFILE_PROFILE_EXTRACTION_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/cylinder/cylinder_detection.h"
#include "estimator/io/image.h"

namespace weavefit {

// Mean radiance per uniform azimuth bin over the usable rows. Each pixel is
// spread over the bins its footprint covers in azimuth, in proportion to the
// overlap, so bins narrower than a pixel near the limb are not left empty.
// Bins with no unmasked sample have count 0 and mean 0.
struct Profile {
  std::vector<double> azimuth_rad;  // bin centres, ascending
  std::vector<double> mean;         // linear radiance, background included
  std::vector<double> stderr_mean;  // standard error of mean, from row blocks
  std::vector<double> count;        // unmasked pixels in the bin (fractional)
  std::vector<double> saturated;    // saturated (left out) pixels in the bin
  // The sum of those pixels' values as decoded: at the clip level, below
  // what the sensor saw. (mean·count + saturated_sum)/(count + saturated) is
  // a lower bound on the bin's true mean, and a far tighter one than the
  // mean of its unclipped pixels where glints clip.
  std::vector<double> saturated_sum;
  double bin_width_rad = 0.0;
  // Radius of the cylinder in pixels: a pixel spans about
  // 1/(radius_px·cos φ) rad of azimuth (orthographic), wider than a bin
  // near the limb.
  double radius_px = 0.0;
  // Level and noise (robust sigma of one pixel) outside the cylinder.
  double background = 0.0;
  double background_noise = 0.0;
  // The sensor's shot noise: a pixel's variance grows by noise_gain per unit
  // of level above the background (Poisson–Gaussian: variance =
  // background_noise² + noise_gain·(level − background)), estimated from the
  // differences of vertically neighbouring pixels, which the radiance
  // running along the axis leaves to the noise (EstimateNoiseGain). 0 when the
  // photograph does not show it (a dark body, too few samples).
  double noise_gain = 0.0;
  std::int64_t saturated_samples = 0;

  // Partial sums per block of consecutive rows, so that estimators can
  // resample over rows: block_sum[block·num_bins + bin].
  int num_blocks = 0;
  std::vector<double> block_sum;
  std::vector<double> block_count;

  int NumBins() const { return static_cast<int>(azimuth_rad.size()); }
  // One pixel's noise sigma at bin i's mean level (the mean variance of its
  // pixels, glints included: the model is linear in the level).
  double PixelNoise(int i) const {
    const double shot = noise_gain * std::max(mean[i] - background, 0.0);
    return std::sqrt(background_noise * background_noise + shot);
  }
};

// The Poisson part of a Poisson–Gaussian sensor noise (Profile::noise_gain)
// from the differences of vertically neighbouring pixels across the whole
// width (background, limbs and cylinder all run along the axis): grouped by
// level, each group's variance (the mean square of its differences within
// 4 robust sigmas, half of it per pixel), and the line variance = c +
// gain·level through the groups by weighted least squares, leaving out
// one at a time the groups far above it (glints and thread edges:
// structure, not noise). Sparse rows and columns: about 96 × 128 pairs
// at most. 0 when the groups cannot tell the gain from none.
double EstimateNoiseGain(const Image& luminance, const CylinderGeometry& geometry,
                         double background, double background_noise);

struct ProfileOptions {
  double bin_width_deg = 0.25;       // azimuth bin width
  int num_blocks = 32;               // row blocks for the standard errors
  double max_abs_azimuth_deg = 86.0; // bins beyond are dropped (limb pixels)
  // At most this many usable rows are read, evenly spaced (0: every row).
  // A quick look needs far fewer than a 12 Mpx photograph has: the counts
  // and standard errors are those of the rows read.
  int max_rows = 0;

  absl::Status Validate() const;
};

// Averages the usable rows of a one-channel linear image per azimuth bin,
// along lines perpendicular to the (tilted) axis. Saturated pixels are left
// out and counted. INVALID_ARGUMENT for inconsistent input.
absl::StatusOr<Profile> ExtractProfile(const Image& luminance,
                                       const CylinderGeometry& geometry,
                                       const Projection& projection,
                                       const ProfileOptions& options);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_PROFILE_PROFILE_EXTRACTION_H_
