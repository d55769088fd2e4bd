// Unit tests of glints/comb_fit: the comb of glints fitted row by row, through
// the whole pipeline (EstimateFromImage) and stage by stage (render →
// DetectCylinder → ExtractProfile → PickPeaks → ExtractArcSignals →
// ChooseCombRows → ExtractArcPixels → FitGlintComb), on renders with known
// truth; and ExtractArcPixels (profile/arc_signals) on a synthetic image.
#include "estimator/glints/comb_fit.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
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
// m = 0.2356 (26.52°), phase 10°, 320×240 (R = 128 px: 16 px per period).
RenderScene GauzeScene() {
  RenderScene scene;
  scene.width_px = 320;
  scene.height_px = 240;
  scene.model = ProfileModel::kSinusoid;
  scene.wavelength_mm = 2.88;
  scene.amplitude_mm = 0.108;
  scene.phase_angle_deg = 10.0;
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
  acquisition.pixels_linear = true;
  return acquisition;
}

bool AnyWarningContains(const Estimate& e, const std::string& text) {
  for (const std::string& w : e.warnings) {
    if (w.find(text) != std::string::npos) return true;
  }
  return false;
}

std::string AllWarnings(const Estimate& e) {
  std::string all;
  for (const std::string& w : e.warnings) all += "\n  " + w;
  return all;
}

// Stage by stage, as the pipeline's FitCombOverLobe chains them: the lobe
// from the profile's peaks, the rows chosen for `wavelength_mm`, and the
// comb fitted from the peaks' max slope.
struct CombRun {
  RenderTruth truth;
  PeakPickingResult peaks;
  GlintModel model;
  CombRows rows;
  ArcPixels pixels;
  absl::StatusOr<CombFitResult> fit = absl::UnknownError("not run");
};

CombRun RunComb(const Rendered& rendered, double phase_deg, double wavelength_mm,
                const CombFitOptions& options = CombFitOptions()) {
  CombRun run;
  run.truth = rendered.truth;
  const Image luminance = Luminance(rendered.image);
  const Acquisition acquisition = Lab(phase_deg);
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
  run.peaks = *peaks;
  EXPECT_TRUE(peaks->split_resolved);

  run.model.max_slope = peaks->max_slope;
  run.model.max_slope_stderr = peaks->max_slope_stderr;
  run.model.phase_angle_rad = acquisition.phase_angle_rad;
  run.model.projection = projection;
  run.model.mm_per_px = projection.radius_mm / cylinder->radius_px;
  run.model.pixel_noise = profile->background_noise;

  // The whole lobe and a margin beyond the peaks read.
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
  absl::StatusOr<CombRows> rows =
      ChooseCombRows(*signals, run.model, wavelength_mm, options.max_rows);
  if (!rows.ok()) {
    run.fit = rows.status();
    return run;
  }
  run.rows = *rows;
  const double columns = (OffsetFromAzimuth(wide.to_rad, projection) -
                          OffsetFromAzimuth(wide.from_rad, projection)) *
                         cylinder->radius_px / std::cos(cylinder->axis_angle_rad);
  const int bin = std::max(1, static_cast<int>(std::ceil(columns / options.max_samples_per_row)));
  absl::StatusOr<ArcPixels> pixels = ExtractArcPixels(luminance, *cylinder, projection,
                                                      rows->rows, wide.from_rad, wide.to_rad, bin);
  EXPECT_TRUE(pixels.ok()) << pixels.status();
  if (!pixels.ok()) return run;
  run.pixels = *pixels;
  run.fit = FitGlintComb(*pixels, *rows, run.model, wavelength_mm, options);
  return run;
}

void Print(const char* what, const Estimate& e, const RenderTruth& truth) {
  std::printf(
      "%s: method %s spacing %.4f±%.4f (truth %.4f) slope %.5f±%.5f (truth %.5f) "
      "lambda %.5f±%.5f h0 %.5f±%.5f mirror %.4f±%.4f (truth %.4f)%s\n",
      what, e.method.c_str(), e.peak_spacing_rad.value / kDeg,
      e.peak_spacing_rad.stderr_value / kDeg, truth.peak_spacing_deg, e.max_slope.value,
      e.max_slope.stderr_value, truth.max_slope, e.wavelength_mm.value,
      e.wavelength_mm.stderr_value, e.amplitude_mm.value, e.amplitude_mm.stderr_value,
      e.specular_azimuth_rad.value / kDeg, e.specular_azimuth_rad.stderr_value / kDeg,
      truth.mirror_azimuth_deg, AllWarnings(e).c_str());
}

