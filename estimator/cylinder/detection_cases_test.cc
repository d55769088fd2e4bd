// Cylinder detection and the azimuth mapping on rendered photographs with
// known truth, case by case (issue 4): axis tilts, cylinder ends and a mount
// in the frame, clipped glints, perspective, oblique and back lighting, a
// body darker than the background, a limb lost in darkness, and frames
// without a cylinder. The basic cases (upright and slightly tilted axis,
// region of interest, bad input) are in cylinder_detection_test.cc.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/cylinder/cylinder_detection.h"
#include "estimator/io/decode.h"
#include "estimator/io/encode.h"
#include "estimator/io/image.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;
// Issue 4: each observed limb within half a pixel, the tilt within 0.1°.
constexpr double kLimbTolerancePx = 0.5;
constexpr double kTiltToleranceDeg = 0.1;

// A small scene (≈ 0.07 s): 320×240, radius 128. The renderer samples a
// pixel at 4 columns off the arc, so an upright limb is rendered exactly only
// on a quarter pixel: with limbs at 31.75 and 287.75 the truth is the
// rendered edge, and the half-level of the limb pixel (0.75 covered) tests
// the detector's sub-pixel placement. (At 2 samples a limb at x.6 renders as
// x.5, an error of the scene, not of the detector.)
RenderScene CaseScene() {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.samples_per_pixel = 4;
  scene.center_x_px = 159.75;
  scene.radius_px = 128.0;
  scene.phase_angle_deg = 10.0;
  scene.seed = 23;
  return scene;
}

Rendered Render(const RenderScene& scene) {
  absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
  EXPECT_TRUE(rendered.ok()) << rendered.status();
  return rendered.ok() ? *rendered : Rendered();
}

double MiddleRow(const RenderScene& scene) { return (scene.height_px - 1) / 2.0; }

// Limb columns at the image's middle row: the axis column ± the radius
// (perpendicular to the axis) stretched to a horizontal half-width.
struct Limbs {
  double left = 0.0;
  double right = 0.0;
};

Limbs TrueLimbs(const RenderTruth& truth) {
  const double half = truth.radius_px / std::cos(truth.axis_angle_deg * kDeg);
  return {truth.center_x_px - half, truth.center_x_px + half};
}

Limbs DetectedLimbs(const RenderScene& scene, const CylinderGeometry& g) {
  const double axis = g.AxisColumn(MiddleRow(scene));
  const double half = g.radius_px / std::cos(g.axis_angle_rad);
  return {axis - half, axis + half};
}

absl::StatusOr<CylinderGeometry> Detect(const Rendered& rendered) {
  return DetectCylinder(rendered.image, CylinderDetectionOptions());
}

// Both limbs seen and within kLimbTolerancePx, the tilt within
// kTiltToleranceDeg.
void ExpectLimbsAndTilt(const RenderScene& scene, const Rendered& rendered,
                        const CylinderGeometry& g) {
  const Limbs truth = TrueLimbs(rendered.truth);
  const Limbs found = DetectedLimbs(scene, g);
  EXPECT_TRUE(g.left_observed);
  EXPECT_TRUE(g.right_observed);
  EXPECT_NEAR(found.left, truth.left, kLimbTolerancePx);
  EXPECT_NEAR(found.right, truth.right, kLimbTolerancePx);
  EXPECT_NEAR(g.axis_angle_rad / kDeg, rendered.truth.axis_angle_deg,
              kTiltToleranceDeg);
  // The radius's stated error: the edge model's allowance (0.05 px for two
  // seen limbs) and the bands' scatter, and honest: it sets the wavelength's
  // scale.
  EXPECT_GE(g.radius_stderr_px, 0.049);
  EXPECT_LT(g.radius_stderr_px, 0.2);
  EXPECT_LE(std::fabs(g.radius_px - rendered.truth.radius_px), 3.0 * g.radius_stderr_px);
}

void ExpectDetected(const RenderScene& scene) {
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = Detect(rendered);
  ASSERT_TRUE(g.ok()) << g.status();
  ExpectLimbsAndTilt(scene, rendered, *g);
}

// Test names for angles in degrees: Minus5Deg, Plus0Deg, ...
std::string DegreesName(const ::testing::TestParamInfo<double>& info) {
  const int deg = static_cast<int>(std::lround(info.param));
  return (deg < 0 ? "Minus" : "Plus") + std::to_string(std::abs(deg)) + "Deg";
}

// --- Axis tilt --------------------------------------------------------------

class TiltTest : public ::testing::TestWithParam<double> {};

TEST_P(TiltTest, LimbsAndTilt) {
  RenderScene scene = CaseScene();
  scene.axis_angle_deg = GetParam();
  ExpectDetected(scene);
}

INSTANTIATE_TEST_SUITE_P(DetectionCases, TiltTest,
                         ::testing::Values(-5.0, -2.0, 0.0, 2.0, 5.0),
                         DegreesName);

// --- Cylinder ends and the mount --------------------------------------------

// The usable rows lie inside the cylinder's rows and lose at most kLostRows
// at each end.
constexpr int kLostRows = 15;

void ExpectEnds(const RenderScene& scene) {
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = Detect(rendered);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_GE(g->top_row, scene.top_row_px);
  EXPECT_LE(g->top_row, scene.top_row_px + kLostRows);
  EXPECT_LE(g->bottom_row, scene.bottom_row_px);
  EXPECT_GE(g->bottom_row, scene.bottom_row_px - kLostRows);
  ExpectLimbsAndTilt(scene, rendered, *g);
}

TEST(DetectionCasesTest, CylinderEndsInTheFrame) {
  RenderScene scene = CaseScene();
  scene.top_row_px = 40;
  scene.bottom_row_px = 201;
  ExpectEnds(scene);
}

TEST(DetectionCasesTest, CylinderEndsOnAMount) {
  // Beyond both ends a block 0.6 radii wide at 0.2 (brighter than the
  // body): its edges must not be taken for limbs.
  RenderScene scene = CaseScene();
  scene.top_row_px = 40;
  scene.bottom_row_px = 201;
  scene.mount_level = 0.2;
  ExpectEnds(scene);
}

TEST(DetectionCasesTest, CylinderEndsOnAMountMidBandLightOnTheLeft) {
  // Ends in the middle of the detector's 10-row bands, light on the left.
  RenderScene scene = CaseScene();
  scene.top_row_px = 33;
  scene.bottom_row_px = 185;
  scene.mount_level = 0.2;
  scene.phase_angle_deg = -30.0;
  ExpectEnds(scene);
}

// --- Photometric cases ------------------------------------------------------

// Glints clipped at full scale. Only the circumferential threads' glints
// (axial threads dark): their clipped comb around the mirror azimuth must
// not move the limbs.
TEST(DetectionCasesTest, ClippedGlints) {
  RenderScene scene = CaseScene();
  scene.exposure = 0.05;
  scene.axial_reflectance = 0.0;
  const Rendered rendered = Render(scene);
  // The case is what it claims: many glint pixels are clipped at full scale.
  EXPECT_GT(rendered.image.SaturatedCount(), 200);
  absl::StatusOr<CylinderGeometry> g = Detect(rendered);
  ASSERT_TRUE(g.ok()) << g.status();
  ExpectLimbsAndTilt(scene, rendered, *g);
  EXPECT_EQ(g->top_row, 0);
  EXPECT_EQ(g->bottom_row, scene.height_px - 1);
}

// The same exposure with the axial threads lit (the default scene): besides
// the clipped glints, their grazing scatter lobe (∝ 1/cos φ, DESIGN.md §3)
// makes a bright rim inside the lit limb.
TEST(DetectionCasesTest, ClippedGlintsWithBrightGrazingScatter) {
  RenderScene scene = CaseScene();
  scene.exposure = 0.05;
  const Rendered rendered = Render(scene);
  EXPECT_GT(rendered.image.SaturatedCount(), 200);
  absl::StatusOr<CylinderGeometry> g = Detect(rendered);
  ASSERT_TRUE(g.ok()) << g.status();
  const Limbs truth = TrueLimbs(rendered.truth);
  const Limbs found = DetectedLimbs(scene, *g);
  // The rim's S/cos φ rise is part of the limb model (RefineEdge), so it
  // does not push the lit limb outward.
  EXPECT_NEAR(found.right, truth.right, kLimbTolerancePx);
  ExpectLimbsAndTilt(scene, rendered, *g);
}

