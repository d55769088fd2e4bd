// Unit tests of glints/comb_fit: the comb of glints fitted row by row, through
// the whole pipeline (EstimateFromImage) and stage by stage as the pipeline
// chains them (render → DetectCylinder → ExtractProfile → PickPeaks →
// ExtractArcSignals → ChooseCombRows → ExtractArcPixels → FitGlintComb), on
// renders with known truth; and ExtractArcPixels (profile/arc_signals), which
// feeds the fit, on synthetic images with exactly known pixels.
#include "estimator/glints/comb_fit.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "estimator/cylinder/azimuth_mapping.h"
#include "estimator/cylinder/cylinder_detection.h"
#include "estimator/glints/glint_period.h"
#include "estimator/io/image.h"
#include "estimator/peaks/peak_picking.h"
#include "estimator/pipeline/estimate.h"
#include "estimator/profile/arc_signals.h"
#include "estimator/profile/profile_extraction.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The paper's coarse copper gauze (DESIGN.md §3): λ = 2.88 mm, h0 = 0.108 mm,
// m = 0.2356 (26.52° as a sinusoid), phase 10° (mirror at 5°), 320×240
// (R = 128 px: 16 px per period, ~30 threads across the lobe), ≈ 0.1 s.
constexpr double kWavelengthMm = 2.88;
constexpr double kAmplitudeMm = 0.108;

RenderScene GauzeScene() {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.model = ProfileModel::kSinusoid;
  scene.wavelength_mm = kWavelengthMm;
  scene.amplitude_mm = kAmplitudeMm;
  scene.phase_angle_deg = 10.0;
  scene.camera_distance_mm = 0.0;
  scene.seed = 7;
  return scene;
}

Rendered Render(const RenderScene& scene) {
  absl::StatusOr<Rendered> r = RenderPhotograph(scene);
  EXPECT_TRUE(r.ok()) << r.status();
  return r.ok() ? *r : Rendered();
}

// Each scene rendered once for all tests of this file.
const Rendered& GauzeRender() {
  static const Rendered* rendered = new Rendered(Render(GauzeScene()));
  return *rendered;
}

// The same scene through a lens PSF of σ = 0.8 px.
const Rendered& BlurredGauzeRender() {
  static const Rendered* rendered = [] {
    RenderScene scene = GauzeScene();
    scene.optics_blur_px = 0.8;
    return new Rendered(Render(scene));
  }();
  return *rendered;
}

Acquisition Lab(double phase_deg = 10.0) {
  Acquisition acquisition;
  acquisition.phase_angle_rad = phase_deg * kDeg;
  acquisition.cylinder_diameter_mm = 46.0;
  acquisition.camera_distance_mm = 0.0;
  acquisition.pixels_linear = true;
  return acquisition;
}

bool AnyWarningContains(const Estimate& e, const std::string& text) {
  for (const std::string& w : e.warnings) {
    if (w.find(text) != std::string::npos) return true;
  }
  return false;
}

// All warnings, one per line, for failure messages.
std::string Warnings(const Estimate& e) {
  std::string all;
  for (const std::string& w : e.warnings) all += "\n  " + w;
  return all;
}

Estimate EstimateOrDie(const Image& image, const Acquisition& acquisition) {
  absl::StatusOr<Estimate> e = EstimateFromImage(image, acquisition, EstimateOptions());
  EXPECT_TRUE(e.ok()) << e.status();
  return e.ok() ? *e : Estimate();
}

// A steep fine weave lit from 88°, rendered with the threads' relief
// parallax (render/render.h): R = 250 px, λ = 1.74 mm (19 px per period),
// m = 0.443, h0 = 0.123 mm, a lens blur of 1 px. Toward the limb each glint
// stands up to 1.2 px from where the mean cylinder would put it.
constexpr double kParallaxWavelengthMm = 1.7406;
const Rendered& ParallaxRender() {
  static const Rendered* rendered = [] {
    RenderScene scene;
    scene.width_px = 640;
    scene.height_px = 480;
    scene.radius_px = 250.0;
    scene.model = ProfileModel::kSinusoid;
    scene.wavelength_mm = kParallaxWavelengthMm;
    scene.amplitude_mm = 0.1228;
    scene.phase_angle_deg = 88.3;
    scene.source_blur_deg = 0.5;
    scene.axial_glint_width = 0.15;
    scene.stray_light = 0.02;
    scene.optics_blur_px = 1.0;
    scene.relief_parallax = true;
    scene.seed = 1;
    return new Rendered(Render(scene));
  }();
  return *rendered;
}

// ---------------------------------------------------------------------------
// Through the pipeline.

// Measured (seed 7): spacing 26.538° ± 0.051° (truth 26.516°), λ 2.8814 ±
// 0.0043 mm (+0.05 %), h0 0.10814 ± 0.00027 mm, mirror 5.0000° ± 0.030°.
// Over seeds 1–8 the spacing came within 0.035° and λ within 0.06 %.
TEST(CombFitTest, CoarseGauzeThroughThePipeline) {
  const Rendered& r = GauzeRender();
  ASSERT_NEAR(r.truth.max_slope, 0.2356, 1e-4);
  ASSERT_NEAR(r.truth.peak_spacing_deg, 26.52, 0.01);
  const Estimate e = EstimateOrDie(r.image, Lab());
  ASSERT_EQ(e.method, "comb-fit") << Warnings(e);
  EXPECT_EQ(e.model, ProfileModel::kSinusoid) << ProfileModelName(e.model);

  ASSERT_TRUE(e.peak_spacing_rad.resolved);
  ASSERT_TRUE(e.max_slope.resolved);
  ASSERT_TRUE(e.wavelength_mm.resolved);
  ASSERT_TRUE(e.amplitude_mm.resolved);
  ASSERT_TRUE(e.specular_azimuth_rad.resolved);
  const double spacing_error_deg = e.peak_spacing_rad.value / kDeg - r.truth.peak_spacing_deg;
  EXPECT_LT(std::fabs(spacing_error_deg), 0.15);
  EXPECT_LT(std::fabs(e.wavelength_mm.value / kWavelengthMm - 1.0), 0.003)
      << e.wavelength_mm.value;
  EXPECT_NEAR(e.specular_azimuth_rad.value / kDeg, r.truth.mirror_azimuth_deg, 0.15);

  // Honest errors: positive, and the truth within three of them.
  EXPECT_GT(e.peak_spacing_rad.stderr_value, 0.0);
  EXPECT_GT(e.max_slope.stderr_value, 0.0);
  EXPECT_GT(e.wavelength_mm.stderr_value, 0.0);
  EXPECT_GT(e.amplitude_mm.stderr_value, 0.0);
  EXPECT_GT(e.specular_azimuth_rad.stderr_value, 0.0);
  EXPECT_LE(std::fabs(spacing_error_deg), 3.0 * e.peak_spacing_rad.stderr_value / kDeg);
  EXPECT_NEAR(e.max_slope.value, r.truth.max_slope, 3.0 * e.max_slope.stderr_value);
  EXPECT_NEAR(e.wavelength_mm.value, kWavelengthMm, 3.0 * e.wavelength_mm.stderr_value);
  EXPECT_NEAR(e.amplitude_mm.value, kAmplitudeMm, 3.0 * e.amplitude_mm.stderr_value);

  // The reported quantities agree with each other: spacing = 2·arctan(m),
  // h0 = m·λ/(2π) (DESIGN.md §2–3).
  EXPECT_NEAR(e.peak_spacing_rad.value, 2.0 * std::atan(e.max_slope.value), 1e-12);
  EXPECT_NEAR(e.amplitude_mm.value, e.max_slope.value * e.wavelength_mm.value / (2.0 * M_PI),
              1e-12);

  // The comb fit is the one selected candidate, and says so.
  int selected = 0;
  for (const CandidateScore& c : e.candidates) {
    if (!c.selected) continue;
    ++selected;
    EXPECT_EQ(c.model, ProfileModel::kSinusoid);
    EXPECT_NE(c.method.find("comb"), std::string::npos) << c.method;
  }
  EXPECT_EQ(selected, 1);
  EXPECT_TRUE(AnyWarningContains(e, "comb of glints fitted")) << Warnings(e);
  // The stated phase angle is right: no complaint about it.
  EXPECT_FALSE(AnyWarningContains(e, "phase angle")) << Warnings(e);
}

