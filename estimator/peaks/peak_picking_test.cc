// Unit tests of peaks/peak_picking: on profiles of rendered photographs with
// known truth (render → Luminance → DetectCylinder → ExtractProfile →
// PickPeaks) and on analytic profiles built from optics/radiance.
#include "estimator/peaks/peak_picking.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

#include "absl/status/status.h"
#include "estimator/cylinder/cylinder_detection.h"
#include "estimator/io/image.h"
#include "estimator/optics/radiance.h"
#include "estimator/profile/profile_extraction.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// 400×300 at 2×8 samples per pixel (≈ 0.2 s), phase 10°, m = 0.24 unless
// changed; λ = 1 mm gives ~7 px per period and ~85 threads in view.
RenderScene Scene(ProfileModel model, double max_slope, std::uint32_t seed) {
  RenderScene scene;
  scene.width_px = 400;
  scene.height_px = 300;
  scene.samples_per_pixel = 2;
  scene.model = model;
  scene.wavelength_mm = 1.0;
  scene.amplitude_mm = model == ProfileModel::kSawtooth
                           ? max_slope * scene.wavelength_mm / 4.0
                           : max_slope * scene.wavelength_mm / (2.0 * M_PI);
  scene.phase_angle_deg = 10.0;
  scene.seed = seed;
  return scene;
}

Projection SceneProjection(const RenderScene& scene) {
  return Projection{scene.diameter_mm / 2.0, scene.camera_distance_mm};
}

struct Analysis {
  RenderTruth truth;
  Profile profile;
  PeakPickingResult peaks;
};

// The chain up to the profile (render, detect, extract); fails the test on
// any error and returns false then.
bool RenderProfile(const RenderScene& scene, Analysis* out) {
  absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
  EXPECT_TRUE(rendered.ok()) << rendered.status();
  if (!rendered.ok()) return false;
  out->truth = rendered->truth;
  const Image luminance = Luminance(rendered->image);
  absl::StatusOr<CylinderGeometry> geometry =
      DetectCylinder(luminance, CylinderDetectionOptions());
  EXPECT_TRUE(geometry.ok()) << geometry.status();
  if (!geometry.ok()) return false;
  absl::StatusOr<Profile> profile =
      ExtractProfile(luminance, *geometry, SceneProjection(scene), ProfileOptions());
  EXPECT_TRUE(profile.ok()) << profile.status();
  if (!profile.ok()) return false;
  out->profile = *profile;
  return true;
}

// The whole chain up to the peaks; fails the test on any error.
Analysis Analyse(const RenderScene& scene,
                 const PeakPickingOptions& options = PeakPickingOptions()) {
  Analysis out;
  if (!RenderProfile(scene, &out)) return out;
  absl::StatusOr<PeakPickingResult> peaks =
      PickPeaks(out.profile, scene.phase_angle_deg * kDeg, SceneProjection(scene), options);
  EXPECT_TRUE(peaks.ok()) << peaks.status();
  if (peaks.ok()) out.peaks = *peaks;
  return out;
}

void ExpectSplit(const Analysis& a, double tolerance_deg) {
  const PeakPickingResult& p = a.peaks;
  EXPECT_TRUE(p.split_resolved);
  EXPECT_NEAR(p.spacing_rad / kDeg, a.truth.peak_spacing_deg, tolerance_deg);
  EXPECT_NEAR(p.max_slope, std::tan(0.5 * p.spacing_rad), 1e-12);
  EXPECT_LT(p.left_peak_rad, p.right_peak_rad);
  EXPECT_NEAR(p.mirror_rad, 0.5 * (p.left_peak_rad + p.right_peak_rad), 1e-12);
  EXPECT_NEAR(p.mirror_rad / kDeg, a.truth.mirror_azimuth_deg, 0.5);
  // Standard errors from the row-block bootstrap (and the comb and bin
  // granularity): positive, below a degree, and consistent with the
  // max-slope error through m = tan(spacing/2).
  EXPECT_GT(p.spacing_stderr_rad, 0.0);
  EXPECT_LT(p.spacing_stderr_rad / kDeg, 1.0);
  EXPECT_GT(p.mirror_stderr_rad, 0.0);
  EXPECT_LT(p.mirror_stderr_rad / kDeg, 1.0);
  const double sec = 1.0 / std::cos(0.5 * p.spacing_rad);
  EXPECT_NEAR(p.max_slope_stderr, 0.5 * sec * sec * p.spacing_stderr_rad, 1e-12);
  EXPECT_GT(p.dip_sigmas, 5.0);
}

