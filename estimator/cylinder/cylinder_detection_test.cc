// Unit tests of cylinder/cylinder_detection on rendered photographs with
// known axis, radius and tilt, and on images without a cylinder.
#include "estimator/cylinder/cylinder_detection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A small, fast scene (≈ 0.2 s): 400×300, 2×8 samples per pixel.
RenderScene SmallScene() {
  RenderScene scene;
  scene.width_px = 400;
  scene.height_px = 300;
  scene.samples_per_pixel = 2;
  scene.center_x_px = 190.3;
  scene.radius_px = 152.0;
  scene.phase_angle_deg = 10.0;
  scene.seed = 7;
  return scene;
}

Rendered Render(const RenderScene& scene) {
  absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
  EXPECT_TRUE(rendered.ok()) << rendered.status();
  return rendered.ok() ? *rendered : Rendered();
}

// Axis column of the truth at image row y (DESIGN.md §2: positive tilt leans
// the top of the axis toward the image right).
double TrueAxisColumn(const RenderScene& scene, const RenderTruth& truth,
                      double y) {
  const double center_row = (scene.height_px - 1) / 2.0;
  return truth.center_x_px + (center_row - y) * std::tan(truth.axis_angle_deg * kDeg);
}

void ExpectGeometry(const RenderScene& scene, const Rendered& rendered) {
  absl::StatusOr<CylinderGeometry> g =
      DetectCylinder(rendered.image, CylinderDetectionOptions());
  ASSERT_TRUE(g.ok()) << g.status();
  const RenderTruth& truth = rendered.truth;
  EXPECT_NEAR(g->center_x_px, TrueAxisColumn(scene, truth, g->center_row_px), 0.5);
  EXPECT_NEAR(g->radius_px, truth.radius_px, 1.0);
  EXPECT_NEAR(g->axis_angle_rad / kDeg, truth.axis_angle_deg, 0.1);
  EXPECT_TRUE(g->left_observed);
  EXPECT_TRUE(g->right_observed);
  EXPECT_LT(g->limb_rms_px, 0.5);
  // The cylinder fills the frame vertically: every row is usable.
  EXPECT_EQ(g->top_row, 0);
  EXPECT_EQ(g->bottom_row, scene.height_px - 1);
  // The geometry's own mapping puts the limbs at ±1 on every row.
  for (double y : {0.0, 150.0, 299.0}) {
    const double axis = TrueAxisColumn(scene, truth, y);
    const double half_width = truth.radius_px / std::cos(truth.axis_angle_deg * kDeg);
    EXPECT_NEAR(g->NormalisedOffset(axis + half_width, y), 1.0, 0.01) << y;
    EXPECT_NEAR(g->NormalisedOffset(axis - half_width, y), -1.0, 0.01) << y;
  }
}

TEST(CylinderDetectionTest, UprightAxis) {
  const RenderScene scene = SmallScene();
  ExpectGeometry(scene, Render(scene));
}

TEST(CylinderDetectionTest, TiltedAxis) {
  RenderScene scene = SmallScene();
  scene.axis_angle_deg = 1.5;
  ExpectGeometry(scene, Render(scene));
}

TEST(CylinderDetectionTest, TiltedAxisLightOnTheLeft) {
  RenderScene scene = SmallScene();
  scene.axis_angle_deg = -2.0;
  scene.phase_angle_deg = -25.0;
  scene.model = ProfileModel::kSawtooth;
  ExpectGeometry(scene, Render(scene));
}

TEST(CylinderDetectionTest, LargerImageNearTheTerminator) {
  // At α = 10° the unlit limb shows only ~4 px of ambient-lit surface before
  // the terminator; the limb must still be placed at the body's edge.
  RenderScene scene = SmallScene();
  scene.width_px = 640;
  scene.height_px = 240;
  scene.center_x_px = 319.5;
  scene.radius_px = 256.0;
  scene.samples_per_pixel = 1;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g =
      DetectCylinder(rendered.image, CylinderDetectionOptions());
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_NEAR(g->center_x_px, 319.5, 0.5);
  EXPECT_NEAR(g->radius_px, 256.0, 1.0);
  EXPECT_NEAR(g->axis_angle_rad / kDeg, 0.0, 0.1);
}