// A lens PSF (σ 0.8 px) is fitted, not mistaken for a shorter split.
// Measured (seed 7): spacing 26.484° (−0.033°), λ −0.16 %, lens blur 0.80 px.
// Over seeds 1–8 the spacing came within 0.07° and λ within −0.16 %.
// Noise-free, 16 samples per pixel: what is left is the model's own error.
// The miss taken as linear over each of 8 sub-intervals per bin fell short
// at the caustics, where it bends most, and the max slope came out 0.079 %
// long at α = −60° (seeds 1-4; 0.011 % with 64 sub-intervals); the sum
// extrapolated from 8 and 4 sub-intervals gives within ±0.01 % on three
// seeds of four (+0.033 % on the fourth). The
// radius's own error is taken out: a radius short by a fraction ε spreads
// the glints' azimuths and makes m long by about ε.
TEST(CombFitTest, NoiseFreeMaxSlopeIsNotBiasedByTheQuadrature) {
  RenderScene scene = GauzeScene();
  scene.wavelength_mm = 2.0;
  scene.amplitude_mm = 0.3 * 2.0 / (2.0 * M_PI);
  scene.phase_angle_deg = -60.0;
  scene.photons_full_scale = 0.0;
  scene.read_noise = 0.0;
  scene.quantisation_bits = 0;
  scene.samples_per_pixel = 16;
  scene.seed = 3;
  const Rendered r = Render(scene);
  const Estimate e = EstimateOrDie(r.image, Lab(-60.0));
  ASSERT_EQ(e.method, "comb-fit") << Warnings(e);
  const double radius_error = e.cylinder.radius_px / r.truth.radius_px - 1.0;
  const double slope_error = e.max_slope.value / r.truth.max_slope - 1.0;
  EXPECT_LT(std::fabs(slope_error + radius_error), 3e-4)
      << "max slope " << e.max_slope.value << " truth " << r.truth.max_slope << ", radius error "
      << radius_error;
}

TEST(CombFitTest, LensBlurIsFitted) {
  const Rendered& r = BlurredGauzeRender();
  const Estimate e = EstimateOrDie(r.image, Lab());
  ASSERT_EQ(e.method, "comb-fit") << Warnings(e);
  ASSERT_TRUE(e.peak_spacing_rad.resolved);
  EXPECT_NEAR(e.peak_spacing_rad.value / kDeg, r.truth.peak_spacing_deg, 0.2);
  ASSERT_TRUE(e.wavelength_mm.resolved);
  EXPECT_LT(std::fabs(e.wavelength_mm.value / kWavelengthMm - 1.0), 0.003)
      << e.wavelength_mm.value;
  EXPECT_TRUE(AnyWarningContains(e, "lens blur")) << Warnings(e);
}

// At 60° with seed 124 the main solve stops with the source blur at 0.80°
// (truth 0.30°) and the polish moves it to 0.31°: the polished solution also
// costs less on the main solve's quadrature, so it is a better optimum, not
// a slide, and is kept. (Refused, peak picking answered 1.25° off.)
// Measured: spacing +0.007° off, comb fit.
TEST(CombFitTest, APolishThatFindsABetterOptimumIsKept) {
  RenderScene scene = GauzeScene();
  scene.phase_angle_deg = 60.0;
  scene.seed = 124;
  const Rendered r = Render(scene);
  const Estimate e = EstimateOrDie(r.image, Lab(60.0));
  ASSERT_EQ(e.method, "comb-fit") << Warnings(e);
  ASSERT_TRUE(e.peak_spacing_rad.resolved);
  const double error = e.peak_spacing_rad.value / kDeg - r.truth.peak_spacing_deg;
  EXPECT_LE(std::fabs(error), 3.0 * e.peak_spacing_rad.stderr_value / kDeg) << error;
  EXPECT_LT(std::fabs(error), 0.05) << error;
}

// A comb at 110° whose profile starts the max slope 14 % short (0.216 for
// 0.250): from there the fit may settle in a false optimum with the period
// 1 % short, which a second start from its answer leaves. Which path the
// fit takes turns on thousandths of a pixel and a degree of the cylinder
// (0.002 px and 0.001° decided between a converged fit and one stopped at
// its iteration cap), so the cylinder is given: the truth, with the error
// detection states on such a scene.
TEST(CombFitTest, AComb110DegreesFromTheLightFindsItsPeriod) {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.wavelength_mm = 3.0;
  scene.amplitude_mm = 0.119366;
  scene.phase_angle_deg = 110.0;
  scene.radius_px = 128.0;
  scene.seed = 5006;
  const Rendered r = Render(scene);
  Acquisition acquisition = Lab(110.0);
  GivenCylinder cylinder;
  cylinder.center_x_px = r.truth.center_x_px;
  cylinder.radius_px = r.truth.radius_px;
  cylinder.radius_stderr_px = 0.05;
  cylinder.center_stderr_px = 0.05;
  acquisition.given_cylinder = cylinder;
  const Estimate e = EstimateOrDie(r.image, acquisition);
  ASSERT_EQ(e.method, "comb-fit") << Warnings(e);
  ASSERT_TRUE(e.wavelength_mm.resolved);
  const double error = e.wavelength_mm.value - 3.0;
  EXPECT_LT(std::fabs(error), 0.003) << e.wavelength_mm.value;
  EXPECT_LE(std::fabs(error), 3.0 * e.wavelength_mm.stderr_value) << error;
}