TEST(PeakPickingTest, SinusoidSplitAtPhaseTen) {
  const Analysis a = Analyse(Scene(ProfileModel::kSinusoid, 0.24, 3));
  ASSERT_NEAR(a.truth.peak_spacing_deg, 2.0 * std::atan(0.24) / kDeg, 1e-9);  // 26.99°
  EXPECT_EQ(a.peaks.model, ProfileModel::kSinusoid) << ProfileModelName(a.peaks.model);
  ExpectSplit(a, 1.0);
  // Peak picking is biased low (blur pulls the caustics inward), never high
  // by more than the granularity of the comb.
  EXPECT_LT(a.peaks.spacing_rad / kDeg, a.truth.peak_spacing_deg + 0.5);
}

TEST(PeakPickingTest, SinusoidOtherWeaveAndLightOnTheLeft) {
  RenderScene scene = Scene(ProfileModel::kSinusoid, 0.24, 2);
  scene.phase_angle_deg = -20.0;
  const Analysis a = Analyse(scene);
  EXPECT_EQ(a.peaks.model, ProfileModel::kSinusoid) << ProfileModelName(a.peaks.model);
  ExpectSplit(a, 1.0);
  EXPECT_LT(a.peaks.mirror_rad, 0.0);
}

TEST(PeakPickingTest, SawtoothSplit) {
  // The paper's coarse gauze read as a sawtooth: m = 0.15, 17.06°.
  const Analysis a = Analyse(Scene(ProfileModel::kSawtooth, 0.15, 1));
  ASSERT_NEAR(a.truth.peak_spacing_deg, 17.0615, 1e-3);
  EXPECT_EQ(a.peaks.model, ProfileModel::kSawtooth) << ProfileModelName(a.peaks.model);
  ExpectSplit(a, 1.0);
  // Nothing mirrors between the two facet tilts.
  EXPECT_LT(a.peaks.valley_ratio, 0.1);
}

TEST(PeakPickingTest, SmoothSceneHasASinglePeak) {
  const Analysis a = Analyse(Scene(ProfileModel::kSmooth, 0.0, 1));
  const PeakPickingResult& p = a.peaks;
  EXPECT_EQ(p.model, ProfileModel::kSmooth) << ProfileModelName(p.model);
  EXPECT_FALSE(p.split_resolved);
  EXPECT_EQ(p.spacing_rad, 0.0);
  EXPECT_EQ(p.dip_sigmas, 0.0);
  EXPECT_EQ(p.left_peak_rad, p.right_peak_rad);
  EXPECT_EQ(p.mirror_rad, p.left_peak_rad);
  // The mirror point α/2 = 5°; the brightest column sits a little toward the
  // nearer limb (DESIGN.md §3).
  EXPECT_NEAR(p.mirror_rad / kDeg, 5.0, 0.25);
  EXPECT_GT(p.mirror_stderr_rad, 0.0);
  EXPECT_LT(p.mirror_stderr_rad / kDeg, 0.5);
  // The lobe is the source blur (σ_β = 0.3°, FWHM 0.71°) plus smoothing.
  EXPECT_GT(p.single_peak_fwhm_rad / kDeg, 0.5);
  EXPECT_LT(p.single_peak_fwhm_rad / kDeg, 2.5);
  ASSERT_FALSE(p.warnings.empty());
  EXPECT_NE(p.warnings.back().find("not resolved"), std::string::npos);
}

