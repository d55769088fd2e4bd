#include "estimator/profile/arc_signals.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "absl/status/status.h"

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
  if (options.max_rows > 0 && usable > options.max_rows) {
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
      double sum = 0.0;
      double sum_sq = 0.0;
      for (int x = x0; x <= x1; ++x) {
        sum += row[x];
        sum_sq += static_cast<double>(row[x]) * row[x];
      }
      const int n = x1 - x0 + 1;
      const double v = sum_sq - sum * sum / n;
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
  for (std::size_t r = 0; r < out.rows.size(); ++r) {
    const int y = out.rows[r];
    const double axis = geometry.AxisColumn(y);
    const float* row = &luminance.pixels[static_cast<std::size_t>(y) * luminance.width];
    const std::uint8_t* mask =
        luminance.saturated.empty() ? nullptr
                                    : &luminance.saturated[static_cast<std::size_t>(y) * luminance.width];
    for (int k = 0; k < out.num_samples; ++k) {
      const double x = axis + dx[k];
      const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, luminance.width - 2);
      const double t = std::clamp(x - x0, 0.0, 1.0);
      const std::size_t at = r * out.num_samples + k;
      out.values[at] = static_cast<float>((1.0 - t) * row[x0] + t * row[x0 + 1]);
      if (mask != nullptr && (mask[x0] || mask[x0 + 1])) out.valid[at] = 0;
    }
  }
  return out;
}

}  // namespace weavefit