TEST(DetectionCasesTest, PerspectiveAt900Mm) {
  // The rendered limb half-width is radius_px whatever the distance.
  RenderScene scene = CaseScene();
  scene.camera_distance_mm = 900.0;
  scene.axis_angle_deg = 1.0;
  ExpectDetected(scene);
}

class PhaseAngleTest : public ::testing::TestWithParam<double> {};

TEST_P(PhaseAngleTest, BothLimbsWithTheDefaultAmbientBody) {
  RenderScene scene = CaseScene();
  scene.phase_angle_deg = GetParam();
  ExpectDetected(scene);
}

INSTANTIATE_TEST_SUITE_P(DetectionCases, PhaseAngleTest,
                         ::testing::Values(-110.0, -60.0, 60.0, 110.0),
                         DegreesName);

// A cylinder that fills the frame: its limbs lie inside the strips at the
// sides first taken as background (4% of the width, 12.8 px here). Both
// were "no cylinder found" before the strips were narrowed.
TEST(DetectionCasesTest, LimbsTenPixelsFromTheFrame) {
  RenderScene scene = CaseScene();
  scene.center_x_px = 159.5;
  scene.radius_px = 150.0;
  ExpectDetected(scene);
}

TEST(DetectionCasesTest, OneLimbElevenPixelsFromTheFrameAtMinus79Deg) {
  RenderScene scene = CaseScene();
  scene.center_x_px = 148.1;
  scene.radius_px = 136.6;
  scene.phase_angle_deg = -79.0;
  ExpectDetected(scene);
}

TEST(DetectionCasesTest, BodyDarkerThanTheBackgroundTiltedAndOblique) {
  RenderScene scene = CaseScene();
  scene.ambient = 0.002;
  scene.background = 0.05;
  scene.axis_angle_deg = -2.0;
  scene.phase_angle_deg = 60.0;
  ExpectDetected(scene);
}

// A noiseless step (ambient body, no glints, no sensor noise) with the limbs
// at each quarter pixel, where the renderer's 4 samples per pixel make the
// edge exact: the sub-pixel placement itself, without noise to hide a bias.
TEST(DetectionCasesTest, NoiselessStepAtQuarterPixels) {
  double worst = 0.0;
  std::string errors;
  for (double phase : {0.0, 0.25, 0.5, 0.75}) {
    RenderScene scene = CaseScene();
    scene.center_x_px = 160.0 + phase;
    scene.exposure = 0.0;
    scene.axial_reflectance = 0.0;
    scene.photons_full_scale = 0.0;
    scene.read_noise = 0.0;
    scene.quantisation_bits = 0;
    const Rendered rendered = Render(scene);
    absl::StatusOr<CylinderGeometry> g = Detect(rendered);
    ASSERT_TRUE(g.ok()) << g.status();
    const Limbs truth = TrueLimbs(rendered.truth);
    const Limbs found = DetectedLimbs(scene, *g);
    EXPECT_NEAR(found.left, truth.left, kLimbTolerancePx) << phase;
    EXPECT_NEAR(found.right, truth.right, kLimbTolerancePx) << phase;
    EXPECT_NEAR(g->axis_angle_rad / kDeg, 0.0, kTiltToleranceDeg) << phase;
    worst = std::max({worst, std::fabs(found.left - truth.left),
                      std::fabs(found.right - truth.right)});
    errors += " " + std::to_string(found.left - truth.left) + "/" +
              std::to_string(found.right - truth.right);
  }
  // A step this clean is placed to a tenth of a pixel.
  EXPECT_LT(worst, 0.1) << errors;
}

// --- One limb lost in darkness ----------------------------------------------

// Back light (|α| ≥ 90°) with the body's ambient level equal to the
// background: the unlit limb has no contrast at all and the edge on that side
// is the terminator. The detector, told the phase angle, infers the dark limb
// from the lit limb and the terminator.
RenderScene DarkLimbScene(double phase_angle_deg) {
  RenderScene scene = CaseScene();
  scene.phase_angle_deg = phase_angle_deg;
  scene.ambient = 0.01;
  scene.background = 0.01;
  return scene;
}

absl::StatusOr<CylinderGeometry> DetectKnowingPhase(const Rendered& rendered,
                                                    const RenderScene& scene) {
  CylinderDetectionOptions options;
  options.phase_angle_rad = scene.phase_angle_deg * kDeg;
  options.projection = {scene.diameter_mm / 2.0, scene.camera_distance_mm};
  return DetectCylinder(rendered.image, options);
}

// Both limbs seen, each within its tolerance of the truth (px), with the
// phase angle given.
void ExpectBothLimbsSeenWithin(const RenderScene& scene, double left_px, double right_px) {
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  const Limbs truth = TrueLimbs(rendered.truth);
  const Limbs found = DetectedLimbs(scene, *g);
  EXPECT_TRUE(g->left_observed && g->right_observed);
  EXPECT_NEAR(found.left, truth.left, left_px);
  EXPECT_NEAR(found.right, truth.right, right_px);
}

// The lit limb observed within kLimbTolerancePx, the dark one flagged and
// within 2 px, the tilt (from the lit limb) within kTiltToleranceDeg.
void ExpectInferredDarkLimb(const RenderScene& scene) {
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  const bool dark_is_left = scene.phase_angle_deg > 0;  // light on the right
  const Limbs truth = TrueLimbs(rendered.truth);
  const Limbs found = DetectedLimbs(scene, *g);
  const double lit_error = dark_is_left ? found.right - truth.right : found.left - truth.left;
  const double dark_error = dark_is_left ? found.left - truth.left : found.right - truth.right;
  EXPECT_TRUE(dark_is_left ? g->right_observed : g->left_observed);
  EXPECT_FALSE(dark_is_left ? g->left_observed : g->right_observed);
  EXPECT_NEAR(lit_error, 0.0, kLimbTolerancePx);
  EXPECT_NEAR(dark_error, 0.0, 2.0);
  EXPECT_NEAR(g->axis_angle_rad / kDeg, rendered.truth.axis_angle_deg, kTiltToleranceDeg);
  // An inferred limb makes the radius uncertain by about half a pixel, and
  // its stated error says so.
  EXPECT_GE(g->radius_stderr_px, 0.45);
  EXPECT_LE(std::fabs(g->radius_px - rendered.truth.radius_px), 3.0 * g->radius_stderr_px);
}

// The terminator of a coloured fabric's Lambertian term (DESIGN.md §3).
TEST(DarkLimbTest, InferredBeyondALambertianTerminatorLightOnTheRight) {
  RenderScene scene = DarkLimbScene(110.0);
  scene.diffuse = 0.05;
  ExpectInferredDarkLimb(scene);
}

TEST(DarkLimbTest, InferredBeyondALambertianTerminatorLightOnTheLeft) {
  RenderScene scene = DarkLimbScene(-110.0);
  scene.diffuse = 0.05;
  ExpectInferredDarkLimb(scene);
}

// At a small phase angle the dark sliver beyond the terminator is narrow
// (R·(1 − cos α): 10 px at R = 256 px and 16°) and the lobe stands where it
// should whichever edge is taken, so only the edge's shape tells: the
// terminator rises over many pixels, a limb within one or two. Taken for
// the limb, the terminator put the radius 6 px short.
TEST(DarkLimbTest, InferredAtASmallPhaseAngleFromTheTerminatorsRamp) {
  RenderScene scene = DarkLimbScene(-16.0);
  scene.diffuse = 0.045;
  ExpectInferredDarkLimb(scene);
}

TEST(DarkLimbTest, InferredAtASmallPhaseAngleWithTilt) {
  RenderScene scene = DarkLimbScene(20.0);
  scene.diffuse = 0.045;
  scene.axis_angle_deg = -2.5;
  ExpectInferredDarkLimb(scene);
}

TEST(DarkLimbTest, InferredWithTiltAndAWeakerTerm) {
  RenderScene scene = DarkLimbScene(90.0);
  scene.center_x_px = 161.3;
  scene.diffuse = 0.03;
  scene.axis_angle_deg = 3.0;
  ExpectInferredDarkLimb(scene);
}

TEST(DarkLimbTest, InferredInPerspectiveAt900Mm) {
  RenderScene scene = DarkLimbScene(-120.0);
  scene.diffuse = 0.05;
  scene.camera_distance_mm = 900.0;
  ExpectInferredDarkLimb(scene);
}

