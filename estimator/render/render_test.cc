// Unit tests of render/: determinism, the derived truth, the noise-free
// radiance of the body, the sensor model and scene validation.
#include "estimator/render/render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A tiny scene (96×64, 1×4 samples per pixel): a few milliseconds.
RenderScene TinyScene() {
  RenderScene scene;
  scene.width_px = 96;
  scene.height_px = 64;
  scene.samples_per_pixel = 1;
  scene.seed = 5;
  return scene;
}

Rendered Render(const RenderScene& scene) {
  absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
  EXPECT_TRUE(rendered.ok()) << rendered.status();
  return rendered.ok() ? *rendered : Rendered();
}

// A scene without shot noise, read noise or quantisation.
RenderScene NoiseFree(RenderScene scene) {
  scene.photons_full_scale = 0.0;
  scene.read_noise = 0.0;
  scene.quantisation_bits = 0;
  return scene;
}

TEST(RenderTest, SameSeedGivesIdenticalPixels) {
  const RenderScene scene = TinyScene();
  const Rendered a = Render(scene);
  const Rendered b = Render(scene);
  ASSERT_EQ(a.image.pixels.size(), 96u * 64u);
  EXPECT_EQ(a.image.pixels, b.image.pixels);
  EXPECT_EQ(a.image.saturated, b.image.saturated);

  RenderScene other = scene;
  other.seed = 6;
  const Rendered c = Render(other);
  EXPECT_NE(a.image.pixels, c.image.pixels);
}

TEST(RenderTest, ImageShape) {
  const Rendered r = Render(TinyScene());
  EXPECT_EQ(r.image.width, 96);
  EXPECT_EQ(r.image.height, 64);
  EXPECT_EQ(r.image.channels, 1);
  for (float v : r.image.pixels) {
    ASSERT_GE(v, 0.0f);
    ASSERT_LE(v, 1.0f);
  }
}

TEST(RenderTest, TruthFields) {
  RenderScene scene = TinyScene();
  scene.model = ProfileModel::kSinusoid;
  scene.wavelength_mm = 2.88;
  scene.amplitude_mm = 0.108;
  scene.phase_angle_deg = -24.0;
  scene.source_blur_deg = 0.6;
  scene.axis_angle_deg = 1.25;
  Rendered r = Render(scene);
  // Sinusoid: m = 2π·h0/λ (the paper's coarse gauze: 0.2356, 26.52°).
  EXPECT_NEAR(r.truth.max_slope, 2.0 * M_PI * 0.108 / 2.88, 1e-12);
  EXPECT_DOUBLE_EQ(scene.MaxSlope(), r.truth.max_slope);
  EXPECT_NEAR(r.truth.peak_spacing_deg, 26.516, 1e-3);
  EXPECT_DOUBLE_EQ(r.truth.mirror_azimuth_deg, -12.0);
  // Defaults: axis through the middle column, radius 40 % of the width.
  EXPECT_DOUBLE_EQ(r.truth.center_x_px, 47.5);
  EXPECT_DOUBLE_EQ(r.truth.radius_px, 0.4 * 96);
  EXPECT_DOUBLE_EQ(r.truth.axis_angle_deg, 1.25);
  // λ in pixels: mm per pixel = R_mm / R_px.
  EXPECT_NEAR(r.truth.px_per_period, 2.88 / (23.0 / 38.4), 1e-12);
  EXPECT_TRUE(r.truth.period_resolvable);
  // 26.5° ≫ 2 · 2.355 · 0.3°.
  EXPECT_TRUE(r.truth.split_resolvable);

  // Sawtooth: m = 4·h0/λ (0.15, 17.06°).
  scene.model = ProfileModel::kSawtooth;
  r = Render(scene);
  EXPECT_NEAR(r.truth.max_slope, 4.0 * 0.108 / 2.88, 1e-12);
  EXPECT_NEAR(r.truth.max_slope, 0.15, 1e-12);
  EXPECT_NEAR(r.truth.peak_spacing_deg, 17.062, 1e-3);
  EXPECT_TRUE(r.truth.split_resolvable);

  // Smooth: no facets, no split.
  scene.model = ProfileModel::kSmooth;
  r = Render(scene);
  EXPECT_EQ(r.truth.max_slope, 0.0);
  EXPECT_EQ(r.truth.peak_spacing_deg, 0.0);
  EXPECT_FALSE(r.truth.split_resolvable);

  // Explicit geometry, a period below 4 px and a split below the blur.
  scene = TinyScene();
  scene.center_x_px = 40.0;
  scene.radius_px = 30.0;
  scene.wavelength_mm = 3.2;
  scene.amplitude_mm = 0.003;  // m = 0.00589, spacing 0.67°
  scene.source_blur_deg = 1.0;  // 2 · 2.355 · 0.5° = 2.36° > 0.67°
  r = Render(scene);
  EXPECT_DOUBLE_EQ(r.truth.center_x_px, 40.0);
  EXPECT_DOUBLE_EQ(r.truth.radius_px, 30.0);
  EXPECT_NEAR(r.truth.px_per_period, 3.2 / (23.0 / 30.0), 1e-12);  // 4.17 px
  EXPECT_TRUE(r.truth.period_resolvable);
  EXPECT_FALSE(r.truth.split_resolvable);
  scene.wavelength_mm = 2.5;  // 3.26 px per period
  r = Render(scene);
  EXPECT_FALSE(r.truth.period_resolvable);
}