// A tilted axis (3°, orthographic): the arc signals run perpendicular to it.
// Measured (seed 7): spacing 26.519° (+0.002°), axis 3.010°. Over seeds 1–8
// the spacing came within 0.22° (see the report: up to 3.3 standard errors).
TEST(CombFitTest, TiltedAxis) {
  RenderScene scene = GauzeScene();
  scene.axis_angle_deg = 3.0;
  const Rendered r = Render(scene);
  const Estimate e = EstimateOrDie(r.image, Lab());
  EXPECT_NEAR(e.cylinder.axis_angle_rad / kDeg, 3.0, 0.1);
  ASSERT_EQ(e.method, "comb-fit") << Warnings(e);
  ASSERT_TRUE(e.peak_spacing_rad.resolved);
  EXPECT_NEAR(e.peak_spacing_rad.value / kDeg, r.truth.peak_spacing_deg, 0.4);
  ASSERT_TRUE(e.wavelength_mm.resolved);
  EXPECT_LT(std::fabs(e.wavelength_mm.value / kWavelengthMm - 1.0), 0.005)
      << e.wavelength_mm.value;
}

// Rendered at +10°, stated as +12°: the glints put the mirror at the true 5°
// (measured 5.0000°, offset −1.000° from half the stated angle) and the
// estimate says the phase angle is off.
TEST(CombFitTest, WrongStatedPhaseAngleIsReported) {
  const Rendered& r = GauzeRender();
  ASSERT_NEAR(r.truth.mirror_azimuth_deg, 5.0, 1e-9);
  const Estimate e = EstimateOrDie(r.image, Lab(12.0));
  ASSERT_EQ(e.method, "comb-fit") << Warnings(e);
  EXPECT_TRUE(AnyWarningContains(e, "phase angle")) << Warnings(e);
  ASSERT_TRUE(e.specular_azimuth_rad.resolved);
  EXPECT_NEAR(e.specular_azimuth_rad.value / kDeg, 5.0, 0.2);
  // The split does not depend on where the mirror is.
  ASSERT_TRUE(e.peak_spacing_rad.resolved);
  EXPECT_NEAR(e.peak_spacing_rad.value / kDeg, r.truth.peak_spacing_deg, 0.15);
}

// The thread period from the glints along the lobe's rows, as the pipeline
// searches it (ReadWavelength: ExtractArcSignals over 0.9 of the half
// spacing, then EstimateGlintPeriod) after detection, but with the lobe's
// place and max slope from the render's truth: peak picking on an
// overexposed lobe is not what these tests measure, and it misreads this
// one (the spacing 14-16 deg for 26.5), which narrowed the window.
absl::StatusOr<GlintPeriodResult> PeriodOf(const Rendered& rendered) {
  const Image luminance = Luminance(rendered.image);
  const Acquisition acquisition = Lab(10.0);
  const Projection projection = acquisition.GetProjection();
  CylinderDetectionOptions detection;
  detection.phase_angle_rad = acquisition.phase_angle_rad;
  detection.projection = projection;
  absl::StatusOr<CylinderGeometry> cylinder = DetectCylinder(luminance, detection);
  if (!cylinder.ok()) return cylinder.status();
  absl::StatusOr<Profile> profile = ExtractProfile(luminance, *cylinder, projection, ProfileOptions());
  if (!profile.ok()) return profile.status();
  GlintModel model;
  model.max_slope = rendered.truth.max_slope;
  model.phase_angle_rad = acquisition.phase_angle_rad;
  model.projection = projection;
  model.mm_per_px = projection.radius_mm / cylinder->radius_px;
  model.pixel_noise = profile->background_noise;
  ArcSignalOptions arc;
  const double mirror_rad = rendered.truth.mirror_azimuth_deg * kDeg;
  const double spacing_rad = rendered.truth.peak_spacing_deg * kDeg;
  arc.from_rad = mirror_rad - 0.45 * spacing_rad;
  arc.to_rad = mirror_rad + 0.45 * spacing_rad;
  arc.max_rows = 192;
  absl::StatusOr<ArcSignals> signals = ExtractArcSignals(luminance, *cylinder, projection, arc);
  if (!signals.ok()) return signals.status();
  return EstimateGlintPeriod(*signals, model, GlintPeriodOptions());
}

// Glints clipped at the sensor's maximum are masked in the arc signals; each
// short masked run still counts as one glint, so an overexposed photograph
// keeps its period (before, its glint count fell to a fraction).
TEST(GlintPeriodTest, ClippedGlintsStillCount) {
  const Rendered& plain = GauzeRender();
  RenderScene bright = GauzeScene();
  bright.exposure = 25.0 * bright.exposure;
  const Rendered clipped = Render(bright);
  ASSERT_GT(clipped.image.SaturatedCount(), 20 * std::max<std::int64_t>(plain.image.SaturatedCount(), 10));
  absl::StatusOr<GlintPeriodResult> a = PeriodOf(plain);
  absl::StatusOr<GlintPeriodResult> b = PeriodOf(clipped);
  ASSERT_TRUE(a.ok()) << a.status();
  ASSERT_TRUE(b.ok()) << b.status();
  // On this small render the count alone may leave the period to the comb
  // fit (GlintPeriodResult::candidate_mm); either way it must be found.
  auto found = [](const GlintPeriodResult& r) { return r.resolved ? r.wavelength_mm : r.candidate_mm; };
  // 377 and 423 glints here; 12 when clipped glints were dropped.
  EXPECT_GT(b->glints_used, 0.7 * a->glints_used) << a->glints_used << " " << b->glints_used;
  EXPECT_NEAR(found(*a), kWavelengthMm, 0.03 * kWavelengthMm);
  EXPECT_NEAR(found(*b), kWavelengthMm, 0.03 * kWavelengthMm);
}

// ---------------------------------------------------------------------------
// Stage by stage.