TEST(DarkLimbTest, InferredUnderASawtoothLobeWithClippedGlints) {
  RenderScene scene = DarkLimbScene(70.0);
  scene.model = ProfileModel::kSawtooth;
  scene.diffuse = 0.03;
  scene.exposure = 0.02;
  const Rendered rendered = Render(scene);
  EXPECT_GT(rendered.image.SaturatedCount(), 50);
  ExpectInferredDarkLimb(scene);
}

// A larger photograph (1600×1200, R = 640 px, ≈ 2 s to render): the faint
// grazing-scatter step at the terminator, left out, would move it by pixels.
TEST(DarkLimbTest, InferredOnALargerPhotograph) {
  RenderScene scene = DarkLimbScene(110.0);
  scene.width_px = 1600;
  scene.height_px = 1200;
  scene.center_x_px = 799.75;
  scene.radius_px = 640.0;
  scene.samples_per_pixel = 2;
  scene.diffuse = 0.05;
  scene.seed = 2;
  ExpectInferredDarkLimb(scene);
}

// Two renders whose terminator alone placed the dark limb 4.5 and 2.8 px
// off: a faint grazing-scatter step at the terminator trades off against the
// radius. The window by the lit limb, where that scatter rises as 1/cos φ,
// pins it.
TEST(DarkLimbTest, ScatterPinnedByTheLimbWindowInPerspective) {
  RenderScene scene = DarkLimbScene(-120.0);
  scene.center_x_px = 159.5;
  scene.diffuse = 0.05;
  scene.camera_distance_mm = 900.0;
  scene.seed = 1;
  ExpectInferredDarkLimb(scene);
}

TEST(DarkLimbTest, ScatterPinnedByTheLimbWindowOnAMidSizePhotograph) {
  RenderScene scene = DarkLimbScene(100.0);
  scene.width_px = 640;
  scene.height_px = 480;
  scene.center_x_px = 319.5;
  scene.radius_px = 256.0;
  scene.diffuse = 0.03;
  scene.seed = 2;
  ExpectInferredDarkLimb(scene);
}

// A wide split lobe (m = 0.35 at α = 60°: caustics near 11° and 49°) with
// both limbs seen against the background: both stay observed (the lobe's
// position is the mean azimuth of its ends). When the lobe was placed by the
// centroid of its brightest columns, this render had its left limb
// "inferred" 267 px outside the photograph (radius 853 px for 640) and the
// spacing came out 8.6° short.
TEST(DetectionCasesTest, WideSplitLobeKeepsBothSeenLimbs) {
  RenderScene scene;
  scene.width_px = 1600;
  scene.height_px = 1200;
  scene.model = ProfileModel::kSinusoid;
  scene.wavelength_mm = 2.0;
  scene.amplitude_mm = 0.35 * 2.0 / (2.0 * M_PI);
  scene.phase_angle_deg = 60.0;
  scene.seed = 52;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_TRUE(g->left_observed);
  EXPECT_TRUE(g->right_observed);
  EXPECT_NEAR(g->radius_px, rendered.truth.radius_px, kLimbTolerancePx);
  EXPECT_NEAR(g->center_x_px, rendered.truth.center_x_px, kLimbTolerancePx);
}

// --- Lens blur ------------------------------------------------------------------

// A lens PSF smears the grazing scatter's bright rim outward, and a limb
// model without blur followed it: the radius came out 0.27 and 0.87 px long
// at σ = 0.8 and 1.2 px (noise-free, α = 60°). Seen through the blur the
// limbs fit choose, the radius is within 0.05 px, with the phase angle known
// (one limb in shadow) or not (both fitted with the scatter). Measured: radius
// −0.017 and −0.001 px, centre −0.029 and +0.012 px (0.8 and 1.2 px; the same
// or within 0.01 px with the phase unknown); through no blur the centre was
// 0.13-0.14 px off.
class LensBlurTest : public ::testing::TestWithParam<double> {};

TEST_P(LensBlurTest, RadiusIsNotPushedOut) {
  RenderScene scene = CaseScene();
  scene.phase_angle_deg = 60.0;
  scene.optics_blur_px = GetParam();
  const Rendered rendered = Render(scene);
  for (bool knowing_phase : {true, false}) {
    absl::StatusOr<CylinderGeometry> g =
        knowing_phase ? DetectKnowingPhase(rendered, scene) : Detect(rendered);
    ASSERT_TRUE(g.ok()) << g.status();
    EXPECT_NEAR(g->radius_px, rendered.truth.radius_px, 0.05) << "phase known: " << knowing_phase;
    EXPECT_NEAR(g->center_x_px, rendered.truth.center_x_px, 0.05)
        << "phase known: " << knowing_phase;
  }
}

INSTANTIATE_TEST_SUITE_P(DetectionCases, LensBlurTest, ::testing::Values(0.8, 1.2),
                         [](const ::testing::TestParamInfo<double>& info) {
                           return "Sigma" + std::to_string(std::lround(10 * info.param)) + "Tenths";
                         });

// A lens blur beyond the first fit's 1.5 px, refitted through wider windows
// (up to 3.5 px). Through the 9-pixel windows a blur of 2 px put the lit limb
// 3.2 px out and the radius 2.0 px long (640×480, −60°, noise-free). Each
// case: (phase angle, σ px).
void ExpectLimbsThroughWideBlur(const RenderScene& scene) {
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_NEAR(g->radius_px, rendered.truth.radius_px, 0.25);
  EXPECT_NEAR(g->center_x_px, rendered.truth.center_x_px, 0.25);
  EXPECT_LE(std::fabs(g->radius_px - rendered.truth.radius_px), 3.0 * g->radius_stderr_px);
}

class WideLensBlurTest : public ::testing::TestWithParam<std::pair<double, double>> {};

TEST_P(WideLensBlurTest, LimbsInPlace) {
  RenderScene scene = CaseScene();
  scene.phase_angle_deg = GetParam().first;
  scene.optics_blur_px = GetParam().second;
  ExpectLimbsThroughWideBlur(scene);
}

INSTANTIATE_TEST_SUITE_P(
    DetectionCases, WideLensBlurTest,
    ::testing::Values(std::make_pair(10.0, 2.5), std::make_pair(-60.0, 2.0),
                      std::make_pair(-89.0, 3.0)),
    [](const ::testing::TestParamInfo<std::pair<double, double>>& info) {
      const long phase = std::lround(info.param.first);
      return std::string(phase < 0 ? "Minus" : "Plus") + std::to_string(std::labs(phase)) +
             "DegSigma" + std::to_string(std::lround(10 * info.param.second)) + "Tenths";
    });

// At 60-90° the glints may cut the lit limb's window short, and its blurred
// rise was taken for them: at 75° a blur of 1.3 px put that limb 1.1 px out
// and the radius 0.69 px long (640×480, noise-free). It is now seen through
// the blur the limb in shadow proposes, and its window keeps the rise.
// A noise-free 640×480 scene at a phase angle, through a lens blur σ (px).
RenderScene NoiseFreeBlurredScene(double phase_angle_deg, double optics_blur_px) {
  RenderScene scene = CaseScene();
  scene.width_px = 640;
  scene.height_px = 480;
  scene.center_x_px = 319.75;
  scene.radius_px = 256.0;
  scene.phase_angle_deg = phase_angle_deg;
  scene.optics_blur_px = optics_blur_px;
  scene.photons_full_scale = 0.0;
  scene.read_noise = 0.0;
  return scene;
}

TEST(DetectionCasesTest, ABlurredLitLimbIsNotCutAsAGlint) {
  ExpectLimbsThroughWideBlur(NoiseFreeBlurredScene(75.0, 1.3));
}

// From 90° on the limb in shadow may be the terminator, whose ramp would pass
// for blur, so its proposal alone is not used at first, and the lit limb,
// its window cut by the glints, came out too far out (3.4 px at a 2 px blur,
// 100°, 640×480, noise-free). When both limbs come out seen, that edge was a
// limb: the lit limb is placed again through its blur, with an allowance.
TEST(DetectionCasesTest, ABackLitBlurredLimbIsPlacedThroughTheOtherLimbsBlur) {
  ExpectLimbsThroughWideBlur(NoiseFreeBlurredScene(100.0, 2.0));
}

