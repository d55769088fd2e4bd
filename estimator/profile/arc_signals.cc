#include "estimator/profile/arc_signals.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace weavefit {

absl::Status ArcSignalOptions::Validate() const {
  if (max_rows < 0) return absl::InvalidArgumentError("max_rows must be >= 0");
  if (!(to_rad > from_rad) || !std::isfinite(from_rad) || !std::isfinite(to_rad)) {
    return absl::InvalidArgumentError("arc signal range must have from_rad < to_rad");
  }
  if (!(step_rad >= 0.0)) return absl::InvalidArgumentError("step_rad must be >= 0");
  return absl::OkStatus();
}

absl::StatusOr<ArcSignals> ExtractArcSignals(const Image& luminance,
                                             const CylinderGeometry& geometry,
                                             const Projection& projection,
                                             const ArcSignalOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  if (luminance.channels != 1) {
    return absl::InvalidArgumentError("ExtractArcSignals needs a one-channel image");
  }
  const double limb = projection.VisibleLimbRad();
  if (options.from_rad <= -limb || options.to_rad >= limb) {
    return absl::InvalidArgumentError("arc signal range reaches beyond the visible limb");
  }
  ArcSignals out;
  out.radius_mm = projection.radius_mm;
  out.step_rad = options.step_rad > 0 ? options.step_rad : 0.5 / geometry.radius_px;
  out.first_azimuth_rad = options.from_rad;
  out.num_samples = static_cast<int>(std::floor((options.to_rad - options.from_rad) / out.step_rad)) + 1;
  // Column offset of each sample from the axis (horizontal, in px).
  std::vector<double> dx(out.num_samples);
  const double horizontal = geometry.radius_px / std::cos(geometry.axis_angle_rad);
  for (int k = 0; k < out.num_samples; ++k) {
    dx[k] = OffsetFromAzimuth(out.first_azimuth_rad + k * out.step_rad, projection) * horizontal;
  }
  const int usable = geometry.bottom_row - geometry.top_row + 1;
  if (!options.rows.empty()) {
    for (int y : options.rows) {
      if (y < geometry.top_row || y > geometry.bottom_row) {
        return absl::InvalidArgumentError(absl::StrCat(
            "arc signal row ", y, " is outside the usable rows ", geometry.top_row, "-",
            geometry.bottom_row));
      }
    }
    out.rows = options.rows;
  } else if (options.max_rows > 0 && usable > options.max_rows) {
    // Glints line up along thread crests, a few rows of each thread: keep
    // the rows whose pixels over the range vary most (one pass over the raw
    // pixels), in image order.
    std::vector<std::pair<double, int>> spread;
    spread.reserve(usable);
    const double lo = std::min(dx.front(), dx.back());
    const double hi = std::max(dx.front(), dx.back());
    for (int y = geometry.top_row; y <= geometry.bottom_row; ++y) {
      const double axis = geometry.AxisColumn(y);
      const int x0 = std::clamp(static_cast<int>(std::floor(axis + lo)), 0, luminance.width - 1);
      const int x1 = std::clamp(static_cast<int>(std::ceil(axis + hi)), 0, luminance.width - 1);
      const float* row = &luminance.pixels[static_cast<std::size_t>(y) * luminance.width];
      // OpenCV's vectorised mean and standard deviation over the span.
      const int n = x1 - x0 + 1;
      cv::Scalar mean;
      cv::Scalar sd;
      cv::meanStdDev(cv::Mat(1, n, CV_32F, const_cast<float*>(row + x0)), mean, sd);
      const double v = sd[0] * sd[0] * n;
      // A non-finite row (NaN pixels from a direct caller) ranks last.
      spread.push_back({std::isfinite(v) ? v : -std::numeric_limits<double>::infinity(), y});
    }
    std::nth_element(spread.begin(), spread.begin() + options.max_rows, spread.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    for (int i = 0; i < options.max_rows; ++i) out.rows.push_back(spread[i].second);
    std::sort(out.rows.begin(), out.rows.end());
  } else {
    for (int y = geometry.top_row; y <= geometry.bottom_row; ++y) out.rows.push_back(y);
  }
  out.values.assign(out.rows.size() * out.num_samples, 0.0f);
  out.valid.assign(out.values.size(), 1);
  // Each signal runs along the line through the row's axis point
  // perpendicular to the axis (not along the image row): a thread crosses the
  // axis at a right angle, so only then does one signal stay on one thread,
  // with one weave phase, when the axis is tilted. Bilinear interpolation.
  const double cos_t = std::cos(geometry.axis_angle_rad);
  const double sin_t = std::sin(geometry.axis_angle_rad);
  // The sample's displacement from the row's axis point, the same for
  // every row: d·(cos t, sin t) with d = dx·cos t the perpendicular distance.
  std::vector<double> along_x(out.num_samples);
  std::vector<double> along_y(out.num_samples);
  for (int k = 0; k < out.num_samples; ++k) {
    along_x[k] = dx[k] * cos_t * cos_t;
    along_y[k] = dx[k] * cos_t * sin_t;
  }
  for (std::size_t r = 0; r < out.rows.size(); ++r) {
    const int y = out.rows[r];
    const double axis = geometry.AxisColumn(y);
    for (int k = 0; k < out.num_samples; ++k) {
      const double x = axis + along_x[k];
      const double yy = y + along_y[k];
      const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, luminance.width - 2);
      const int y0 = std::clamp(static_cast<int>(std::floor(yy)), 0, luminance.height - 2);
      const double tx = std::clamp(x - x0, 0.0, 1.0);
      const double ty = std::clamp(yy - y0, 0.0, 1.0);
      const float* top = &luminance.pixels[static_cast<std::size_t>(y0) * luminance.width];
      const float* bottom = top + luminance.width;
      const std::size_t at = r * out.num_samples + k;
      out.values[at] = static_cast<float>(
          (1.0 - ty) * ((1.0 - tx) * top[x0] + tx * top[x0 + 1]) +
          ty * ((1.0 - tx) * bottom[x0] + tx * bottom[x0 + 1]));
      const std::uint8_t* m0 = luminance.saturated.Row(y0);
      const std::uint8_t* m1 = luminance.saturated.Row(y0 + 1);
      if ((m0 != nullptr && (m0[x0] || m0[x0 + 1])) || (m1 != nullptr && (m1[x0] || m1[x0 + 1]))) {
        out.valid[at] = 0;
      }
    }
  }
  return out;
}