void PrintFit(const char* what, const CombRun& run) {
  if (!run.fit.ok()) {
    std::printf("%s: %s\n", what, std::string(run.fit.status().message()).c_str());
    return;
  }
  const CombFitResult& f = *run.fit;
  std::printf(
      "%s: conv %d explained %.4f m %.5f±%.5f lambda %.5f±%.5f blur %.4f deg psf %.3f px "
      "offset %.4f±%.4f deg chi2 %.3f rows %d threads %d iter %d msg '%s' (peaks m %.5f, "
      "rows %zu bin %d)\n",
      what, f.converged, f.explained, f.max_slope, f.max_slope_stderr, f.wavelength_mm,
      f.wavelength_stderr_mm, f.blur_rad / kDeg, f.psf_px, f.mirror_offset_rad / kDeg,
      f.mirror_offset_stderr_rad / kDeg, f.reduced_chi2, f.rows_used, f.threads_used,
      f.iterations, f.message.c_str(), run.model.max_slope, run.rows.rows.size(),
      run.pixels.bin_px);
}

TEST(CombFitExplore, Seeds) {
  for (std::uint32_t seed = 1; seed <= 4; ++seed) {
    for (double blur : {0.0, 0.8}) {
      for (double tilt : {0.0}) {
        RenderScene scene = GauzeScene();
        scene.seed = seed;
        scene.optics_blur_px = blur;
        scene.axis_angle_deg = tilt;
        const Rendered r = Render(scene);
        for (double stated : {10.0}) {
          absl::StatusOr<Estimate> e = EstimateFromImage(r.image, Lab(stated), EstimateOptions());
          ASSERT_TRUE(e.ok()) << e.status();
          std::printf("seed %u blur %.1f tilt %.0f stated %.0f: %s dsp %+.4f (se %.4f) dlam %+.3f%% (se %.3f%%) dmir %+.4f (se %.4f) phasewarn %d cx %+.3f r %+.3f\n",
              seed, blur, tilt, stated, e->method.c_str(), e->peak_spacing_rad.value / kDeg - r.truth.peak_spacing_deg,
              e->peak_spacing_rad.stderr_value / kDeg, 100 * (e->wavelength_mm.value / 2.88 - 1),
              100 * e->wavelength_mm.stderr_value / 2.88,
              e->specular_azimuth_rad.value / kDeg - r.truth.mirror_azimuth_deg,
              e->specular_azimuth_rad.stderr_value / kDeg, AnyWarningContains(*e, "phase angle"), e->cylinder.center_x_px - r.truth.center_x_px, e->cylinder.radius_px - r.truth.radius_px);
        }
      }
    }
  }
}

TEST(CombFitExplore, All) {
  {
    absl::StatusOr<Estimate> e = EstimateFromImage(GauzeRender().image, Lab(), EstimateOptions());
    ASSERT_TRUE(e.ok()) << e.status();
    Print("gauze", *e, GauzeRender().truth);
  }
  {
    absl::StatusOr<Estimate> e =
        EstimateFromImage(BlurredGauzeRender().image, Lab(), EstimateOptions());
    ASSERT_TRUE(e.ok()) << e.status();
    Print("blurred", *e, BlurredGauzeRender().truth);
  }
  {
    RenderScene scene = GauzeScene();
    scene.axis_angle_deg = 3.0;
    const Rendered r = Render(scene);
    absl::StatusOr<Estimate> e = EstimateFromImage(r.image, Lab(), EstimateOptions());
    ASSERT_TRUE(e.ok()) << e.status();
    Print("tilted", *e, r.truth);
  }
  {
    absl::StatusOr<Estimate> e =
        EstimateFromImage(GauzeRender().image, Lab(12.0), EstimateOptions());
    ASSERT_TRUE(e.ok()) << e.status();
    Print("phase12", *e, GauzeRender().truth);
  }
  PrintFit("right", RunComb(GauzeRender(), 10.0, 2.88));
  PrintFit("long", RunComb(GauzeRender(), 10.0, 2.88 * 1.25));
  PrintFit("short", RunComb(GauzeRender(), 10.0, 2.88 * 0.8));
  PrintFit("blurred right", RunComb(BlurredGauzeRender(), 10.0, 2.88));
  PrintFit("blurred long", RunComb(BlurredGauzeRender(), 10.0, 2.88 * 1.25));
  PrintFit("blurred short", RunComb(BlurredGauzeRender(), 10.0, 2.88 * 0.8));
  PrintFit("phase12 right", RunComb(GauzeRender(), 12.0, 2.88));
  {
    RenderScene scene = GauzeScene();
    scene.axis_angle_deg = 3.0;
    const Rendered r = Render(scene);
    absl::StatusOr<Estimate> e = EstimateFromImage(r.image, Lab(), EstimateOptions());
    std::printf("tilt axis %.4f deg cx %.3f (%.3f) r %.3f (%.3f)\n", e->cylinder.axis_angle_rad / kDeg,
                e->cylinder.center_x_px, r.truth.center_x_px, e->cylinder.radius_px, r.truth.radius_px);
    PrintFit("tilt right", RunComb(r, 10.0, 2.88));
  }
}

}  // namespace
}  // namespace weavefit
