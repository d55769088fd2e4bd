// Finding the cylinder in a photograph: limbs, axis, radius, usable rows.
#ifndef WEAVEFIT_ESTIMATOR_CYLINDER_CYLINDER_DETECTION_H_
#define WEAVEFIT_ESTIMATOR_CYLINDER_CYLINDER_DETECTION_H_

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/io/image.h"

namespace weavefit {

// The cylinder as seen in the image, in pixels (DESIGN.md §2).
struct CylinderGeometry {
  // Axis column at row center_row_px.
  double center_x_px = 0.0;
  // The reference row: the middle row of the analysed region.
  double center_row_px = 0.0;
  // Observed limb half-width, measured perpendicular to the axis.
  double radius_px = 0.0;
  // Axis tilt, positive when the top of the axis leans toward the image right.
  double axis_angle_rad = 0.0;
  // Usable surface rows, inclusive.
  int top_row = 0;
  int bottom_row = 0;
  // False when that limb was inferred (lost in darkness beyond the
  // terminator), not seen.
  bool left_observed = false;
  bool right_observed = false;
  // RMS distance of the per-band limb points from the fitted lines.
  double limb_rms_px = 0.0;
  // Standard error of radius_px: the limb lines' scatter over the bands and
  // an allowance for the edge model (0.07 px per observed limb, 1 px for an
  // inferred one). It sets the scale from pixels to azimuth, so it enters
  // the wavelength in mm (and the max slope) in proportion.
  double radius_stderr_px = 0.0;
  // The allowances' share of radius_stderr_px (the rest is the lines'
  // scatter): repeated photographs of one set-up share it.
  double radius_systematic_px = 0.0;
  // The same for each limb's column at the reference row: the azimuths read
  // beside a limb move with it most (AzimuthPerLimbPx), so the peaks'
  // spacing and the mirror azimuth take their errors from these.
  double left_limb_stderr_px = 0.0;
  double right_limb_stderr_px = 0.0;
  double left_limb_systematic_px = 0.0;
  double right_limb_systematic_px = 0.0;
  // Each limb's signed move (px, + toward larger columns) when the lens
  // blur moves by its own error: both limbs move together, so this share
  // of their errors (also in *_limb_stderr_px, in quadrature) is coherent.
  double left_limb_blur_px = 0.0;
  double right_limb_blur_px = 0.0;
  // The lens blur (Gaussian σ, px) the limbs were fitted through, and one
  // the limb in shadow proposed that was not used (0 when none; its
  // allowance is then in radius_stderr_px).
  double lens_blur_px = 0.0;
  double unused_blur_px = 0.0;

  // radius_stderr_px / radius_px: the relative error of the scale from
  // pixels to azimuth (0 for an empty geometry).
  double RelativeRadiusError() const {
    return radius_px > 0.0 ? radius_stderr_px / radius_px : 0.0;
  }
  // radius_systematic_px / radius_px.
  double RelativeRadiusSystematic() const {
    return radius_px > 0.0 ? radius_systematic_px / radius_px : 0.0;
  }

  // Axis column at image row y.
  double AxisColumn(double y) const {
    return center_x_px + (center_row_px - y) * std::tan(axis_angle_rad);
  }
  // Signed perpendicular distance of pixel centre (x, y) from the axis, as a
  // fraction of the radius (the limbs are at ±1).
  double NormalisedOffset(double x, double y) const {
    return (x - AxisColumn(y)) * std::cos(axis_angle_rad) / radius_px;
  }
};

// A rectangle of pixels; empty (all zero) means the whole image.
struct PixelRegion {
  int x = 0;
  int y = 0;
  int width = 0;
  int height = 0;
  bool IsEmpty() const { return width == 0 && height == 0; }
};

struct CylinderDetectionOptions {
  // Horizontal bands of rows in which limbs are located independently.
  int num_bands = 24;
  // Fraction of the image width at each side taken as background.
  double background_fraction = 0.04;
  // A limb must rise this many background noise sigmas (of a band mean).
  double edge_sigmas = 8.0;
  // Smallest acceptable radius in pixels.
  double min_radius_px = 8.0;
  PixelRegion region;
  // Phase angle (rad) when known: the brightest part of the surface must
  // then lie within max_lobe_offset_rad of the mirror azimuth α/2, and the
  // part of the disc in shadow (beyond the terminator α − sign(α)·90°) must
  // show no direct light (stray light may light it, FindShadowOnset). When the lobe lies more than
  // min_lobe_offset_to_infer_rad away or the shadow is lit, the edge away
  // from the light is tried as the terminator, with the limb beyond it lost
  // in darkness and inferred (terminator.h); that cylinder is kept when its
  // lobe lies within min_lobe_offset_to_infer_rad of α/2. Otherwise
  // detection fails rather than mislead. NaN = unknown: no check, no
  // inference.
  double phase_angle_rad = std::numeric_limits<double>::quiet_NaN();
  double max_lobe_offset_rad = 40.0 * 3.14159265358979323846 / 180.0;
  double min_lobe_offset_to_infer_rad = 10.0 * 3.14159265358979323846 / 180.0;
  Projection projection;  // for the lobe's azimuth

