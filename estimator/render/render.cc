#include "estimator/render/render.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_format.h"
#include "estimator/cylinder/azimuth_mapping.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Slope h′ of the thread profile at arc position s (mm).
double ThreadSlope(ProfileModel model, double max_slope, double wavelength_mm,
                   double s_mm) {
  const double cycles = s_mm / wavelength_mm;
  switch (model) {
    case ProfileModel::kSinusoid:
      return max_slope * std::cos(2.0 * M_PI * cycles);
    case ProfileModel::kSawtooth:
      return cycles - std::floor(cycles) < 0.5 ? max_slope : -max_slope;
    case ProfileModel::kSmooth:
      break;
  }
  return 0.0;
}

}  // namespace

double RenderScene::MaxSlope() const {
  switch (model) {
    case ProfileModel::kSinusoid:
      return SinusoidMaxSlope(amplitude_mm, wavelength_mm);
    case ProfileModel::kSawtooth:
      return SawtoothMaxSlope(amplitude_mm, wavelength_mm);
    case ProfileModel::kSmooth:
      break;
  }
  return 0.0;
}

absl::Status RenderScene::Validate() const {
  if (width_px < 16 || height_px < 16 || width_px > 16384 || height_px > 16384) {
    return absl::InvalidArgumentError("width_px and height_px must be in [16, 16384]");
  }
  if (!(wavelength_mm > 0)) return absl::InvalidArgumentError("wavelength_mm must be > 0");
  if (!(amplitude_mm >= 0)) return absl::InvalidArgumentError("amplitude_mm must be >= 0");
  if (!(diameter_mm > 0)) return absl::InvalidArgumentError("diameter_mm must be > 0");
  if (!(camera_distance_mm == 0 || camera_distance_mm > diameter_mm / 2)) {
    return absl::InvalidArgumentError("camera_distance_mm must be 0 or exceed the radius");
  }
  if (!(phase_angle_deg > -180 && phase_angle_deg < 180)) {
    return absl::InvalidArgumentError("phase_angle_deg must be in (-180, 180)");
  }
  if (!(source_blur_deg > 0)) return absl::InvalidArgumentError("source_blur_deg must be > 0");
  if (!(gap_fraction >= 0 && gap_fraction < 1)) {
    return absl::InvalidArgumentError("gap_fraction must be in [0, 1)");
  }
  if (samples_per_pixel < 1 || samples_per_pixel > 16) {
    return absl::InvalidArgumentError("samples_per_pixel must be in [1, 16]");
  }
  if (quantisation_bits < 0 || quantisation_bits > 16) {
    return absl::InvalidArgumentError("quantisation_bits must be in [0, 16]");
  }
  if (!(photons_full_scale >= 0) || !(read_noise >= 0)) {
    return absl::InvalidArgumentError("noise parameters must be >= 0");
  }
  return absl::OkStatus();
}

