// A wrong phase angle (most often a wrong sign) must not pass silently, nor
// a lobe too clipped to read.
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

// The scene rendered and estimated with its own phase angle stated.
absl::StatusOr<Estimate> EstimateAtItsPhaseAngle(const RenderScene& scene) {
  absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
  if (!rendered.ok()) return rendered.status();
  Acquisition acquisition;
  acquisition.phase_angle_rad = scene.phase_angle_deg * kDeg;
  return EstimateFromImage(rendered->image, acquisition, EstimateOptions());
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

// A body as dark as the background (ambient = background, no Lambertian,
// 5,000 photons) shows only the lobe's stripe of glints, which detection
// takes for a 27 px cylinder; read on it, the lobe stood 28° from half the
// phase angle and a 25.9° sinusoid came out a 12.9° sawtooth. So far from
// α/2 the estimate is refused, with both possible causes named.
TEST(PhaseChecksTest, ALobeFarFromHalfThePhaseAngleIsRefused) {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.wavelength_mm = 2.0;
  scene.amplitude_mm = 0.0722;
  scene.phase_angle_deg = -28.9;
  scene.axis_angle_deg = -1.0;
  scene.photons_full_scale = 5000;
  scene.optics_blur_px = 0.99;
  scene.ambient = 0.01;
  scene.seed = 102;
  absl::StatusOr<Estimate> e = EstimateAtItsPhaseAngle(scene);
  ASSERT_FALSE(e.ok()) << ProfileModelName(e->model) << " " << e->peak_spacing_rad.value / kDeg;
  EXPECT_EQ(e.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(e.status().message()).find("phase angle"), std::string::npos)
      << e.status();
}

// A sinusoid m = 0.47 at α = −90°, the phase angle stated 16° short: the
// lobe stands 8° from half of it, beyond 3 errors and 5° and short of the
// 20° refusal. Peak picking's numbers are then reported unresolved, with
// the reason. (This check came from the same scene at its own phase angle,
// where the seen unlit limb was once taken for the terminator and the
// cylinder inferred twice its size: 16° short at 12 stated errors.)
RenderScene SteepSinusoidAtMinus90() {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.wavelength_mm = 2.0;
  scene.amplitude_mm = 0.15;
  scene.radius_px = 128.0;
  scene.phase_angle_deg = -90.0;
  scene.seed = 133;
  return scene;
}

TEST(PhaseChecksTest, ALobeSeveralDegreesOffLeavesTheSplitUnresolved) {
  absl::StatusOr<Rendered> rendered = RenderPhotograph(SteepSinusoidAtMinus90());
  ASSERT_TRUE(rendered.ok()) << rendered.status();
  Acquisition acquisition;
  acquisition.phase_angle_rad = -74.0 * kDeg;
  absl::StatusOr<Estimate> e = EstimateFromImage(rendered->image, acquisition, EstimateOptions());
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_FALSE(e->peak_spacing_rad.resolved) << e->peak_spacing_rad.value / kDeg;
  EXPECT_FALSE(e->max_slope.resolved);
  EXPECT_TRUE(HasWarning(*e, "not resolved")) << e->warnings.size();
}

// The same scene at its own phase angle: the body seen in shadow inside
// the unlit limb makes that edge the limb, and the lobe is read where it is.
TEST(PhaseChecksTest, TheBodySeenInShadowKeepsTheUnlitLimb) {
  const RenderScene scene = SteepSinusoidAtMinus90();
  absl::StatusOr<Estimate> e = EstimateAtItsPhaseAngle(scene);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_TRUE(e->cylinder.left_observed);
  EXPECT_TRUE(e->cylinder.right_observed);
  EXPECT_NEAR(e->cylinder.radius_px, scene.radius_px, 0.5);
  ASSERT_TRUE(e->peak_spacing_rad.resolved);
  const double truth = 2.0 * std::atan(2.0 * M_PI * 0.15 / 2.0) / kDeg;
  EXPECT_NEAR(e->peak_spacing_rad.value / kDeg, truth,
              3.0 * e->peak_spacing_rad.stderr_value / kDeg);
}

// A sawtooth m = 0.47 at α = −95° on a dim diffuse body in a vignetted
// frame: its outer caustic lies 6 px inside the lit limb, beyond the
// columns detection looks for the lobe in, so the lobe seemed to stand at
// its inner caustic, 25° from α/2. A dark limb was inferred 300 px out and
// the photograph refused; the body seen in shadow now keeps the seen limb.
TEST(PhaseChecksTest, AnOuterCausticAtTheLimbKeepsTheSeenLimbs) {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.model = ProfileModel::kSawtooth;
  scene.wavelength_mm = 2.0836;
  scene.amplitude_mm = 0.24343;
  scene.phase_angle_deg = -95.43;
  scene.radius_px = 127.0;
  scene.photons_full_scale = 50000.0;
  scene.source_blur_deg = 0.56;
  scene.exposure = 0.0095;
  scene.diffuse = 0.05;
  scene.vignetting = 0.15;
  scene.seed = 18;
  absl::StatusOr<Estimate> e = EstimateAtItsPhaseAngle(scene);
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_NEAR(e->cylinder.radius_px, scene.radius_px, 0.5);
  EXPECT_EQ(e->model, ProfileModel::kSawtooth) << ProfileModelName(e->model);
  ASSERT_TRUE(e->peak_spacing_rad.resolved);
  const double truth = 2.0 * std::atan(4.0 * scene.amplitude_mm / scene.wavelength_mm) / kDeg;
  EXPECT_NEAR(e->peak_spacing_rad.value / kDeg, truth,
              3.0 * e->peak_spacing_rad.stderr_value / kDeg);
}

// A steep sawtooth (m = 0.49) at α = −118°: its outer caustic lies 2.5 px
// inside the lit limb (R = 256 px). The limb fit took the peak for part of
// the edge (2.2 px out) and the spacing came out 3.4° short at 7.7 stated
// errors; now the split is reported unresolved, with the reason.
RenderScene SawtoothWithItsCausticAtTheLimb() {
  RenderScene scene;
  scene.width_px = 640;
  scene.height_px = 480;
  scene.radius_px = 256.0;
  scene.model = ProfileModel::kSawtooth;
  scene.wavelength_mm = 1.0;
  scene.amplitude_mm = 0.1236;
  scene.phase_angle_deg = -118.4;
  scene.seed = 112;
  return scene;
}

TEST(PhaseChecksTest, ACausticAtTheLimbLeavesTheSplitUnresolved) {
  absl::StatusOr<Estimate> e = EstimateAtItsPhaseAngle(SawtoothWithItsCausticAtTheLimb());
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_FALSE(e->peak_spacing_rad.resolved) << e->peak_spacing_rad.value / kDeg;
  EXPECT_FALSE(e->max_slope.resolved);
  EXPECT_TRUE(HasWarning(*e, "inside the limb")) << e->warnings.size();
}

// The same sawtooth under stray light, which shows the plain weave's relief:
// the relief's period stands apart from the caustics, so the wavelength is
// kept (its error counting the limb the caustic may have drawn out), while
// the split, the slope and the amplitude stay unresolved.
TEST(PhaseChecksTest, ACausticAtTheLimbKeepsTheReliefsWavelength) {
  RenderScene scene = SawtoothWithItsCausticAtTheLimb();
  scene.stray_light = 0.04;
  scene.stray_texture = 0.6;
  absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
  ASSERT_TRUE(rendered.ok()) << rendered.status();
  Acquisition acquisition;
  acquisition.phase_angle_rad = scene.phase_angle_deg * kDeg;
  acquisition.cylinder_diameter_mm = scene.diameter_mm;
  absl::StatusOr<Estimate> e = EstimateFromImage(rendered->image, acquisition, EstimateOptions());
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_FALSE(e->peak_spacing_rad.resolved) << e->peak_spacing_rad.value / kDeg;
  EXPECT_FALSE(e->max_slope.resolved);
  EXPECT_FALSE(e->amplitude_mm.resolved);
  EXPECT_TRUE(HasWarning(*e, "inside the limb")) << e->warnings.size();
  ASSERT_TRUE(e->wavelength_mm.resolved);
  EXPECT_TRUE(HasWarning(*e, "the weave's relief"));
  EXPECT_NEAR(e->wavelength_mm.value, scene.wavelength_mm, 3.0 * e->wavelength_mm.stderr_value);
  EXPECT_LT(e->wavelength_mm.stderr_value, 0.05 * scene.wavelength_mm);
}

// The bench sweep's scene (m 0.24, 1.44 mm = 16 px per period, α = 30°) at
// `times` the default exposure.
Image Overexposed(double times) {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.wavelength_mm = 1.44;
  scene.amplitude_mm = 0.24 * scene.wavelength_mm / (2.0 * M_PI);
  scene.phase_angle_deg = 30.0;
  scene.exposure *= times;
  scene.seed = 1017;
  return RenderPhotograph(scene)->image;
}

// A lobe clipped over most of its width is a plateau whose inner glints
// peak picking took for the caustics (8.5° read for 27°, outside its stated
// error): the split is now reported unresolved with the reason, not as a
// wrong number. At 10x the lobe is mostly unclipped and is read.
TEST(ClippedLobeTest, MostlyClippedLobeIsNotReadByPeakPicking) {
  Acquisition acquisition;
  acquisition.phase_angle_rad = 30.0 * kDeg;
  EstimateOptions fast;
  fast.mode = Mode::kFast;
  absl::StatusOr<Estimate> clipped = EstimateFromImage(Overexposed(30.0), acquisition, fast);
  ASSERT_TRUE(clipped.ok()) << clipped.status();
  EXPECT_FALSE(clipped->peak_spacing_rad.resolved) << clipped->peak_spacing_rad.value / kDeg;
  EXPECT_FALSE(clipped->max_slope.resolved);
  EXPECT_TRUE(HasWarning(*clipped, "clipped at the sensor's maximum"));

  absl::StatusOr<Estimate> bright = EstimateFromImage(Overexposed(10.0), acquisition, fast);
  ASSERT_TRUE(bright.ok()) << bright.status();
  ASSERT_TRUE(bright->peak_spacing_rad.resolved);
  EXPECT_FALSE(HasWarning(*bright, "clipped at the sensor's maximum"));
  // Truth 2·arctan(0.24) = 26.99°; fast mode's comb bias is within its error.
  EXPECT_NEAR(bright->peak_spacing_rad.value / kDeg, 26.99,
              3.0 * bright->peak_spacing_rad.stderr_value / kDeg);
}

// Glints that clip only here and there (a few per cent of a bin's pixels,
// under the 5 % at which a bin counts as clipped) took the brightest pixels
// out of the caustic bins when they were left out of the mean: at 5x the
// default exposure this lobe read 15.4 deg short, 3.9 stated errors, and the
// comb fit failed from there. Read at the lower bound the clipped pixels
// give, the peaks are within their error, and the comb fit runs.
TEST(ClippedLobeTest, CausticsWhoseGlintsClipAreStillRead) {
  RenderScene scene;
  scene.width_px = 640;
  scene.height_px = 480;
  scene.phase_angle_deg = 60.0;
  scene.exposure *= 5.0;
  scene.seed = 1;
  const absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
  ASSERT_TRUE(rendered.ok()) << rendered.status();
  ASSERT_GT(rendered->image.SaturatedCount(), 100);
  Acquisition acquisition;
  acquisition.phase_angle_rad = 60.0 * kDeg;
  EstimateOptions fast;
  fast.mode = Mode::kFast;
  absl::StatusOr<Estimate> picked = EstimateFromImage(rendered->image, acquisition, fast);
  ASSERT_TRUE(picked.ok()) << picked.status();
  ASSERT_TRUE(picked->peak_spacing_rad.resolved);
  const double truth = rendered->truth.peak_spacing_deg;
  EXPECT_NEAR(picked->peak_spacing_rad.value / kDeg, truth,
              3.0 * picked->peak_spacing_rad.stderr_value / kDeg);

  absl::StatusOr<Estimate> fitted =
      EstimateFromImage(rendered->image, acquisition, EstimateOptions());
  ASSERT_TRUE(fitted.ok()) << fitted.status();
  EXPECT_EQ(fitted->method, "comb-fit");
  EXPECT_NEAR(fitted->peak_spacing_rad.value / kDeg, truth,
              3.0 * fitted->peak_spacing_rad.stderr_value / kDeg);
}

// At α = 140° the lobe (70° ± 13.5° for m = 0.24) runs into the limb: no
// isolated lobe, a clear error. Once the lit limb was placed right there,
// peak picking read it as a 23.7° sawtooth for a 27.0° sinusoid.
TEST(ClippedLobeTest, ALobeCutByTheLimbIsAnError) {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.wavelength_mm = 1.44;
  scene.amplitude_mm = 0.055;
  scene.phase_angle_deg = 140.0;
  scene.seed = 1;
  const absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
  ASSERT_TRUE(rendered.ok()) << rendered.status();
  Acquisition acquisition;
  acquisition.phase_angle_rad = 140.0 * kDeg;
  for (Mode mode : {Mode::kFast, Mode::kBalanced}) {
    EstimateOptions options;
    options.mode = mode;
    absl::StatusOr<Estimate> e = EstimateFromImage(rendered->image, acquisition, options);
    ASSERT_FALSE(e.ok()) << e->peak_spacing_rad.value / kDeg;
    EXPECT_EQ(e.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(std::string(e.status().message()).find("not isolated"), std::string::npos)
        << e.status();
  }
}

}  // namespace
}  // namespace weavefit