  absl::Status Validate() const;
};

// Whether direct light begins inside the part of the disc that should lie in
// shadow (DESIGN.md §3: stray light reaches the whole body, so the side away
// from the lamp shows a smooth low level and the weave's texture, not black).
// `profile` holds column means (index 0 = the profile's first column);
// columns lo..hi (inclusive) are the region between the unlit limb and the
// terminator; `center` and `half_width` (px, same indexing) map a column to
// azimuth through `projection`; `light_side` is +1 for light on the right.
// Two models of the region's 5-column block means are compared:
//   M0, the body in stray light: a + b·u + c·cos φ + d·u² (a diffuse
//       source's low-order irradiance on a Lambertian cylinder, a + b·sin φ
//       + c·cos φ, plus the background's gradient and vignetting in u);
//   M1, M0 plus an onset at φ0 inside the region growing toward the light:
//       the Lambertian max(0, sin(s·(φ − φ0))) or the axial threads' grazing
//       scatter, a step ∝ 1/cos φ; φ0 scanned over the region.
// `lit` when M1 is decisively better (see the .cc) and its rise exceeds
// min_rise. Regions under 8 blocks are not judged (judged and lit false).
// The detector's test of the shadow: an onset there means the edge taken for
// the unlit limb is not one.
struct ShadowOnset {
  bool judged = false;        // the region held 8 blocks or more
  bool lit = false;
  double delta_bic = 0.0;     // BIC(M0) − BIC(M1) of the best onset
  double onset_column = std::numeric_limits<double>::quiet_NaN();
  double rise = 0.0;          // largest difference of the M1 and M0 fits
  double sigma = 0.0;         // the blocks' scatter about M1
  double level = 0.0;         // median of the block means
};
ShadowOnset FindShadowOnset(const std::vector<double>& profile, int lo, int hi,
                            double center, double half_width, int light_side,
                            const Projection& projection, double min_rise);

// What detection saw, for a picture of why it refused a photograph (`--plot`
// on a refusal): plain data in image coordinates, NaN where nothing was found.
struct DetectionTrace {
  PixelRegion region;                // the region read (never empty once filled)
  int side_px = 0;                   // the side strips read as background, each side
  std::vector<double> column_means;  // all bands' rows; [0] is column region.x
  double left_background = std::numeric_limits<double>::quiet_NaN();
  double right_background = std::numeric_limits<double>::quiet_NaN();
  double noise = std::numeric_limits<double>::quiet_NaN();  // one pixel's
  // Each row band's two edges, where the band found both (FindBandLimbs).
  struct BandEdge {
    double row = 0.0;
    double left_x = 0.0;
    double right_x = 0.0;
  };
  std::vector<BandEdge> band_edges;
  // Each limb as all rows together place it (FindShearedLimbs), at the
  // reference row; NaN when they placed none.
  double all_rows_left_x = std::numeric_limits<double>::quiet_NaN();
  double all_rows_right_x = std::numeric_limits<double>::quiet_NaN();
  // A cylinder the edges were taken to make, and what the photograph said
  // to it: `verdict` gives the figures that kept or rejected it.
  struct Hypothesis {
    std::string name;
    CylinderGeometry cylinder;
    bool kept = false;
    std::string verdict;
  };
  std::vector<Hypothesis> hypotheses;
  double phase_angle_rad = std::numeric_limits<double>::quiet_NaN();
  bool Filled() const { return !column_means.empty(); }
};

// Locates the cylinder in a one-channel linear image. INVALID_ARGUMENT when
// no cylinder is found (the message says why). With `trace`, what was seen
// on the way (of the attempt whose result is returned).
absl::StatusOr<CylinderGeometry> DetectCylinder(const Image& luminance,
                                                const CylinderDetectionOptions& options,
                                                DetectionTrace* trace = nullptr);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_CYLINDER_CYLINDER_DETECTION_H_