// DESIGN.md §3: "The cylinder body may be darker or brighter than the
// background (ambient light, black cloth) ... detect limbs by edges, not by
// brightness."
TEST(CylinderDetectionTest, BodyDarkerThanTheBackground) {
  RenderScene scene = SmallScene();
  scene.ambient = 0.002;
  scene.background = 0.05;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g =
      DetectCylinder(rendered.image, CylinderDetectionOptions());
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_NEAR(g->center_x_px, 190.3, 0.5);
  EXPECT_NEAR(g->radius_px, 152.0, 1.0);
}

TEST(CylinderDetectionTest, UsableRowsStopAtTheCylinderEnds) {
  RenderScene scene = SmallScene();
  scene.top_row_px = 60;
  scene.bottom_row_px = 239;
  const Rendered rendered = Render(scene);
  absl::StatusOr<CylinderGeometry> g =
      DetectCylinder(rendered.image, CylinderDetectionOptions());
  ASSERT_TRUE(g.ok()) << g.status();
  // Bands are 12.5 rows: the usable rows lie inside the cylinder and lose at
  // most a band and a half at each end.
  EXPECT_GE(g->top_row, 60);
  EXPECT_LE(g->top_row, 60 + 19);
  EXPECT_LE(g->bottom_row, 239);
  EXPECT_GE(g->bottom_row, 239 - 19);
  EXPECT_NEAR(g->radius_px, 152.0, 1.0);
  EXPECT_NEAR(g->center_x_px, 190.3, 0.5);
}

TEST(CylinderDetectionTest, RegionOfInterest) {
  const RenderScene scene = SmallScene();
  const Rendered rendered = Render(scene);
  CylinderDetectionOptions options;
  options.region = {20, 40, 360, 200};
  absl::StatusOr<CylinderGeometry> g = DetectCylinder(rendered.image, options);
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_DOUBLE_EQ(g->center_row_px, 40 + (200 - 1) / 2.0);
  EXPECT_NEAR(g->center_x_px, 190.3, 0.5);
  EXPECT_NEAR(g->radius_px, 152.0, 1.0);
  EXPECT_GE(g->top_row, 40);
  EXPECT_LE(g->bottom_row, 239);

  options.region = {100, 0, 400, 300};  // beyond the right edge
  absl::StatusOr<CylinderGeometry> beyond = DetectCylinder(rendered.image, options);
  ASSERT_FALSE(beyond.ok());
  EXPECT_EQ(beyond.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(beyond.status().message()).find("region"), std::string::npos);

  // Fields whose int sum wraps round (issue 30) are beyond the edge too, for
  // callers that skip the pipeline's CheckRegion.
  for (const PixelRegion& wraps : {PixelRegion{2147483547, 0, 200, 100},
                                   PixelRegion{0, 2147483547, 100, 200},
                                   PixelRegion{2147483647, 2147483647, 2147483647, 2147483647}}) {
    options.region = wraps;
    beyond = DetectCylinder(rendered.image, options);
    ASSERT_FALSE(beyond.ok());
    EXPECT_NE(std::string(beyond.status().message()).find("extends beyond"), std::string::npos)
        << beyond.status();
  }
}

Image Uniform(int width, int height, float value) {
  Image image;
  image.width = width;
  image.height = height;
  image.channels = 1;
  image.pixels.assign(static_cast<std::size_t>(width) * height, value);
  return image;
}

void ExpectNoCylinder(const Image& image) {
  absl::StatusOr<CylinderGeometry> g = DetectCylinder(image, CylinderDetectionOptions());
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(g.status().message()).find("no cylinder"), std::string::npos)
      << g.status();
}

