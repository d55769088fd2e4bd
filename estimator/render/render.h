// A photograph renderer with known truth: the thread micro-geometry is
// integrated per pixel (not L(φ) evaluated), so the column average carries
// the comb of individual glints that real photographs show (DESIGN.md §3).
#ifndef WEAVEFIT_ESTIMATOR_RENDER_RENDER_H_
#define WEAVEFIT_ESTIMATOR_RENDER_RENDER_H_

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"
#include "estimator/io/image.h"
#include "estimator/optics/radiance.h"

namespace weavefit {

// Every parameter of a rendered scene. Angles in degrees, lengths in mm or
// px as named; radiance levels are fractions of the sensor's full scale.
struct RenderScene {
  int width_px = 640;
  int height_px = 480;
  ProfileModel model = ProfileModel::kSinusoid;
  double wavelength_mm = 2.0;   // thread undulation period λ
  double amplitude_mm = 0.08;   // h0 (sinusoid h0·sin, sawtooth ±h0)
  double diameter_mm = 46.0;
  double camera_distance_mm = 0.0;  // 0 = orthographic
  double phase_angle_deg = 10.0;    // signed, light on the right when > 0
  double center_x_px = -1.0;        // axis column at the middle row; <0 = centre
  double radius_px = -1.0;          // limb half-width; <0 = 40 % of the width
  double axis_angle_deg = 0.0;      // top of the axis toward the right when > 0
  int top_row_px = -1;              // first row of the cylinder; <0 = above the frame
  int bottom_row_px = -1;           // last row; <0 = below the frame
  double source_blur_deg = 0.6;     // angular σ of the source (blur in β is half)
  double exposure = 0.004;          // E0 in full-scale units (scales the lobe)
  // Reflectance of the threads along the axis relative to the circumferential
  // ones. They are small round specular cylinders: their glints add up to the
  // grazing scatter lobe ∝ cos(α/2)/cos φ (DESIGN.md §3).
  double axial_reflectance = 1.0;
  double diffuse = 0.0;             // Lambertian level
  double ambient = 0.03;            // uniform level of the cylinder body
  double background = 0.01;         // level outside the cylinder
  // A mount beyond the cylinder's ends (rows outside top/bottom_row_px): a
  // block 0.6 radii wide on the axis at this level; < 0 = no mount.
  double mount_level = -1.0;
  double gap_fraction = 0.15;       // share of each thread pitch showing axial threads
  // Largest out-of-plane tilt of a circumferential thread's surface at its
  // edges (0 = flat ribbons). A rounded thread glints only along its crest.
  double crest_tilt_deg = 6.0;
  double phase_step = 0.5;          // weave phase between neighbouring threads, periods
  bool regular_weave = false;       // no drift or jitter of the weave phase
  double phase_jitter = 0.04;       // per-thread random phase shift, in periods
  double phase_drift = 0.02;        // random-walk step of the phase, in periods
  double optics_blur_px = 0.0;      // Gaussian σ of the lens PSF, px
  double vignetting = 0.0;          // relative fall-off at the image corners
  // Colour: per-channel factors (R, G, B) of the circumferential threads,
  // the axial threads and the diffuse term; all 1 renders one channel.
  double specular_rgb[3] = {1.0, 1.0, 1.0};
  double axial_rgb[3] = {1.0, 1.0, 1.0};
  double diffuse_rgb[3] = {1.0, 1.0, 1.0};
  double photons_full_scale = 20000.0;  // Poisson gain; 0 = no shot noise
  double read_noise = 0.002;        // Gaussian σ in full-scale units
  int quantisation_bits = 12;       // sensor ADC; 0 = none
  int samples_per_pixel = 4;        // per axis (the arc gets 4× more)
  std::uint32_t seed = 1;

  absl::Status Validate() const;
  double MaxSlope() const;
  bool IsColour() const;
};

// The derived truth of a scene (library units except where named).
struct RenderTruth {
  double max_slope = 0.0;
  double peak_spacing_deg = 0.0;
  double mirror_azimuth_deg = 0.0;
  double center_x_px = 0.0;
  double radius_px = 0.0;
  double axis_angle_deg = 0.0;
  double px_per_period = 0.0;
  bool split_resolvable = false;
  bool period_resolvable = false;
};

struct Rendered {
  Image image;  // one channel, linear, full scale 1.0
  RenderTruth truth;
};

absl::StatusOr<Rendered> RenderPhotograph(const RenderScene& scene);

// The truth sidecar: every scene parameter and the derived truth, as JSON.
std::string TruthJson(const RenderScene& scene, const RenderTruth& truth,
                      const std::string& image_file);

}  // namespace weavefit

#endif  // WEAVEFIT_ESTIMATOR_RENDER_RENDER_H_
