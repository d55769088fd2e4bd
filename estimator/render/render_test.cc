// Unit tests of render/: determinism, the derived truth, the noise-free
// radiance of the body, the sensor model, scene validation, and the
// conditions of lab photographs (stray light, axial glint lines, background
// gradient, pedestal, mount).
#include "estimator/render/render.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "estimator/io/decode.h"
#include "estimator/io/encode.h"

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
  EXPECT_FALSE(r.truth.period_resolvable);

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

// A sensor whose ADC has fewer bits than the file (12 in 16) stores its
// clipped samples at 65520, not 65535: decoded, they still read as
// saturated, from the pile-up at the file's largest value.
TEST(RenderTest, WhiteLevelBelowTheFormatMaximumStillReadsAsClipped) {
  RenderScene scene = TinyScene();
  scene.exposure = 5.0;
  scene.white_level = 65520.0 / 65535.0;
  const Rendered r = Render(scene);
  ASSERT_GT(r.image.SaturatedCount(), 2);
  for (std::size_t i = 0; i < r.image.pixels.size(); ++i) {
    const bool clipped = r.image.IsSaturated(static_cast<int>(i % r.image.width),
                                             static_cast<int>(i / r.image.width));
    if (clipped) {
      ASSERT_EQ(r.image.pixels[i], static_cast<float>(scene.white_level));
    } else {
      ASSERT_LT(r.image.pixels[i], static_cast<float>(scene.white_level));
    }
  }
  absl::StatusOr<std::string> png = EncodeImage(r.image, EncodeFormat::kPng16);
  ASSERT_TRUE(png.ok()) << png.status();
  absl::StatusOr<Image> decoded = DecodeImage(*png, DecodeOptions());
  ASSERT_TRUE(decoded.ok()) << decoded.status();
  EXPECT_EQ(decoded->SaturatedCount(), r.image.SaturatedCount());
  EXPECT_FLOAT_EQ(*std::max_element(decoded->pixels.begin(), decoded->pixels.end()),
                  65520.0f / 65535.0f);
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

// ---------------------------------------------------------------------------
// What lab photographs do (issue 31): each effect is present when asked for
// and absent at the defaults, which render as before.

// Light from the right at α = 60°: the lamp's terminator at φ = α − 90° = −30°,
// so columns with φ < −40° see no direct light.
RenderScene StrayScene(double stray_light) {
  RenderScene scene = NoiseFree(TinyScene());
  scene.width_px = 200;
  scene.height_px = 160;
  scene.radius_px = 80.0;
  scene.center_x_px = 99.5;
  scene.phase_angle_deg = 60.0;
  scene.wavelength_mm = 4.0;  // pitch 2 mm = 7 px
  scene.amplitude_mm = 0.15;
  scene.samples_per_pixel = 4;
  scene.stray_light = stray_light;
  return scene;
}

struct Stats {
  double mean = 0.0, variance = 0.0;
};
Stats StatsOf(const std::vector<double>& v) {
  Stats s;
  for (double x : v) s.mean += x;
  s.mean /= v.size();
  for (double x : v) s.variance += (x - s.mean) * (x - s.mean);
  s.variance /= v.size();
  return s;
}

// The shadowed side's pixels (φ from −65° to −45°), by rows and along the arc.
std::vector<double> ShadowedSide(const Rendered& r) {
  std::vector<double> out;
  for (int y = 0; y < r.image.height; ++y) {
    for (int x = 28; x <= 43; ++x) out.push_back(r.image.At(x, y));
  }
  return out;
}

TEST(RenderLabTest, StrayLightShowsTheWeaveOnTheShadowedSide) {
  const RenderScene dark = StrayScene(0.0);
  const Stats none = StatsOf(ShadowedSide(Render(dark)));
  // Default: the shadowed side is the uniform ambient level, no texture.
  EXPECT_NEAR(none.mean, dark.ambient, 1e-6);
  EXPECT_LT(none.variance, 1e-12);
  double last_mean = none.mean, last_variance = none.variance;
  for (double level : {0.02, 0.08}) {
    const Stats lit = StatsOf(ShadowedSide(Render(StrayScene(level))));
    // A stray level L adds between L·(1 − texture)/2 (a gap's bottom at the
    // limb) and L (a crest facing the camera).
    EXPECT_GT(lit.mean - dark.ambient, 0.5 * (1.0 - 0.6) * level) << level;
    EXPECT_LT(lit.mean - dark.ambient, level) << level;
    EXPECT_GT(lit.mean, last_mean) << level;
    // The texture: a standard deviation of a sizeable share of the level.
    EXPECT_GT(std::sqrt(lit.variance), 0.08 * level) << level;
    EXPECT_GT(lit.variance, last_variance) << level;
    last_mean = lit.mean;
    last_variance = lit.variance;
  }
  // Without the relief's shading only the facets' tilts (±13° here) and the
  // fall-off toward the limb remain: less variance.
  RenderScene flat = StrayScene(0.08);
  flat.stray_texture = 0.0;
  const Stats uniform = StatsOf(ShadowedSide(Render(flat)));
  EXPECT_LT(uniform.variance, 0.5 * last_variance);
}

TEST(RenderLabTest, StrayLightCanMatchTheBackground) {
  // The unlit body as bright as the background (a "dark limb"): the shadowed
  // side's mean within a few per cent of the background.
  RenderScene scene = StrayScene(0.0);
  scene.ambient = 0.0;
  scene.background = 0.02;
  scene.stray_light = 0.05;
  const Stats side = StatsOf(ShadowedSide(Render(scene)));
  EXPECT_GT(side.mean, 0.5 * scene.background);
  EXPECT_LT(side.mean, 2.0 * scene.background);
}

TEST(RenderLabTest, BackgroundGradientIsLinearAcrossTheFrame) {
  RenderScene scene = NoiseFree(TinyScene());
  scene.width_px = 200;
  scene.height_px = 100;
  scene.radius_px = 40.0;  // wide background on both sides
  for (float v : {Render(scene).image.At(0, 50), Render(scene).image.At(199, 50)}) {
    EXPECT_EQ(v, static_cast<float>(scene.background));  // default: uniform
  }
  scene.background = 0.05;
  scene.background_gradient = 0.04;  // brighter toward the right
  Rendered r = Render(scene);
  const double slope = (r.image.At(40, 50) - r.image.At(0, 50)) / 40.0;
  EXPECT_NEAR(slope, 0.04 / 200.0, 1e-6);
  EXPECT_NEAR(r.image.At(0, 10), 0.05 - 0.02 * 199.0 / 200.0, 1e-6);
  EXPECT_NEAR(r.image.At(199, 10), 0.05 + 0.02 * 199.0 / 200.0, 1e-6);
  EXPECT_NEAR(r.image.At(0, 10), r.image.At(0, 90), 1e-7);  // no change down the frame
  scene.background_gradient_deg = 90.0;  // brighter toward the bottom
  r = Render(scene);
  EXPECT_NEAR(r.image.At(5, 90) - r.image.At(5, 10), 0.04 * 80.0 / 100.0, 1e-6);
  EXPECT_NEAR(r.image.At(5, 50), r.image.At(195, 50), 1e-7);
}

TEST(RenderLabTest, BlackLevelIsAPedestalKeptInTheFile) {
  RenderScene scene = NoiseFree(TinyScene());
  const Rendered plain = Render(scene);
  scene.black_level = 0.05;
  const Rendered raised = Render(scene);
  for (std::size_t i = 0; i < plain.image.pixels.size(); ++i) {
    ASSERT_NEAR(raised.image.pixels[i] - plain.image.pixels[i], 0.05, 1e-6) << i;
  }
  // With noise, the background's mean is the level plus the pedestal.
  scene = TinyScene();
  scene.radius_px = 20.0;
  scene.black_level = 0.04;
  const Rendered noisy = Render(scene);
  double sum = 0.0;
  for (int y = 0; y < 64; ++y) sum += noisy.image.At(2, y) + noisy.image.At(93, y);
  EXPECT_NEAR(sum / 128.0, scene.background + 0.04, 0.002);
}

// A scene for the axial threads: a smooth body whose own glint lies on the
// right (α = 40°, mirror at 20°), the axial threads' lobe over the left.
RenderScene AxialScene() {
  RenderScene scene = NoiseFree(TinyScene());
  scene.model = ProfileModel::kSmooth;
  scene.width_px = 400;
  scene.height_px = 200;
  scene.radius_px = 180.0;  // 23 mm / 180 px = 0.128 mm per px
  scene.center_x_px = 199.5;
  scene.phase_angle_deg = 40.0;
  scene.wavelength_mm = 4.0;  // axial threads 2 mm = 15.7 px apart
  scene.gap_fraction = 0.3;
  scene.exposure = 0.05;
  scene.ambient = 0.0;
  scene.regular_weave = true;
  scene.samples_per_pixel = 4;
  return scene;
}

// The image along the arc, rectified: the mean over rows every 0.05 mm of
// arc (linear interpolation between columns) over 16 mm from φ = −40°.
std::vector<double> ArcProfile(const Rendered& r, const RenderScene& scene) {
  const double radius_mm = scene.diameter_mm / 2.0;
  const double s0 = radius_mm * (-40.0 * kDeg);
  std::vector<double> out;
  for (int i = 0; i < 320; ++i) {
    const double x = scene.center_x_px + scene.radius_px * std::sin((s0 + 0.05 * i) / radius_mm);
    const int x0 = static_cast<int>(std::floor(x));
    const double f = x - x0;
    double sum = 0.0;
    for (int y = 0; y < scene.height_px; ++y) {
      sum += (1.0 - f) * r.image.At(x0, y) + f * r.image.At(x0 + 1, y);
    }
    out.push_back(sum / scene.height_px);
  }
  return out;
}

// Normalised autocorrelation of a mean-subtracted profile at one lag.
double Autocorrelation(const std::vector<double>& v, int lag) {
  const Stats s = StatsOf(v);
  double acc = 0.0;
  for (std::size_t i = 0; i + lag < v.size(); ++i) acc += (v[i] - s.mean) * (v[i + lag] - s.mean);
  return acc / ((v.size() - lag) * std::max(s.variance, 1e-30));
}

TEST(RenderLabTest, AxialThreadsGlintAsLinesHalfAWavelengthApart) {
  RenderScene scene = AxialScene();
  // Default: the axial threads are a uniform lobe, no structure along the arc.
  const std::vector<double> smooth = ArcProfile(Render(scene), scene);
  const Stats smooth_stats = StatsOf(smooth);
  EXPECT_LT(std::sqrt(smooth_stats.variance), 0.15 * smooth_stats.mean);

  scene.axial_glint_width = 0.1;
  const Rendered r = Render(scene);
  const std::vector<double> lines = ArcProfile(r, scene);
  const Stats line_stats = StatsOf(lines);
  // The mean lobe is kept; it is concentrated into lines.
  EXPECT_NEAR(line_stats.mean, smooth_stats.mean, 0.05 * smooth_stats.mean);
  EXPECT_GT(std::sqrt(line_stats.variance), 0.8 * line_stats.mean);
  // The strongest repeat along the arc: λ/2 = 2 mm = 40 bins.
  int best = 0;
  double best_value = -1.0;
  for (int lag = 20; lag <= 60; ++lag) {
    const double a = Autocorrelation(lines, lag);
    if (a > best_value) best_value = a, best = lag;
  }
  EXPECT_NEAR(best * 0.05, 2.0, 0.1);
  EXPECT_GT(best_value, 0.5);

  // Broken where the circumferential threads cross over them: along the
  // brightest column (a line) it is lit only in the gaps (30 % of the rows).
  auto lit_share = [&](const Rendered& image) {
    int column = 0;
    double column_best = -1.0;
    for (int x = 80; x < 200; ++x) {
      double sum = 0.0;
      for (int y = 0; y < scene.height_px; ++y) sum += image.image.At(x, y);
      if (sum > column_best) column_best = sum, column = x;
    }
    float peak = 0.0f;
    for (int y = 0; y < scene.height_px; ++y) peak = std::max(peak, image.image.At(column, y));
    int lit = 0;
    for (int y = 0; y < scene.height_px; ++y) lit += image.image.At(column, y) > 0.3f * peak;
    return static_cast<double>(lit) / scene.height_px;
  };
  const double gaps_only = lit_share(r);
  EXPECT_NEAR(gaps_only, scene.gap_fraction, 0.12);
  // A plain weave's floats: each axial thread also runs over every other
  // circumferential thread, so its lines grow longer, still broken.
  scene.axial_float_width = 0.3;
  const double with_floats = lit_share(Render(scene));
  EXPECT_GT(with_floats, gaps_only + 0.15);
  EXPECT_LT(with_floats, 0.9);
}

// One row of a noise-free sinusoid of flat ribbons without gaps, nothing
// but its glints, lit at `alpha_deg`: R = 1000 px for 23 mm, λ = 2.35 mm
// (102 px), m = 0.48, so h0 = 0.18 mm = 7.8 px.
constexpr double kParallaxRadiusPx = 1000.0;
constexpr double kParallaxCentrePx = 1049.5;
std::vector<double> GlintRow(double alpha_deg, bool parallax) {
  RenderScene scene = NoiseFree(TinyScene());
  scene.width_px = 2100;
  scene.height_px = 16;
  scene.radius_px = kParallaxRadiusPx;
  scene.center_x_px = kParallaxCentrePx;
  scene.wavelength_mm = 2.35;
  scene.amplitude_mm = 0.18;
  scene.phase_angle_deg = alpha_deg;
  scene.source_blur_deg = 0.3;
  scene.gap_fraction = 0.0;
  scene.crest_tilt_deg = 0.0;
  scene.axial_reflectance = 0.0;
  scene.ambient = 0.0;
  scene.background = 0.0;
  scene.exposure = 0.02;
  scene.regular_weave = true;
  scene.phase_step = 0.0;       // every thread in step: the lens blur mixes rows
  scene.samples_per_pixel = 4;  // 16 along the arc: a glint over several samples
  scene.optics_blur_px = 1.0;   // each glint over a few pixels
  scene.relief_parallax = parallax;
  const Rendered r = Render(scene);
  std::vector<double> row(scene.width_px);
  for (int x = 0; x < scene.width_px; ++x) row[x] = r.image.At(x, 8);
  return row;
}

// The glints in `row` (px): its local maxima above a fiftieth of its peak,
// each refined by the parabola through it and its neighbours.
std::vector<double> GlintCentroids(const std::vector<double>& row) {
  const double peak = *std::max_element(row.begin(), row.end());
  std::vector<double> out;
  for (std::size_t x = 1; x + 1 < row.size(); ++x) {
    const double l = row[x - 1], c = row[x], r = row[x + 1];
    if (c > 0.02 * peak && c > l && c >= r) {
      out.push_back(static_cast<double>(x) + 0.5 * (l - r) / (l - 2.0 * c + r));
    }
  }
  return out;
}

// A glint stands where its facet lies, z off the mean cylinder, and is
// seen z·sin φ from where the mean cylinder's point at φ is (orthographic).
// A facet tilted by β* = φ − α/2 mirrors where m·cos θ = tan β*, at height
// z = ±h0·sin θ: each glint moves by that much, up to 5.9 px here, within
// 0.6 px (the renderer's samples along the arc, a sixteenth of a pixel
// each, and the parabola's bias) and 15 %, clear of the caustics. Glints nearer their neighbour
// than the moves could be told apart by are left out. The light is kept.
TEST(RenderLabTest, ReliefParallaxMovesEachGlintByItsHeight) {
  const double m = 2.0 * M_PI * 0.18 / 2.35;
  const double h0_px = 0.18 / (23.0 / kParallaxRadiusPx);
  for (double alpha : {20.0, 90.0}) {
    const std::vector<double> plain_row = GlintRow(alpha, false);
    const std::vector<double> moved_row = GlintRow(alpha, true);
    const std::vector<double> plain = GlintCentroids(plain_row);
    const std::vector<double> moved = GlintCentroids(moved_row);
    int checked = 0;
    for (double x : plain) {
      const double phi = std::asin((x - kParallaxCentrePx) / kParallaxRadiusPx);
      const double tilt = std::tan(phi - 0.5 * alpha * kDeg) / m;
      // At a caustic a glint also slides along its thread as the azimuth
      // it is met at changes the tilt that mirrors there.
      if (std::fabs(tilt) > 0.9) continue;
      const double expected = h0_px * std::sqrt(1.0 - tilt * tilt) * std::fabs(std::sin(phi));
      double neighbour = 1e9;
      for (double y : plain) {
        if (y != x) neighbour = std::min(neighbour, std::fabs(y - x));
      }
      if (neighbour < 2.5 * expected + 2.0) continue;
      double nearest = 1e9;
      for (double y : moved) nearest = std::min(nearest, std::fabs(y - x));
      EXPECT_NEAR(nearest, expected, 0.6 + 0.15 * expected) << "alpha " << alpha << " at " << x;
      ++checked;
    }
    EXPECT_GT(checked, 10) << alpha;
    double a = 0.0, b = 0.0;
    for (std::size_t x = 0; x < plain_row.size(); ++x) a += plain_row[x], b += moved_row[x];
    EXPECT_NEAR(b / a, 1.0, 0.03) << alpha;
  }
}

TEST(RenderLabTest, MountHalfWidth) {
  RenderScene scene = NoiseFree(TinyScene());
  scene.top_row_px = 10;
  scene.mount_level = 0.2;
  // Radius 38.4 px about column 47.5: 0.6 radii reach columns 25-70.
  EXPECT_FLOAT_EQ(Render(scene).image.At(20, 3), static_cast<float>(scene.background));
  EXPECT_FLOAT_EQ(Render(scene).image.At(47, 3), 0.2f);
  scene.mount_half_width = 1.2;
  EXPECT_FLOAT_EQ(Render(scene).image.At(20, 3), 0.2f);
  EXPECT_FLOAT_EQ(Render(scene).image.At(0, 3), static_cast<float>(scene.background));
}

TEST(RenderLabTest, SidecarCarriesTheLabConditionsOnlyWhenSet) {
  RenderScene scene = TinyScene();
  const Rendered r = Render(scene);
  const std::string plain = TruthJson(scene, r.truth, "a.png");
  for (const char* key : {"strayLight", "strayTexture", "axialGlintWidth", "axialFloatWidth",
                          "backgroundGradient", "blackLevel", "mountHalfWidth"}) {
    EXPECT_EQ(plain.find(key), std::string::npos) << key;
  }
  scene.stray_light = 0.03;
  scene.axial_glint_width = 0.2;
  scene.background_gradient = -0.01;
  scene.black_level = 0.02;
  const std::string lab = TruthJson(scene, r.truth, "a.png");
  for (const char* key : {"\"strayLight\": 0.03", "\"strayTexture\": 0.6",
                          "\"axialGlintWidth\": 0.2", "\"backgroundGradient\": -0.01",
                          "\"blackLevel\": 0.02"}) {
    EXPECT_NE(lab.find(key), std::string::npos) << key;
  }
  EXPECT_EQ(lab.find("axialFloatWidth"), std::string::npos);
}

TEST(RenderLabTest, ValidateNamesTheLabFields) {
  auto message = [](const RenderScene& scene) {
    return std::string(RenderPhotograph(scene).status().message());
  };
  RenderScene scene = TinyScene();
  scene.stray_light = -0.1;
  EXPECT_NE(message(scene).find("stray_light"), std::string::npos);
  scene = TinyScene();
  scene.stray_texture = 1.5;
  EXPECT_NE(message(scene).find("stray_texture"), std::string::npos);
  scene = TinyScene();
  scene.axial_float_width = 1.0;
  EXPECT_NE(message(scene).find("axial_float_width"), std::string::npos);
  scene = TinyScene();
  scene.black_level = -0.01;
  EXPECT_NE(message(scene).find("black_level"), std::string::npos);
  scene = TinyScene();
  scene.mount_half_width = 0.0;
  EXPECT_NE(message(scene).find("mount_half_width"), std::string::npos);
  scene = TinyScene();
  scene.white_level = 1.5;
  EXPECT_NE(message(scene).find("white_level"), std::string::npos);
}

}  // namespace
}  // namespace weavefit