// What the pipeline's FitCombOverLobe does, spelled out: the lobe from the
// profile's peaks with a margin beyond them, the rows chosen for
// `wavelength_mm`, pixels binned to at most max_samples_per_row per row, and
// the comb fitted from the peaks' max slope.
struct CombRun {
  PeakPickingResult peaks;
  GlintModel model;
  ArcSignals signals;
  CombRows rows;
  absl::Status rows_status;
  absl::StatusOr<CombFitResult> fit = absl::UnknownError("not run");
};

CombRun RunComb(const Rendered& rendered, double stated_phase_deg, double wavelength_mm,
                const CombFitOptions& options = CombFitOptions()) {
  CombRun run;
  const Image luminance = Luminance(rendered.image);
  const Acquisition acquisition = Lab(stated_phase_deg);
  const Projection projection = acquisition.GetProjection();
  CylinderDetectionOptions detection;
  detection.phase_angle_rad = acquisition.phase_angle_rad;
  detection.projection = projection;
  absl::StatusOr<CylinderGeometry> cylinder = DetectCylinder(luminance, detection);
  EXPECT_TRUE(cylinder.ok()) << cylinder.status();
  if (!cylinder.ok()) return run;
  absl::StatusOr<Profile> profile =
      ExtractProfile(luminance, *cylinder, projection, ProfileOptions());
  EXPECT_TRUE(profile.ok()) << profile.status();
  if (!profile.ok()) return run;
  absl::StatusOr<PeakPickingResult> peaks =
      PickPeaks(*profile, acquisition.phase_angle_rad, projection, PeakPickingOptions());
  EXPECT_TRUE(peaks.ok()) << peaks.status();
  if (!peaks.ok()) return run;
  EXPECT_TRUE(peaks->split_resolved);
  run.peaks = *peaks;

  run.model.max_slope = peaks->max_slope;
  run.model.max_slope_stderr = peaks->max_slope_stderr;
  run.model.phase_angle_rad = acquisition.phase_angle_rad;
  run.model.projection = projection;
  run.model.mm_per_px = projection.radius_mm / cylinder->radius_px;
  run.model.pixel_noise = profile->background_noise;

  const double half = 0.5 * peaks->spacing_rad;
  const double limit = projection.VisibleLimbRad() - 3.0 * kDeg;
  const double reach = half + std::max(4.0 * kDeg, 0.25 * half);
  ArcSignalOptions wide;
  wide.from_rad = std::max(peaks->mirror_rad - reach, -limit);
  wide.to_rad = std::min(peaks->mirror_rad + reach, limit);
  wide.max_rows = 192;
  absl::StatusOr<ArcSignals> signals = ExtractArcSignals(luminance, *cylinder, projection, wide);
  EXPECT_TRUE(signals.ok()) << signals.status();
  if (!signals.ok()) return run;
  run.signals = *signals;
  absl::StatusOr<CombRows> rows =
      ChooseCombRows(*signals, run.model, wavelength_mm, options.max_rows);
  run.rows_status = rows.status();
  if (!rows.ok()) return run;
  run.rows = *rows;
  const double columns = (OffsetFromAzimuth(wide.to_rad, projection) -
                          OffsetFromAzimuth(wide.from_rad, projection)) *
                         cylinder->radius_px / std::cos(cylinder->axis_angle_rad);
  const int bin = std::max(1, static_cast<int>(std::ceil(columns / options.max_samples_per_row)));
  absl::StatusOr<ArcPixels> pixels = ExtractArcPixels(luminance, *cylinder, projection,
                                                      rows->rows, wide.from_rad, wide.to_rad, bin);
  EXPECT_TRUE(pixels.ok()) << pixels.status();
  if (!pixels.ok()) return run;
  run.fit = FitGlintComb(*pixels, *rows, run.model, wavelength_mm, options);
  return run;
}

std::string Describe(const CombFitResult& f) {
  return "converged " + std::to_string(f.converged) + ", explained " + std::to_string(f.explained) +
         ", max slope " + std::to_string(f.max_slope) + ", period " +
         std::to_string(f.wavelength_mm) + " mm, psf " + std::to_string(f.psf_px) +
         " px, hidden share " + std::to_string(f.hidden_share) + ", rows " +
         std::to_string(f.rows_used) + ", message '" + f.message + "'";
}

// From the right period the comb is confirmed. Measured: explained 0.998,
// m 0.23582 (truth 0.23562, start 0.2451 from the peaks), λ 2.8814 mm,
// source blur 0.299° (rendered σ_β 0.3°), lens blur 0.25 px, offset 0.0000°;
// 30 rows of 30 threads. Blurred: explained 0.992, lens blur 0.800 px.
TEST(CombFitTest, RightPeriodIsConfirmed) {
  const CombRun run = RunComb(GauzeRender(), 10.0, kWavelengthMm);
  ASSERT_TRUE(run.fit.ok()) << run.fit.status() << " / rows: " << run.rows_status;
  const CombFitResult& f = *run.fit;
  EXPECT_TRUE(f.converged) << Describe(f);
  EXPECT_GT(f.explained, 0.9) << Describe(f);
  EXPECT_LT(f.psf_px, 0.5) << Describe(f);
  EXPECT_EQ(f.hidden_share, 0.0) << "the comb alone explains the rows: no floats modelled";
  EXPECT_NEAR(f.max_slope, GauzeRender().truth.max_slope, 0.002) << Describe(f);
  EXPECT_NEAR(f.wavelength_mm, kWavelengthMm, 0.01) << Describe(f);
  EXPECT_NEAR(f.blur_rad / kDeg, 0.3, 0.05) << Describe(f);
  EXPECT_NEAR(f.mirror_offset_rad / kDeg, 0.0, 0.05) << Describe(f);
  EXPECT_GT(f.max_slope_stderr, 0.0);
  EXPECT_GT(f.wavelength_stderr_mm, 0.0);
  EXPECT_GE(f.rows_used, 16);
  EXPECT_LE(f.rows_used, CombFitOptions().max_rows);
  EXPECT_GE(f.threads_used, 8);
  EXPECT_LE(f.threads_used, f.rows_used);

  const CombRun blurred = RunComb(BlurredGauzeRender(), 10.0, kWavelengthMm);
  ASSERT_TRUE(blurred.fit.ok()) << blurred.fit.status() << " / rows: " << blurred.rows_status;
  EXPECT_TRUE(blurred.fit->converged) << Describe(*blurred.fit);
  EXPECT_GT(blurred.fit->explained, 0.9) << Describe(*blurred.fit);
  EXPECT_NEAR(blurred.fit->psf_px, 0.8, 0.15) << Describe(*blurred.fit);
  EXPECT_NEAR(blurred.fit->max_slope, BlurredGauzeRender().truth.max_slope, 0.002)
      << Describe(*blurred.fit);
}

