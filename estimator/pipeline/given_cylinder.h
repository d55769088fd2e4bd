// A cylinder known before a photograph is read (issue 31): given by the user
// when the photograph cannot show it, or shared by a measurement series, in
// which the lamp moves and the camera and sample stay (DESIGN.md §3), so
// that every photograph shows the same cylinder and the series measures it
// once, from the photographs that show it best.
#ifndef WEAVEFIT_ESTIMATOR_PIPELINE_GIVEN_CYLINDER_H_
#define WEAVEFIT_ESTIMATOR_PIPELINE_GIVEN_CYLINDER_H_

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "estimator/cylinder/cylinder_detection.h"

namespace weavefit {

// Where the cylinder an estimate used came from.
enum class CylinderSource {
  kDetected = 1,  // detected on the photograph itself
  kGiven = 2,     // given by the user
  kShared = 3,    // detected on the photographs of its series, combined
};
const char* CylinderSourceName(CylinderSource source);  // "DETECTED", ...

// The cylinder in pixels of the full image (DESIGN.md §2). The errors are
// one standard error each; all of them are counted systematic, and common
// to every photograph estimated with this cylinder: each of them reads its
// azimuths through the same limbs, so averaging them does not reduce it.
struct GivenCylinder {
  // Axis column at the image's middle row, (height − 1)/2, whatever the
  // region of interest.
  double center_x_px = 0.0;
  // Limb half-width, measured perpendicular to the axis.
  double radius_px = 0.0;
  // Axis tilt, positive when the top of the axis leans toward the image
  // right; |tilt| < kMaxTiltDeg.
  double axis_angle_rad = 0.0;
  // Standard errors of radius_px and center_x_px (px). Each limb's is their
  // quadrature sum (a limb is centre ∓ radius), as for two independent
  // limbs of equal error, whose centre and radius each have 1/√2 of it.
  double radius_stderr_px = kDefaultStderrPx;
  double center_stderr_px = kDefaultStderrPx;
  // The lens blur (Gaussian σ, px) the photograph is seen through: the
  // profile fits and the comb fit model it. 0 = sharp.
  double lens_blur_px = 0.0;
  CylinderSource source = CylinderSource::kGiven;

  // When the user gives no error: half a pixel, about what a limb read by
  // eye off a photograph at full size is good for.
  static constexpr double kDefaultStderrPx = 0.5;
  // Detection's own smallest radius (CylinderDetectionOptions::min_radius_px).
  static constexpr double kMinRadiusPx = 8.0;
  // The axis is nearly vertical in the image (DESIGN.md §2).
  static constexpr double kMaxTiltDeg = 45.0;
  // A lens blur beyond this (σ, px) blurs a limb over a good part of any
  // cylinder worth measuring.
  static constexpr double kMaxLensBlurPx = 50.0;

  // The fields on their own: finite, radius >= kMinRadiusPx, |tilt| <
  // kMaxTiltDeg, errors >= 0 and below the radius, lens blur in [0,
  // kMaxLensBlurPx], source GIVEN or SHARED. INVALID_ARGUMENT naming the wire
  // field (given_cylinder.radius_px, ...).
  absl::Status Validate() const;
};

// The geometry the pipeline reads a photograph through, from a given
// cylinder, checked against a width × height image: Validate, then, at the
// first and the last analysed row (the region's rows, or the whole image's),
// the axis and both limbs inside the image (the profile reads the
// background beyond the limbs). The rows analysed are all the region's (all
// the image's when it is empty): a cylinder whose ends are in view needs a
// region that leaves them out. Both limbs are marked not observed: neither
// was measured on this photograph. INVALID_ARGUMENT naming the field.
// `region` must have passed CheckRegion.
absl::StatusOr<CylinderGeometry> GeometryFromGiven(const GivenCylinder& given, int width,
                                                   int height, const PixelRegion& region);

// A geometry (e.g. a detected or a shared one) as a given cylinder of an
// image `height` rows high: its centre moved to the image's middle row, its
// centre's error from its limbs' (CenterStderrPx), `source` as stated.
GivenCylinder GivenFromGeometry(const CylinderGeometry& geometry, int height,
                                CylinderSource source);

// The standard error of the axis column at the reference row, and its
// systematic share, from the limbs' and the radius's (a limb is centre ∓
// radius, so a limb's variance is the centre's plus the radius's when the
// two are independent, as they are for two independent limbs of equal
// error, and for a GivenCylinder by construction).
double CenterStderrPx(const CylinderGeometry& geometry);
double CenterSystematicPx(const CylinderGeometry& geometry);

// One sentence for the reply's warnings: where the cylinder came from and
// what its errors are.
std::string GivenCylinderWarning(const GivenCylinder& given);

struct SharedCylinderOptions {
  // A detection whose centre or radius lies farther than this (px) from the
  // median of the detections used is left out as a misdetection (a
  // terminator taken for a limb moves a limb by many pixels).
  double max_disagreement_px = 2.0;
};

// The series' cylinder and how it was made.
struct SharedCylinder {
  CylinderGeometry cylinder;  // referenced to the first detection's row
  // Indices into the detections that entered it.
  std::vector<int> used;
  // Reduced chi-square of the used radii and centres about the combined
  // ones (1 when they agree as their errors say; the statistical share of
  // the combined errors is scaled by its root when above 1); 0 for one.
  double chi2 = 0.0;
  std::vector<std::string> warnings;
};

// The cylinder a series of photographs of one set-up shares, from each
// photograph's own detection (nullopt-like: a failed one is left out by the
// caller). Those with both limbs observed are used when there are any (an
// inferred limb carries a 1 px allowance and the terminator's bias); of
// them, those within options.max_disagreement_px of the median centre and
// radius. Centre, radius and tilt are their inverse-variance weighted means
// (weights 1/radius_stderr² for the radius, 1/centre stderr² for centre and
// tilt), each re-referenced to the first detection's reference row; the
// statistical shares of the errors shrink with the number combined, the
// systematic shares (the edge model's allowance, the same at every
// photograph) are their weighted means. The lens blur is the weighted
// mean of theirs. The detections must come from images of one size (the
// caller checks). INVALID_ARGUMENT for no detections.
absl::StatusOr<SharedCylinder> CombineCylinders(const std::vector<CylinderGeometry>& detections,
                                                const SharedCylinderOptions& options = {});

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_PIPELINE_GIVEN_CYLINDER_H_
