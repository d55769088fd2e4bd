#include "estimator/pipeline/given_cylinder.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The smallest standard error a detection is weighted with (px): a
// geometry that states none is not infinitely precise.
constexpr double kMinWeightingStderrPx = 1e-3;

absl::Status Invalid(const std::string& message) {
  return absl::InvalidArgumentError(message);
}

// One reading of a quantity the series combines: value, standard error and
// its systematic share.
struct Reading {
  double value = 0.0;
  double stderr_value = 0.0;
  double systematic = 0.0;
};

struct Combined {
  double value = 0.0;
  double stderr_value = 0.0;
  double systematic = 0.0;
  double chi2 = 0.0;  // reduced; 0 for one reading
};

// The inverse-variance weighted mean of `readings` (not empty): the
// statistical shares combine as independent errors, scaled by the root of
// the reduced chi-square when above 1; the systematic shares, the same
// allowance at every reading, by their weighted mean.
Combined InverseVarianceMean(const std::vector<Reading>& readings) {
  double sum_w = 0.0;
  double sum_wv = 0.0;
  double sum_ws = 0.0;
  double sum_w2_stat2 = 0.0;
  for (const Reading& r : readings) {
    const double se = std::max(r.stderr_value, kMinWeightingStderrPx);
    const double w = 1.0 / (se * se);
    const double stat2 = std::max(0.0, r.stderr_value * r.stderr_value - r.systematic * r.systematic);
    sum_w += w;
    sum_wv += w * r.value;
    sum_ws += w * r.systematic;
    sum_w2_stat2 += w * w * stat2;
  }
  Combined c;
  c.value = sum_wv / sum_w;
  if (readings.size() > 1) {
    double chi2 = 0.0;
    for (const Reading& r : readings) {
      const double se = std::max(r.stderr_value, kMinWeightingStderrPx);
      chi2 += (r.value - c.value) * (r.value - c.value) / (se * se);
    }
    c.chi2 = chi2 / static_cast<double>(readings.size() - 1);
  }
  const double statistical = std::sqrt(sum_w2_stat2) / sum_w * std::sqrt(std::max(1.0, c.chi2));
  c.systematic = sum_ws / sum_w;
  c.stderr_value = std::hypot(statistical, c.systematic);
  return c;
}

double LowerMedian(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[(values.size() - 1) / 2];
}

// The detections the series' cylinder is made of: those with both limbs
// observed (all when none has), then those near the median centre and
// radius. Each left out gets a warning.
std::vector<int> SelectDetections(const std::vector<CylinderGeometry>& detections,
                                  double reference_row, const SharedCylinderOptions& options,
                                  std::vector<std::string>* warnings) {
  std::vector<int> candidates;
  for (int i = 0; i < static_cast<int>(detections.size()); ++i) {
    if (detections[i].left_observed && detections[i].right_observed) candidates.push_back(i);
  }
  if (candidates.empty()) {
    for (int i = 0; i < static_cast<int>(detections.size()); ++i) candidates.push_back(i);
  } else if (candidates.size() < detections.size()) {
    std::vector<std::string> left_out;
    for (int i = 0; i < static_cast<int>(detections.size()); ++i) {
      if (std::find(candidates.begin(), candidates.end(), i) == candidates.end()) {
        left_out.push_back(absl::StrCat(i + 1));
      }
    }
    warnings->push_back(absl::StrCat(
        "the series' cylinder leaves out detection(s) ", absl::StrJoin(left_out, ", "),
        " of ", detections.size(), ": a limb there was inferred, not seen"));
  }
  std::vector<double> centres;
  std::vector<double> radii;
  for (int i : candidates) {
    centres.push_back(detections[i].AxisColumn(reference_row));
    radii.push_back(detections[i].radius_px);
  }
  const double centre = LowerMedian(centres);
  const double radius = LowerMedian(radii);
  std::vector<int> used;
  for (int i : candidates) {
    const double dc = detections[i].AxisColumn(reference_row) - centre;
    const double dr = detections[i].radius_px - radius;
    if (std::fabs(dc) <= options.max_disagreement_px &&
        std::fabs(dr) <= options.max_disagreement_px) {
      used.push_back(i);
    } else {
      warnings->push_back(absl::StrFormat(
          "the series' cylinder leaves out detection %d of %d: its axis (column %.1f) and "
          "radius (%.1f px) lie %.1f and %.1f px from the series' median, more than %.1f px: "
          "taken for a misdetection",
          i + 1, detections.size(), detections[i].AxisColumn(reference_row),
          detections[i].radius_px, dc, dr, options.max_disagreement_px));
    }
  }
  return used;
}

}  // namespace

const char* CylinderSourceName(CylinderSource source) {
  switch (source) {
    case CylinderSource::kDetected:
      return "DETECTED";
    case CylinderSource::kGiven:
      return "GIVEN";
    case CylinderSource::kShared:
      return "SHARED";
  }
  return "UNKNOWN";
}