TEST(PeakPickingTest, BootstrapIsSeededAndCanBeTurnedOff) {
  // One render, three pickings of its profile.
  const RenderScene scene = Scene(ProfileModel::kSawtooth, 0.15, 1);
  const Analysis a = Analyse(scene);
  const Projection projection;
  PeakPickingOptions options;
  absl::StatusOr<PeakPickingResult> again =
      PickPeaks(a.profile, scene.phase_angle_deg * kDeg, projection, options);
  ASSERT_TRUE(again.ok()) << again.status();
  EXPECT_EQ(again->spacing_rad, a.peaks.spacing_rad);
  EXPECT_EQ(again->spacing_stderr_rad, a.peaks.spacing_stderr_rad);

  options.bootstrap_samples = 0;
  absl::StatusOr<PeakPickingResult> plain =
      PickPeaks(a.profile, scene.phase_angle_deg * kDeg, projection, options);
  ASSERT_TRUE(plain.ok()) << plain.status();
  // Same peaks; the error is then the position quantisation (no comb on a
  // sawtooth): per peak the wider of a bin and a pixel's footprint in
  // azimuth, 1/(radius·cos φ), as a uniform error; and the sawtooth's shape
  // allowance, 1 % of the spacing, common to the sample.
  EXPECT_EQ(plain->spacing_rad, a.peaks.spacing_rad);
  const double bin = a.profile.bin_width_rad;
  auto q = [&](double phi) {
    return std::max(bin, 1.0 / (a.profile.radius_px * std::cos(phi))) / std::sqrt(12.0);
  };
  const double shape = 0.01 * plain->spacing_rad;
  EXPECT_NEAR(plain->spacing_stderr_rad,
              std::hypot(q(plain->left_peak_rad), q(plain->right_peak_rad), shape), 1e-12);
  EXPECT_NEAR(plain->spacing_common_rad, shape, 1e-12);
  EXPECT_GE(a.peaks.spacing_stderr_rad, plain->spacing_stderr_rad);
}

// A sawtooth at −115° under a strong diffuse dome (random scene 4047:
// m = 0.60, diffuse 0.19): its inner caustic stands 1° inside the
// terminator and its outer beyond the limb. The window searched runs into
// both; cut to where the grazing scatter keeps its law, it held only the
// dome's flank, read as one peak: SMOOTH. One peak in the cut window is no
// evidence of a smooth lobe, so the photograph is refused.
TEST(PeakPickingTest, OnePeakInTheCutWindowIsRefusedNotSmooth) {
  RenderScene scene = Scene(ProfileModel::kSawtooth, 0.6046, 4047);
  scene.wavelength_mm = 3.1427;
  scene.amplitude_mm = 0.47498;
  scene.phase_angle_deg = -114.93;
  scene.diffuse = 0.187;
  scene.source_blur_deg = 0.34;
  scene.exposure = 0.0075;
  Analysis a;
  ASSERT_TRUE(RenderProfile(scene, &a));
  absl::StatusOr<PeakPickingResult> p = PickPeaks(a.profile, scene.phase_angle_deg * kDeg,
                                                  SceneProjection(scene), PeakPickingOptions());
  if (p.ok()) {
    EXPECT_NE(p->model, ProfileModel::kSmooth);
  } else {
    EXPECT_NE(p.status().message().find("not isolated"), std::string::npos) << p.status();
  }
}

// A profile of num_blocks identical row blocks holding the analytic
// radiance (no comb, no noise) plus `extra`(φ) on bins of width bin_deg.
Profile AnalyticProfile(const RadianceParams<double>& params, double bin_deg,
                        const std::function<double(double)>& extra = nullptr) {
  Profile p;
  const double bin = bin_deg * kDeg;
  const int half = static_cast<int>(std::floor(86.0 / bin_deg + 1e-9));
  p.bin_width_rad = bin;
  p.num_blocks = 8;
  p.background = 0.01;
  p.background_noise = 0.002;
  const double per_block = 50.0;  // pixels per bin and block
  for (int i = 0; i < 2 * half; ++i) {
    const double phi = (i - half + 0.5) * bin;
    const double value = Radiance(params, phi) + p.background + (extra ? extra(phi) : 0.0);
    p.azimuth_rad.push_back(phi);
    p.mean.push_back(value);
    p.stderr_mean.push_back(p.background_noise / std::sqrt(per_block * p.num_blocks));
    p.count.push_back(per_block * p.num_blocks);
    p.saturated.push_back(0.0);
  }
  const int n = p.NumBins();
  p.block_sum.resize(static_cast<std::size_t>(n) * p.num_blocks);
  p.block_count.resize(p.block_sum.size());
  for (int b = 0; b < p.num_blocks; ++b) {
    for (int i = 0; i < n; ++i) {
      p.block_sum[static_cast<std::size_t>(b) * n + i] = per_block * p.mean[i];
      p.block_count[static_cast<std::size_t>(b) * n + i] = per_block;
    }
  }
  return p;
}

