// Unit tests of cylinder/azimuth_mapping: column offset ↔ azimuth φ,
// orthographic and perspective (DESIGN.md §2).
#include "estimator/cylinder/azimuth_mapping.h"

#include <gtest/gtest.h>

#include <cmath>

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

Projection Orthographic() { return Projection{23.0, 0.0}; }
Projection Perspective() { return Projection{23.0, 900.0}; }

TEST(AzimuthMappingTest, OrthographicIsSine) {
  const Projection p = Orthographic();
  EXPECT_FALSE(p.IsPerspective());
  EXPECT_DOUBLE_EQ(p.VisibleLimbRad(), M_PI / 2.0);
  EXPECT_DOUBLE_EQ(OffsetFromAzimuth(30.0 * kDeg, p), 0.5);
  EXPECT_DOUBLE_EQ(OffsetFromAzimuth(-30.0 * kDeg, p), -0.5);
  EXPECT_NEAR(AzimuthFromOffset(0.5, p), 30.0 * kDeg, 1e-15);
  EXPECT_DOUBLE_EQ(AzimuthFromOffset(1.0, p), M_PI / 2.0);
  EXPECT_DOUBLE_EQ(AzimuthFromOffset(-1.0, p), -M_PI / 2.0);
}

TEST(AzimuthMappingTest, OrthographicRoundTrip) {
  const Projection p = Orthographic();
  for (double deg = -89.5; deg <= 89.5; deg += 0.5) {
    const double phi = deg * kDeg;
    EXPECT_NEAR(AzimuthFromOffset(OffsetFromAzimuth(phi, p), p), phi, 1e-12)
        << deg;
  }
  for (double offset = -1.0; offset <= 1.0; offset += 0.01) {
    EXPECT_NEAR(OffsetFromAzimuth(AzimuthFromOffset(offset, p), p), offset, 1e-12);
  }
}

TEST(AzimuthMappingTest, PerspectiveRoundTrip) {
  for (double distance : {900.0, 200.0, 40.0}) {
    const Projection p{23.0, distance};
    ASSERT_TRUE(p.IsPerspective());
    const double limb = p.VisibleLimbRad();
    for (double f = -0.999; f <= 0.999; f += 0.003) {
      const double phi = f * limb;
      const double offset = OffsetFromAzimuth(phi, p);
      ASSERT_LE(std::fabs(offset), 1.0) << distance << " " << phi;
      EXPECT_NEAR(AzimuthFromOffset(offset, p), phi, 1e-9)
          << "D = " << distance << ", phi = " << phi / kDeg << " deg";
    }
    for (double offset = -1.0; offset <= 1.0; offset += 0.01) {
      EXPECT_NEAR(OffsetFromAzimuth(AzimuthFromOffset(offset, p), p), offset, 1e-9);
    }
  }
}

TEST(AzimuthMappingTest, PerspectiveMatchesPinholeGeometry) {
  // Camera at (0, D), surface point (R sin φ, R cos φ): the image offset is
  // the tangent of the ray's angle from the axis direction, normalised by
  // that of the tangent ray to the limb, R / sqrt(D² − R²).
  const Projection p = Perspective();
  const double r = p.radius_mm;
  const double d = p.camera_distance_mm;
  const double limb_tan = r / std::sqrt(d * d - r * r);
  for (double deg = -88.0; deg <= 88.0; deg += 4.0) {
    const double phi = deg * kDeg;
    const double ray_tan = r * std::sin(phi) / (d - r * std::cos(phi));
    EXPECT_NEAR(OffsetFromAzimuth(phi, p), ray_tan / limb_tan, 1e-12) << deg;
  }
}

TEST(AzimuthMappingTest, PerspectiveLimbIsArccosRadiusOverDistance) {
  const Projection p = Perspective();
  const double limb = std::acos(23.0 / 900.0);
  EXPECT_NEAR(limb / kDeg, 88.5356, 1e-4);  // DESIGN.md §3: ≈ 88.5°
  EXPECT_DOUBLE_EQ(p.VisibleLimbRad(), limb);
  EXPECT_NEAR(AzimuthFromOffset(1.0, p), limb, 1e-7);
  EXPECT_NEAR(AzimuthFromOffset(-1.0, p), -limb, 1e-7);
  EXPECT_NEAR(OffsetFromAzimuth(limb, p), 1.0, 1e-12);
  EXPECT_NEAR(OffsetFromAzimuth(-limb, p), -1.0, 1e-12);
  // Offsets are normalised to the observed limb, which sits short of 90°:
  // the image of a given azimuth lies further out than sin φ, by at most
  // sqrt(D² − R²)/(D − R) − 1 ≈ 2.6 % (at the axis).
  for (double deg = 5.0; deg < 88.0; deg += 5.0) {
    const double ratio = OffsetFromAzimuth(deg * kDeg, p) / std::sin(deg * kDeg);
    EXPECT_GT(ratio, 1.0) << deg;
    EXPECT_LT(ratio, 1.026) << deg;
  }
}

