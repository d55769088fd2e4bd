// The whole estimate for one photograph: decode → detect cylinder → profile
// → peaks (DESIGN.md §1). Plain data in, plain data out; the daemon, the
// client and the benchmarks all call this.
#ifndef WEAVEFIT_ESTIMATOR_PIPELINE_ESTIMATE_H_
#define WEAVEFIT_ESTIMATOR_PIPELINE_ESTIMATE_H_

#include <cmath>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "estimator/cylinder/cylinder_detection.h"
#include "estimator/glints/comb_fit.h"
#include "estimator/glints/glint_period.h"
#include "estimator/glints/round_threads.h"
#include "estimator/glints/weave_lattice.h"
#include "estimator/fit/profile_fit.h"
#include "estimator/io/decode.h"
#include "estimator/io/image.h"
#include "estimator/optics/radiance.h"
#include "estimator/pipeline/given_cylinder.h"
#include "estimator/peaks/peak_picking.h"
#include "estimator/profile/profile_extraction.h"

namespace weavefit {

// What the lab knows about the photograph, in library units.
struct Acquisition {
  double phase_angle_rad = 0.0;        // signed, in (−π, π)
  // In [kMinDiameterMm, kMaxDiameterMm], or 0 = not given: then the
  // wavelength and amplitude are reported unresolved, their values in
  // cylinder radii in the reason (WithoutDiameter), never from a guessed
  // diameter; a camera distance needs it (perspective is R/D).
  double cylinder_diameter_mm = 0.0;
  double camera_distance_mm = 0.0;     // from the axis; 0 = orthographic
  PixelRegion region;                  // empty = whole image
  bool pixels_linear = false;          // skip sRGB decoding of 8-bit files
  double saturation_level = 0.0;       // file units; 0 = format maximum
  // The cylinder, when known beforehand (given by the user, or shared by a
  // series): used instead of detecting it (GeometryFromGiven). nullopt =
  // detect it on the photograph.
  std::optional<GivenCylinder> given_cylinder;

  // The physical ranges Validate holds a request to: those of a lab cylinder
  // with cloth wrapped round it, wide enough for any such set-up. From a
  // 0.1 mm wire (about one thread's thickness: no weave wraps round a thinner
  // one) to a 10 m drum (no lab photographs a larger one whole). A camera
  // farther than 1 km from the axis is no lab set-up either; a distant one
  // is given as 0 (orthographic). Outside them the numbers under- or
  // overflow rather than mean anything: a 1e-300 mm diameter gave NaN
  // standard errors marked resolved.
  static constexpr double kMinDiameterMm = 0.1;
  static constexpr double kMaxDiameterMm = 10000.0;
  static constexpr double kMaxCameraDistanceMm = 1e6;

  // OK, or INVALID_ARGUMENT naming the wire field and the constraint it
  // broke. The region is checked for its own consistency here (fields >= 0,
  // width and height both given or both 0), and a given cylinder's fields
  // (GivenCylinder::Validate); against the image's size by CheckRegion and
  // GeometryFromGiven, once the size is known.
  absl::Status Validate() const;
  bool HasDiameter() const { return cylinder_diameter_mm != 0.0; }
  Projection GetProjection() const {
    return Projection{cylinder_diameter_mm / 2.0, camera_distance_mm};
  }
};

// kFast: peak picking on the profile only (no wavelength); kBalanced: peak
// picking and the wavelength from the glints; kAccurate: besides, a
// least-squares fit of every candidate model, the lowest BIC chosen.
enum class Mode { kFast = 1, kBalanced = 2, kAccurate = 3 };

struct EstimateOptions {
  Mode mode = Mode::kBalanced;
  std::int64_t max_pixels = 64LL * 1024 * 1024;  // decoded width × height
  // Largest EstimateWorkingBytes a photograph may need, bytes (0 = no
  // limit): checked from the file's header before any pixel is decoded.
  std::int64_t max_working_bytes = 0;
  CylinderDetectionOptions detection;
  ProfileOptions profile;
  PeakPickingOptions peaks;
  AxialPitchOptions lattice;
  RoundThreadOptions round_threads;
  GlintPeriodOptions glints;
  CombFitOptions comb;
  int fit_max_iterations = 100;  // accurate mode's least-squares fits
  // Also return the curves a fit plot shows (Estimate::curves): the profile
  // as peak picking smoothed it and each model's least-squares fit to it (in
  // every mode; a plot costs the fits' time).
  bool include_curves = false;
  // Asked after every stage (decode, detect, profile, ...): a non-OK status
  // stops the estimate and is returned as it is. The daemon passes its
  // deadline and the client's cancellation here. Unset: never interrupted.
  std::function<absl::Status()> interrupt;