// The analytic radiance's highest value over ±80°, sampled every 0.05°.
double HighestRadiance(const RadianceParams<double>& params) {
  double top = 0.0;
  for (double phi = -80.0 * kDeg; phi < 80.0 * kDeg; phi += 0.05 * kDeg) {
    top = std::max(top, Radiance(params, phi));
  }
  return top;
}

TEST(PeakPickingTest, AnalyticSinusoidProfile) {
  // L(φ) of optics/radiance for m = 0.24 at α = 10°, blur σ = 0.2°: the
  // caustic maxima sit 0.77σ inside ±arctan m, and the light smoothing pulls
  // them a little further; the lobe's outer half-maximum points say by how
  // much, and peak picking undoes it.
  RadianceParams<double> params;
  params.model = ProfileModel::kSinusoid;
  params.max_slope = 0.24;
  params.mirror_rad = 5.0 * kDeg;
  params.blur_rad = 0.2 * kDeg;
  params.scale = 0.01;
  params.phase_angle_rad = 10.0 * kDeg;
  const Profile profile = AnalyticProfile(params, 0.25);
  absl::StatusOr<PeakPickingResult> p =
      PickPeaks(profile, 10.0 * kDeg, Projection(), PeakPickingOptions());
  ASSERT_TRUE(p.ok()) << p.status();
  const double truth = 2.0 * std::atan(0.24) / kDeg;
  EXPECT_TRUE(p->split_resolved);
  EXPECT_EQ(p->model, ProfileModel::kSinusoid);
  EXPECT_NEAR(p->spacing_rad / kDeg, truth, 0.1);
  EXPECT_LE(std::fabs(p->spacing_rad / kDeg - truth), 3.0 * p->spacing_stderr_rad / kDeg);
  EXPECT_NEAR(p->mirror_rad / kDeg, 5.0, 0.1);
}

// A small split under a wide blur (m = 0.05, σ = 0.5° in tilt): the maxima
// are pulled in by a fifth of the spacing; the correction brings it back.
TEST(PeakPickingTest, BlurPullOnASmallSinusoidSplitIsUndone) {
  RadianceParams<double> params;
  params.model = ProfileModel::kSinusoid;
  params.max_slope = 0.05;
  params.mirror_rad = 10.0 * kDeg;
  params.blur_rad = 0.5 * kDeg;
  params.scale = 0.01;
  params.phase_angle_rad = 20.0 * kDeg;
  const Profile profile = AnalyticProfile(params, 0.25);
  absl::StatusOr<PeakPickingResult> p =
      PickPeaks(profile, 20.0 * kDeg, Projection(), PeakPickingOptions());
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->split_resolved);
  EXPECT_EQ(p->model, ProfileModel::kSinusoid);
  EXPECT_NEAR(p->max_slope, 0.05, 0.003);
}

TEST(PeakPickingTest, AnalyticSawtoothAndSmoothProfiles) {
  RadianceParams<double> params;
  params.model = ProfileModel::kSawtooth;
  params.max_slope = 0.15;
  params.mirror_rad = -8.0 * kDeg;
  params.blur_rad = 0.3 * kDeg;
  params.scale = 0.01;
  params.phase_angle_rad = -16.0 * kDeg;
  absl::StatusOr<PeakPickingResult> saw = PickPeaks(
      AnalyticProfile(params, 0.25), -16.0 * kDeg, Projection(), PeakPickingOptions());
  ASSERT_TRUE(saw.ok()) << saw.status();
  EXPECT_EQ(saw->model, ProfileModel::kSawtooth);
  // Two separate Gaussians: peak picking is unbiased up to the bins.
  EXPECT_NEAR(saw->spacing_rad / kDeg, 2.0 * std::atan(0.15) / kDeg, 0.1);
  EXPECT_NEAR(saw->mirror_rad / kDeg, -8.0, 0.05);

  params.model = ProfileModel::kSmooth;
  absl::StatusOr<PeakPickingResult> smooth = PickPeaks(
      AnalyticProfile(params, 0.25), -16.0 * kDeg, Projection(), PeakPickingOptions());
  ASSERT_TRUE(smooth.ok()) << smooth.status();
  EXPECT_EQ(smooth->model, ProfileModel::kSmooth);
  EXPECT_FALSE(smooth->split_resolved);
  EXPECT_NEAR(smooth->mirror_rad / kDeg, -8.0, 0.1);
}