TEST(AzimuthMappingTest, OffsetsBeyondTheLimbAreNan) {
  for (const Projection& p : {Orthographic(), Perspective()}) {
    EXPECT_TRUE(std::isnan(AzimuthFromOffset(1.0001, p)));
    EXPECT_TRUE(std::isnan(AzimuthFromOffset(-1.5, p)));
    EXPECT_TRUE(std::isnan(AzimuthFromOffset(std::nan(""), p)));
    EXPECT_EQ(AzimuthFromOffset(0.0, p), 0.0);
  }
}

TEST(AzimuthMappingTest, OffsetIsMonotonic) {
  const Projection p = Perspective();
  double previous = -2.0;
  for (double deg = -88.5; deg <= 88.5; deg += 0.25) {
    const double offset = OffsetFromAzimuth(deg * kDeg, p);
    EXPECT_GT(offset, previous) << deg;
    previous = offset;
  }
}

TEST(ViewAngleTest, ZeroWhenOrthographic) {
  for (double deg : {-60.0, 0.0, 45.0}) {
    EXPECT_EQ(ViewAngleRad(deg * kDeg, Orthographic()), 0.0);
  }
}

TEST(ViewAngleTest, SignAndValueForLabGeometry) {
  const Projection p = Perspective();  // D = 900 mm, R = 23 mm
  EXPECT_EQ(ViewAngleRad(0.0, p), 0.0);
  // Hand-computed: −atan(23·sin 30° / (900 − 23·cos 30°)).
  EXPECT_NEAR(ViewAngleRad(30.0 * kDeg, p), -0.0130662292559, 1e-12);
  EXPECT_NEAR(ViewAngleRad(-30.0 * kDeg, p), 0.0130662292559, 1e-12);
  for (double deg = 1.0; deg < 88.0; deg += 7.0) {
    // For φ > 0 the surface point sits right of the axis: the camera is
    // seen toward the image left, a negative angle.
    EXPECT_LT(ViewAngleRad(deg * kDeg, p), 0.0) << deg;
    EXPECT_GT(ViewAngleRad(-deg * kDeg, p), 0.0) << deg;
  }
  // At the limb the line of sight is tangent: v = φ − π/2.
  const double limb = p.VisibleLimbRad();
  EXPECT_NEAR(ViewAngleRad(limb, p), limb - M_PI / 2.0, 1e-12);
}

// Orthographic, x = c + H·sin φ with c = (L + R)/2, H = (R − L)/2: moving
// the right limb by 1 px moves φ by −(1 + sin φ)/(2H·cos φ), the left by
// −(1 − sin φ)/(2H·cos φ) (hand-differentiated).
TEST(AzimuthPerLimbTest, OrthographicByHand) {
  const double half = 200.0;
  for (double deg : {-70.0, -20.0, 0.0, 35.0, 80.0}) {
    const double phi = deg * kDeg;
    const AzimuthPerLimb d = AzimuthPerLimbPx(phi, half, Orthographic());
    EXPECT_NEAR(d.right, -(1.0 + std::sin(phi)) / (2.0 * half * std::cos(phi)), 1e-9) << deg;
    EXPECT_NEAR(d.left, -(1.0 - std::sin(phi)) / (2.0 * half * std::cos(phi)), 1e-9) << deg;
  }
}

// In perspective, against the column mapped again through moved limbs.
TEST(AzimuthPerLimbTest, PerspectiveMatchesRemappedColumns) {
  const Projection p = Perspective();
  const double half = 250.0;
  const double dx = 0.01;
  for (double deg : {-75.0, -10.0, 40.0, 85.0}) {
    const double phi = deg * kDeg;
    const double x = half * (1.0 + OffsetFromAzimuth(phi, p));  // left limb at 0
    // Limbs at l and r (centred differences of ±dx).
    auto remapped = [&](double l, double r) {
      return AzimuthFromOffset((2.0 * x - l - r) / (r - l), p);
    };
    const AzimuthPerLimb d = AzimuthPerLimbPx(phi, half, p);
    const double r0 = 2.0 * half;
    EXPECT_NEAR(d.right, (remapped(0.0, r0 + dx) - remapped(0.0, r0 - dx)) / (2.0 * dx),
                1e-4 * std::fabs(d.right)) << deg;
    EXPECT_NEAR(d.left, (remapped(dx, r0) - remapped(-dx, r0)) / (2.0 * dx),
                1e-4 * std::fabs(d.left)) << deg;
  }
}

}  // namespace
}  // namespace weavefit