absl::Status GivenCylinder::Validate() const {
  const std::pair<const char*, double> fields[] = {
      {"given_cylinder.center_x_px", center_x_px},
      {"given_cylinder.radius_px", radius_px},
      {"given_cylinder.axis_angle_deg", axis_angle_rad / kDeg},
      {"given_cylinder.radius_stderr_px", radius_stderr_px},
      {"given_cylinder.center_stderr_px", center_stderr_px},
      {"given_cylinder.lens_blur_px", lens_blur_px}};
  for (const auto& [name, value] : fields) {
    if (!std::isfinite(value)) {
      return Invalid(absl::StrFormat("%s must be a finite number, got %g", name, value));
    }
  }
  if (!(radius_px >= kMinRadiusPx)) {
    return Invalid(absl::StrFormat("given_cylinder.radius_px must be >= %g, got %g",
                                   kMinRadiusPx, radius_px));
  }
  if (!(std::fabs(axis_angle_rad) < kMaxTiltDeg * kDeg)) {
    return Invalid(absl::StrFormat(
        "given_cylinder.axis_angle_deg must be in (-%g, %g) (the axis is nearly vertical in "
        "the image), got %g",
        kMaxTiltDeg, kMaxTiltDeg, axis_angle_rad / kDeg));
  }
  if (!(radius_stderr_px >= 0.0 && radius_stderr_px < radius_px)) {
    return Invalid(absl::StrFormat(
        "given_cylinder.radius_stderr_px must be >= 0 and below the radius %g, got %g",
        radius_px, radius_stderr_px));
  }
  if (!(center_stderr_px >= 0.0 && center_stderr_px < radius_px)) {
    return Invalid(absl::StrFormat(
        "given_cylinder.center_stderr_px must be >= 0 and below the radius %g, got %g",
        radius_px, center_stderr_px));
  }
  if (!(lens_blur_px >= 0.0 && lens_blur_px <= kMaxLensBlurPx)) {
    return Invalid(absl::StrFormat("given_cylinder.lens_blur_px must be in [0, %g], got %g",
                                   kMaxLensBlurPx, lens_blur_px));
  }
  if (source != CylinderSource::kGiven && source != CylinderSource::kShared) {
    return Invalid("given_cylinder.source must be GIVEN or SHARED");
  }
  return absl::OkStatus();
}

absl::StatusOr<CylinderGeometry> GeometryFromGiven(const GivenCylinder& given, int width,
                                                   int height, const PixelRegion& region) {
  if (absl::Status s = given.Validate(); !s.ok()) return s;
  if (width <= 0 || height <= 0) return Invalid("the image is empty");
  CylinderGeometry g;
  // CheckRegion has held y + height within the image, so no sum wraps.
  g.top_row = region.IsEmpty() ? 0 : region.y;
  g.bottom_row = region.IsEmpty() ? height - 1 : region.y + region.height - 1;
  g.center_row_px = 0.5 * (g.top_row + static_cast<double>(g.bottom_row));
  g.axis_angle_rad = given.axis_angle_rad;
  g.radius_px = given.radius_px;
  const double middle = 0.5 * (height - 1.0);
  g.center_x_px = given.center_x_px + (middle - g.center_row_px) * std::tan(given.axis_angle_rad);
  const double half = given.radius_px / std::cos(given.axis_angle_rad);
  const double last_column = width - 1.0;
  for (const int row : {g.top_row, g.bottom_row}) {
    const double axis = g.AxisColumn(row);
    if (!(axis >= 0.0 && axis <= last_column)) {
      return Invalid(absl::StrFormat(
          "given_cylinder.center_x_px %g with axis_angle_deg %g puts the axis at column %.1f in "
          "row %d, outside the image (width %d)",
          given.center_x_px, given.axis_angle_rad / kDeg, axis, row, width));
    }
    if (!(axis - half >= 0.0 && axis + half <= last_column)) {
      return Invalid(absl::StrFormat(
          "given_cylinder.radius_px %g puts the %s limb at column %.1f in row %d, outside the "
          "image (width %d): the profile reads the background beyond both limbs",
          given.radius_px, axis - half < 0.0 ? "left" : "right",
          axis - half < 0.0 ? axis - half : axis + half, row, width));
    }
  }
  // Neither limb was measured on this photograph, and every error is the
  // given one, shared by all photographs read through it (systematic).
  g.left_observed = false;
  g.right_observed = false;
  g.radius_stderr_px = given.radius_stderr_px;
  g.radius_systematic_px = given.radius_stderr_px;
  const double limb = std::hypot(given.center_stderr_px, given.radius_stderr_px);
  g.left_limb_stderr_px = limb;
  g.right_limb_stderr_px = limb;
  g.left_limb_systematic_px = limb;
  g.right_limb_systematic_px = limb;
  g.lens_blur_px = given.lens_blur_px;
  return g;
}

