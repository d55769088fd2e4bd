// Per-row signals along the arc, for the thread-period analysis (DESIGN.md
// §3: the wavelength comes only from the image's fine structure).
#ifndef WEAVEFIT_ESTIMATOR_PROFILE_ARC_SIGNALS_H_
#define WEAVEFIT_ESTIMATOR_PROFILE_ARC_SIGNALS_H_

#include <cstdint>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/cylinder/cylinder_detection.h"
#include "estimator/io/image.h"

namespace weavefit {

// Each usable row resampled on one uniform azimuth grid (linear
// interpolation between pixel centres along the row). Arc length on the
// cylinder is s = radius_mm · φ.
struct ArcSignals {
  double first_azimuth_rad = 0.0;
  double step_rad = 0.0;
  int num_samples = 0;
  std::vector<int> rows;                 // image row of each signal
  std::vector<float> values;             // rows × num_samples, linear
  std::vector<std::uint8_t> valid;       // 0 where a saturated pixel was used
  double radius_mm = 0.0;

  double StepMm() const { return step_rad * radius_mm; }
  const float* Row(int i) const { return &values[static_cast<std::size_t>(i) * num_samples]; }
};

struct ArcSignalOptions {
  double from_rad = 0.0;   // azimuth range, from < to, inside the visible limb
  double to_rad = 0.0;
  // Grid step; 0 = half a pixel at the axis (0.5 / radius_px).
  double step_rad = 0.0;
  // At most this many rows: those whose pixels over the range vary most
  // (glints follow thread crests); 0 = all usable rows.
  int max_rows = 0;
  // When not empty, exactly these image rows (each within the usable rows),
  // in this order, and max_rows is not used: a wider range over the rows
  // an earlier call chose, without ranking the rows again.
  std::vector<int> rows;

  absl::Status Validate() const;
};

absl::StatusOr<ArcSignals> ExtractArcSignals(const Image& luminance,
                                             const CylinderGeometry& geometry,
                                             const Projection& projection,
                                             const ArcSignalOptions& options);

// The raw pixels of chosen rows along the arc, for fitting glints pixel by
// pixel (glints/comb_fit.h): each signal runs along the line through the
// row's axis point perpendicular to the axis (so that it stays on one thread
// when the axis is tilted) and takes, in every image column, the two pixels
// above and below the line, interpolated linearly along the column only: along
// the arc every value is exactly whole pixels' average. Neighbouring columns
// are averaged into bins of bin_px. Each bin carries the perpendicular
// distance of its centre from the axis and its width, in px.
struct ArcPixels {
  int bin_px = 1;
  double radius_px = 0.0;        // limb half-width, perpendicular to the axis
  double bin_width_px = 0.0;     // one bin's width perpendicular to the axis
  std::vector<int> rows;         // anchor row of each signal (on the axis)
  std::vector<std::vector<float>> values;        // per row, per bin
  std::vector<std::vector<double>> offset_px;    // per row, per bin: centre
  std::vector<std::vector<std::uint8_t>> valid;  // 0 where a pixel clipped
};

// Columns whose centres lie between the azimuths from_rad and to_rad, in bins
// of `bin_px` columns, for each anchor row in `rows`.
absl::StatusOr<ArcPixels> ExtractArcPixels(const Image& luminance, const CylinderGeometry& geometry,
                                           const Projection& projection,
                                           const std::vector<int>& rows, double from_rad,
                                           double to_rad, int bin_px);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_PROFILE_ARC_SIGNALS_H_