absl::StatusOr<Rendered> RenderPhotograph(const RenderScene& scene) {
  if (absl::Status s = scene.Validate(); !s.ok()) return s;
  const double width = scene.width_px;
  const double height = scene.height_px;
  const double cx = scene.center_x_px >= 0 ? scene.center_x_px : (width - 1) / 2.0;
  const double cy = (height - 1) / 2.0;
  const double radius_px = scene.radius_px > 0 ? scene.radius_px : 0.4 * width;
  const double tilt = scene.axis_angle_deg * kDeg;
  const double alpha = scene.phase_angle_deg * kDeg;
  const double m = scene.MaxSlope();
  const double sigma_beta = 0.5 * scene.source_blur_deg * kDeg;
  const Projection projection{scene.diameter_mm / 2.0, scene.camera_distance_mm};
  const double radius_mm = scene.diameter_mm / 2.0;
  const double mm_per_px = radius_mm / radius_px;  // along the axis, near it
  const double pitch_mm = scene.wavelength_mm / 2.0;  // plain weave
  const int top = scene.top_row_px >= 0 ? scene.top_row_px : -1000000;
  const int bottom = scene.bottom_row_px >= 0 ? scene.bottom_row_px : 1000000;

  // Weave phase per circumferential thread: half a period between
  // neighbours, plus (unless regular) a slow random walk and a jitter.
  std::mt19937 rng(scene.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double axis_length_mm = (height + width) * mm_per_px * 2.0;
  const int num_threads = static_cast<int>(std::ceil(axis_length_mm / pitch_mm)) + 4;
  const int first_thread = -num_threads / 2;
  std::vector<double> thread_phase_mm(num_threads);
  double walk = 0.0;
  for (int j = 0; j < num_threads; ++j) {
    double phase = ((first_thread + j) & 1) ? 0.5 * scene.wavelength_mm : 0.0;
    if (!scene.regular_weave) {
      walk += scene.phase_drift * normal(rng);
      phase += (walk + scene.phase_jitter * normal(rng)) * scene.wavelength_mm;
    }
    thread_phase_mm[j] = phase;
  }

  Rendered out;
  Image& image = out.image;
  image.width = scene.width_px;
  image.height = scene.height_px;
  image.channels = 1;
  image.pixels.assign(static_cast<std::size_t>(image.width) * image.height, 0.0f);
  const int sy_count = scene.samples_per_pixel;
  const int sx_count = 4 * scene.samples_per_pixel;
  const double inv_gauss = 1.0 / (std::sqrt(2.0 * M_PI) * sigma_beta);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      double sum = 0.0;
      for (int j = 0; j < sy_count; ++j) {
        const double v = y - 0.5 + (j + 0.5) / sy_count;
        for (int i = 0; i < sx_count; ++i) {
          const double u = x - 0.5 + (i + 0.5) / sx_count;
          const double axis_u = cx + (cy - v) * std::tan(tilt);
          const double offset = (u - axis_u) * std::cos(tilt) / radius_px;
          const double along_px = (cy - v) / std::cos(tilt) + (u - axis_u) * std::sin(tilt);
          const int row_on_axis = static_cast<int>(std::lround(cy - along_px));
          if (std::fabs(offset) >= 1.0 || row_on_axis < top || row_on_axis > bottom) {
            sum += scene.background;
            continue;
          }
          const double phi = AzimuthFromOffset(offset, projection);
          const double view = ViewAngleRad(phi, projection);
          const double mirror = 0.5 * (alpha + view);
          const double cos_phi = std::max(std::cos(phi), kMinCosAzimuth);
          double value = scene.ambient;
          // Scatter of the axial threads and Lambertian term (DESIGN.md §3).
          if (std::cos(phi - alpha) > 0) {
            value += scene.scatter * std::cos(alpha / 2.0) / cos_phi +
                     scene.diffuse * std::cos(phi - alpha);
          }
          const double z_mm = along_px * mm_per_px;
          const double pitches = z_mm / pitch_mm;
          const int thread = static_cast<int>(std::floor(pitches));
          const double across = pitches - thread;
          const bool in_gap = across < 0.5 * scene.gap_fraction ||
                              across > 1.0 - 0.5 * scene.gap_fraction;
          const int index = std::clamp(thread - first_thread, 0, num_threads - 1);
          if (!in_gap) {
            const double s_mm = radius_mm * phi + thread_phase_mm[index];
            const double beta = -std::atan(ThreadSlope(scene.model, m, scene.wavelength_mm, s_mm));
            const double eps = phi + beta - mirror;
            // Mirror radiance of a Gaussian source, E0·G(2ε; 2σ_β), times
            // the facet's projected width over the mean surface's
            // (DESIGN.md §3): cos(φ+β) / (cos β · cos φ).
            const double source = 0.5 * scene.exposure * inv_gauss *
                                  std::exp(-0.5 * eps * eps / (sigma_beta * sigma_beta));
            value += source * std::max(std::cos(phi + beta - view), 0.0) /
                     (std::cos(beta) * cos_phi) / (1.0 - scene.gap_fraction);
          }
          sum += value;
        }
      }
      image.pixels[static_cast<std::size_t>(y) * image.width + x] =
          static_cast<float>(sum / (sx_count * sy_count));
    }
  }

  // Sensor: Poisson–Gaussian noise, saturation at full scale, quantisation.
  const double levels = scene.quantisation_bits > 0 ? std::ldexp(1.0, scene.quantisation_bits) - 1 : 0.0;
  image.saturated.assign(image.pixels.size(), 0);
  for (std::size_t i = 0; i < image.pixels.size(); ++i) {
    double v = image.pixels[i];
    if (scene.photons_full_scale > 0) {
      std::poisson_distribution<long long> photons(std::max(v, 0.0) * scene.photons_full_scale);
      v = photons(rng) / scene.photons_full_scale;
    }
    v += scene.read_noise * normal(rng);
    v = std::clamp(v, 0.0, 1.0);
    if (levels > 0) v = std::round(v * levels) / levels;
    image.saturated[i] = v >= 1.0;
    image.pixels[i] = static_cast<float>(v);
  }

  RenderTruth& truth = out.truth;
  truth.max_slope = m;
  truth.peak_spacing_deg = PeakSpacingRad(m) / kDeg;
  truth.mirror_azimuth_deg = scene.phase_angle_deg / 2.0;
  truth.center_x_px = cx;
  truth.radius_px = radius_px;
  truth.axis_angle_deg = scene.axis_angle_deg;
  truth.px_per_period = scene.wavelength_mm / mm_per_px;
  // A split shows when the peaks stand further apart than about twice the
  // blur's full width at half maximum in azimuth (2.355·σ_β each).
  truth.split_resolvable = scene.model != ProfileModel::kSmooth &&
                           PeakSpacingRad(m) > 2.0 * 2.355 * sigma_beta;
  truth.period_resolvable = truth.px_per_period >= 4.0;
  return out;
}