// The same where the cylinder fills the frame: its limb in shadow lies
// inside the side strips, so detection runs again with narrow strips, and
// that run too places the lit limb through the other limb's blur. (A
// sawtooth at 93°, 1024×768, limb 18 px from the edge: its lit limb was
// 3.3 px out, the spacing read as a sinusoid's.)
TEST(DetectionCasesTest, ABackLitBlurredLimbInTheSideStripsIsPlacedThroughTheOtherLimbsBlur) {
  RenderScene scene = NoiseFreeBlurredScene(100.0, 2.0);
  scene.center_x_px = 310.25;
  scene.radius_px = 292.0;
  ExpectLimbsThroughWideBlur(scene);
}

// Through a lens blur the limbs are placed through the blur they show,
// and that blur's own error moves both together: the radius must say so.
// Without it, over 16 noise draws of a 0.8 px blur (the blur read 0.58 to
// 0.74 px), the radius spread 2.7 times its stated statistical error.
TEST(DetectionCasesTest, TheRadiusErrorCountsTheLensBlursOwnError) {
  RenderScene scene = CaseScene();
  scene.optics_blur_px = 0.8;
  constexpr int kDraws = 24;
  double sum = 0.0;
  double sum_sq = 0.0;
  double stated_sq = 0.0;
  for (int d = 0; d < kDraws; ++d) {
    scene.seed = 100 + d;
    const Rendered rendered = Render(scene);
    absl::StatusOr<CylinderGeometry> g = Detect(rendered);
    ASSERT_TRUE(g.ok()) << g.status();
    const double error = g->radius_px - rendered.truth.radius_px;
    sum += error;
    sum_sq += error * error;
    stated_sq += g->radius_stderr_px * g->radius_stderr_px -
                 g->radius_systematic_px * g->radius_systematic_px;
  }
  const double mean = sum / kDraws;
  const double spread = std::sqrt((sum_sq - kDraws * mean * mean) / (kDraws - 1));
  const double stated = std::sqrt(stated_sq / kDraws);
  // Both figures are estimates over the draws: the spread's own relative
  // error is 1/√(2·(kDraws − 1)), 15 %; the stated error's square is, in a
  // few draws, mostly the blur's error, itself one sample (half the
  // difference of two halves' blurs, a χ² of one degree), whose mean over
  // 24 draws spreads by √(2/24), 29 %. With the background measured beside
  // each limb, stated/spread came to 1.8 over 12 draws and 1.5 over these 24.
  EXPECT_LE(spread, 1.5 * stated) << "radius spread " << spread << " px, stated " << stated;
  EXPECT_GE(spread, stated / 2.0) << "radius spread " << spread << " px, stated " << stated;
}

// Overexposed (300 times the default exposure), the limbs' bright rims of
// grazing scatter clip at the sensor's maximum: those pixels only bound the
// light from below and are left out of the edge fits. Fitted as levels,
// they drew the edges inward: the radius 0.21 px short, 4 stated errors.
TEST(DetectionCasesTest, ClippedLimbPixelsAreNotFittedAsLevels) {
  RenderScene scene = CaseScene();
  scene.wavelength_mm = 1.44;
  scene.amplitude_mm = 0.24 * scene.wavelength_mm / (2.0 * M_PI);
  scene.phase_angle_deg = 30.0;
  scene.center_x_px = -1.0;
  scene.exposure *= 300.0;
  scene.seed = 2017;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = Detect(rendered);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_LE(std::fabs(g->radius_px - rendered.truth.radius_px), 3.0 * g->radius_stderr_px)
      << "radius " << g->radius_px << " ± " << g->radius_stderr_px << " for "
      << rendered.truth.radius_px;
}

// At 120° the outer caustic lies about 6 px inside the lit limb and its
// glints cut that limb's window: placed through the blur it is still out
// (2.7 px for a sinusoid of h0 = 0.1 mm, seed 1), and the radius's stated
// error covers it.
TEST(DetectionCasesTest, GlintsBlurredIntoTheLitLimbWidenTheRadiusError) {
  const RenderScene scene = NoiseFreeBlurredScene(120.0, 2.0);
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_GE(g->radius_stderr_px, 0.5);
  EXPECT_LE(std::fabs(g->radius_px - rendered.truth.radius_px), 3.0 * g->radius_stderr_px)
      << "radius " << g->radius_px << " ± " << g->radius_stderr_px;
}

// Below 12° the limb away from the light is lit only from the terminator on,
// R·(1 − cos α) inside it (0.5 to 1.2 px here), and its grazing scatter starts
// there. Noise-free, before the model knew it: radius 0.029 px short and the
// centre 0.023 px toward the light at 5° and -8° (the coarse gauze).
class TerminatorOnsetTest : public ::testing::TestWithParam<double> {};

TEST_P(TerminatorOnsetTest, TheUnlitLimbIsNotDrawnIn) {
  RenderScene scene = CaseScene();
  scene.phase_angle_deg = GetParam();
  scene.photons_full_scale = 0.0;
  scene.read_noise = 0.0;
  scene.quantisation_bits = 0;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_NEAR(g->radius_px, rendered.truth.radius_px, 0.01);
  EXPECT_NEAR(g->center_x_px, rendered.truth.center_x_px, 0.01);
}

INSTANTIATE_TEST_SUITE_P(DetectionCases, TerminatorOnsetTest, ::testing::Values(5.0, -8.0),
                         [](const ::testing::TestParamInfo<double>& info) {
                           return (info.param < 0 ? "Minus" : "Plus") +
                                  std::to_string(std::lround(std::fabs(info.param))) + "Deg";
                         });

// --- Glints at the limb toward the light --------------------------------------

// At large phase angles the lobe's outer caustic reaches the limb toward the
// light: at α = 130° it lies 5 px inside a 256 px limb, at α = 140° 1.4 px.
// The edge fit must stop short of those glints. Before it did, the lit limb
// came out 0.44 px inward at 130° (which put the spacing 0.66° long, 4.7
// stated errors) and 3.5 px outward at 140°.
void ExpectLimbsWithGlintsAtTheLitLimb(double phase_angle_deg, double tolerance_px) {
  RenderScene scene;
  scene.width_px = 640;
  scene.height_px = 480;
  scene.center_x_px = 319.5;
  scene.radius_px = 256.0;
  scene.phase_angle_deg = phase_angle_deg;
  scene.seed = 1;
  ExpectBothLimbsSeenWithin(scene, tolerance_px, tolerance_px);
}

TEST(DetectionCasesTest, GlintsAtTheLitLimbLeaveItInPlace) {
  ExpectLimbsWithGlintsAtTheLitLimb(130.0, 0.15);
  ExpectLimbsWithGlintsAtTheLitLimb(-130.0, 0.15);
}

TEST(DetectionCasesTest, AGlintOnePixelInsideTheLitLimbLeavesItInPlace) {
  ExpectLimbsWithGlintsAtTheLitLimb(140.0, kLimbTolerancePx);
}

// Without a lit terminator (no Lambertian term) nothing places the unlit
// limb, and nor is the lit limb seen beyond the lobe: a clear error, never a
// confident wrong cylinder.
void ExpectNoCylinderWithoutATerminator(double phase_angle_deg) {
  const RenderScene scene = DarkLimbScene(phase_angle_deg);
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_FALSE(g.ok()) << "centre " << g->center_x_px << " radius " << g->radius_px;
  EXPECT_EQ(g.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(g.status().message()).find("phase angle"), std::string::npos)
      << g.status();
}

TEST(DarkLimbTest, NoTerminatorLightOnTheRightIsAnError) {
  ExpectNoCylinderWithoutATerminator(110.0);
}

TEST(DarkLimbTest, NoTerminatorLightOnTheLeftIsAnError) {
  ExpectNoCylinderWithoutATerminator(-110.0);
}

// The ordinary back-lit scene, whose body is brighter than the background,
// keeps both limbs observed when the phase angle is known.
TEST(DarkLimbTest, BothLimbsObservedWhenTheBodyShows) {
  for (double alpha : {-110.0, 110.0}) {
    RenderScene scene = CaseScene();
    scene.phase_angle_deg = alpha;
    const Rendered rendered = Render(scene);
    absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
    ASSERT_TRUE(g.ok()) << g.status();
    EXPECT_TRUE(g->left_observed && g->right_observed) << alpha;
    ExpectLimbsAndTilt(scene, rendered, *g);
  }
}