// A smooth lobe (σ = 2° in tilt, peak at 0.01 above the background) clipped
// at 0.6 of its height: the bins above the clip level hold clipped pixels
// only. They are read at the clip level, not interpolated from the flanks
// (which left no peak to find), and the plateau's middle is the mirror.
TEST(PeakPickingTest, AFullyClippedSmoothLobeIsReadAtItsPlateau) {
  RadianceParams<double> params;
  params.model = ProfileModel::kSmooth;
  params.mirror_rad = -8.0 * kDeg;
  params.blur_rad = 2.0 * kDeg;
  params.scale = 0.01;
  params.phase_angle_rad = -16.0 * kDeg;
  Profile profile = AnalyticProfile(params, 0.25);
  double top = 0.0;
  for (double v : profile.mean) top = std::max(top, v - profile.background);
  const double clip = profile.background + 0.6 * top;
  profile.saturated_sum.assign(profile.NumBins(), 0.0);
  const int n = profile.NumBins();
  int full = 0;
  for (int i = 0; i < n; ++i) {
    if (profile.mean[i] < clip) continue;
    profile.saturated[i] = profile.count[i];
    profile.saturated_sum[i] = profile.count[i] * clip;
    profile.count[i] = 0.0;
    profile.mean[i] = 0.0;
    for (int b = 0; b < profile.num_blocks; ++b) {
      profile.block_sum[static_cast<std::size_t>(b) * n + i] = 0.0;
      profile.block_count[static_cast<std::size_t>(b) * n + i] = 0.0;
    }
    ++full;
  }
  ASSERT_GE(full, 8);
  absl::StatusOr<PeakPickingResult> p =
      PickPeaks(profile, -16.0 * kDeg, Projection(), PeakPickingOptions());
  ASSERT_TRUE(p.ok()) << p.status();
  EXPECT_EQ(p->model, ProfileModel::kSmooth);
  EXPECT_NEAR(p->mirror_rad / kDeg, -8.0, 0.2);
}

// Threads along the axis that glint in thin lines λ/2 apart over the whole
// lit arc (as independently rendered photographs show them) stand between a
// sawtooth's caustics as a comb of teeth, just as they stand outside them.
// The teeth alone made it a sinusoid (12 such sawtooths of 12, spacings up
// to 4.6 deg long); smoothed over the comb, the level between the peaks is the
// chord's, a sawtooth's. A sinusoid under the same lines stays a sinusoid.
TEST(PeakPickingTest, AxialGlintLinesBetweenTheCausticsDoNotMakeASinusoid) {
  for (ProfileModel model : {ProfileModel::kSawtooth, ProfileModel::kSinusoid}) {
    RadianceParams<double> params;
    params.model = model;
    params.max_slope = 0.3;
    params.mirror_rad = 20.0 * kDeg;
    params.blur_rad = 0.3 * kDeg;
    params.scale = 0.01;
    params.phase_angle_rad = 40.0 * kDeg;
    const double top = HighestRadiance(params);
    // Lines 3.5° apart, σ 0.3°, a quarter of the lobe's highest, over the
    // lit arc (φ > α − 90°).
    auto lines = [&](double phi) {
      if (phi < params.phase_angle_rad - M_PI / 2.0) return 0.0;
      const double spacing = 3.5 * kDeg;
      const double d = std::remainder(phi - 0.7 * kDeg, spacing);
      return 0.25 * top * std::exp(-0.5 * std::pow(d / (0.3 * kDeg), 2));
    };
    absl::StatusOr<PeakPickingResult> p =
        PickPeaks(AnalyticProfile(params, 0.25, lines), params.phase_angle_rad, Projection(),
                  PeakPickingOptions());
    ASSERT_TRUE(p.ok()) << p.status();
    ASSERT_TRUE(p->split_resolved);
    EXPECT_EQ(p->model, model);
    const double truth = 2.0 * std::atan(0.3) / kDeg;
    EXPECT_NEAR(p->spacing_rad / kDeg, truth, 1.0) << static_cast<int>(model);
    EXPECT_LE(std::fabs(p->spacing_rad / kDeg - truth), 3.0 * p->spacing_stderr_rad / kDeg);
  }
}