  absl::Status Validate() const;
};

// One measured quantity in library units. When !resolved, value and stderr
// are 0 and carry no meaning.
struct Quantity {
  double value = 0.0;
  double stderr_value = 0.0;
  bool resolved = false;
  // When !resolved: an upper bound the photograph does support (0 = none).
  double upper_bound = 0.0;
  // The part of stderr_value that is an allowance for what the models leave
  // out (the error floors, the limb edge's placement, peaks located on the
  // profile's bins), as opposed to what the photograph's noise and texture
  // scatter: stderr_value² = statistical² + systematic². Repeated
  // photographs of one set-up share it; the statistical part is what they
  // spread by.
  double systematic = 0.0;
  // The part of `systematic` that photographs of the sample at other phase
  // angles or placements share too (the models' floors, the limb's
  // allowance: biases of one sign), so that a joint estimate does not
  // average it away. The rest (peaks on the bins, the glint comb's
  // positions) moves with the geometry and averages like noise.
  double common = 0.0;

  double Statistical() const {
    const double s2 = stderr_value * stderr_value - systematic * systematic;
    return s2 > 0.0 ? std::sqrt(s2) : 0.0;
  }
};

struct CandidateScore {
  ProfileModel model = ProfileModel::kSmooth;
  std::string method;
  double score = 0.0;  // lower is better
  bool selected = false;
};

// A curve over the azimuthal profile, for plots: peak picking's smoothed
// profile, or one model's least-squares fit to it.
struct ModelCurve {
  std::string label;  // "smoothed profile", "SINUSOID fit", ...
  ProfileModel model = ProfileModel::kSmooth;
  bool selected = false;  // the model the estimate reports
  std::vector<double> azimuth_rad;
  std::vector<double> value;  // profile units
};

struct StageTime {
  std::string stage;
  double milliseconds = 0.0;
};

struct ImageSummary {
  int width = 0;
  int height = 0;
  int channels = 0;
  std::string format;
  int bit_depth = 0;
  std::int64_t saturated_pixels = 0;
};

// One colour channel of a three-channel photograph (library units).
struct ChannelSummary {
  std::string channel;  // "R", "G", "B"
  ProfileModel model = ProfileModel::kSmooth;
  Quantity peak_spacing_rad;
  Quantity specular_azimuth_rad;
  double lobe_level = 0.0;     // highest lobe level above the background
  double grazing_level = 0.0;  // mean level at 70–84° toward the light, above the background
};

// The largest inclination of a thread to the cloth's surface, arctan of the
// max slope m, in radians: the u_max of Irawan & Marschner's woven-cloth
// model, and half the peak spacing (DESIGN.md §2). Its standard error is the
// slope's carried through d(arctan m)/dm = 1/(1 + m²); an unresolved slope
// gives an unresolved inclination bounded by arctan of the slope's bound
// (0 = no bound).
Quantity MaxInclinationFromSlope(const Quantity& max_slope);

// The peak spacing 2·arctan(m) of a resolved max slope, its errors (both
// shares) carried through 2/(1 + m²). An unresolved slope gives an
// unresolved spacing bounded by the slope's bound.
Quantity SpacingFromSlope(const Quantity& max_slope);

// The amplitude h0 (DESIGN.md §2): m·λ/(2π) for a sinusoid, m·λ/4 for a
// sawtooth; relative errors, and their systematic shares, in quadrature.
// Unresolved unless both are resolved.
Quantity AmplitudeFrom(ProfileModel model, const Quantity& max_slope,
                       const Quantity& wavelength_mm);

struct Estimate {
  ProfileModel model = ProfileModel::kSmooth;
  Quantity peak_spacing_rad;
  Quantity max_slope;
  Quantity max_inclination_rad;  // MaxInclinationFromSlope(max_slope)
  Quantity wavelength_mm;
  Quantity amplitude_mm;
  Quantity specular_azimuth_rad;
  CylinderGeometry cylinder;
  CylinderSource cylinder_source = CylinderSource::kDetected;  // where `cylinder` came from
  std::vector<CandidateScore> candidates;
  std::vector<std::string> warnings;
  std::vector<StageTime> timings;
  ImageSummary image;
  std::string method;
  // What it was asked: the acquisition as given (its diameter 0 where none
  // was) and the mode, so that a result stands on its own.
  Acquisition acquisition;
  Mode mode = Mode::kBalanced;
  // The azimuthal profile the estimate was made from, and the smoothing
  // (σ, rad) the peaks were located at: for plots and diagnostics.
  Profile profile;
  double smoothing_rad = 0.0;
  // Per colour channel, for three-channel photographs; empty otherwise.
  std::vector<ChannelSummary> channels;
  // With EstimateOptions::include_curves; empty otherwise.
  std::vector<ModelCurve> curves;
  // The least-squares fits of the lobe, where they ran (FitProfileModels;
  // empty otherwise): what the model was chosen from (estimator/select).
  ProfileFitResult lobe_fits;
  // The BIC per independent bin by which the chosen lobe fit beat the other
  // split model's (ModelChoice::evidence) where a lobe fit's numbers were
  // taken; 0 where peak picking's reading stands.
  double model_evidence = 0.0;
  // One line for logs: model, spacing and slope with their errors.
  std::string BriefReport() const;
};

// The most memory an estimate of this encoded photograph holds at once,
// bytes, from its header alone: what decoding holds (DecodedBytes), the
// luminance copy of a colour image, and the detection's and profile's
// working arrays (a float per pixel at most). The daemon admits estimates
// against its memory budget with it. INVALID_ARGUMENT for an unreadable
// header.
absl::StatusOr<std::int64_t> EstimateWorkingBytes(const std::string& bytes);

// OK when `region` (empty = the whole image) lies inside a width × height
// image; otherwise INVALID_ARGUMENT naming the wire fields (roi.x_px, ...)
// that reach past it. The sums are taken in 64 bits, so that no pair of
// 32-bit request fields can wrap round to pass. The pipeline calls it from
// the file's header, before any pixel is allocated, and for a decoded image.
absl::Status CheckRegion(const PixelRegion& region, int width, int height);

// Estimates from an encoded file. INVALID_ARGUMENT for undecodable or
// inconsistent input (including "no cylinder found", and a given cylinder
// that does not fit the image: checked from the file's header, before
// decoding), RESOURCE_EXHAUSTED when the image exceeds options.max_pixels or options.max_working_bytes.
absl::StatusOr<Estimate> EstimateFromBytes(const std::string& bytes,
                                           const Acquisition& acquisition,
                                           const EstimateOptions& options);
// The same, releasing the file's bytes as soon as they are decoded: the
// pipeline then holds the decoded image alone (a 12 Mpx 16-bit PNG is 14 MB
// beside the 50 MB image).
absl::StatusOr<Estimate> EstimateFromBytes(std::string&& bytes, const Acquisition& acquisition,
                                           const EstimateOptions& options);

// The same from a decoded image (any number of channels).
absl::StatusOr<Estimate> EstimateFromImage(const Image& image,
                                           const Acquisition& acquisition,
                                           const EstimateOptions& options);

// The cylinder alone, as the estimate of these bytes would detect it (the
// acquisition's region, phase angle and projection; the same limits), with
// the image's size: what a series detects on each of its photographs
// before it combines them (CombineCylinders). The acquisition's given
// cylinder, if any, is ignored. The errors are EstimateFromBytes's. With
// `trace`, what detection saw (DetectCylinder), filled when it got as far
// as reading the photograph, refused or not.
struct DetectedCylinder {
  CylinderGeometry cylinder;
  int width = 0;
  int height = 0;
};
absl::StatusOr<DetectedCylinder> DetectCylinderInBytes(const std::string& bytes,
                                                       const Acquisition& acquisition,
                                                       const EstimateOptions& options,
                                                       DetectionTrace* trace = nullptr);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_PIPELINE_ESTIMATE_H_
