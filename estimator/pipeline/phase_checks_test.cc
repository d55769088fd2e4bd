// A wrong phase angle (most often a wrong sign) must not pass silently.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "estimator/pipeline/estimate.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

Image Render(double phase_angle_deg) {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.radius_px = 128;
  scene.wavelength_mm = 2.0;
  scene.amplitude_mm = 0.0764;  // m = 0.24
  scene.phase_angle_deg = phase_angle_deg;
  scene.seed = 7;
  return RenderPhotograph(scene)->image;
}

bool HasWarning(const Estimate& e, const std::string& text) {
  for (const std::string& w : e.warnings) {
    if (w.find(text) != std::string::npos) return true;
  }
  return false;
}

TEST(PhaseChecksTest, RightPhaseAngleRaisesNoFlag) {
  Acquisition acquisition;
  acquisition.phase_angle_rad = 60.0 * kDeg;
  absl::StatusOr<Estimate> e = EstimateFromImage(Render(60.0), acquisition, EstimateOptions());
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_FALSE(HasWarning(*e, "mirror azimuth"));
}

TEST(PhaseChecksTest, WrongSignAtSixtyDegreesIsRefused) {
  Acquisition acquisition;
  acquisition.phase_angle_rad = -60.0 * kDeg;  // the light was on the right
  absl::StatusOr<Estimate> e = EstimateFromImage(Render(60.0), acquisition, EstimateOptions());
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(e.status().message()).find("phase angle"), std::string::npos)
      << e.status();
}

TEST(PhaseChecksTest, WrongSignAtTenDegreesIsFlagged) {
  Acquisition acquisition;
  acquisition.phase_angle_rad = -10.0 * kDeg;
  absl::StatusOr<Estimate> e = EstimateFromImage(Render(10.0), acquisition, EstimateOptions());
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_TRUE(HasWarning(*e, "mirror azimuth"));
  // The mirror azimuth itself is measured, not taken from the phase angle.
  EXPECT_NEAR(e->specular_azimuth_rad.value / kDeg, 5.0, 3.0 * e->specular_azimuth_rad.stderr_value / kDeg + 0.5);
}

}  // namespace
}  // namespace weavefit