absl::StatusOr<ArcPixels> ExtractArcPixels(const Image& luminance, const CylinderGeometry& geometry,
                                           const Projection& projection,
                                           const std::vector<int>& rows, double from_rad,
                                           double to_rad, int bin_px) {
  if (luminance.channels != 1) {
    return absl::InvalidArgumentError("ExtractArcPixels needs a one-channel image");
  }
  const double limb = projection.VisibleLimbRad();
  if (!(from_rad < to_rad) || from_rad <= -limb || to_rad >= limb) {
    return absl::InvalidArgumentError("arc pixel range must lie inside the visible limb");
  }
  if (bin_px < 1) return absl::InvalidArgumentError("bin_px must be >= 1");
  const double cos_t = std::cos(geometry.axis_angle_rad);
  const double tan_t = std::tan(geometry.axis_angle_rad);
  const double sin_t = std::sin(geometry.axis_angle_rad);
  ArcPixels out;
  out.bin_px = bin_px;
  out.radius_px = geometry.radius_px;
  out.bin_width_px = bin_px / cos_t;  // a column is 1/cos t along the line
  // Horizontal offsets (px from the axis point) of the range's ends.
  const double horizontal = geometry.radius_px / cos_t;
  const double lo = OffsetFromAzimuth(from_rad, projection) * horizontal;
  const double hi = OffsetFromAzimuth(to_rad, projection) * horizontal;
  for (int y0 : rows) {
    if (y0 < 0 || y0 >= luminance.height) {
      return absl::InvalidArgumentError("arc pixel row outside the image");
    }
    const double axis = geometry.AxisColumn(y0);
    const int x_first = std::max(static_cast<int>(std::ceil(axis + lo)), 0);
    const int x_last = std::min(static_cast<int>(std::floor(axis + hi)), luminance.width - 1);
    std::vector<float> values;
    std::vector<double> offsets;
    std::vector<std::uint8_t> valid;
    for (int x = x_first; x + bin_px - 1 <= x_last; x += bin_px) {
      double sum = 0.0, offset = 0.0;
      bool ok = true;
      for (int xx = x; xx < x + bin_px; ++xx) {
        // The line crosses this column at y_line: the two pixels above and
        // below it, linearly (a column's pixel stays whole along the arc).
        const double y_line = y0 + (xx - axis) * tan_t;
        const int ya = std::clamp(static_cast<int>(std::floor(y_line)), 0, luminance.height - 2);
        const double f = std::clamp(y_line - ya, 0.0, 1.0);
        const std::size_t at = static_cast<std::size_t>(ya) * luminance.width + xx;
        const std::size_t below = at + luminance.width;
        sum += (1.0 - f) * luminance.pixels[at] + f * luminance.pixels[below];
        ok = ok && !(f < 1.0 && luminance.IsSaturated(xx, ya)) &&
             !(f > 0.0 && luminance.IsSaturated(xx, ya + 1));
        // Signed distance of the point on the line from the axis.
        offset += (xx - axis) * cos_t + (y_line - y0) * sin_t;
      }
      values.push_back(static_cast<float>(sum / bin_px));
      offsets.push_back(offset / bin_px);
      valid.push_back(ok && std::isfinite(sum) ? 1 : 0);
    }
    out.rows.push_back(y0);
    out.values.push_back(std::move(values));
    out.offset_px.push_back(std::move(offsets));
    out.valid.push_back(std::move(valid));
  }
  return out;
}

}  // namespace weavefit