// A lit backdrop (a gradient across the frame) and a body in stray light
// that stands at the background's level beside its unlit limb, at 80°: the
// body's level in shadow is judged against the background beside that limb
// (its trend carried in from beyond it), not against a side strip whose
// level the gradient has moved as far as the body stands from it. Refused
// before ("the body continues beyond the unlit edge").
TEST(DetectionCasesTest, AStrayLitBodyUnderABackgroundGradientKeepsItsLimbs) {
  RenderScene scene = CaseScene();
  scene.phase_angle_deg = 80.0;
  scene.ambient = 0.0;
  scene.stray_light = 0.015;
  scene.background = 0.012;
  scene.background_gradient = 0.004;
  scene.wavelength_mm = 3.0;
  scene.amplitude_mm = 0.28;
  scene.seed = 5;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_TRUE(g->left_observed && g->right_observed);
  ExpectLimbsAndTilt(scene, rendered, *g);
}

// A broad stray source shades the body like any diffuse surface, a + R·cos φ:
// the body meets the background near its own level at the limb and rises
// over tens of pixels (cos φ ≈ √(2d/r)). A flat body level in the edge
// model met that rise pixels inside the limb (the radius 2 px short here).
RenderScene StrayLitScene(double background) {
  RenderScene scene = CaseScene();
  scene.model = ProfileModel::kSawtooth;
  scene.phase_angle_deg = 60.0;
  scene.ambient = 0.0;
  scene.stray_light = 0.03;
  scene.background = background;
  scene.seed = 3;
  return scene;
}

TEST(DetectionCasesTest, AStrayLitBodyThatRollsOffIntoItsLimbKeepsItsRadius) {
  const RenderScene scene = StrayLitScene(0.010);
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  ExpectLimbsAndTilt(scene, rendered, *g);
}

// The same under a background gradient, which moves the background at the
// limb away from the side strip's level: the edge model stands on the
// background beside the limb. (On the strip's level, a wrong cylinder.)
TEST(DetectionCasesTest, AStrayLitBodyRollingOffUnderAGradientKeepsItsLimbs) {
  RenderScene scene = StrayLitScene(0.014);
  scene.background_gradient = 0.004;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  const Limbs truth = TrueLimbs(rendered.truth);
  const Limbs found = DetectedLimbs(scene, *g);
  // The limb away from the light (left) is the one the shading moves.
  EXPECT_NEAR(found.left, truth.left, kLimbTolerancePx);
  EXPECT_NEAR(g->radius_px, rendered.truth.radius_px, 1.0);
}

// A limb 23 px from the frame's edge (the side strip beside it holds it),
// with the body in strong stray light that rises slowly from it: its rise
// is as soft as a terminator's ramp, and too few bands see both limbs to
// tell the shading from a ramp. The lobe stands at α/2 on the cylinder of
// both limbs (0.3° off) and 5.5° off with that edge taken for the
// terminator: the limb stays (inferred, the radius came 41 px long).
TEST(DetectionCasesTest, ASoftLimbWhoseLobeStandsAtHalfThePhaseAngleIsNoTerminator) {
  RenderScene scene = CaseScene();
  scene.width_px = 640;
  scene.height_px = 480;
  scene.model = ProfileModel::kSmooth;
  scene.wavelength_mm = 4.2166;
  scene.amplitude_mm = 0.6501;
  scene.phase_angle_deg = 43.02;
  scene.center_x_px = 299.8;
  scene.radius_px = 276.8;
  scene.source_blur_deg = 0.44;
  scene.exposure = 0.0086;
  scene.ambient = 0.0113;
  scene.background = 0.0416;
  scene.photons_full_scale = 10000.0;
  scene.read_noise = 0.002;
  scene.stray_light = 0.0643;
  scene.stray_texture = 0.34;
  scene.axial_glint_width = 0.271;
  scene.axial_float_width = 0.26;
  scene.background_gradient = 0.0112;
  scene.background_gradient_deg = 30.0;
  scene.black_level = 0.0254;
  scene.seed = 104;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_TRUE(g->left_observed && g->right_observed);
  EXPECT_NEAR(g->radius_px, rendered.truth.radius_px, 2.0);
  EXPECT_NEAR(g->center_x_px, rendered.truth.center_x_px, 1.5);
}

// The lit limb of a body in stray light alone (no diffuse term) at 59°: the
// shading R·cos φ meets the limb at the ambient level, darker than the
// backdrop there, and crosses the backdrop's level some 25 px inside, where
// a search for the first step from the background fires. Below and above
// the cylinder a mount wider than it puts its own edges 12 px outside the
// limbs. The wide window's model of background, shading and direct light
// places the limb. (The first step taken for it: a radius 30 px short.)
TEST(DetectionCasesTest, AStrayLitBodyDarkerThanTheBackdropAtItsLitLimbKeepsThatLimb) {
  RenderScene scene = CaseScene();
  scene.width_px = 512;
  scene.height_px = 384;
  scene.model = ProfileModel::kSawtooth;
  scene.wavelength_mm = 2.8549;
  scene.amplitude_mm = 0.06362;
  scene.phase_angle_deg = -59.26;
  scene.center_x_px = 241.0;
  scene.radius_px = 144.0;
  scene.top_row_px = 27;
  scene.bottom_row_px = 322;
  scene.source_blur_deg = 0.41;
  scene.exposure = 0.0088;
  scene.ambient = 0.0179;
  scene.background = 0.0425;
  scene.mount_level = 0.074;
  scene.mount_half_width = 1.08;
  scene.stray_light = 0.0452;
  scene.stray_texture = 0.68;
  scene.axial_glint_width = 0.235;
  scene.background_gradient = 0.0224;
  scene.background_gradient_deg = 63.0;
  scene.photons_full_scale = 50000.0;
  scene.read_noise = 0.002;
  scene.seed = 3;
  ExpectBothLimbsSeenWithin(scene, 1.0, 1.0);
}

// Vignetting of 0.27 lifts the backdrop between the side strips toward the
// frame's centre by as much as the faint stray-lit body (0.027) stands from
// it. Against the strips' one level, the bands' edges fell 80-150 px outside
// the limbs, and a tilted line through them and the end bands' true limbs
// made the cylinder 120 px off with a tilt of 34°. The backdrop fitted with
// its fall-off, and the weave's texture beside the limbs, place them.
TEST(DetectionCasesTest, VignettingThatLiftsTheBackdropBetweenTheStripsKeepsTheLimbs) {
  RenderScene scene = CaseScene();
  scene.width_px = 1024;
  scene.height_px = 768;
  scene.model = ProfileModel::kSawtooth;
  scene.wavelength_mm = 1.3916;
  scene.amplitude_mm = 0.15606;
  scene.phase_angle_deg = -43.91;
  scene.radius_px = 272.6;
  scene.center_x_px = 516.4;
  scene.camera_distance_mm = 577.0;
  scene.photons_full_scale = 3000.0;
  scene.source_blur_deg = 1.17;
  scene.exposure = 0.0037;
  scene.vignetting = 0.27;
  scene.stray_light = 0.0272;
  scene.stray_texture = 0.66;
  scene.ambient = 0.0092;
  scene.background = 0.0223;
  scene.black_level = 0.0113;
  scene.seed = 9;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_TRUE(g->left_observed && g->right_observed);
  EXPECT_NEAR(g->radius_px, rendered.truth.radius_px, 1.0);
  EXPECT_NEAR(g->center_x_px, rendered.truth.center_x_px, 1.0);
  EXPECT_NEAR(g->axis_angle_rad / kDeg, 0.0, kTiltToleranceDeg);
}

