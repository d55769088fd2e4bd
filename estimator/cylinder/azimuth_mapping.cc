#include "estimator/cylinder/azimuth_mapping.h"

#include <cmath>
#include <algorithm>
#include <limits>

namespace weavefit {

double Projection::VisibleLimbRad() const {
  if (!IsPerspective()) return M_PI / 2.0;
  return std::acos(radius_mm / camera_distance_mm);
}

double OffsetFromAzimuth(double azimuth_rad, const Projection& projection) {
  if (!projection.IsPerspective()) return std::sin(azimuth_rad);
  const double r = projection.radius_mm;
  const double d = projection.camera_distance_mm;
  return std::sqrt(d * d - r * r) * std::sin(azimuth_rad) /
         (d - r * std::cos(azimuth_rad));
}

double AzimuthFromOffset(double offset, const Projection& projection) {
  if (!(std::fabs(offset) <= 1.0)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  if (!projection.IsPerspective()) return std::asin(offset);
  // sin φ + t·R·cos φ = t·D with t = offset / sqrt(D² − R²), i.e.
  // A·sin(φ + δ) = t·D, A = sqrt(1 + t²R²), δ = atan(t·R).
  const double r = projection.radius_mm;
  const double d = projection.camera_distance_mm;
  const double t = offset / std::sqrt(d * d - r * r);
  const double a = std::sqrt(1.0 + t * t * r * r);
  const double s = std::clamp(t * d / a, -1.0, 1.0);
  return std::asin(s) - std::atan(t * r);
}

double ViewAngleRad(double azimuth_rad, const Projection& projection) {
  if (!projection.IsPerspective()) return 0.0;
  const double r = projection.radius_mm;
  const double d = projection.camera_distance_mm;
  return -std::atan(r * std::sin(azimuth_rad) / (d - r * std::cos(azimuth_rad)));
}

double OffsetPerRadian(double azimuth_rad, const Projection& projection) {
  const double limb = projection.VisibleLimbRad() - 0.05;
  const double phi = std::clamp(azimuth_rad, -limb, limb);
  const double h = 1e-5;
  return (OffsetFromAzimuth(phi + h, projection) - OffsetFromAzimuth(phi - h, projection)) /
         (2.0 * h);
}

AzimuthPerLimb AzimuthPerLimbPx(double azimuth_rad, double half_width_px,
                                const Projection& projection) {
  if (!(half_width_px > 0.0)) return {};
  const double du_dphi = OffsetPerRadian(azimuth_rad, projection);
  if (!(du_dphi > 0.0)) return {};
  const double u = OffsetFromAzimuth(azimuth_rad, projection);
  return {-(1.0 - u) / (2.0 * half_width_px * du_dphi),
          -(1.0 + u) / (2.0 * half_width_px * du_dphi)};
}

}  // namespace weavefit
