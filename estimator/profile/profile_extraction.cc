#include "estimator/profile/profile_extraction.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include <opencv2/imgproc.hpp>

#include "absl/status/status.h"
#include "estimator/stats/median.h"
#include "absl/strings/str_cat.h"

namespace weavefit {

absl::Status ProfileOptions::Validate() const {
  if (!(bin_width_deg > 0.0 && bin_width_deg <= 10.0)) {
    return absl::InvalidArgumentError("bin_width_deg must be in (0, 10]");
  }
  if (num_blocks < 2) return absl::InvalidArgumentError("num_blocks must be >= 2");
  if (max_rows < 0) return absl::InvalidArgumentError("max_rows must be >= 0");
  if (!(max_abs_azimuth_deg > 0.0 && max_abs_azimuth_deg < 90.0)) {
    return absl::InvalidArgumentError("max_abs_azimuth_deg must be in (0, 90)");
  }
  return absl::OkStatus();
}

double EstimateNoiseGain(const Image& luminance, const CylinderGeometry& geometry,
                         double background, double background_noise) {
  if (luminance.channels != 1 || !(geometry.radius_px > 2.0)) return 0.0;
  const int top = std::max(geometry.top_row, 0);
  const int bottom = std::min(geometry.bottom_row, luminance.height - 1);
  if (bottom - top < 2) return 0.0;
  // At most about 96 × 128 pairs: plenty for 24 groups of 300, and about
  // a millisecond (every pixel of a 320×240 photograph, 76,000 pairs, took
  // 9 ms of fast mode's 22; 38,000 took 6).
  const int row_step = std::max(1, (bottom - top + 95) / 96);
  const int col_step = std::max(1, (luminance.width + 127) / 128);
  // Pairs of vertically neighbouring pixels over the whole width: the
  // background and the cylinder's darkest parts fix the read noise, the
  // brighter parts its growth with the level. The cylinder's radiance, the
  // background's and the limbs' run along the axis, so a pair differs by the
  // noise alone, save at glints' and threads' edges (structure).
  const double dark_below = background + 5.0 * background_noise;
  std::vector<std::pair<double, double>> dark;    // (level, |difference|)
  std::vector<std::pair<double, double>> bright;
  const std::size_t most = static_cast<std::size_t>((bottom - top) / row_step + 1) *
                           static_cast<std::size_t>(luminance.width / col_step + 1);
  dark.reserve(most);
  bright.reserve(most);
  for (int y = top; y < bottom; y += row_step) {
    for (int x = 0; x < luminance.width; x += col_step) {
      if (luminance.IsSaturated(x, y) || luminance.IsSaturated(x, y + 1)) continue;
      const double a = luminance.At(x, y);
      const double b = luminance.At(x, y + 1);
      if (!std::isfinite(a) || !std::isfinite(b)) continue;
      const double level = 0.5 * (a + b);
      (level < dark_below ? dark : bright).emplace_back(level, std::fabs(b - a));
    }
  }
  // Groups of neighbouring levels, each with its level, the variance of
  // its differences' core (below) and that variance's standard error.
  struct Group {
    double level, variance, error;
  };
  std::vector<Group> groups;
  constexpr std::size_t kPerGroup = 300;
  auto add_groups = [&](std::vector<std::pair<double, double>>& pairs, std::size_t max_groups) {
    if (pairs.size() < kPerGroup) return;
    std::sort(pairs.begin(), pairs.end());
    const std::size_t count = std::min(max_groups, pairs.size() / kPerGroup);
    std::vector<double> levels;
    std::vector<double> diffs;
    for (std::size_t g = 0; g < count; ++g) {
      const std::size_t lo = pairs.size() * g / count;
      const std::size_t hi = pairs.size() * (g + 1) / count;
      levels.clear();
      diffs.clear();
      for (std::size_t k = lo; k < hi; ++k) {
        levels.push_back(pairs[k].first);
        diffs.push_back(pairs[k].second);
      }
      // The MAD moves in whole quantisation steps (on a 12-bit body at
      // 0.03 of full scale it took three values): it only sets the clip for
      // the mean square of the differences within 4 sigmas, which keeps
      // out the glints' edges and thread edges but not the noise.
      const double clip = 4.0 * std::max(1.4826 * Median(diffs), 1e-9);
      double sum2 = 0.0;
      int inside = 0;
      for (double d : diffs) {
        if (d > clip) continue;
        sum2 += d * d;
        ++inside;
      }
      const double variance = inside > 0 ? 0.5 * sum2 / inside : 0.0;
      // A level within 2.5 sigmas of zero is clipped there (a sensor that
      // clips at its black level): its variance is short (the 0.01
      // background of a 0.01 read noise read 0.84 of it, which tripled the
      // gain drawn through it).
      const double level = Median(levels);
      if (level < 2.5 * std::sqrt(variance)) continue;
      groups.push_back({level, variance,
                        std::max(variance, 1e-12) * std::sqrt(2.0 / (hi - lo))});
    }
  };
  add_groups(dark, 4);
  add_groups(bright, 20);
  if (groups.size() < 3) return 0.0;
  // variance = c + gain·level by weighted least squares. Structure only
  // adds variance: the group farthest above the line, if 3 errors or more,
  // is left out and the line fitted again (one at a time: the comb of a
  // lobe's glints, tens of times the noise's variance, drew the first line
  // so steep that the background's groups lay above it).
  std::vector<bool> kept(groups.size(), true);
  double gain = 0.0;
  double gain_error = 0.0;
  for (;;) {
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    int used = 0;
    for (std::size_t k = 0; k < groups.size(); ++k) {
      if (!kept[k]) continue;
      const double w = 1.0 / (groups[k].error * groups[k].error);
      sw += w;
      sx += w * groups[k].level;
      sy += w * groups[k].variance;
      sxx += w * groups[k].level * groups[k].level;
      sxy += w * groups[k].level * groups[k].variance;
      ++used;
    }
    const double det = sw * sxx - sx * sx;
    if (used < 3 || !(det > 0.0)) return 0.0;
    gain = (sw * sxy - sx * sy) / det;
    gain_error = std::sqrt(sw / det);
    const double c = (sy - gain * sx) / sw;
    // The groups scatter about the line more than their sampling errors
    // say where the weave's texture (gaps between threads, their edges)
    // adds variance at every level (on a 12-bit fixture body at 0.03, 5
    // times their errors): the errors are scaled by the standardised
    // residuals' robust spread before any group is judged an outlier.
    std::vector<double> z(groups.size(), 0.0);
    std::vector<double> abs_z;
    for (std::size_t k = 0; k < groups.size(); ++k) {
      if (!kept[k]) continue;
      z[k] = (groups[k].variance - (c + gain * groups[k].level)) / groups[k].error;
      abs_z.push_back(std::fabs(z[k]));
    }
    const double scale = std::max(1.0, 1.4826 * Median(abs_z));
    gain_error *= scale;
    int worst = -1;
    double worst_z = 3.0;
    for (std::size_t k = 0; k < groups.size(); ++k) {
      if (kept[k] && z[k] / scale > worst_z) {
        worst_z = z[k] / scale;
        worst = static_cast<int>(k);
      }
    }
    if (worst < 0) break;
    kept[worst] = false;
  }
  // A gain the groups' levels cannot tell from none (a dark body: every
  // bright pixel a glint) is taken as none.
  if (!(gain > gain_error)) return 0.0;
  return std::max(gain, 0.0);
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
  profile.saturated_sum.assign(num_bins, 0.0);

  const int rows = geometry.bottom_row - geometry.top_row + 1;
  // φ as a function of the normalised offset, tabulated every 1/16 px (every
  // 1/4096 of the radius on radii over 256 px) and interpolated linearly for
  // |offset| < 0.9 (error below 1e-7 rad there): one table instead of an
  // arcsine per pixel edge. Toward the limb the mapping's slope diverges, so
  // the few pixels there get the exact value.
  constexpr double kTabulated = 0.9;
  const double step = 1.0 / std::min(16.0 * geometry.radius_px, 4096.0);
  const int table_half = static_cast<int>(std::ceil(kTabulated / step)) + 1;
  std::vector<double> table(2 * table_half + 1);
  for (int i = 0; i <= 2 * table_half; ++i) {
    table[i] = AzimuthFromOffset(std::clamp((i - table_half) * step, -1.0, 1.0), projection);
  }
  auto azimuth_of = [&](double offset) {
    if (!(std::fabs(offset) < kTabulated)) {
      return AzimuthFromOffset(std::clamp(offset, -1.0, 1.0), projection);
    }
    const double t = offset / step + table_half;
    const int i = static_cast<int>(t);
    return table[i] + (t - i) * (table[i + 1] - table[i]);
  };
  // A pixel is kept when its centre lies inside the azimuth limit: compared
  // in offsets, where the mapping is monotonic and exact.
  const double limit_offset = OffsetFromAzimuth(limb, projection);
  const double cos_tilt = std::cos(geometry.axis_angle_rad);
  const double reach = 1.0 / cos_tilt;
  struct Footprints {
    std::vector<int> start;  // per column offset: first entry in bins/weights
    std::vector<int> bins;
    std::vector<double> weights;
  };
  constexpr int kSubpixel = 32;
  std::vector<Footprints> footprints(kSubpixel);
  const int half_span = static_cast<int>(std::ceil(geometry.radius_px * reach)) + 2;
  const int width = 2 * half_span + 1;
  struct ColumnSums {
    std::vector<double> sum;        // per block and column offset
    std::vector<double> saturated;  // masked pixels
    std::vector<double> saturated_sum;  // their values as decoded
    // Unmasked pixels: each run of them counts 1 over its span, kept as a
    // difference array per block (width + 1 entries) and summed at the end.
    std::vector<double> span_diff;
  };
  std::vector<ColumnSums> column_sums(kSubpixel);
  // Background samples beyond 1.15 radii, and those from 4 px beyond the
  // limb to there, used when the first are too few: a cylinder that fills
  // the frame leaves nothing beyond 1.15 radii (a 144 px radius in a 320 px
  // frame), and the background's level and noise came out 0, so that every
  // ripple of the profile became a significant glint (a sawtooth read as a
  // 18-tooth sinusoid).
  std::vector<double> outside;
  std::vector<double> near_outside;
  constexpr double kFarBeyondRadii = 1.15;
  constexpr double kNearBeyondPx = 4.0;
  constexpr std::size_t kMinBackgroundSamples = 64;
  // Rows read: every row, or evenly spaced ones when options.max_rows caps
  // them. The background is sampled on every background_row_step-th row read.
  const int row_stride =
      options.max_rows > 0 ? std::max(1, (rows + options.max_rows - 1) / options.max_rows) : 1;
  const int background_row_step = std::max(1, std::max(4, rows / 256) / row_stride);
  // Every 4th pixel, or sparser on photographs over 512 px wide: at most
  // 128 per row over the whole width (a few thousand samples in all are
  // plenty for a level and a robust sigma).
  const int background_x_step = std::max(4, luminance.width / 128);
  for (int y = geometry.top_row; y <= geometry.bottom_row; y += row_stride) {
    const int block = static_cast<int>(
        static_cast<long long>(y - geometry.top_row) * options.num_blocks / rows);
    const double axis = geometry.AxisColumn(y);
    // Background samples: beyond 1.15 radii, every background_x_step-th
    // pixel of every background_row_step-th row (about 256 rows in all).
    if ((y - geometry.top_row) / row_stride % background_row_step == 0) {
      const double beyond = kFarBeyondRadii * geometry.radius_px / cos_tilt;  // px from the axis
      const double near = geometry.radius_px / cos_tilt + kNearBeyondPx;
      auto sample = [&](int x, std::vector<double>* to) {
        if (!luminance.IsSaturated(x, y)) to->push_back(luminance.At(x, y));
      };
      const int left_end = static_cast<int>(std::ceil(axis - beyond)) - 1;
      const int right_start = static_cast<int>(std::floor(axis + beyond)) + 1;
      for (int x = 0; x <= std::min(left_end, luminance.width - 1); x += background_x_step) {
        sample(x, &outside);
      }
      for (int x = std::max(right_start, 0); x < luminance.width; x += background_x_step) {
        sample(x, &outside);
      }
      const int near_left_end = static_cast<int>(std::ceil(axis - near)) - 1;
      const int near_right_start = static_cast<int>(std::floor(axis + near)) + 1;
      for (int x = std::max(left_end + 1, 0); x <= std::min(near_left_end, luminance.width - 1);
           x += background_x_step) {
        sample(x, &near_outside);
      }
      for (int x = std::max(near_right_start, 0); x < std::min(right_start, luminance.width);
           x += background_x_step) {
        sample(x, &near_outside);
      }
    }
    // The row's pixel footprints as (bin, weight) pairs, relative to the
    // axis column quantised to 1/kSubpixel px (a 1/64 px shift moves φ by
    // < 0.001° at any radius worth measuring): rows whose axes share the
    // fractional part share the table, whatever the tilt.
    const double axis_q = std::round(axis * kSubpixel) / kSubpixel;
    const double base = std::floor(axis_q);
    const int key = static_cast<int>(std::lround((axis_q - base) * kSubpixel)) % kSubpixel;
    Footprints& fp = footprints[key];
    if (fp.start.empty()) {
      const double frac = static_cast<double>(key) / kSubpixel;
      fp.start.assign(2 * half_span + 2, 0);
      for (int dx = -half_span; dx <= half_span; ++dx) {
        fp.start[dx + half_span] = static_cast<int>(fp.bins.size());
        const double centre = (dx - frac) * cos_tilt / geometry.radius_px;
        // Pixels centred beyond the limit (limb pixels, mostly background)
        // stay out, as options.max_abs_azimuth_deg promises; spreading
        // their footprint would carry the background into the outer bins.
        if (!(std::fabs(centre) < limit_offset)) continue;
        // The pixel's footprint in azimuth, clipped to the visible range.
        const double a = std::max(azimuth_of((dx - 0.5 - frac) * cos_tilt / geometry.radius_px), -limb);
        const double b = std::min(azimuth_of((dx + 0.5 - frac) * cos_tilt / geometry.radius_px), limb);
        if (!(b > a)) continue;
        const int first = std::max(0, static_cast<int>(std::floor(a / bin)) + half_bins);
        const int last = std::min(num_bins - 1, static_cast<int>(std::floor(b / bin)) + half_bins);
        for (int k = first; k <= last; ++k) {
          const double lo = (k - half_bins) * bin;
          const double w = (std::min(b, lo + bin) - std::max(a, lo)) / (b - a);
          if (w <= 0.0) continue;
          fp.bins.push_back(k);
          fp.weights.push_back(w);
        }
      }
      fp.start[2 * half_span + 1] = static_cast<int>(fp.bins.size());
    }
    // Pixels are summed per column offset first (one add each); the sums
    // are spread over their footprints once at the end, per table and block.
    ColumnSums& cs = column_sums[key];
    if (cs.sum.empty()) {
      cs.sum.assign(static_cast<std::size_t>(options.num_blocks) * width, 0.0);
      cs.saturated.assign(cs.sum.size(), 0.0);
      cs.saturated_sum.assign(cs.sum.size(), 0.0);
      cs.span_diff.assign(static_cast<std::size_t>(options.num_blocks) * (width + 1), 0.0);
    }
    const std::size_t at0 = static_cast<std::size_t>(block) * width + half_span;
    const float* row = &luminance.pixels[static_cast<std::size_t>(y) * luminance.width];
    const std::uint8_t* mask = luminance.saturated.Row(y);
    const int b0 = static_cast<int>(base);
    const int dx_lo = std::max(-half_span, -b0);
    const int dx_hi = std::min(half_span, luminance.width - 1 - b0);
    double* sum = cs.sum.data() + at0;
    double* saturated = cs.saturated.data() + at0;
    double* saturated_sum = cs.saturated_sum.data() + at0;
    // A run of unmasked pixels [from, to] (column offsets): OpenCV's
    // vectorised float-into-double accumulation, and one count each through
    // the block's difference array.
    double* diff = cs.span_diff.data() + static_cast<std::size_t>(block) * (width + 1) + half_span;
    auto add_run = [&](int from, int to) {
      if (to < from) return;
      const int n = to - from + 1;
      cv::accumulate(cv::Mat(1, n, CV_32F, const_cast<float*>(row + b0 + from)),
                     cv::Mat(1, n, CV_64F, sum + from));
      diff[from] += 1.0;
      diff[to + 1] -= 1.0;
    };
    if (mask == nullptr) {
      add_run(dx_lo, dx_hi);
    } else {
      // The runs between masked pixels (any nonzero byte: a clipped glint
      // masks a few pixels of a row), skipping unmasked stretches eight mask
      // bytes at a time; a row without one is a single run.
      int run = dx_lo;
      int dx = dx_lo;
      while (dx <= dx_hi) {
        if (dx + 8 <= dx_hi + 1) {
          std::uint64_t word;
          std::memcpy(&word, mask + b0 + dx, sizeof(word));
          if (word == 0) {
            dx += 8;
            continue;
          }
        }
        if (mask[b0 + dx]) {
          add_run(run, dx - 1);
          saturated[dx] += 1.0;
          if (std::isfinite(row[b0 + dx])) saturated_sum[dx] += row[b0 + dx];
          run = dx + 1;
        }
        ++dx;
      }
      add_run(run, dx_hi);
    }
  }
  for (int key = 0; key < kSubpixel; ++key) {
    ColumnSums& cs = column_sums[key];
    if (cs.sum.empty()) continue;
    const Footprints& fp = footprints[key];
    for (int block = 0; block < options.num_blocks; ++block) {
      // Unmasked pixels per column offset: the running sum of the runs'
      // difference array.
      double count = 0.0;
      const double* diff = cs.span_diff.data() + static_cast<std::size_t>(block) * (width + 1);
      double* sums = &profile.block_sum[static_cast<std::size_t>(block) * num_bins];
      double* counts = &profile.block_count[static_cast<std::size_t>(block) * num_bins];
      for (int dx = -half_span; dx <= half_span; ++dx) {
        count += diff[dx + half_span];
        const int from = fp.start[dx + half_span];
        const int to = fp.start[dx + half_span + 1];
        if (from == to) continue;
        const std::size_t at = static_cast<std::size_t>(block) * width + dx + half_span;
        const double sum = cs.sum[at];
        const double saturated = cs.saturated[at];
        const double saturated_sum = cs.saturated_sum[at];
        profile.saturated_samples += static_cast<int>(saturated);
        for (int j = from; j < to; ++j) {
          sums[fp.bins[j]] += fp.weights[j] * sum;
          counts[fp.bins[j]] += fp.weights[j] * count;
          profile.saturated[fp.bins[j]] += fp.weights[j] * saturated;
          profile.saturated_sum[fp.bins[j]] += fp.weights[j] * saturated_sum;
        }
      }
    }
  }

  if (outside.size() < kMinBackgroundSamples) {
    outside.insert(outside.end(), near_outside.begin(), near_outside.end());
  }
  if (!outside.empty()) {
    profile.background = Median(outside);
    for (double& v : outside) v = std::fabs(v - profile.background);
    profile.background_noise = 1.4826 * Median(outside);  // robust sigma (MAD)
  }

  profile.noise_gain =
      EstimateNoiseGain(luminance, geometry, profile.background, profile.background_noise);

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
