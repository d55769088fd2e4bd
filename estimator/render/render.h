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
  // A sawtooth's share of arc in its rounded corners, where the slope turns
  // from one flank's to the other's at a constant rate (circular-arc
  // corners, half the share at each); 0 = sharp corners.
  double corner_share = 0.0;
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
  // block on the axis, mount_half_width radii to either side, at this level;
  // < 0 = no mount.
  double mount_level = -1.0;
  double mount_half_width = 0.6;    // half-width of the mount, cylinder radii
  // Stray light (a lab's room, walls and camera side): a broad diffuse source
  // that lights the whole body, the side away from the lamp included. A
  // facet whose normal makes θ with the camera direction sees (1 + cos θ)/2
  // of it (a uniform hemisphere on the camera's side), and the weave's relief
  // shades it: crests of the threads get all, the bottoms of the gaps
  // between the axial threads 1 − stray_texture of it.
  double stray_light = 0.0;         // level of a fully exposed crest facing the camera; 0 = none
  double stray_texture = 0.6;       // share of the stray light the relief shades in the deepest gaps
  // Axial threads resolved one by one: each glints as a line along the axis
  // whose width is this share of the axial pitch λ/2, carrying the mean of
  // the grazing lobe over its pitch; 0 = unresolved, a uniform lobe across
  // each gap.
  double axial_glint_width = 0.0;   // share of λ/2
  // Plain weave: an axial thread floats over each other circumferential
  // thread, at that thread's trough, over this share of λ/2 of the arc; the
  // axial thread hides the circumferential one there. 0 = axial threads are
  // seen in the gaps only.
  double axial_float_width = 0.0;   // share of λ/2
  // A lit backdrop: the background level changes linearly across the frame
  // by background_gradient from one edge to the other, brightening toward
  // background_gradient_deg (0 = toward the right, 90 = toward the bottom).
  double background_gradient = 0.0;     // full-scale units over the frame
  double background_gradient_deg = 0.0; // direction, deg
  double black_level = 0.0;         // sensor pedestal kept in the file, full-scale units
  // The file's value of a saturated sample, a share of its full scale: a
  // sensor whose ADC has fewer bits than the file stores its codes shifted
  // up (12 bits in 16: 65520 of 65535, 0.99977), and a raw converter's
  // white level may lie anywhere below the maximum. Clipped samples then
  // pile up there, not at the format's maximum.
  double white_level = 1.0;
  double gap_fraction = 0.15;       // share of each thread pitch showing axial threads
  // Largest out-of-plane tilt of a circumferential thread's surface at its
  // edges (0 = flat ribbons). A rounded thread glints only along its crest.
  double crest_tilt_deg = 6.0;
  // Thread relief parallax (DESIGN.md §3): the circumferential threads
  // stand up to h0 off the mean cylinder, so a ray meets a thread at an
  // azimuth other than the mean surface's, z·tan(φ − v)/R from it (z the
  // height there): toward the limb the two glints of a period move apart or
  // together by up to 2·h0·tan(φ − v) of arc. Where the relief folds over
  // itself (m·tan(φ − v) > 1) the ray's nearest point is the one seen; a
  // crest's shadow on the next thread is not modelled. Off: every ray meets
  // the mean cylinder, the facet's tilt weighting its light instead.
  bool relief_parallax = false;
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
