#include "estimator/profile/profile_extraction.h"

#include <algorithm>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace weavefit {

absl::Status ProfileOptions::Validate() const {
  if (!(bin_width_deg > 0.0 && bin_width_deg <= 10.0)) {
    return absl::InvalidArgumentError("bin_width_deg must be in (0, 10]");
  }
  if (num_blocks < 2) return absl::InvalidArgumentError("num_blocks must be >= 2");
  if (!(max_abs_azimuth_deg > 0.0 && max_abs_azimuth_deg < 90.0)) {
    return absl::InvalidArgumentError("max_abs_azimuth_deg must be in (0, 90)");
  }
  return absl::OkStatus();
}

absl::StatusOr<Profile> ExtractProfile(const Image& luminance,
                                       const CylinderGeometry& geometry,
                                       const Projection& projection,
                                       const ProfileOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (luminance.channels != 1) {
    return absl::InvalidArgumentError("ExtractProfile needs a one-channel image");
  }
  if (!(geometry.radius_px > 0) || geometry.top_row < 0 ||
      geometry.bottom_row >= luminance.height ||
      geometry.bottom_row < geometry.top_row) {
    return absl::InvalidArgumentError("cylinder geometry does not fit the image");
  }
  const double limb = std::min(projection.VisibleLimbRad(),
                               options.max_abs_azimuth_deg * M_PI / 180.0);
  const double bin = options.bin_width_deg * M_PI / 180.0;
  // The small tolerance keeps a limit that is a whole number of bins (86° /
  // 0.25°) from losing its last bin to the rounding of the degree-to-radian
  // conversions.
  const int half_bins = static_cast<int>(std::floor(limb / bin + 1e-9));
  const int num_bins = 2 * half_bins;

  Profile profile;
  profile.bin_width_rad = bin;
  profile.radius_px = geometry.radius_px;
  profile.num_blocks = options.num_blocks;
  profile.azimuth_rad.resize(num_bins);
  for (int i = 0; i < num_bins; ++i) {
    profile.azimuth_rad[i] = (i - half_bins + 0.5) * bin;
  }
  profile.block_sum.assign(static_cast<std::size_t>(num_bins) * options.num_blocks, 0.0);
  profile.block_count.assign(profile.block_sum.size(), 0.0);
  profile.saturated.assign(num_bins, 0.0);

  const int rows = geometry.bottom_row - geometry.top_row + 1;
  std::vector<double> outside;
  for (int y = geometry.top_row; y <= geometry.bottom_row; ++y) {
    const int block = static_cast<int>(
        static_cast<long long>(y - geometry.top_row) * options.num_blocks / rows);
    double* sums = &profile.block_sum[static_cast<std::size_t>(block) * num_bins];
    double* counts = &profile.block_count[static_cast<std::size_t>(block) * num_bins];
    const double axis = geometry.AxisColumn(y);
    const double reach = 1.0 / std::cos(geometry.axis_angle_rad);
    const int x0 = std::max(0, static_cast<int>(std::floor(axis - geometry.radius_px * reach)) - 1);
    const int x1 = std::min(luminance.width - 1,
                            static_cast<int>(std::ceil(axis + geometry.radius_px * reach)) + 1);
    // Background samples: beyond 1.15 radii, every 4th pixel.
    for (int x = 0; x < luminance.width; x += 4) {
      if (std::fabs(geometry.NormalisedOffset(x, y)) > 1.15 && !luminance.IsSaturated(x, y)) {
        outside.push_back(luminance.At(x, y));
      }
    }
    for (int x = x0; x <= x1; ++x) {
      // Pixels centred beyond the limit (limb pixels, mostly background)
      // stay out, as options.max_abs_azimuth_deg promises; spreading their
      // footprint would carry the background into the outermost bins.
      const double centre = AzimuthFromOffset(geometry.NormalisedOffset(x, y), projection);
      if (!(std::fabs(centre) < limb)) continue;
      // The pixel's footprint in azimuth, clipped to the visible range.
      double a = AzimuthFromOffset(std::clamp(geometry.NormalisedOffset(x - 0.5, y), -1.0, 1.0), projection);
      double b = AzimuthFromOffset(std::clamp(geometry.NormalisedOffset(x + 0.5, y), -1.0, 1.0), projection);
      a = std::max(a, -limb);
      b = std::min(b, limb);
      if (!(b > a)) continue;
      const bool saturated = luminance.IsSaturated(x, y);
      if (saturated) ++profile.saturated_samples;
      const float value = luminance.At(x, y);
      const double width = b - a;
      const int first = std::max(0, static_cast<int>(std::floor(a / bin)) + half_bins);
      const int last = std::min(num_bins - 1, static_cast<int>(std::floor(b / bin)) + half_bins);
      for (int k = first; k <= last; ++k) {
        const double lo = (k - half_bins) * bin;
        const double w = (std::min(b, lo + bin) - std::max(a, lo)) / width;
        if (w <= 0.0) continue;
        if (saturated) {
          profile.saturated[k] += w;
        } else {
          sums[k] += w * value;
          counts[k] += w;
        }
      }
    }
  }

  if (!outside.empty()) {
    auto mid = outside.begin() + outside.size() / 2;
    std::nth_element(outside.begin(), mid, outside.end());
    profile.background = *mid;
    for (double& v : outside) v = std::fabs(v - profile.background);
    mid = outside.begin() + outside.size() / 2;
    std::nth_element(outside.begin(), mid, outside.end());
    profile.background_noise = 1.4826 * *mid;
  }

  profile.mean.assign(num_bins, 0.0);
  profile.stderr_mean.assign(num_bins, 0.0);
  profile.count.assign(num_bins, 0.0);
  for (int i = 0; i < num_bins; ++i) {
    double sum = 0.0;
    double n = 0.0;
    for (int b = 0; b < options.num_blocks; ++b) {
      sum += profile.block_sum[static_cast<std::size_t>(b) * num_bins + i];
      n += profile.block_count[static_cast<std::size_t>(b) * num_bins + i];
    }
    profile.count[i] = n;
    if (n <= 0.0) continue;
    const double mean = sum / n;
    profile.mean[i] = mean;
    // Spread of the block means about the overall mean, weighted by counts:
    // this includes the thread structure, not only pixel noise.
    double ss = 0.0;
    int blocks = 0;
    for (int b = 0; b < options.num_blocks; ++b) {
      const std::size_t at = static_cast<std::size_t>(b) * num_bins + i;
      const double nb = profile.block_count[at];
      if (nb <= 0.0) continue;
      const double d = profile.block_sum[at] / nb - mean;
      ss += nb * d * d;
      ++blocks;
    }
    profile.stderr_mean[i] =
        blocks > 1 ? std::sqrt(ss / n / (blocks - 1))
                   : profile.background_noise / std::sqrt(n);
  }
  return profile;
}

}  // namespace weavefit