// A plain weave at 43 px per period in stray light, its axial threads
// floating over the circumferential ones (a fifth of each period, 0.3 of
// the threads' pitch) and glinting there: the floats hide the glints the
// comb predicts within them. The comb alone explains too little of the rows
// (measured: 0.73) and is not taken; with the floats it is, and the max
// slope and the period come out within their errors (with the fit's
// floors). Measured: explained 0.976, hidden share 0.13, m 0.24012 ± 0.00013
// (truth 0.24002), λ 1.99908 ± 0.00013 mm.
TEST(CombFitTest, FloatsThatHideGlintsAreModelled) {
  RenderScene scene;
  scene.width_px = 1280;
  scene.height_px = 960;
  scene.radius_px = 500;
  scene.model = ProfileModel::kSinusoid;
  scene.wavelength_mm = 2.0;
  scene.amplitude_mm = 0.0764;
  scene.phase_angle_deg = 10.0;
  scene.axial_glint_width = 0.15;
  scene.axial_float_width = 0.3;
  scene.stray_light = 0.02;
  scene.seed = 3;
  const Rendered r = Render(scene);
  CombFitOptions plain;
  plain.model_floats = false;
  const CombRun alone = RunComb(r, 10.0, 2.0, plain);
  ASSERT_TRUE(alone.fit.ok()) << alone.fit.status() << " / rows: " << alone.rows_status;
  EXPECT_TRUE(!alone.fit->converged || alone.fit->explained < plain.min_explained ||
              !CombPsfPlausible(alone.fit->psf_px, alone.model.lens_blur_px))
      << Describe(*alone.fit);
  EXPECT_EQ(alone.fit->hidden_share, 0.0);

  const CombRun run = RunComb(r, 10.0, 2.0);
  ASSERT_TRUE(run.fit.ok()) << run.fit.status() << " / rows: " << run.rows_status;
  const CombFitResult& f = *run.fit;
  EXPECT_TRUE(f.converged) << Describe(f);
  EXPECT_GT(f.explained, CombFitOptions().min_explained) << Describe(f);
  EXPECT_TRUE(CombPsfPlausible(f.psf_px, run.model.lens_blur_px)) << Describe(f);
  EXPECT_GT(f.hidden_share, 0.1) << Describe(f);
  EXPECT_LT(f.hidden_share, 0.3) << Describe(f);
  const double slope_error = std::hypot(f.max_slope_stderr, 0.001 * f.max_slope);
  EXPECT_NEAR(f.max_slope, r.truth.max_slope, 3.0 * slope_error) << Describe(f);
  EXPECT_NEAR(f.wavelength_mm, 2.0, 3.0 * std::hypot(f.wavelength_stderr_mm, 0.0003 * 2.0))
      << Describe(f);
}

// A comb sharper than a pixel (no lens blur: the fitted PSF sits at its
// floor) is polished to convergence, not stopped wherever the iteration cap
// leaves it: four times the cap gives the same answer. With the PSF's width
// σ = hypot(q, 0.1), which has no slope at the floor, each Gauss-Newton step
// flung q out and was rejected, and on these scenes the max slope at the
// cap differed from the one at four times it by 1.1 and 1.0 of its stated
// errors (0.249970 and 0.249921; 0.250120 and 0.250081); now by nothing.
// (The polish runs to its cap or its tolerances here: not ended once its
// answer has settled, CombFitOptions::polish_settled_share.)
TEST(CombFitTest, ASharpCombIsPolishedToConvergence) {
  for (const auto& [phase_deg, seed] : {std::pair{10.0, 8}, std::pair{60.0, 1}}) {
    SCOPED_TRACE(::testing::Message() << "phase " << phase_deg << " deg, seed " << seed);
    RenderScene scene = GauzeScene();
    scene.wavelength_mm = 3.0;
    scene.amplitude_mm = 0.119366;
    scene.phase_angle_deg = phase_deg;
    scene.seed = seed;
    const Rendered r = Render(scene);
    CombFitOptions capped;
    capped.polish_settled_share = 0.0;
    CombFitOptions longer = capped;
    longer.polish_iterations = 4 * capped.polish_iterations;
    const CombRun a = RunComb(r, phase_deg, 3.0, capped);
    const CombRun b = RunComb(r, phase_deg, 3.0, longer);
    ASSERT_TRUE(a.fit.ok() && b.fit.ok()) << a.rows_status;
    ASSERT_TRUE(a.fit->converged) << Describe(*a.fit);
    EXPECT_LT(a.fit->psf_px, 0.2) << Describe(*a.fit);
    EXPECT_NEAR(a.fit->max_slope, b.fit->max_slope, 0.05 * b.fit->max_slope_stderr)
        << Describe(*a.fit) << " / " << Describe(*b.fit);
    EXPECT_NEAR(a.fit->wavelength_mm, b.fit->wavelength_mm, 0.05 * b.fit->wavelength_stderr_mm)
        << Describe(*a.fit) << " / " << Describe(*b.fit);
  }
}

// A polish whose answer has settled ends before its cap, and its answer
// stays within CombFitOptions::polish_settled_share of its errors of the
// answer the polish to its cap gives: a gauze in stray light whose axial
// threads glint too, as in lab photographs. Measured: 30 iterations in all
// against 48, the max slope 0.02 of its error from the polish to the cap's.
TEST(CombFitTest, APolishEndsOnceItsAnswerHasSettled) {
  RenderScene scene = GauzeScene();
  scene.phase_angle_deg = 60.0;
  scene.stray_light = 0.03;
  scene.axial_glint_width = 0.15;
  const Rendered r = Render(scene);
  const CombFitOptions settled;
  CombFitOptions to_cap;
  to_cap.polish_settled_share = 0.0;
  const CombRun a = RunComb(r, 60.0, kWavelengthMm, settled);
  const CombRun b = RunComb(r, 60.0, kWavelengthMm, to_cap);
  ASSERT_TRUE(a.fit.ok() && b.fit.ok()) << a.rows_status;
  ASSERT_TRUE(a.fit->converged && b.fit->converged)
      << Describe(*a.fit) << " / " << Describe(*b.fit);
  EXPECT_LT(a.fit->iterations, b.fit->iterations);
  const double share = settled.polish_settled_share;
  EXPECT_NEAR(a.fit->max_slope, b.fit->max_slope, share * b.fit->max_slope_stderr);
  EXPECT_NEAR(a.fit->wavelength_mm, b.fit->wavelength_mm, share * b.fit->wavelength_stderr_mm);
  EXPECT_NEAR(a.fit->mirror_offset_rad, b.fit->mirror_offset_rad,
              share * b.fit->mirror_offset_stderr_rad);
}