// At 96° a body in stray light alone meets its lit limb at the ambient
// level, under a backdrop that a gradient across the frame takes from
// brighter than the body at one side to darker at the other. The wide
// window's model finds that limb 24 px out of where the first step from
// the background fired; the body between the limbs is then judged against
// the backdrop's line between the strips and each strip's own noise (their
// spread about one level, which the gradient inflates, found only a tenth
// of the columns apart from it and refused). The first step taken for the
// limb: a radius 12 px short.
TEST(DetectionCasesTest, ABodyAtTheBackdropsLevelUnderAGradientKeepsItsLitLimb) {
  RenderScene scene = CaseScene();
  scene.width_px = 640;
  scene.height_px = 480;
  scene.model = ProfileModel::kSawtooth;
  scene.wavelength_mm = 3.0019;
  scene.amplitude_mm = 0.1914;
  scene.phase_angle_deg = 96.21;
  scene.center_x_px = 302.9;
  scene.radius_px = 257.5;
  scene.top_row_px = 37;
  scene.bottom_row_px = 436;
  scene.source_blur_deg = 0.89;
  scene.exposure = 0.0042;
  scene.ambient = 0.0192;
  scene.background = 0.0394;
  scene.mount_level = 0.035;
  scene.mount_half_width = 0.81;
  scene.vignetting = 0.16;
  scene.photons_full_scale = 3000.0;
  scene.stray_light = 0.0233;
  scene.stray_texture = 0.75;
  scene.axial_glint_width = 0.281;
  scene.background_gradient = 0.0233;
  scene.background_gradient_deg = 190.0;
  scene.seed = 2;
  ExpectBothLimbsSeenWithin(scene, 1.0, 1.0);
}

// A limb just inside the side strip's inner edge (4 % of the width) leaves
// every band of the cylinder's rows out (its limb is not measured there),
// and a mount narrower than the cylinder, above and below it, gave the only
// bands with two edges: the mount was refused as a cylinder and so was the
// photograph. More bands saw the body reach into a strip than found two
// limbs, so the strips are narrowed and the cylinder found.
TEST(DetectionCasesTest, ALimbAtTheSideStripsEdgeIsFoundBesideAMount) {
  RenderScene scene = CaseScene();
  scene.width_px = 512;
  scene.height_px = 384;
  scene.samples_per_pixel = 2;
  scene.radius_px = 227.0;
  scene.center_x_px = 19.9 + scene.radius_px;  // the strip is columns 0-19
  scene.top_row_px = 51;
  scene.bottom_row_px = 336;
  scene.phase_angle_deg = 88.75;
  scene.exposure = 0.0105;
  scene.diffuse = 0.054;
  scene.ambient = 0.0238;
  scene.background = 0.0283;
  scene.mount_level = 0.08;
  scene.mount_half_width = 0.82;
  scene.stray_light = 0.0433;
  scene.seed = 108;
  ExpectBothLimbsSeenWithin(scene, 1.0, 1.0);
}

// A glossy body as dark and as smooth as the backdrop shows only its
// glints: edges found on the outermost glints would place a cylinder that
// is not there, and the photograph is refused.
TEST(DetectionCasesTest, ABodyShowingOnlyItsGlintsIsRefused) {
  RenderScene scene = CaseScene();
  scene.width_px = 640;
  scene.height_px = 480;
  scene.center_x_px = 319.5;
  scene.radius_px = 256.0;
  scene.model = ProfileModel::kSawtooth;
  scene.phase_angle_deg = 30.0;
  scene.diffuse = 0.0;
  scene.ambient = 0.01;
  scene.background = 0.01;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_FALSE(g.ok()) << "radius " << g->radius_px;
  EXPECT_NE(std::string(g.status().message()).find("differ from the background"), std::string::npos)
      << g.status();
}

// At 110° a body in stray light alone rises slowly from its unlit limb,
// and one caustic of a sawtooth's split lobe stands far from α/2: the
// unlit edge reads as a terminator, and the limb inferred beyond it came
// out 1,300 px outside the 800 px frame, where a lobe at that caustic
// "fit". A limb is never inferred outside the frame: the side strip there
// would be body in shadow, read as background, and nothing places it.
TEST(DetectionCasesTest, NoLimbIsInferredOutsideTheFrame) {
  RenderScene scene = CaseScene();
  scene.width_px = 800;
  scene.height_px = 600;
  scene.model = ProfileModel::kSawtooth;
  scene.wavelength_mm = 1.8167;
  scene.amplitude_mm = 0.19534;
  scene.phase_angle_deg = 109.62;
  scene.center_x_px = 388.3;
  scene.radius_px = 343.6;
  scene.source_blur_deg = 1.21;
  scene.exposure = 0.0047;
  scene.ambient = 0.0023;
  scene.background = 0.0255;
  scene.photons_full_scale = 3000.0;
  scene.stray_light = 0.0595;
  scene.stray_texture = 0.66;
  scene.axial_glint_width = 0.208;
  scene.background_gradient = -0.0009;
  scene.background_gradient_deg = 296.0;
  scene.seed = 75;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  if (!g.ok()) return;  // a refusal is an honest answer here
  const Limbs found = DetectedLimbs(scene, *g);
  EXPECT_GE(found.left, 0.0);
  EXPECT_LE(found.right, scene.width_px - 1.0);
}

// At −7.5° the limb away from the light is lit from a pixel or two inside
// it, and a matte body's direct light (with the stray light's) falls to
// it as cos φ, over tens of pixels. Too close to the terminator for the
// shading to be measured beyond the lens blur, it is taken from the wide
// window's model and held in the edge model. (Without it that limb stood
// 8 px inside, where a flat body's step fits the fall-off best.)
TEST(DetectionCasesTest, AMatteBodyFallingOffToItsUnlitLimbAtASmallPhaseAngleKeepsIt) {
  RenderScene scene = CaseScene();
  scene.width_px = 640;
  scene.height_px = 480;
  scene.model = ProfileModel::kSmooth;
  scene.wavelength_mm = 1.8555;
  scene.amplitude_mm = 0.05277;
  scene.phase_angle_deg = -7.47;
  scene.center_x_px = 296.8;
  scene.radius_px = 165.0;
  scene.axis_angle_deg = -0.13;
  scene.top_row_px = 29;
  scene.bottom_row_px = 398;
  scene.source_blur_deg = 1.27;
  scene.exposure = 0.0039;
  scene.diffuse = 0.089;
  scene.ambient = 0.0122;
  scene.background = 0.0373;
  scene.mount_level = 0.049;
  scene.mount_half_width = 0.76;
  scene.stray_light = 0.0203;
  scene.stray_texture = 0.35;
  scene.axial_glint_width = 0.124;
  scene.axial_float_width = 0.35;
  scene.black_level = 0.0215;
  scene.seed = 149;
  // The lit limb (left): its own body's rise (the direct light's cos φ,
  // which its edge model does not hold) puts it a pixel in.
  ExpectBothLimbsSeenWithin(scene, 1.5, 1.0);
}

// A mount 0.69 radii wide above and below the cylinder, brighter than the
// body in shadow: over all rows its edges put steps into the shadow's
// column means, which read as direct light there (refused). The phase
// checks read the cylinder's own rows.
TEST(DetectionCasesTest, AMountAcrossTheShadowIsNotDirectLight) {
  RenderScene scene = CaseScene();
  scene.width_px = 800;
  scene.height_px = 600;
  scene.model = ProfileModel::kSmooth;
  scene.wavelength_mm = 4.3916;
  scene.amplitude_mm = 0.6131;
  scene.phase_angle_deg = 85.38;
  scene.center_x_px = 411.9;
  scene.radius_px = 318.3;
  scene.top_row_px = 70;
  scene.bottom_row_px = 501;
  scene.source_blur_deg = 1.47;
  scene.exposure = 0.009;
  scene.ambient = 0.006;
  scene.background = 0.0285;
  scene.mount_level = 0.064;
  scene.mount_half_width = 0.69;
  scene.photons_full_scale = 10000.0;
  scene.read_noise = 0.002;
  scene.stray_light = 0.0635;
  scene.stray_texture = 0.62;
  scene.seed = 72;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_TRUE(g->left_observed && g->right_observed);
  EXPECT_NEAR(g->radius_px, rendered.truth.radius_px, 1.0);
  EXPECT_NEAR(g->center_x_px, rendered.truth.center_x_px, 1.0);
}

