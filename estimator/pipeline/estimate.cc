#include "estimator/pipeline/estimate.h"

#include <chrono>
#include <cmath>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Wall time per stage, appended in order.
class StageClock {
 public:
  void Lap(const char* stage) {
    const auto now = std::chrono::steady_clock::now();
    laps_.push_back({stage, std::chrono::duration<double, std::milli>(now - last_).count()});
    last_ = now;
  }
  const std::vector<StageTime>& laps() const { return laps_; }

 private:
  std::vector<StageTime> laps_;
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

absl::StatusOr<Estimate> EstimateFromLuminance(const Image& image,
                                               const Acquisition& acquisition,
                                               const EstimateOptions& options,
                                               Estimate estimate,
                                               StageClock& clock) {
  // One channel is used as it is; three are reduced to luminance (a copy).
  Image converted;
  if (image.channels != 1) converted = Luminance(image);
  const Image& luminance = image.channels != 1 ? converted : image;
  CylinderDetectionOptions detection = options.detection;
  detection.region = acquisition.region;
  absl::StatusOr<CylinderGeometry> cylinder = DetectCylinder(luminance, detection);
  if (!cylinder.ok()) return cylinder.status();
  estimate.cylinder = *cylinder;
  clock.Lap("detect");


  const Projection projection = acquisition.GetProjection();
  absl::StatusOr<Profile> profile =
      ExtractProfile(luminance, *cylinder, projection, options.profile);
  if (!profile.ok()) return profile.status();
  clock.Lap("profile");

  absl::StatusOr<PeakPickingResult> peaks =
      PickPeaks(*profile, acquisition.phase_angle_rad, projection, options.peaks);
  if (!peaks.ok()) return peaks.status();
  clock.Lap("peaks");
  estimate.timings = clock.laps();

  estimate.method = "peak-picking";
  estimate.profile = *std::move(profile);
  estimate.smoothing_rad = peaks->smoothing_rad;
  estimate.model = peaks->model;
  estimate.specular_azimuth_rad = {peaks->mirror_rad, peaks->mirror_stderr_rad, true};
  if (peaks->split_resolved) {
    estimate.peak_spacing_rad = {peaks->spacing_rad, peaks->spacing_stderr_rad, true};
    estimate.max_slope = {peaks->max_slope, peaks->max_slope_stderr, true};
  }
  // Scores: minus the significance of the dip between the peaks for a
  // split, minus the decision threshold for a single peak; lower is better.
  const double split_score = -peaks->dip_sigmas;
  const double smooth_score = -options.peaks.min_dip_sigmas;
  const ProfileModel split_model =
      peaks->split_resolved ? peaks->model : ProfileModel::kSinusoid;
  estimate.candidates.push_back({ProfileModel::kSmooth, "peak-picking",
                                 smooth_score, !peaks->split_resolved});
  estimate.candidates.push_back({split_model, "peak-picking", split_score,
                                 peaks->split_resolved});
  estimate.warnings.insert(estimate.warnings.end(), peaks->warnings.begin(),
                           peaks->warnings.end());
  if (estimate.profile.saturated_samples > 0) {
    estimate.warnings.push_back(absl::StrCat(
        estimate.profile.saturated_samples,
        " saturated pixels on the cylinder were left out of the profile; "
        "lower the exposure if they fall on the peaks"));
  }
  estimate.warnings.push_back(
      "wavelength and amplitude are not measured by this version (the "
      "far-field profile fixes only the max slope; the glint periodicity "
      "analysis is not implemented yet)");
  return estimate;
}

}  // namespace

absl::Status Acquisition::Validate() const {
  if (!(phase_angle_rad > -M_PI && phase_angle_rad < M_PI)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "phase_angle_deg must be in (-180, 180), got %g", phase_angle_rad / kDeg));
  }
  if (!(cylinder_diameter_mm > 0.0) || !std::isfinite(cylinder_diameter_mm)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "cylinder_diameter_mm must be > 0, got %g", cylinder_diameter_mm));
  }
  if (!(camera_distance_mm >= 0.0) || !std::isfinite(camera_distance_mm)) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "camera_distance_mm must be >= 0 (0 = orthographic), got %g",
        camera_distance_mm));
  }
  if (camera_distance_mm > 0.0 && camera_distance_mm <= cylinder_diameter_mm / 2.0) {
    return absl::InvalidArgumentError(absl::StrFormat(
        "camera_distance_mm (%g) must exceed the cylinder radius (%g)",
        camera_distance_mm, cylinder_diameter_mm / 2.0));
  }
  if (region.x < 0 || region.y < 0 || region.width < 0 || region.height < 0) {
    return absl::InvalidArgumentError("roi fields must be >= 0");
  }
  if (!(saturation_level >= 0.0)) {
    return absl::InvalidArgumentError("saturation_level must be >= 0");
  }
  return absl::OkStatus();
}

absl::Status EstimateOptions::Validate() const {
  if (max_pixels <= 0) return absl::InvalidArgumentError("max_pixels must be > 0");
  if (absl::Status s = detection.Validate(); !s.ok()) return s;
  if (absl::Status s = profile.Validate(); !s.ok()) return s;
  return peaks.Validate();
}

std::string Estimate::BriefReport() const {
  if (!peak_spacing_rad.resolved) {
    return absl::StrFormat("%s, mirror %.2f±%.2f deg, split unresolved",
                           ProfileModelName(model), specular_azimuth_rad.value / kDeg,
                           specular_azimuth_rad.stderr_value / kDeg);
  }
  return absl::StrFormat("%s, spacing %.2f±%.2f deg, max slope %.4f±%.4f",
                         ProfileModelName(model), peak_spacing_rad.value / kDeg,
                         peak_spacing_rad.stderr_value / kDeg, max_slope.value,
                         max_slope.stderr_value);
}

absl::StatusOr<Estimate> EstimateFromImage(const Image& image,
                                           const Acquisition& acquisition,
                                           const EstimateOptions& options) {
  if (absl::Status s = acquisition.Validate(); !s.ok()) return s;
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  Estimate estimate;
  estimate.image = {image.width, image.height, image.channels, image.format,
                    image.bit_depth, image.SaturatedCount()};
  StageClock clock;
  return EstimateFromLuminance(image, acquisition, options, std::move(estimate), clock);
}

absl::StatusOr<Estimate> EstimateFromBytes(const std::string& bytes,
                                           const Acquisition& acquisition,
                                           const EstimateOptions& options) {
  if (absl::Status s = acquisition.Validate(); !s.ok()) return s;
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  Estimate estimate;
  StageClock clock;
  DecodeOptions decode;
  decode.pixels_linear = acquisition.pixels_linear;
  decode.saturation_level = acquisition.saturation_level;
  decode.max_pixels = options.max_pixels;
  absl::StatusOr<Image> image = DecodeImage(bytes, decode);
  if (!image.ok()) return image.status();
  clock.Lap("decode");
  estimate.image = {image->width, image->height, image->channels, image->format,
                    image->bit_depth, image->SaturatedCount()};
  return EstimateFromLuminance(*image, acquisition, options, std::move(estimate), clock);
}

}  // namespace weavefit