// A second fit on a first's rows (the pipeline's, from the first's answer)
// reads their phases again at its own period: the rows and their threads
// stay, so that the two fits' shares explained compare on the same pixels.
TEST(CombFitTest, RowsRephasedAreTheSameRows) {
  const CombRun run = RunComb(GauzeRender(), 10.0, kWavelengthMm);
  ASSERT_TRUE(run.rows_status.ok()) << run.rows_status;
  absl::StatusOr<CombRows> same = RephaseCombRows(run.signals, run.model, kWavelengthMm, run.rows);
  ASSERT_TRUE(same.ok()) << same.status();
  EXPECT_EQ(same->rows, run.rows.rows);
  EXPECT_EQ(same->thread, run.rows.thread);
  EXPECT_EQ(same->phase_mm, run.rows.phase_mm);
  absl::StatusOr<CombRows> longer =
      RephaseCombRows(run.signals, run.model, 1.02 * kWavelengthMm, run.rows);
  ASSERT_TRUE(longer.ok()) << longer.status();
  EXPECT_EQ(longer->rows, run.rows.rows);
  EXPECT_EQ(longer->thread, run.rows.thread);
  EXPECT_NE(longer->phase_mm, run.rows.phase_mm);
  EXPECT_EQ(RephaseCombRows(run.signals, run.model, 0.0, run.rows).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// A wrong period is not confirmed: it never both converges and explains 0.9
// of the rows' variance. Measured: 1.25× → converged, explained 0.24
// (blurred: left its range, period 4.07 mm); 0.8× → explained 0.65 (blurred
// 0.71), converged at 2.24 mm (2.23 mm).
TEST(CombFitTest, WrongPeriodIsNotConfirmed) {
  const CombFitOptions options;
  for (const Rendered* r : {&GauzeRender(), &BlurredGauzeRender()}) {
    for (double factor : {1.25, 0.8}) {
      SCOPED_TRACE(::testing::Message() << "period × " << factor << ", lens blur "
                                        << (r == &GauzeRender() ? "none" : "0.8 px"));
      const CombRun run = RunComb(*r, 10.0, kWavelengthMm * factor, options);
      // The rows are found (so the fit itself is what is tested).
      ASSERT_TRUE(run.rows_status.ok()) << run.rows_status;
      ASSERT_TRUE(run.fit.ok()) << run.fit.status();
      const CombFitResult& f = *run.fit;
      EXPECT_FALSE(f.converged && f.explained >= options.min_explained_alone) << Describe(f);
      if (!f.converged) {
        EXPECT_FALSE(f.message.empty());
      }
    }
  }
}

// The comb with its glints placed where their facets stand off the mean
// cylinder (CombFitOptions::relief) reads the parallax render: measured
// spacing +0.045° ± 0.22°, λ +0.11 %. With its glints on the mean cylinder
// alone the comb fell short and the lobe's fit answered −0.53° ± 0.95°,
// λ unresolved.
TEST(CombFitTest, TheReliefsParallaxIsModelled) {
  const Rendered& r = ParallaxRender();
  const Acquisition lab = Lab(88.3);
  const Estimate e = EstimateOrDie(r.image, lab);
  ASSERT_EQ(e.method, "comb-fit") << Warnings(e);
  EXPECT_TRUE(AnyWarningContains(e, "relief")) << Warnings(e);
  const double error_deg = e.peak_spacing_rad.value / kDeg - r.truth.peak_spacing_deg;
  EXPECT_LT(std::fabs(error_deg), 0.1);
  EXPECT_LE(std::fabs(error_deg), 3.0 * e.peak_spacing_rad.stderr_value / kDeg);
  ASSERT_TRUE(e.wavelength_mm.resolved) << Warnings(e);
  EXPECT_NEAR(e.wavelength_mm.value / kParallaxWavelengthMm, 1.0, 0.005);

  EstimateOptions plain;
  plain.comb.relief = CombFitOptions::Relief::kMeanCylinder;
  absl::StatusOr<Estimate> without = EstimateFromImage(r.image, lab, plain);
  ASSERT_TRUE(without.ok()) << without.status();
  const double plain_error_deg = without->peak_spacing_rad.value / kDeg - r.truth.peak_spacing_deg;
  EXPECT_GT(std::fabs(plain_error_deg), 3.0 * std::fabs(error_deg)) << Warnings(*without);
}

// A wrong period that the main solve leaves explaining little of the rows
// is not polished (CombFitOptions::min_explained_to_polish): the fit ends
// unconverged, saying so, in fewer iterations than with the polish.
TEST(CombFitTest, AWrongPeriodIsNotPolished) {
  CombFitOptions polished;
  polished.min_explained_to_polish = 0.0;
  const CombRun screened_run = RunComb(GauzeRender(), 10.0, kWavelengthMm * 1.25);
  const CombRun polished_run = RunComb(GauzeRender(), 10.0, kWavelengthMm * 1.25, polished);
  ASSERT_TRUE(screened_run.fit.ok()) << screened_run.fit.status();
  ASSERT_TRUE(polished_run.fit.ok()) << polished_run.fit.status();
  const CombFitResult& screened = *screened_run.fit;
  EXPECT_FALSE(screened.converged) << Describe(screened);
  EXPECT_NE(screened.message.find("before its polish"), std::string::npos) << screened.message;
  EXPECT_LT(polished_run.fit->explained, polished.min_explained) << Describe(*polished_run.fit);
  EXPECT_LT(screened.iterations, polished_run.fit->iterations);
}

// The fit leaves the mirror free: with the phase angle stated 2° too large
// the mirror's offset from half of it is −1° (measured −1.0000° ± 0.0008°),
// the max slope as before.
TEST(CombFitTest, MirrorOffsetMeasuresThePhaseAngle) {
  const CombRun run = RunComb(GauzeRender(), 12.0, kWavelengthMm);
  ASSERT_TRUE(run.fit.ok()) << run.fit.status() << " / rows: " << run.rows_status;
  const CombFitResult& f = *run.fit;
  ASSERT_TRUE(f.converged) << Describe(f);
  EXPECT_NEAR(f.mirror_offset_rad / kDeg, -1.0, 0.05) << Describe(f);
  EXPECT_GT(f.mirror_offset_stderr_rad, 0.0);
  EXPECT_GT(f.explained, 0.9) << Describe(f);
  EXPECT_NEAR(f.max_slope, GauzeRender().truth.max_slope, 0.002) << Describe(f);
}

TEST(CombFitTest, InvalidArgumentsAreErrors) {
  CombFitOptions options;
  EXPECT_TRUE(options.Validate().ok());
  options.max_rows = 3;
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument);
  options = CombFitOptions();
  options.min_explained = 0.95;  // above min_explained_alone
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument);
  options = CombFitOptions();
  options.min_explained_to_polish = options.min_explained;
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument);
  options = CombFitOptions();
  options.subintervals = 0;
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument);
  options = CombFitOptions();
  options.polish_settled_share = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument);

  GlintModel model;
  model.max_slope = 0.2356;
  model.mm_per_px = 0.18;
  ArcPixels pixels;
  CombRows rows;
  // No rows at all, a missing wavelength, a missing max slope.
  EXPECT_EQ(FitGlintComb(pixels, rows, model, 2.88, CombFitOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);
  rows.rows = {10};
  rows.phase_mm = {0.0};
  rows.thread = {0};
  pixels.rows = {10, 11};  // one signal per chosen row is needed
  pixels.values.resize(2);
  pixels.offset_px.resize(2);
  pixels.valid.resize(2);
  EXPECT_EQ(FitGlintComb(pixels, rows, model, 2.88, CombFitOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(FitGlintComb(pixels, rows, model, 0.0, CombFitOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);
  GlintModel flat = model;
  flat.max_slope = 0.0;
  EXPECT_EQ(FitGlintComb(pixels, rows, flat, 2.88, CombFitOptions()).status().code(),
            absl::StatusCode::kInvalidArgument);
  ArcSignals signals;
  EXPECT_EQ(ChooseCombRows(signals, model, 0.0, 32).status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(ChooseCombRows(signals, model, 2.88, 3).status().code(),
            absl::StatusCode::kInvalidArgument);
}

// ---------------------------------------------------------------------------
// ExtractArcPixels on a synthetic image whose every pixel is known.

// One channel, value = 1000·row + column (exact in float).
Image Ramp(int width, int height) {
  Image image;
  image.width = width;
  image.height = height;
  image.channels = 1;
  image.pixels.resize(static_cast<std::size_t>(width) * height);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      image.pixels[static_cast<std::size_t>(y) * width + x] = static_cast<float>(1000 * y + x);
    }
  }
  return image;
}

// An upright cylinder, axis at column 50.3, radius 40 px, over 101×20 px:
// ±30° in azimuth is ±20 px, columns 31 to 70.
CylinderGeometry Upright() {
  CylinderGeometry geometry;
  geometry.center_x_px = 50.3;
  geometry.center_row_px = 10.0;
  geometry.radius_px = 40.0;
  geometry.axis_angle_rad = 0.0;
  geometry.top_row = 0;
  geometry.bottom_row = 19;
  return geometry;
}

const Projection kOrthographic{23.0, 0.0};

TEST(ArcPixelsTest, UprightAxisTakesTheAnchorRowsPixels) {
  const Image image = Ramp(101, 20);
  const std::vector<int> rows = {0, 3, 10, 19};
  absl::StatusOr<ArcPixels> pixels =
      ExtractArcPixels(image, Upright(), kOrthographic, rows, -30.0 * kDeg, 30.0 * kDeg, 1);
  ASSERT_TRUE(pixels.ok()) << pixels.status();
  EXPECT_EQ(pixels->bin_px, 1);
  EXPECT_DOUBLE_EQ(pixels->radius_px, 40.0);
  EXPECT_DOUBLE_EQ(pixels->bin_width_px, 1.0);
  ASSERT_EQ(pixels->rows, rows);
  ASSERT_EQ(pixels->values.size(), rows.size());
  ASSERT_EQ(pixels->offset_px.size(), rows.size());
  ASSERT_EQ(pixels->valid.size(), rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    SCOPED_TRACE(::testing::Message() << "row " << rows[r]);
    ASSERT_EQ(pixels->values[r].size(), 40u);
    ASSERT_EQ(pixels->offset_px[r].size(), 40u);
    ASSERT_EQ(pixels->valid[r].size(), 40u);
    for (int j = 0; j < 40; ++j) {
      const int x = 31 + j;
      EXPECT_FLOAT_EQ(pixels->values[r][j], image.At(x, rows[r])) << "column " << x;
      EXPECT_NEAR(pixels->offset_px[r][j], x - 50.3, 1e-9) << "column " << x;
      EXPECT_EQ(pixels->valid[r][j], 1) << "column " << x;
    }
  }
}

// ArcSignalOptions::rows: exactly the rows given, in their order, with the
// same samples as the rows ranked or taken whole; rows outside the usable
// range are an error.
TEST(ArcSignalsTest, GivenRowsAreSampledAsGiven) {
  const Image image = Ramp(101, 20);
  ArcSignalOptions options;
  options.from_rad = -30.0 * kDeg;
  options.to_rad = 30.0 * kDeg;
  absl::StatusOr<ArcSignals> all = ExtractArcSignals(image, Upright(), kOrthographic, options);
  ASSERT_TRUE(all.ok()) << all.status();
  ASSERT_EQ(all->rows.size(), 20u);
  options.rows = {12, 3, 19};
  absl::StatusOr<ArcSignals> some = ExtractArcSignals(image, Upright(), kOrthographic, options);
  ASSERT_TRUE(some.ok()) << some.status();
  ASSERT_EQ(some->rows, options.rows);
  ASSERT_EQ(some->num_samples, all->num_samples);
  for (std::size_t r = 0; r < options.rows.size(); ++r) {
    for (int k = 0; k < some->num_samples; ++k) {
      EXPECT_EQ(some->values[r * some->num_samples + k],
                all->values[options.rows[r] * all->num_samples + k]);
    }
  }
  options.rows = {5, 20};
  EXPECT_EQ(ExtractArcSignals(image, Upright(), kOrthographic, options).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(ArcPixelsTest, BinsAverageNeighbouringColumns) {
  const Image image = Ramp(101, 20);
  absl::StatusOr<ArcPixels> pairs =
      ExtractArcPixels(image, Upright(), kOrthographic, {5}, -30.0 * kDeg, 30.0 * kDeg, 2);
  ASSERT_TRUE(pairs.ok()) << pairs.status();
  EXPECT_EQ(pairs->bin_px, 2);
  EXPECT_DOUBLE_EQ(pairs->bin_width_px, 2.0);
  ASSERT_EQ(pairs->values[0].size(), 20u);
  for (int j = 0; j < 20; ++j) {
    const int x = 31 + 2 * j;
    EXPECT_FLOAT_EQ(pairs->values[0][j], 0.5f * (image.At(x, 5) + image.At(x + 1, 5)));
    EXPECT_NEAR(pairs->offset_px[0][j], x + 0.5 - 50.3, 1e-9);
  }
  // Bins of three: the 40 columns make 13 whole bins, the last column left.
  absl::StatusOr<ArcPixels> triples =
      ExtractArcPixels(image, Upright(), kOrthographic, {5}, -30.0 * kDeg, 30.0 * kDeg, 3);
  ASSERT_TRUE(triples.ok()) << triples.status();
  ASSERT_EQ(triples->values[0].size(), 13u);
  EXPECT_FLOAT_EQ(triples->values[0].back(), image.At(68, 5));  // mean of 67, 68, 69
  EXPECT_NEAR(triples->offset_px[0].back(), 68 - 50.3, 1e-9);
}

TEST(ArcPixelsTest, SaturatedPixelInvalidatesItsBinOnly) {
  Image image = Ramp(101, 20);
  image.MarkSaturated(40, 3);
  absl::StatusOr<ArcPixels> pixels =
      ExtractArcPixels(image, Upright(), kOrthographic, {3, 4}, -30.0 * kDeg, 30.0 * kDeg, 2);
  ASSERT_TRUE(pixels.ok()) << pixels.status();
  for (int j = 0; j < 20; ++j) {
    const int x = 31 + 2 * j;
    const bool holds_it = x <= 40 && 40 <= x + 1;
    EXPECT_EQ(pixels->valid[0][j], holds_it ? 0 : 1) << "row 3, bin at column " << x;
    EXPECT_EQ(pixels->valid[1][j], 1) << "row 4, bin at column " << x;
  }
}

// With a tilted axis each signal runs through the anchor row's axis point
// perpendicular to the axis, interpolating along the column only: on a
// pattern linear in the row, every value is exactly 1000·y_line + column.
TEST(ArcPixelsTest, TiltedAxisInterpolatesAlongTheColumn) {
  const Image image = Ramp(101, 20);
  CylinderGeometry geometry = Upright();
  const double tilt = 2.0 * kDeg;
  geometry.axis_angle_rad = tilt;
  const int y0 = 8;
  absl::StatusOr<ArcPixels> pixels =
      ExtractArcPixels(image, geometry, kOrthographic, {y0}, -30.0 * kDeg, 30.0 * kDeg, 1);
  ASSERT_TRUE(pixels.ok()) << pixels.status();
  const double axis = geometry.AxisColumn(y0);
  ASSERT_GT(pixels->values[0].size(), 30u);
  const double first = pixels->offset_px[0].front() * std::cos(tilt) + axis;
  for (std::size_t j = 0; j < pixels->values[0].size(); ++j) {
    const double x = first + static_cast<double>(j);
    ASSERT_NEAR(x, std::round(x), 1e-9);  // whole columns
    const double y_line = y0 + (x - axis) * std::tan(tilt);
    EXPECT_NEAR(pixels->values[0][j], 1000.0 * y_line + x, 0.01) << "column " << x;
    // The perpendicular distance from the axis of the point on the line.
    EXPECT_NEAR(pixels->offset_px[0][j], (x - axis) / std::cos(tilt), 1e-9) << "column " << x;
  }
  // The limb half-width along the arc is the geometry's (perpendicular).
  EXPECT_DOUBLE_EQ(pixels->radius_px, 40.0);
}

TEST(ArcPixelsTest, InvalidRequestsAreErrors) {
  const Image image = Ramp(101, 20);
  const CylinderGeometry geometry = Upright();
  auto code = [&](const std::vector<int>& rows, double from_deg, double to_deg, int bin) {
    return ExtractArcPixels(image, geometry, kOrthographic, rows, from_deg * kDeg, to_deg * kDeg,
                            bin)
        .status()
        .code();
  };
  EXPECT_EQ(code({5}, -30.0, 30.0, 1), absl::StatusCode::kOk);
  // Beyond the visible limb (90° orthographic), on either side.
  EXPECT_EQ(code({5}, -30.0, 90.0, 1), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code({5}, -95.0, 30.0, 1), absl::StatusCode::kInvalidArgument);
  // An empty or reversed range, no bins, rows outside the image.
  EXPECT_EQ(code({5}, 10.0, 10.0, 1), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code({5}, 30.0, -30.0, 1), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code({5}, -30.0, 30.0, 0), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code({-1}, -30.0, 30.0, 1), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(code({5, 20}, -30.0, 30.0, 1), absl::StatusCode::kInvalidArgument);
  // Under perspective the limb is nearer: arccos(23/100) ≈ 76.7°.
  const Projection near{23.0, 100.0};
  EXPECT_EQ(ExtractArcPixels(image, geometry, near, {5}, -30.0 * kDeg, 80.0 * kDeg, 1)
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
  // Three channels.
  Image colour = image;
  colour.channels = 3;
  colour.pixels.resize(colour.pixels.size() * 3, 0.0f);
  EXPECT_EQ(ExtractArcPixels(colour, geometry, kOrthographic, {5}, -30.0 * kDeg, 30.0 * kDeg, 1)
                .status()
                .code(),
            absl::StatusCode::kInvalidArgument);
}

// ComparePeriods: a comb's period 1.2 % short of twice the lines' pitch,
// each stated to 0.2-0.3 %, is counted; one within its errors is not; a
// lattice that is the period itself is compared as such.
TEST(ComparePeriodsTest, ADisagreementBeyondBothErrorsIsCounted) {
  CombFitOptions options;
  CombFitResult comb;
  comb.wavelength_mm = 0.9785;
  comb.wavelength_stderr_mm = 0.0002;
  comb.reduced_chi2 = 1.09;
  const PeriodReadings apart = ComparePeriods(comb, options, 0.4931, 0.0013);
  EXPECT_NEAR(apart.lattice_mm, 0.9862, 1e-9);
  EXPECT_NEAR(apart.counted_mm, 0.0077, 1e-9);
  // Within twice the errors combined (0.0026 for the lines): not counted.
  const PeriodReadings close = ComparePeriods(comb, options, 0.4912, 0.0013);
  EXPECT_NEAR(close.lattice_mm, 0.9824, 1e-9);
  EXPECT_EQ(close.counted_mm, 0.0);
  // A relief lattice repeats with the period itself.
  const PeriodReadings relief = ComparePeriods(comb, options, 0.9862, 0.0026);
  EXPECT_NEAR(relief.lattice_mm, 0.9862, 1e-9);
  EXPECT_NEAR(relief.counted_mm, 0.0077, 1e-9);
  // No lattice: nothing to compare.
  EXPECT_EQ(ComparePeriods(comb, options, 0.0, 0.0).counted_mm, 0.0);
}

}  // namespace
}  // namespace weavefit