TEST(CylinderDetectionTest, UniformImageHasNoCylinder) {
  ExpectNoCylinder(Uniform(200, 150, 0.3f));
  ExpectNoCylinder(Uniform(200, 150, 0.0f));
}

TEST(CylinderDetectionTest, NoiseOnlyImageHasNoCylinder) {
  Image image = Uniform(300, 200, 0.0f);
  std::mt19937 rng(42);
  std::normal_distribution<float> noise(0.1f, 0.02f);
  for (float& v : image.pixels) v = noise(rng);
  ExpectNoCylinder(image);
  // Poisson-like noise with a gentle horizontal gradient is no cylinder either.
  std::poisson_distribution<int> photons(50);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      image.pixels[static_cast<std::size_t>(y) * image.width + x] =
          photons(rng) / 500.0f;
    }
  }
  ExpectNoCylinder(image);
}

TEST(CylinderDetectionTest, RejectsBadInput) {
  Image rgb = Uniform(100, 100, 0.2f);
  rgb.channels = 3;
  rgb.pixels.resize(rgb.pixels.size() * 3, 0.2f);
  EXPECT_EQ(DetectCylinder(rgb, CylinderDetectionOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);

  absl::StatusOr<CylinderGeometry> tiny =
      DetectCylinder(Uniform(20, 20, 0.1f), CylinderDetectionOptions());
  ASSERT_FALSE(tiny.ok());
  EXPECT_NE(std::string(tiny.status().message()).find("too small"), std::string::npos);

  CylinderDetectionOptions options;
  options.num_bands = 2;
  EXPECT_NE(std::string(options.Validate().message()).find("num_bands"), std::string::npos);
  options = CylinderDetectionOptions();
  options.background_fraction = 0.3;
  EXPECT_NE(std::string(options.Validate().message()).find("background_fraction"),
            std::string::npos);
  options = CylinderDetectionOptions();
  options.edge_sigmas = 0.0;
  EXPECT_NE(std::string(options.Validate().message()).find("edge_sigmas"), std::string::npos);
  options = CylinderDetectionOptions();
  options.region.x = -1;
  EXPECT_NE(std::string(options.Validate().message()).find("region"), std::string::npos);
}

TEST(CylinderGeometryTest, AxisColumnAndNormalisedOffset) {
  CylinderGeometry g;
  g.center_x_px = 100.0;
  g.center_row_px = 50.0;
  g.radius_px = 40.0;
  g.axis_angle_rad = 0.1;
  // Rows above the reference row lie toward the right for a positive tilt.
  EXPECT_NEAR(g.AxisColumn(40.0), 100.0 + 10.0 * std::tan(0.1), 1e-12);
  EXPECT_NEAR(g.AxisColumn(60.0), 100.0 - 10.0 * std::tan(0.1), 1e-12);
  EXPECT_NEAR(g.NormalisedOffset(100.0 + 40.0 / std::cos(0.1), 50.0), 1.0, 1e-12);
  EXPECT_NEAR(g.NormalisedOffset(g.AxisColumn(10.0), 10.0), 0.0, 1e-12);
}

// FindShadowOnset on synthetic column profiles: a cylinder 300 px in
// half-width about column 400, light on the right at α = 60°, so the shadow
// runs from the left limb (100) to the terminator at φ = −30° (250), taken
// with margins as columns 103..233.
struct ShadowScene {
  double center = 400.0;
  double half = 300.0;
  int lo = 103;
  int hi = 233;
  Projection projection;
  double Azimuth(double x) const {
    return AzimuthFromOffset(std::clamp((x - center) / half, -1.0, 1.0), projection);
  }
  // The body in stray light: a level, a gradient across the image, the
  // diffuse light's cos φ shading, and the weave's texture (a thread every
  // 7 px) with noise.
  std::vector<double> StrayLit(int seed) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, 0.3);
    std::vector<double> profile(800, 10.0);
    for (int x = 0; x < 800; ++x) {
      const double u = (x - center) / half;
      if (std::fabs(u) > 1.0) continue;
      profile[x] = 20.0 + 3.0 * u + 6.0 * std::cos(Azimuth(x)) +
                   0.8 * std::sin(2.0 * M_PI * x / 7.0) + noise(rng);
    }
    return profile;
  }
};