TEST(RenderTest, NoiseFreeBodyRadiance) {
  // Without noise, away from the specular lobe the column average holds the
  // ambient level plus the glints of the axial threads (round specular
  // cylinders in the gaps): gap · E0/4 · cos(α/2)/cos φ, the paper's
  // surface-scattering lobe (DESIGN.md §3); the background outside.
  RenderScene scene = NoiseFree(TinyScene());
  scene.model = ProfileModel::kSmooth;
  scene.phase_angle_deg = 60.0;  // mirror at 30°, the lobe far from φ ≤ 0
  scene.width_px = 200;
  scene.height_px = 240;
  scene.radius_px = 80.0;
  scene.center_x_px = 99.5;
  scene.wavelength_mm = 2.0;  // pitch 1 mm = 3.5 px
  scene.exposure = 0.2;
  scene.samples_per_pixel = 8;
  const Rendered r = Render(scene);
  const double alpha = 60.0 * kDeg;
  auto column_mean = [&](int x) {
    double sum = 0.0;
    for (int y = 0; y < scene.height_px; ++y) sum += r.image.At(x, y);
    return sum / scene.height_px;
  };
  for (int x : {40, 60, 80, 99, 110}) {  // φ from −48° to 7.5°
    const double phi = std::asin((x - 99.5) / 80.0);
    // Lit only where the light is above the local horizon, φ > α − 90° = −30°.
    const bool lit = std::cos(phi - alpha) > 0.0;
    const double axial =
        lit ? scene.gap_fraction * scene.exposure * 0.25 * std::cos(alpha / 2.0) / std::cos(phi) : 0.0;
    EXPECT_NEAR(column_mean(x), scene.ambient + axial, 0.05 * axial + 1e-6) << "x " << x;
  }
  for (int x : {0, 5, 194, 199}) {
    EXPECT_FLOAT_EQ(r.image.At(x, 10), static_cast<float>(scene.background)) << x;
  }
  // In the cylinder's own shadow, only the ambient level.
  const int dark = static_cast<int>(std::lround(99.5 + 80.0 * std::sin(-70.0 * kDeg)));
  EXPECT_NEAR(column_mean(dark), scene.ambient, 1e-6);
}

TEST(RenderTest, NoiseFreeSmoothLobePeaksNearTheMirror) {
  RenderScene scene = NoiseFree(TinyScene());
  scene.model = ProfileModel::kSmooth;
  scene.phase_angle_deg = 20.0;
  scene.width_px = 400;
  scene.height_px = 16;
  scene.radius_px = 180.0;
  scene.center_x_px = 199.5;
  scene.axial_reflectance = 0.0;
  const Rendered r = Render(scene);
  // Column sums: single rows may fall between thread crests or in a gap.
  std::vector<double> column(scene.width_px, 0.0);
  for (int x = 0; x < scene.width_px; ++x) {
    for (int y = 0; y < scene.height_px; ++y) column[x] += r.image.At(x, y);
  }
  const int best = static_cast<int>(std::max_element(column.begin(), column.end()) - column.begin());
  // The mirror point φ = α/2 = 10° is at column 199.5 + 180·sin 10° = 230.8.
  const double phi = std::asin((best - 199.5) / 180.0) / kDeg;
  EXPECT_NEAR(phi, 10.0, 0.5);
}