double CenterStderrPx(const CylinderGeometry& g) {
  const double limbs2 = 0.5 * (g.left_limb_stderr_px * g.left_limb_stderr_px +
                               g.right_limb_stderr_px * g.right_limb_stderr_px);
  return std::sqrt(std::max(0.0, limbs2 - g.radius_stderr_px * g.radius_stderr_px));
}

double CenterSystematicPx(const CylinderGeometry& g) {
  const double limbs2 = 0.5 * (g.left_limb_systematic_px * g.left_limb_systematic_px +
                               g.right_limb_systematic_px * g.right_limb_systematic_px);
  return std::sqrt(std::max(0.0, limbs2 - g.radius_systematic_px * g.radius_systematic_px));
}

GivenCylinder GivenFromGeometry(const CylinderGeometry& geometry, int height,
                                CylinderSource source) {
  GivenCylinder given;
  given.center_x_px = geometry.AxisColumn(0.5 * (height - 1.0));
  given.radius_px = geometry.radius_px;
  given.axis_angle_rad = geometry.axis_angle_rad;
  given.radius_stderr_px = geometry.radius_stderr_px;
  given.center_stderr_px = CenterStderrPx(geometry);
  given.lens_blur_px = geometry.lens_blur_px;
  given.source = source;
  return given;
}

std::string GivenCylinderWarning(const GivenCylinder& given) {
  const std::string what =
      given.source == CylinderSource::kShared
          ? "the cylinder is the one the series shares (detected on the photographs that show "
            "it best and combined), not this photograph's own detection"
          : "the cylinder was given, not detected on this photograph";
  return absl::StrFormat(
      "%s: axis at column %.2f +- %.2f px in the image's middle row, radius %.2f +- %.2f px, "
      "tilt %.3f deg, lens blur %.2f px; its errors enter every quantity read through it, "
      "and as systematic: every photograph read through this cylinder shares them",
      what, given.center_x_px, given.center_stderr_px, given.radius_px, given.radius_stderr_px,
      given.axis_angle_rad / kDeg, given.lens_blur_px);
}

absl::StatusOr<SharedCylinder> CombineCylinders(const std::vector<CylinderGeometry>& detections,
                                                const SharedCylinderOptions& options) {
  if (detections.empty()) return Invalid("no cylinder detected on any photograph of the series");
  if (!(options.max_disagreement_px > 0.0)) {
    return Invalid("max_disagreement_px must be > 0");
  }
  SharedCylinder shared;
  const double reference_row = detections[0].center_row_px;
  shared.used = SelectDetections(detections, reference_row, options, &shared.warnings);
  std::vector<Reading> centres;
  std::vector<Reading> radii;
  std::vector<Reading> tilts;  // weighted as the centres
  double blur_sum = 0.0;
  double blur_weight = 0.0;
  for (int i : shared.used) {
    const CylinderGeometry& d = detections[i];
    const double centre_se = CenterStderrPx(d);
    centres.push_back({d.AxisColumn(reference_row), centre_se, CenterSystematicPx(d)});
    radii.push_back({d.radius_px, d.radius_stderr_px, d.radius_systematic_px});
    tilts.push_back({d.axis_angle_rad, centre_se, 0.0});
    const double se = std::max(d.radius_stderr_px, kMinWeightingStderrPx);
    blur_sum += d.lens_blur_px / (se * se);
    blur_weight += 1.0 / (se * se);
  }
  const Combined centre = InverseVarianceMean(centres);
  const Combined radius = InverseVarianceMean(radii);
  const Combined tilt = InverseVarianceMean(tilts);
  CylinderGeometry& g = shared.cylinder;
  g = detections[shared.used[0]];
  g.center_row_px = reference_row;
  g.center_x_px = centre.value;
  g.radius_px = radius.value;
  g.axis_angle_rad = tilt.value;
  g.radius_stderr_px = radius.stderr_value;
  g.radius_systematic_px = radius.systematic;
  g.left_limb_stderr_px = g.right_limb_stderr_px = std::hypot(centre.stderr_value, radius.stderr_value);
  g.left_limb_systematic_px = g.right_limb_systematic_px =
      std::hypot(centre.systematic, radius.systematic);
  g.left_limb_blur_px = g.right_limb_blur_px = 0.0;
  g.lens_blur_px = blur_sum / blur_weight;
  g.unused_blur_px = 0.0;
  shared.chi2 = std::max(centre.chi2, radius.chi2);
  if (shared.chi2 > 1.0) {
    shared.warnings.push_back(absl::StrFormat(
        "the series' detections of its cylinder differ by more than their errors say (reduced "
        "chi-square %.1f for the %s): its errors are scaled up by %.2f; check that neither "
        "camera nor sample moved",
        shared.chi2, centre.chi2 >= radius.chi2 ? "axis" : "radius", std::sqrt(shared.chi2)));
  }
  return shared;
}

}  // namespace weavefit
