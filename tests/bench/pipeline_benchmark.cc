// Per-stage cost of the estimate on a large photograph (issue 4): decode and
// each later stage separately, on a 4096×3072 16-bit PNG rendered once.
// Timings live here, never in pass/fail tests (machines are shared).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <string>
#include <tuple>

#include "estimator/cylinder/cylinder_detection.h"
#include "estimator/fit/profile_fit.h"
#include "estimator/io/decode.h"
#include "estimator/io/encode.h"
#include "estimator/peaks/peak_picking.h"
#include "estimator/pipeline/estimate.h"
#include "estimator/profile/profile_extraction.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The shared input: rendered once (coarse sampling, it is only input).
struct Input {
  std::string png;
  Image image;
  Image luminance;
  CylinderGeometry geometry;
  Profile profile;
  Acquisition acquisition;
};

const Input& TheInput() {
  static const Input* input = [] {
    auto* in = new Input;
    RenderScene scene;
    scene.width_px = 4096;
    scene.height_px = 3072;
    scene.radius_px = 1600;
    scene.wavelength_mm = 2.0;
    scene.amplitude_mm = 0.0764;
    scene.phase_angle_deg = 10.0;
    scene.samples_per_pixel = 1;
    in->image = RenderPhotograph(scene)->image;
    in->png = *EncodeImage(in->image, EncodeFormat::kPng16);
    in->image = *DecodeImage(in->png, DecodeOptions());
    in->luminance = Luminance(in->image);
    in->geometry = *DetectCylinder(in->luminance, CylinderDetectionOptions());
    in->acquisition.phase_angle_rad = 10.0 * kDeg;
    in->profile = *ExtractProfile(in->luminance, in->geometry,
                                  in->acquisition.GetProjection(), ProfileOptions());
    std::fprintf(stderr, "input: %dx%d 16-bit PNG, %zu bytes\n", in->image.width,
                 in->image.height, in->png.size());
    return in;
  }();
  return *input;
}

void BM_Decode(benchmark::State& state) {
  const Input& in = TheInput();
  DecodeOptions options;
  options.max_pixels = 1LL << 26;
  for (auto _ : state) benchmark::DoNotOptimize(DecodeImage(in.png, options));
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(in.png.size()));
}

void BM_DetectCylinder(benchmark::State& state) {
  const Input& in = TheInput();
  for (auto _ : state) {
    benchmark::DoNotOptimize(DetectCylinder(in.luminance, CylinderDetectionOptions()));
  }
}

// The argument is ProfileOptions::max_rows (0: every row; fast mode: 768).
void BM_ExtractProfile(benchmark::State& state) {
  const Input& in = TheInput();
  const Projection projection = in.acquisition.GetProjection();
  ProfileOptions options;
  options.max_rows = static_cast<int>(state.range(0));
  for (auto _ : state) {
    benchmark::DoNotOptimize(ExtractProfile(in.luminance, in.geometry, projection, options));
  }
}

void BM_PickPeaks(benchmark::State& state) {
  const Input& in = TheInput();
  const Projection projection = in.acquisition.GetProjection();
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        PickPeaks(in.profile, in.acquisition.phase_angle_rad, projection, PeakPickingOptions()));
  }
}

// The lobe fits (three models from two starting blurs) one after another,
// from peak picking's slope and smoothing, on a sinusoid of the size of a
// lab photograph (1280×960, m = 0.47 at α = 60°).
void BM_FitProfileModels(benchmark::State& state) {
  static const auto* lobe = [] {
    RenderScene scene;
    scene.width_px = 1280;
    scene.height_px = 960;
    scene.radius_px = 500;
    scene.amplitude_mm = 0.15;
    scene.phase_angle_deg = 60.0;
    scene.samples_per_pixel = 1;
    const Image luminance = Luminance(RenderPhotograph(scene)->image);
    const CylinderGeometry geometry = *DetectCylinder(luminance, CylinderDetectionOptions());
    Acquisition acquisition;
    acquisition.phase_angle_rad = scene.phase_angle_deg * kDeg;
    const Projection projection = acquisition.GetProjection();
    const Profile profile = *ExtractProfile(luminance, geometry, projection, ProfileOptions());
    const PeakPickingResult peaks =
        *PickPeaks(profile, acquisition.phase_angle_rad, projection, PeakPickingOptions());
    ProfileFitOptions options;
    options.smoothing_rad = peaks.smoothing_rad;
    options.lens_blur_px = geometry.lens_blur_px;
    options.half_width_px = geometry.radius_px;
    options.parallel = false;
    return new std::tuple<Profile, Acquisition, double, ProfileFitOptions>(
        profile, acquisition, peaks.max_slope, options);
  }();
  const auto& [profile, acquisition, max_slope, options] = *lobe;
  absl::StatusOr<ProfileFitResult> last;
  for (auto _ : state) {
    last = FitProfileModels(profile, acquisition.phase_angle_rad, acquisition.GetProjection(),
                            max_slope, options);
    benchmark::DoNotOptimize(last);
  }
  // That the work timed is the whole job: every model's fit converged.
  int converged = 0;
  if (last.ok()) {
    for (const ModelFit& f : last->fits) converged += f.converged ? 1 : 0;
  }
  state.counters["converged"] = converged;
}

// Everything after decoding, as the pipeline runs it.
// Every stage after decoding, in the mode given by the argument (1 fast,
// 2 balanced, 3 accurate); the counters are each stage's share of the last
// run, in ms.
void BM_AfterDecode(benchmark::State& state) {
  const Input& in = TheInput();
  EstimateOptions options;
  options.mode = static_cast<Mode>(state.range(0));
  absl::StatusOr<Estimate> last;
  for (auto _ : state) {
    last = EstimateFromImage(in.image, in.acquisition, options);
    benchmark::DoNotOptimize(last);
  }
  if (last.ok()) {
    for (const StageTime& t : last->timings) state.counters[t.stage + "_ms"] = t.milliseconds;
    // That the work timed is the whole job: the period was found.
    state.counters["wavelength_resolved"] = last->wavelength_mm.resolved ? 1 : 0;
  }
}

void BM_WholeEstimate(benchmark::State& state) {
  const Input& in = TheInput();
  EstimateOptions options;
  options.max_pixels = 1LL << 26;
  for (auto _ : state) {
    benchmark::DoNotOptimize(EstimateFromBytes(in.png, in.acquisition, options));
  }
}

BENCHMARK(BM_Decode)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_DetectCylinder)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ExtractProfile)->Arg(0)->Arg(768)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_PickPeaks)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_FitProfileModels)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_AfterDecode)->Arg(1)->Arg(2)->Arg(3)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_WholeEstimate)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace weavefit

BENCHMARK_MAIN();