TEST(RenderTest, SensorNoiseAndQuantisation) {
  RenderScene scene = TinyScene();
  scene.width_px = 200;
  scene.height_px = 100;
  scene.radius_px = 50.0;  // wide background on both sides
  const Rendered r = Render(scene);
  // 12-bit ADC: every value is a multiple of 1/4095.
  for (float v : r.image.pixels) {
    const double code = v * 4095.0;
    ASSERT_NEAR(code, std::round(code), 1e-3);
  }
  // Background noise: Poisson (level / photons) and read noise in quadrature.
  std::vector<double> outside;
  for (int y = 0; y < scene.height_px; ++y) {
    for (int x = 0; x < 30; ++x) outside.push_back(r.image.At(x, y));
  }
  double mean = 0.0;
  for (double v : outside) mean += v;
  mean /= outside.size();
  double ss = 0.0;
  for (double v : outside) ss += (v - mean) * (v - mean);
  const double sigma = std::sqrt(ss / (outside.size() - 1));
  const double expected = std::sqrt(scene.background / scene.photons_full_scale +
                                    scene.read_noise * scene.read_noise);
  EXPECT_NEAR(mean, scene.background, 3.0 * expected / std::sqrt(outside.size()) + 1e-4);
  EXPECT_NEAR(sigma, expected, 0.15 * expected);
}

TEST(RenderTest, SaturationIsClippedAndFlagged) {
  RenderScene scene = TinyScene();
  scene.exposure = 5.0;  // far beyond full scale at the lobe
  const Rendered r = Render(scene);
  EXPECT_GT(r.image.SaturatedCount(), 0);
  for (std::size_t i = 0; i < r.image.pixels.size(); ++i) {
    if (r.image.IsSaturated(static_cast<int>(i % r.image.width),
                            static_cast<int>(i / r.image.width))) {
      ASSERT_EQ(r.image.pixels[i], 1.0f);
    } else {
      ASSERT_LT(r.image.pixels[i], 1.0f);
    }
  }
}

TEST(RenderTest, CylinderEndsShowTheBackground) {
  RenderScene scene = NoiseFree(TinyScene());
  scene.top_row_px = 10;
  scene.bottom_row_px = 49;
  const Rendered r = Render(scene);
  const float background = static_cast<float>(scene.background);
  for (int x = 0; x < scene.width_px; ++x) {
    EXPECT_EQ(r.image.At(x, 5), background) << x;
    EXPECT_EQ(r.image.At(x, 55), background) << x;
  }
  // On the cylinder the body is at least the ambient level.
  EXPECT_GE(r.image.At(47, 30), scene.ambient - 1e-6);
}

TEST(RenderTest, ValidateNamesTheField) {
  auto message = [](const RenderScene& scene) {
    return std::string(RenderPhotograph(scene).status().message());
  };
  RenderScene scene = TinyScene();
  EXPECT_TRUE(scene.Validate().ok());
  scene.width_px = 8;
  EXPECT_NE(message(scene).find("width_px"), std::string::npos);
  scene = TinyScene();
  scene.wavelength_mm = 0.0;
  EXPECT_NE(message(scene).find("wavelength_mm"), std::string::npos);
  scene = TinyScene();
  scene.camera_distance_mm = 20.0;  // inside the 23 mm radius
  EXPECT_NE(message(scene).find("camera_distance_mm"), std::string::npos);
  scene = TinyScene();
  scene.phase_angle_deg = 180.0;
  EXPECT_NE(message(scene).find("phase_angle_deg"), std::string::npos);
  scene = TinyScene();
  scene.gap_fraction = 1.0;
  EXPECT_NE(message(scene).find("gap_fraction"), std::string::npos);
  scene = TinyScene();
  scene.samples_per_pixel = 0;
  EXPECT_NE(message(scene).find("samples_per_pixel"), std::string::npos);
  scene = TinyScene();
  scene.source_blur_deg = 0.0;
  EXPECT_NE(message(scene).find("source_blur_deg"), std::string::npos);
  EXPECT_EQ(RenderPhotograph(scene).status().code(), absl::StatusCode::kInvalidArgument);
}

TEST(RenderTest, TruthJsonCarriesTheTruth) {
  const RenderScene scene = TinyScene();
  const Rendered r = Render(scene);
  const std::string json = TruthJson(scene, r.truth, "scene_01.png");
  EXPECT_NE(json.find("\"scene_01.png\""), std::string::npos);
  EXPECT_NE(json.find("\"peakSpacingDeg\""), std::string::npos);
  EXPECT_NE(json.find("\"model\": \"SINUSOID\""), std::string::npos);
  EXPECT_EQ(std::count(json.begin(), json.end(), '{'),
            std::count(json.begin(), json.end(), '}'));
}

}  // namespace
}  // namespace weavefit