// The paper's gauze at a 110° phase angle under a strong grazing scatter:
// cos(α/2)/cos φ over the lit arc (DESIGN.md §3), softened within a few
// degrees of the terminator and of the limb, where the threads shadow and
// mask each other. The window searched around α/2 runs from beyond the
// terminator (20°) to the limb; its ends, an unlit level and a masked one,
// drew a baseline that left the lobe running into them ("not isolated"),
// whatever the shape drawn through them. The ends are now taken where the
// scatter follows its law.
TEST(PeakPickingTest, AStrongGrazingScatterAtOneHundredTenDegreesLeavesTheLobeIsolated) {
  RadianceParams<double> params;
  params.model = ProfileModel::kSinusoid;
  params.max_slope = 0.2356;
  params.mirror_rad = 55.0 * kDeg;
  params.blur_rad = 0.5 * kDeg;
  params.scale = 0.01;
  params.phase_angle_rad = 110.0 * kDeg;
  const double at_mirror = Radiance(params, params.mirror_rad);
  auto scatter = [&](double phi) {
    const double lit = std::cos(phi - params.phase_angle_rad);
    if (lit <= 0.0) return 0.0;
    const double soft = std::min(1.0, lit / 0.12) * std::min(1.0, std::cos(phi) / 0.12);
    return 1.5 * at_mirror * std::cos(params.mirror_rad) / std::cos(phi) * soft;
  };
  absl::StatusOr<PeakPickingResult> p =
      PickPeaks(AnalyticProfile(params, 0.25, scatter), params.phase_angle_rad, Projection(),
                PeakPickingOptions());
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->split_resolved);
  EXPECT_EQ(p->model, ProfileModel::kSinusoid);
  const double truth = 2.0 * std::atan(0.2356) / kDeg;
  EXPECT_NEAR(p->spacing_rad / kDeg, truth, 1.0);
  EXPECT_LE(std::fabs(p->spacing_rad / kDeg - truth), 3.0 * p->spacing_stderr_rad / kDeg);
}

// On a small cylinder the limb's own light, spread by the pixel and the
// lens, covers the last degrees of azimuth: on a radius of 227 px a glow of
// σ = 1.5 px from the limb reaches 79 deg, where the search window around
// α/2 ends at α = 79°. No baseline through that end isolated the lobe
// ("not isolated", as on the shared photographs at half their size); the
// window trimmed to the scatter's lawful range, clear of the limb's edge
// (kLimbEdgePx), does.
TEST(PeakPickingTest, TheLimbsGlowOnASmallCylinderLeavesTheLobeIsolated) {
  RadianceParams<double> params;
  params.model = ProfileModel::kSinusoid;
  params.max_slope = 0.394;
  params.mirror_rad = 39.5 * kDeg;
  params.blur_rad = 0.3 * kDeg;
  params.scale = 0.01;
  params.phase_angle_rad = 79.0 * kDeg;
  const double radius_px = 227.0;
  const double at_mirror = Radiance(params, params.mirror_rad);
  auto extra = [&](double phi) {
    const double lit = std::cos(phi - params.phase_angle_rad);
    const double scatter =
        lit <= 0.0 ? 0.0 : 0.5 * at_mirror * lit / std::max(std::cos(phi), 0.05);
    const double from_limb_px = radius_px * (1.0 - std::fabs(std::sin(phi)));
    const double glow =
        phi > 0.0 ? 10.0 * at_mirror * std::exp(-0.5 * std::pow(from_limb_px / 1.5, 2)) : 0.0;
    return scatter + glow;
  };
  Profile profile = AnalyticProfile(params, 0.25, extra);
  profile.radius_px = radius_px;
  absl::StatusOr<PeakPickingResult> p =
      PickPeaks(profile, params.phase_angle_rad, Projection(), PeakPickingOptions());
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->split_resolved);
  EXPECT_EQ(p->model, ProfileModel::kSinusoid);
  const double truth = 2.0 * std::atan(0.394) / kDeg;
  EXPECT_NEAR(p->spacing_rad / kDeg, truth, 1.0);
}

