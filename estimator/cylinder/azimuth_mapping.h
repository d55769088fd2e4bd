// Mapping between image offsets from the cylinder axis and azimuth φ
// (DESIGN.md §2), orthographic or perspective.
#ifndef WEAVEFIT_ESTIMATOR_CYLINDER_AZIMUTH_MAPPING_H_
#define WEAVEFIT_ESTIMATOR_CYLINDER_AZIMUTH_MAPPING_H_

namespace weavefit {

// How the camera sees the cylinder.
struct Projection {
  double radius_mm = 23.0;           // cylinder radius
  double camera_distance_mm = 0.0;   // from the axis; 0 = orthographic

  bool IsPerspective() const { return camera_distance_mm > 0.0; }
  // Azimuth of the visible limb: π/2 orthographic, arccos(R/D) perspective.
  double VisibleLimbRad() const;
};

// Signed offset of the image of a surface point at azimuth φ from the axis,
// as a fraction of the observed limb half-width (the limb is at ±1).
// Orthographic: sin φ. Perspective (camera at distance D from the axis):
// sqrt(D² − R²)·sin φ / (D − R·cos φ).
double OffsetFromAzimuth(double azimuth_rad, const Projection& projection);

// Inverse of OffsetFromAzimuth on the visible branch; NaN when |offset| > 1.
double AzimuthFromOffset(double offset, const Projection& projection);

// Direction to the camera seen from the surface point at φ, as an angle from
// +y positive toward the image right: 0 orthographic,
// −atan(R·sin φ / (D − R·cos φ)) perspective. The mirror condition for a facet
// of tilt β is then φ + β = (α + v)/2.
double ViewAngleRad(double azimuth_rad, const Projection& projection);

// du/dφ, the offset's rate (OffsetFromAzimuth) per radian of azimuth, by a
// central difference, with φ held 0.05 rad inside the visible limb, where
// it falls to zero: what one pixel spans in azimuth, 1/(half-width·du/dφ).
double OffsetPerRadian(double azimuth_rad, const Projection& projection);

// How the azimuth read at a surface point moves with the limbs it was mapped
// through: ∂φ/∂(left limb column) and ∂φ/∂(right limb column), rad per px,
// for a point at φ between limbs half_width_px apart. A column's offset is
// u = (2x − L − R)/(R − L), so ∂u/∂R = −(1 + u)/(2·half) and ∂u/∂L =
// −(1 − u)/(2·half); near a limb dφ/du grows as 1/cos φ (held at
// cos φ = 0.05), so a limb's error moves the azimuths beside it most.
struct AzimuthPerLimb {
  double left = 0.0;
  double right = 0.0;
};
AzimuthPerLimb AzimuthPerLimbPx(double azimuth_rad, double half_width_px,
                                const Projection& projection);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_CYLINDER_AZIMUTH_MAPPING_H_