std::string TruthJson(const RenderScene& s, const RenderTruth& t,
                      const std::string& image_file) {
  auto b = [](bool v) { return v ? "true" : "false"; };
  return absl::StrFormat(
      "{\n"
      "  \"image\": \"%s\",\n"
      "  \"acquisition\": {\n"
      "    \"phaseAngleDeg\": %.6g,\n"
      "    \"cylinderDiameterMm\": %.6g,\n"
      "    \"cameraDistanceMm\": %.6g\n"
      "  },\n"
      "  \"truth\": {\n"
      "    \"model\": \"%s\",\n"
      "    \"wavelengthMm\": %.6g,\n"
      "    \"amplitudeMm\": %.6g,\n"
      "    \"maxSlope\": %.6g,\n"
      "    \"peakSpacingDeg\": %.6g,\n"
      "    \"mirrorAzimuthDeg\": %.6g,\n"
      "    \"centerXPx\": %.6g,\n"
      "    \"radiusPx\": %.6g,\n"
      "    \"axisAngleDeg\": %.6g,\n"
      "    \"pxPerPeriod\": %.6g,\n"
      "    \"splitResolvable\": %s,\n"
      "    \"periodResolvable\": %s\n"
      "  },\n"
      "  \"scene\": {\n"
      "    \"widthPx\": %d, \"heightPx\": %d,\n"
      "    \"model\": \"%s\", \"wavelengthMm\": %.6g, \"amplitudeMm\": %.6g,\n"
      "    \"diameterMm\": %.6g, \"cameraDistanceMm\": %.6g, \"phaseAngleDeg\": %.6g,\n"
      "    \"centerXPx\": %.6g, \"radiusPx\": %.6g, \"axisAngleDeg\": %.6g,\n"
      "    \"topRowPx\": %d, \"bottomRowPx\": %d,\n"
      "    \"sourceBlurDeg\": %.6g, \"exposure\": %.6g, \"scatter\": %.6g,\n"
      "    \"diffuse\": %.6g, \"ambient\": %.6g, \"background\": %.6g,\n"
      "    \"gapFraction\": %.6g, \"regularWeave\": %s, \"phaseJitter\": %.6g,\n"
      "    \"phaseDrift\": %.6g, \"photonsFullScale\": %.6g, \"readNoise\": %.6g,\n"
      "    \"quantisationBits\": %d, \"samplesPerPixel\": %d, \"seed\": %u\n"
      "  }\n"
      "}\n",
      image_file, s.phase_angle_deg, s.diameter_mm, s.camera_distance_mm,
      ProfileModelName(s.model), s.wavelength_mm, s.amplitude_mm,
      t.max_slope, t.peak_spacing_deg, t.mirror_azimuth_deg, t.center_x_px,
      t.radius_px, t.axis_angle_deg, t.px_per_period, b(t.split_resolvable),
      b(t.period_resolvable), s.width_px, s.height_px, ProfileModelName(s.model),
      s.wavelength_mm, s.amplitude_mm, s.diameter_mm, s.camera_distance_mm,
      s.phase_angle_deg, t.center_x_px, t.radius_px, s.axis_angle_deg,
      s.top_row_px, s.bottom_row_px, s.source_blur_deg, s.exposure, s.scatter,
      s.diffuse, s.ambient, s.background, s.gap_fraction, b(s.regular_weave),
      s.phase_jitter, s.phase_drift, s.photons_full_scale, s.read_noise,
      s.quantisation_bits, s.samples_per_pixel, s.seed);
}

}  // namespace weavefit