// A sawtooth's two narrow caustic peaks on a strong diffuse dome seen
// through vignetting: the Lambertian term, brightest at α, is darkened
// toward the image's edges, so the dome peaks nearer the image's centre
// (random scene 5109: −34° for α = −40.7°, 8-bit, diffuse 0.08, vignetting
// 0.26). Neither a straight chord nor a + b·cos(φ − α) follows it between
// the peaks 54° apart; the dome filled the empty valley and the sawtooth
// was called a sinusoid. The chord may now be a dome of free centre.
TEST(PeakPickingTest, ASawtoothOnAVignettedDiffuseDomeStaysASawtooth) {
  RadianceParams<double> params;
  params.model = ProfileModel::kSawtooth;
  params.max_slope = 0.507;
  params.mirror_rad = -20.33 * kDeg;
  params.blur_rad = 0.3 * kDeg;
  params.scale = 0.002;
  params.phase_angle_rad = -40.67 * kDeg;
  const double top = HighestRadiance(params);
  // Lambertian, then the renderer's vignetting, 1 − v·r²/r²(corner) with
  // v = 0.26, averaged over the rows: for scene 5109's 414 px radius in a
  // 1024×768 frame, 0.97 − 0.11·(sin φ − 0.075)².
  auto dome = [&](double phi) {
    const double lit = std::max(0.0, std::cos(phi - params.phase_angle_rad));
    const double x = std::sin(phi) - 0.075;
    return 2.5 * top * lit * (0.97 - 0.11 * x * x);
  };
  absl::StatusOr<PeakPickingResult> p =
      PickPeaks(AnalyticProfile(params, 0.25, dome), params.phase_angle_rad, Projection(),
                PeakPickingOptions());
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->split_resolved);
  EXPECT_EQ(p->model, ProfileModel::kSawtooth) << p->valley_ratio << " " << p->caustic_asymmetry;
  EXPECT_NEAR(p->spacing_rad / kDeg, 2.0 * std::atan(0.507) / kDeg, 0.5);
}

// Stray light from the camera's side on the whole body is a dome about the
// line of sight, ∝ 1 + cos φ: under a steep sawtooth at −48.7° its centre
// lies just beyond the inner caustic's outside point. A chord refused for
// that (straight, or Lambertian at α) lies low under the dome between the
// peaks, which filled the sawtooth's empty valley as a sinusoid's glints
// would (lab scenes: the valley 0.59 of the way to a sinusoid's).
TEST(PeakPickingTest, ASawtoothUnderStrayLightsDomeStaysASawtooth) {
  RadianceParams<double> params;
  params.model = ProfileModel::kSawtooth;
  params.max_slope = 0.388;
  params.mirror_rad = -24.33 * kDeg;
  params.blur_rad = 0.5 * kDeg;
  params.scale = 0.002;
  params.phase_angle_rad = -48.65 * kDeg;
  const double top = HighestRadiance(params);
  // The dome rises to the caustics' height at the line of sight.
  auto stray = [&](double phi) { return 0.5 * top * (1.0 + std::cos(phi)); };
  absl::StatusOr<PeakPickingResult> p =
      PickPeaks(AnalyticProfile(params, 0.25, stray), params.phase_angle_rad, Projection(),
                PeakPickingOptions());
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->split_resolved);
  EXPECT_EQ(p->model, ProfileModel::kSawtooth) << p->valley_ratio << " " << p->caustic_asymmetry;
  EXPECT_NEAR(p->spacing_rad / kDeg, 2.0 * std::atan(0.388) / kDeg, 0.5);
}