TEST(FindShadowOnsetTest, StrayLitShadowWithGradientAndTextureIsNotLit) {
  const ShadowScene scene;
  for (int seed = 1; seed <= 5; ++seed) {
    const ShadowOnset onset = FindShadowOnset(scene.StrayLit(seed), scene.lo, scene.hi,
                                              scene.center, scene.half, 1, scene.projection, 0.1);
    EXPECT_TRUE(onset.judged);
    EXPECT_FALSE(onset.lit) << "seed " << seed << ": dBIC " << onset.delta_bic << " rise "
                            << onset.rise << " sigma " << onset.sigma;
  }
}

TEST(FindShadowOnsetTest, LambertianRampStartingInsideIsLit) {
  const ShadowScene scene;
  std::vector<double> profile = scene.StrayLit(3);
  const double phi0 = scene.Azimuth(170.0);
  for (int x = 170; x < 800; ++x) {
    const double u = (x - scene.center) / scene.half;
    if (u > 1.0) break;
    profile[x] += 60.0 * std::max(0.0, std::sin(scene.Azimuth(x) - phi0));
  }
  const ShadowOnset onset = FindShadowOnset(profile, scene.lo, scene.hi, scene.center,
                                            scene.half, 1, scene.projection, 0.1);
  EXPECT_TRUE(onset.lit) << "dBIC " << onset.delta_bic << " rise " << onset.rise << " sigma " << onset.sigma;
  EXPECT_NEAR(onset.onset_column, 170.0, 8.0);
}

TEST(FindShadowOnsetTest, GrazingScatterStepInsideIsLit) {
  const ShadowScene scene;
  std::vector<double> profile = scene.StrayLit(4);
  for (int x = 190; x < 700; ++x) profile[x] += 2.0 / std::cos(scene.Azimuth(x));
  const ShadowOnset onset = FindShadowOnset(profile, scene.lo, scene.hi, scene.center,
                                            scene.half, 1, scene.projection, 0.1);
  EXPECT_TRUE(onset.lit) << "dBIC " << onset.delta_bic << " rise " << onset.rise << " sigma " << onset.sigma;
  EXPECT_NEAR(onset.onset_column, 190.0, 5.0);
}

TEST(FindShadowOnsetTest, MirroredLightOnTheLeft) {
  // The same scenes reflected about the axis, the light on the left.
  const ShadowScene scene;
  auto mirror = [](const std::vector<double>& p) {
    std::vector<double> m(p.rbegin(), p.rend());
    return m;
  };
  const int lo = 799 - scene.hi;
  const int hi = 799 - scene.lo;
  const double center = 799.0 - scene.center;
  const std::vector<double> stray = scene.StrayLit(2);
  EXPECT_FALSE(FindShadowOnset(mirror(stray), lo, hi, center, scene.half, -1, scene.projection,
                               0.1).lit);
  std::vector<double> lit = stray;
  const double phi0 = scene.Azimuth(170.0);
  for (int x = 170; x < 700; ++x) lit[x] += 60.0 * std::max(0.0, std::sin(scene.Azimuth(x) - phi0));
  const ShadowOnset onset =
      FindShadowOnset(mirror(lit), lo, hi, center, scene.half, -1, scene.projection, 0.1);
  EXPECT_TRUE(onset.lit);
  EXPECT_NEAR(onset.onset_column, 799.0 - 170.0, 8.0);
}

TEST(FindShadowOnsetTest, NarrowRegionIsNotJudged) {
  const ShadowScene scene;
  const ShadowOnset onset = FindShadowOnset(scene.StrayLit(1), 103, 130, scene.center,
                                            scene.half, 1, scene.projection, 0.1);
  EXPECT_FALSE(onset.judged);
  EXPECT_FALSE(onset.lit);
}

}  // namespace
}  // namespace weavefit