// A mount 0.8 radii wide above and below the cylinder: the stretch just
// inside each limb (offsets 0.75-0.95) holds the mount over its first
// quarter, whose mean over both sides stood apart from the background, so
// rows of the mount beyond each end were counted as cylinder (34 and 44 of
// them in this scene at 2000×1500), and their steps across the shadow read
// as direct light there (refused). Most of the stretch is background: its
// median tells.
TEST(DetectionCasesTest, AMountNarrowerThanTheCylinderIsNotCountedAsItsRows) {
  RenderScene scene = CaseScene();
  scene.width_px = 800;
  scene.height_px = 600;
  scene.model = ProfileModel::kSinusoid;
  scene.wavelength_mm = 0.542;
  scene.amplitude_mm = 0.05436;
  scene.phase_angle_deg = 53.73;
  scene.center_x_px = 385.1;
  scene.radius_px = 316.2;
  scene.top_row_px = 88;
  scene.bottom_row_px = 482;
  scene.source_blur_deg = 0.57;
  scene.exposure = 0.0066;
  scene.diffuse = 0.035;
  scene.ambient = 0.0228;
  scene.background = 0.0303;
  scene.mount_level = 0.09;
  scene.mount_half_width = 0.8;
  scene.stray_light = 0.0523;
  scene.stray_texture = 0.6;
  scene.axial_glint_width = 0.12;
  scene.black_level = 0.0037;
  scene.photons_full_scale = 3000.0;
  scene.seed = 23;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_GE(g->top_row, scene.top_row_px);
  EXPECT_LE(g->top_row, scene.top_row_px + 3);
  EXPECT_LE(g->bottom_row, scene.bottom_row_px);
  EXPECT_GE(g->bottom_row, scene.bottom_row_px - 3);
  EXPECT_NEAR(g->radius_px, rendered.truth.radius_px, 0.5);
}

// --- What detection saw ----------------------------------------------------------

TEST(DetectionTraceTest, ARefusalRecordsTheColumnsTheEdgesAndEachCylinderTried) {
  RenderScene scene = CaseScene();
  scene.phase_angle_deg = 60.0;
  const Rendered rendered = Render(scene);
  CylinderDetectionOptions options;
  options.phase_angle_rad = -60.0 * kDeg;  // the wrong sign: refused
  DetectionTrace trace;
  absl::StatusOr<CylinderGeometry> g = DetectCylinder(rendered.image, options, &trace);
  ASSERT_FALSE(g.ok());
  ASSERT_TRUE(trace.Filled());
  EXPECT_EQ(trace.column_means.size(), static_cast<std::size_t>(scene.width_px));
  EXPECT_EQ(trace.region.width, scene.width_px);
  EXPECT_GT(trace.side_px, 0);
  EXPECT_GT(trace.noise, 0.0);
  EXPECT_NEAR(trace.left_background, scene.background, 0.002);
  EXPECT_GE(trace.band_edges.size(), 3u);
  const Limbs truth = TrueLimbs(rendered.truth);
  for (const DetectionTrace::BandEdge& e : trace.band_edges) {
    EXPECT_NEAR(e.left_x, truth.left, 3.0) << e.row;
    EXPECT_NEAR(e.right_x, truth.right, 3.0) << e.row;
  }
  ASSERT_FALSE(trace.hypotheses.empty());
  for (const DetectionTrace::Hypothesis& h : trace.hypotheses) {
    EXPECT_FALSE(h.kept) << h.name;
    EXPECT_FALSE(h.verdict.empty()) << h.name;
  }
  EXPECT_EQ(trace.hypotheses.front().name, "both edges are limbs");
  EXPECT_NEAR(trace.hypotheses.front().cylinder.radius_px, rendered.truth.radius_px, 1.0);
}

TEST(DetectionTraceTest, AFoundCylinderIsTheOneHypothesisKept) {
  RenderScene scene = CaseScene();
  scene.phase_angle_deg = 60.0;
  const Rendered rendered = Render(scene);
  CylinderDetectionOptions options;
  options.phase_angle_rad = 60.0 * kDeg;
  DetectionTrace trace;
  absl::StatusOr<CylinderGeometry> g = DetectCylinder(rendered.image, options, &trace);
  ASSERT_TRUE(g.ok()) << g.status();
  int kept = 0;
  for (const DetectionTrace::Hypothesis& h : trace.hypotheses) {
    if (!h.kept) continue;
    ++kept;
    EXPECT_DOUBLE_EQ(h.cylinder.radius_px, g->radius_px);
    EXPECT_DOUBLE_EQ(h.cylinder.center_x_px, g->center_x_px);
  }
  EXPECT_EQ(kept, 1);
  // The same cylinder with or without a trace.
  absl::StatusOr<CylinderGeometry> plain = DetectCylinder(rendered.image, options);
  ASSERT_TRUE(plain.ok());
  EXPECT_DOUBLE_EQ(plain->radius_px, g->radius_px);
}

// --- No cylinder --------------------------------------------------------------

void ExpectNoCylinder(const Rendered& rendered) {
  absl::StatusOr<CylinderGeometry> g = Detect(rendered);
  ASSERT_FALSE(g.ok()) << "found a cylinder at " << g->center_x_px
                       << " radius " << g->radius_px;
  EXPECT_EQ(g.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(g.status().message()).find("no cylinder"),
            std::string::npos)
      << g.status();
}

// The renderer with the cylinder wholly below the frame: only the background.
RenderScene EmptyScene() {
  RenderScene scene = CaseScene();
  scene.top_row_px = 1000;
  scene.bottom_row_px = 1100;
  return scene;
}

TEST(DetectionCasesTest, FlatGreyFrameHasNoCylinder) {
  RenderScene scene = EmptyScene();
  scene.background = 0.18;
  scene.photons_full_scale = 0.0;
  scene.read_noise = 0.0;
  const Rendered rendered = Render(scene);
  ASSERT_EQ(*std::min_element(rendered.image.pixels.begin(), rendered.image.pixels.end()),
            *std::max_element(rendered.image.pixels.begin(), rendered.image.pixels.end()));
  ExpectNoCylinder(rendered);
}

TEST(DetectionCasesTest, SensorNoiseFrameHasNoCylinder) {
  // Shot noise, read noise and 12-bit quantisation of a dark background.
  RenderScene scene = EmptyScene();
  scene.background = 0.02;
  scene.photons_full_scale = 5000.0;
  scene.read_noise = 0.004;
  ExpectNoCylinder(Render(scene));
}

// --- Azimuth mapping after detection ------------------------------------------

// Over the rows and the columns with |φ| < 70°, φ from the detected geometry
// differs from φ from the true axis and radius by < 0.1°.
void ExpectAzimuthAccuracy(const RenderScene& scene) {
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = Detect(rendered);
  ASSERT_TRUE(g.ok()) << g.status();
  const Projection projection{scene.diameter_mm / 2.0, scene.camera_distance_mm};
  CylinderGeometry truth;
  truth.center_x_px = rendered.truth.center_x_px;
  truth.center_row_px = MiddleRow(scene);
  truth.radius_px = rendered.truth.radius_px;
  truth.axis_angle_rad = rendered.truth.axis_angle_deg * kDeg;
  const Limbs true_limbs = TrueLimbs(rendered.truth);
  const Limbs found = DetectedLimbs(scene, *g);
  double worst = 0.0;
  int compared = 0;
  for (int y = 0; y < scene.height_px; y += 17) {
    for (int x = 0; x < scene.width_px; ++x) {
      const double phi_true = AzimuthFromOffset(truth.NormalisedOffset(x, y), projection);
      if (!(std::fabs(phi_true) < 70.0 * kDeg)) continue;
      const double phi = AzimuthFromOffset(g->NormalisedOffset(x, y), projection);
      ASSERT_TRUE(std::isfinite(phi)) << x << "," << y;
      worst = std::max(worst, std::fabs(phi - phi_true) / kDeg);
      ++compared;
    }
  }
  ASSERT_GT(compared, 1000);
  // Issue 4: under 0.1° (0.064° orthographic, 0.055° at D = 900 mm when
  // written); 0.1° at 70° needs the axis and radius within ~0.08 px.
  EXPECT_LT(worst, 0.1) << "limbs " << found.left - true_limbs.left << " / "
                        << found.right - true_limbs.right << " px";
}

TEST(AzimuthAfterDetectionTest, Orthographic) {
  RenderScene scene = CaseScene();
  scene.axis_angle_deg = 2.0;
  ExpectAzimuthAccuracy(scene);
}

TEST(AzimuthAfterDetectionTest, PerspectiveAt900Mm) {
  RenderScene scene = CaseScene();
  scene.camera_distance_mm = 900.0;
  scene.axis_angle_deg = -2.0;
  ExpectAzimuthAccuracy(scene);
}