// The weave's relief under a diffuse light ripples the whole lit body's
// profile with the thread period; on a large photograph those ripples
// stand far out of the pixel noise. On a diffuse dome three times a glint's
// height they rise above the window's baseline as a comb's teeth do, and
// the outermost of them, beyond the caustics, were read as the split: 45°
// for 26.9° (lab scenes rendered at 2.5 times their size: twice the
// spacing). The texture measured beside the lobe tells its ripples from
// the lobe's glints.
TEST(PeakPickingTest, TheWeavesTextureOnADiffuseDomeIsNotTheSplit) {
  // A comb of glints: a sinusoid's (m = 0.239, λ = 4.24 mm on R = 23 mm)
  // glints from four weave phases, each a Gaussian of the source's width
  // in the mirror miss.
  const double m = 0.239;
  const double mirror = -40.0 * kDeg;
  const double sigma = 0.4 * kDeg;
  const double k = 2.0 * M_PI / 4.24;
  const double radius_mm = 23.0;
  auto glints = [&](double phi) {
    double sum = 0.0;
    for (double c : {0.0, 2.12, 0.7, 2.82}) {
      const double miss = (phi - mirror) - std::atan(m * std::cos(k * (radius_mm * phi + c)));
      sum += std::exp(-0.5 * miss * miss / (sigma * sigma));
    }
    return sum / std::max(std::cos(phi), 0.05);
  };
  RadianceParams<double> params;
  params.scale = 0.0;
  params.phase_angle_rad = -80.0 * kDeg;
  const double glint = 0.01;
  // The dome, brightest at α, and the texture's ripple (a tenth of a
  // glint) every 5.3° over the whole body.
  auto scene = [&](double phi) {
    const double lit = std::max(0.0, std::cos(phi - params.phase_angle_rad));
    const double ripple = 0.1 * (1.0 + std::cos(2.0 * M_PI * phi / (5.3 * kDeg)));
    return glint * (glints(phi) + 3.0 * lit + ripple);
  };
  absl::StatusOr<PeakPickingResult> p =
      PickPeaks(AnalyticProfile(params, 0.25, scene), params.phase_angle_rad, Projection(),
                PeakPickingOptions());
  ASSERT_TRUE(p.ok()) << p.status();
  ASSERT_TRUE(p->split_resolved);
  // The outermost glints stand up to a tooth gap inside each caustic.
  const double truth = 2.0 * std::atan(m);
  EXPECT_LT(p->spacing_rad, truth + p->spacing_stderr_rad);
  EXPECT_NEAR(p->spacing_rad, truth, 3.0 * p->spacing_stderr_rad);
}

TEST(PeakPickingTest, ErrorsForProfilesWithoutALobe) {
  // A flat profile: no lobe near α/2.
  RadianceParams<double> params;
  params.scale = 0.0;
  params.diffuse = 0.0;
  Profile flat = AnalyticProfile(params, 0.25);
  absl::StatusOr<PeakPickingResult> p =
      PickPeaks(flat, 10.0 * kDeg, Projection(), PeakPickingOptions());
  ASSERT_FALSE(p.ok());
  EXPECT_EQ(p.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(p.status().message()).find("specular"), std::string::npos)
      << p.status();

  // The body's diffuse dome alone (a specular lobe lost in it): one peak,
  // far wider than a smooth glossy lobe, is no lobe.
  params.diffuse = 0.1;
  params.phase_angle_rad = 22.0 * kDeg;
  absl::StatusOr<PeakPickingResult> dome =
      PickPeaks(AnalyticProfile(params, 0.25), 22.0 * kDeg, Projection(), PeakPickingOptions());
  ASSERT_FALSE(dome.ok()) << static_cast<int>(dome->model) << " " << dome->single_peak_fwhm_rad;
  EXPECT_NE(std::string(dome.status().message()).find("no specular lobe stands out"),
            std::string::npos)
      << dome.status();

  // Too short or inconsistent.
  Profile shorter = flat;
  shorter.block_sum.pop_back();
  EXPECT_EQ(PickPeaks(shorter, 0.0, Projection(), PeakPickingOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);
  Profile empty;
  EXPECT_EQ(PickPeaks(empty, 0.0, Projection(), PeakPickingOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);

  PeakPickingOptions options;
  options.smoothing_deg = -1.0;
  EXPECT_NE(std::string(options.Validate().message()).find("smoothing_deg"),
            std::string::npos);
  options = PeakPickingOptions();
  options.search_half_width_deg = 0.5;
  EXPECT_NE(std::string(options.Validate().message()).find("search_half_width_deg"),
            std::string::npos);
  options = PeakPickingOptions();
  options.bootstrap_samples = -1;
  EXPECT_NE(std::string(options.Validate().message()).find("bootstrap_samples"),
            std::string::npos);
  EXPECT_EQ(PickPeaks(flat, 0.0, Projection(), options).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace weavefit