// The scene rendered, saved as `format` and read back, and the cylinder
// detected knowing the phase angle: both limbs within `tolerance_px`.
void ExpectLimbsThroughFile(const RenderScene& scene, EncodeFormat format, double tolerance_px) {
  const Rendered rendered = Render(scene);
  absl::StatusOr<std::string> file = EncodeImage(rendered.image, format);
  ASSERT_TRUE(file.ok()) << file.status();
  absl::StatusOr<Image> decoded = DecodeImage(*file, DecodeOptions());
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  CylinderDetectionOptions options;
  options.phase_angle_rad = scene.phase_angle_deg * kDeg;
  absl::StatusOr<CylinderGeometry> g = DetectCylinder(Luminance(*decoded), options);
  ASSERT_TRUE(g.ok()) << g.status();
  const Limbs truth = TrueLimbs(rendered.truth);
  const Limbs found = DetectedLimbs(scene, *g);
  EXPECT_NEAR(found.left, truth.left, tolerance_px);
  EXPECT_NEAR(found.right, truth.right, tolerance_px);
}

}  // namespace
// A JPEG holds less noise than one of its 8-bit codes over a plain
// backdrop: its smoothing takes the sensor's noise out, and a backdrop's
// gradient and vignetting become a staircase of whole codes, whose column
// means in a side strip step by up to a code. Against the strip's noise
// alone that step was a limb in the strip, and the photograph was refused
// (three of the shared photographs saved as JPEGs). A limb steps by many
// codes; the strips' step test counts one code as the file's own.
TEST(DetectionCasesTest, AJpegsStaircaseOfCodesOverTheBackdropIsNoLimb) {
  RenderScene scene = CaseScene();
  scene.width_px = 640;
  scene.height_px = 480;
  scene.center_x_px = 321.3;
  scene.radius_px = 200.0;
  scene.phase_angle_deg = -57.0;
  // A dim backdrop (8.6 codes of the sRGB curve per 0.01 there), a gradient
  // of 0.01 across the frame and a vignetting of 0.25, with no noise left.
  scene.background = 0.03;
  scene.background_gradient = 0.01;
  scene.background_gradient_deg = 20.0;
  scene.vignetting = 0.25;
  scene.photons_full_scale = 0.0;
  scene.read_noise = 0.0;
  scene.quantisation_bits = 0;
  ExpectLimbsThroughFile(scene, EncodeFormat::kJpeg, 1.0);
}

// A mount wider than the cylinder and darker than the backdrop holds it
// beyond its ends, and the body meets its lit limb at the backdrop's level
// (stray light alone, no diffuse term): the bands find that limb far in,
// all rows put it right. Carried onto the all-rows line with the
// cylinder's bands, the mount's bands entered the wide window beside that
// limb as a dark rim outside it, and the limb moved 7.5 px in.
TEST(DetectionCasesTest, AMountBeyondTheEndsStaysOutOfTheLimbsWindow) {
  RenderScene scene = CaseScene();
  scene.width_px = 800;
  scene.height_px = 600;
  scene.model = ProfileModel::kSawtooth;
  scene.wavelength_mm = 0.6542;
  scene.amplitude_mm = 0.04529;
  scene.phase_angle_deg = 65.26;
  scene.center_x_px = 390.3;
  scene.radius_px = 226.2;
  scene.top_row_px = 40;
  scene.bottom_row_px = 560;
  scene.source_blur_deg = 0.42;
  scene.exposure = 0.006;
  scene.diffuse = 0.0;
  scene.ambient = 0.0243;
  scene.background = 0.0424;
  scene.mount_level = 0.035;
  scene.mount_half_width = 1.13;
  scene.stray_light = 0.0383;
  scene.stray_texture = 0.66;
  scene.axial_glint_width = 0.288;
  scene.photons_full_scale = 10000.0;
  scene.seed = 105;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g = DetectKnowingPhase(rendered, scene);
  ASSERT_TRUE(g.ok()) << g.status();
  const Limbs truth = TrueLimbs(rendered.truth);
  const Limbs found = DetectedLimbs(scene, *g);
  EXPECT_NEAR(found.left, truth.left, 1.0);
  EXPECT_NEAR(found.right, truth.right, 1.0);
}

// An 8-bit photograph of a backdrop under vignetting: the side strips'
// block levels fall on a few of the file's codes. Taken as medians, most
// were one code, their spread about it came out 0, and every other block
// was left out as an outlier with the fall-off it showed; the backdrop
// between the strips, lifted by the vignetting, then stood above the flat
// model by more than a band's threshold, and the bands traced its contour
// instead of the limbs.
TEST(DetectionCasesTest, AnEightBitPhotographKeepsItsVignetting) {
  RenderScene scene = CaseScene();
  scene.width_px = 800;
  scene.height_px = 600;
  scene.wavelength_mm = 1.3902;
  scene.amplitude_mm = 0.0694;
  scene.phase_angle_deg = -118.3;
  scene.center_x_px = 408.3;
  scene.radius_px = 286.3;
  scene.top_row_px = 106;
  scene.bottom_row_px = 537;
  scene.source_blur_deg = 0.38;
  scene.exposure = 0.0031;
  scene.diffuse = 0.087;
  scene.ambient = 0.005;
  scene.background = 0.0493;
  scene.mount_level = 0.028;
  scene.mount_half_width = 0.88;
  scene.vignetting = 0.15;
  scene.stray_light = 0.0579;
  scene.stray_texture = 0.6;
  scene.axial_glint_width = 0.064;
  scene.axial_float_width = 0.28;
  scene.photons_full_scale = 20000.0;
  scene.seed = 128;
  ExpectLimbsThroughFile(scene, EncodeFormat::kPng8, 1.0);
}

// At 90° a body in weak stray light alone (no diffuse term) meets its limbs
// near the backdrop's level, under a gradient across the frame: each band
// finds its lit limb's first step further in, where the body's shading
// rises, and the photograph was refused (the surface beyond that edge went
// on past the terminator). Its texture over all rows, 1.5-2.5 times the
// backdrop's variance, reaches out to the limb.
TEST(DetectionCasesTest, ABodysTextureOverAllRowsReachesItsLimb) {
  RenderScene scene = CaseScene();
  scene.wavelength_mm = 4.1843;
  scene.amplitude_mm = 0.07486;
  scene.phase_angle_deg = 90.49;
  scene.center_x_px = 163.9;
  scene.radius_px = 89.4;
  scene.axis_angle_deg = 0.59;
  scene.source_blur_deg = 1.41;
  scene.exposure = 0.0067;
  scene.diffuse = 0.0;
  scene.ambient = 0.0193;
  scene.background = 0.0239;
  scene.photons_full_scale = 10000.0;
  scene.stray_light = 0.0253;
  scene.stray_texture = 0.47;
  scene.axial_glint_width = 0.201;
  scene.axial_float_width = 0.36;
  scene.background_gradient = -0.0262;
  scene.background_gradient_deg = 29.0;
  scene.black_level = 0.0141;
  scene.seed = 78;
  ExpectLimbsThroughFile(scene, EncodeFormat::kPng8, 1.0);
}

// The limb away from the light at -105°, in stray light that leaves the body
// 0.002 above the backdrop there, under a gradient; the weave's relief
// draws stripes beside the limb, where each band's and all rows' breaks
// fell 4-5 px in. The texture against the backdrop's beside it (1.3-1.5
// times) reaches out to the limb.
TEST(DetectionCasesTest, AFaintLimbBesideStripesOfReliefIsFoundByItsTexture) {
  RenderScene scene = CaseScene();
  scene.width_px = 640;
  scene.height_px = 480;
  scene.wavelength_mm = 4.2795;
  scene.amplitude_mm = 0.14908;
  scene.phase_angle_deg = -105.29;
  scene.center_x_px = 345.3;
  scene.radius_px = 212.7;
  scene.source_blur_deg = 0.45;
  scene.exposure = 0.0067;
  scene.diffuse = 0.0;
  scene.ambient = 0.0198;
  scene.background = 0.0468;
  scene.optics_blur_px = 0.86;
  scene.photons_full_scale = 3000.0;
  scene.stray_light = 0.0748;
  scene.stray_texture = 0.35;
  scene.axial_glint_width = 0.224;
  scene.background_gradient = 0.016;
  scene.background_gradient_deg = 7.0;
  scene.black_level = 0.023;
  scene.white_level = 0.99977;
  scene.seed = 20;
  ExpectLimbsThroughFile(scene, EncodeFormat::kPng8, 2.0);
}

}  // namespace weavefit
