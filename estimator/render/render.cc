#include "estimator/render/render.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "estimator/cylinder/azimuth_mapping.h"

#include <opencv2/imgproc.hpp>
#include <thread>

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Slope h′ of the thread profile at arc position s (mm). A sawtooth's
// corners (at the crest, half a period in, and at the trough) turn the slope
// linearly over `corner_share`/2 of a period each.
double ThreadSlope(ProfileModel model, double max_slope, double wavelength_mm,
                   double s_mm, double corner_share) {
  const double cycles = s_mm / wavelength_mm;
  switch (model) {
    case ProfileModel::kSinusoid:
      return max_slope * std::cos(2.0 * M_PI * cycles);
    case ProfileModel::kSawtooth: {
      const double f = cycles - std::floor(cycles);
      const double half_corner = 0.25 * corner_share;  // cycles either side of a corner
      const double to_crest = 0.5 - f;
      const double from_trough = f < 0.5 ? f : f - 1.0;
      if (std::fabs(to_crest) < half_corner) return max_slope * to_crest / half_corner;
      if (std::fabs(from_trough) < half_corner) return max_slope * from_trough / half_corner;
      return f < 0.5 ? max_slope : -max_slope;
    }
    case ProfileModel::kSmooth:
      break;
  }
  return 0.0;
}

// Height of the thread profile at arc position s, in units of h0: from −1
// at a trough to +1 at a crest (the integral of ThreadSlope; a sawtooth's
// rounded corners, which lower it by at most corner_share/4 of h0 near the
// crest and trough, are left out: it only shades the stray light).
double ThreadHeight(ProfileModel model, double wavelength_mm, double s_mm) {
  const double cycles = s_mm / wavelength_mm;
  const double f = cycles - std::floor(cycles);
  switch (model) {
    case ProfileModel::kSinusoid:
      return std::sin(2.0 * M_PI * cycles);
    case ProfileModel::kSawtooth:
      return f < 0.5 ? 4.0 * f - 1.0 : 3.0 - 4.0 * f;
    case ProfileModel::kSmooth:
      break;
  }
  return 0.0;
}

// Where in its period (cycles) a circumferential thread has its trough: in a
// plain weave an axial thread passes over it there, and under it at the
// crest half a period on; the axial threads lie λ/2 apart.
double TroughCycles(ProfileModel model) {
  return model == ProfileModel::kSinusoid ? 0.75 : 0.0;
}

// Axial threads resolved one by one. q is the arc position in axial pitches
// (λ/2), with a thread's centre at every integer; each thread's glint is a
// line of width f (pitches) centred `shift` from the thread's centre and
// carrying the mean lobe of one pitch. Returns a sample's mean over
// [q − dq/2, q + dq/2] in units of that mean lobe (integrated exactly, since
// the lines are narrower than a pixel).
double AxialLines(double q, double dq, double shift, double f) {
  const double lo = q - 0.5 * dq;
  const double hi = q + 0.5 * dq;
  double overlap = 0.0;
  for (double k = std::floor(lo - shift - f); k <= std::ceil(hi - shift + f); k += 1.0) {
    const double a = std::max(lo, k + shift - 0.5 * f);
    const double b = std::min(hi, k + shift + 0.5 * f);
    if (b > a) overlap += b - a;
  }
  return overlap / (f * dq);
}

// Mean of exp(−(κ·(t − ½))²/2) over t in [t0, t1]: the share of a rounded
// thread's cross-section whose out-of-plane tilt still sends the source into
// the camera (the tilt grows linearly from the crest at t = ½).
double CrestFactor(double t0, double t1, double kappa) {
  if (kappa < 1e-9 || t1 <= t0) return 1.0;
  const double a = kappa * (t0 - 0.5) / std::sqrt(2.0);
  const double b = kappa * (t1 - 0.5) / std::sqrt(2.0);
  return std::sqrt(M_PI / 2.0) / (kappa * (t1 - t0)) * (std::erf(b) - std::erf(a));
}

// The geometric terms of one surface sample, before colour and exposure.
struct Terms {
  bool on_cylinder = false;
  bool mount = false;     // on the mount beyond a cylinder end
  double specular = 0.0;  // circumferential threads, per unit E0
  double axial = 0.0;     // axial threads, per unit E0
  double diffuse = 0.0;   // max(0, cos(φ − α))
  double stray = 0.0;     // share of the stray light sent to the camera
};

// Everything per scene that the per-sample geometry needs.
class Sampler {
 public:
  explicit Sampler(const RenderScene& scene) : scene_(scene) {
    cx_ = scene.center_x_px >= 0 ? scene.center_x_px : (scene.width_px - 1) / 2.0;
    cy_ = (scene.height_px - 1) / 2.0;
    radius_px_ = scene.radius_px > 0 ? scene.radius_px : 0.4 * scene.width_px;
    const double tilt = scene.axis_angle_deg * kDeg;
    tan_tilt_ = std::tan(tilt);
    cos_tilt_ = std::cos(tilt);
    sin_tilt_ = std::sin(tilt);
    alpha_ = scene.phase_angle_deg * kDeg;
    m_ = scene.MaxSlope();
    sigma_beta_ = 0.5 * scene.source_blur_deg * kDeg;
    projection_ = Projection{scene.diameter_mm / 2.0, scene.camera_distance_mm};
    radius_mm_ = scene.diameter_mm / 2.0;
    mm_per_px_ = radius_mm_ / radius_px_;
    pitch_mm_ = scene.wavelength_mm / 2.0;  // plain weave
    h0_mm_ = scene.amplitude_mm;
    top_ = scene.top_row_px >= 0 ? scene.top_row_px : -1000000;
    bottom_ = scene.bottom_row_px >= 0 ? scene.bottom_row_px : 1000000;
    inv_gauss_ = 1.0 / (std::sqrt(2.0 * M_PI) * sigma_beta_);
    // Crest: out-of-plane tilt γ = γmax·(2t − 1) across the thread (t in
    // [0, 1]); an out-of-plane normal tilt γ turns the reflected ray by
    // 2γ·cos h, against a source of angular σ. Normalised to the whole
    // thread at h = 0, so that `exposure` keeps its meaning and only the
    // 1/cos(α/2) growth of the level remains (DESIGN.md §3).
    const double gamma_max = scene.crest_tilt_deg * kDeg;
    crest_kappa0_ = 4.0 * gamma_max / (scene.source_blur_deg * kDeg);
    crest_norm_ = CrestFactor(0.0, 1.0, crest_kappa0_);
    stray_ = scene.stray_light > 0.0;
    resolved_lines_ = scene.axial_glint_width > 0.0;
    axial_coordinates_ = stray_ || resolved_lines_;
    // Axial threads half their pitch thick, or as wide as they float.
    axial_radius_ = scene.axial_float_width > 0.0 ? 0.5 * scene.axial_float_width : 0.25;
    trough_cycles_ = TroughCycles(scene.model);

    // Weave phase per circumferential thread: phase_step periods between
    // neighbours (½ for a plain weave) plus, unless regular, a slow random
    // walk and a jitter.
    std::mt19937 rng(scene.seed);
    std::normal_distribution<double> normal(0.0, 1.0);
    const double axis_length_mm = (scene.height_px + scene.width_px) * mm_per_px_ * 2.0;
    num_threads_ = static_cast<int>(std::ceil(axis_length_mm / pitch_mm_)) + 4;
    first_thread_ = -num_threads_ / 2;
    thread_phase_mm_.resize(num_threads_);
    double walk = 0.0;
    for (int j = 0; j < num_threads_; ++j) {
      double cycles = scene.phase_step * (first_thread_ + j);
      if (!scene.regular_weave) {
        walk += scene.phase_drift * normal(rng);
        cycles += walk + scene.phase_jitter * normal(rng);
      }
      thread_phase_mm_[j] = cycles * scene.wavelength_mm;
    }
  }

  double cx() const { return cx_; }
  double radius_px() const { return radius_px_; }
  double max_slope() const { return m_; }
  double mm_per_px() const { return mm_per_px_; }
  double sigma_beta() const { return sigma_beta_; }

  // Whether a pixel centred at (x, y) may hold an in-plane glint, so that
  // it needs the fine sampling along the arc.
  bool MayGlint(double x, double y) const {
    const double offset = Offset(x, y);
    if (std::fabs(offset) >= 1.0) return false;
    const double phi = AzimuthFromOffset(offset, projection_);
    const double mirror = 0.5 * (alpha_ + ViewAngleRad(phi, projection_));
    const double pixel_rad = 1.5 / (radius_px_ * std::max(std::cos(phi), 0.05));
    // A glint may be seen up to the relief's parallax from its facet.
    const double parallax_rad =
        scene_.relief_parallax
            ? h0_mm_ * std::fabs(std::tan(phi - ViewAngleRad(phi, projection_))) / radius_mm_
            : 0.0;
    return std::fabs(phi - mirror) <= std::atan(m_) + 7.0 * sigma_beta_ + pixel_rad + parallax_rad;
  }

  // The sample at image point (u, v) covering du × dv pixels.
  Terms Sample(double u, double v, double du, double dv) const {
    Terms t;
    const double axis_u = cx_ + (cy_ - v) * tan_tilt_;
    const double offset = (u - axis_u) * cos_tilt_ / radius_px_;
    const double along_px = (cy_ - v) / cos_tilt_ + (u - axis_u) * sin_tilt_;
    const int row_on_axis = static_cast<int>(std::lround(cy_ - along_px));
    if (row_on_axis < top_ || row_on_axis > bottom_) {
      t.mount = scene_.mount_level >= 0.0 && std::fabs(offset) < scene_.mount_half_width;
      return t;
    }
    if (std::fabs(offset) >= 1.0) return t;
    t.on_cylinder = true;
    const double phi = AzimuthFromOffset(offset, projection_);
    const double view = ViewAngleRad(phi, projection_);
    const double mirror = 0.5 * (alpha_ + view);  // facet normal that mirrors
    const double cos_h = std::cos(mirror - view);  // incidence on that facet
    const double cos_phi = std::max(std::cos(phi), kMinCosAzimuth);
    t.diffuse = std::max(0.0, std::cos(phi - alpha_));

    const double pitches = along_px * mm_per_px_ / pitch_mm_;
    const int thread = static_cast<int>(std::floor(pitches));
    const double across = pitches - thread;
    const double g = scene_.gap_fraction;
    // Axial thread: a small round specular cylinder whose normal sweeps
    // ψ over (−90°, 90°) around φ with density cos ψ / 2 per mean arc.
    // Its glint (at ψ* = mirror − φ) is far narrower than a pixel, so it
    // is integrated analytically: E0/2 · cos h · p(ψ*) / (cos ψ* · cos φ).
    // Only where the surface is lit: a thread lying in the cylinder's own
    // shadow (light below its local horizon, φ < α − 90°) gets none.
    const double axial_lobe =
        t.diffuse > 0.0 && std::fabs(mirror - phi) < M_PI / 2.0 ? 0.25 * cos_h / cos_phi : 0.0;
    // The axial threads one by one: arc in axial pitches, a sample's width
    // in them, and the glint's place on a round thread (radius in pitches).
    const double dq = du * mm_per_px_ * cos_tilt_ / cos_phi / pitch_mm_;
    const double shift = axial_radius_ * std::sin(mirror - phi);
    auto axial = [&](double q) {
      return resolved_lines_ ? axial_lobe * AxialLines(q, dq, shift, scene_.axial_glint_width)
                             : axial_lobe;
    };
    if (across < 0.5 * g || across > 1.0 - 0.5 * g) {
      if (!axial_coordinates_) {
        t.axial = axial_lobe;
        return t;
      }
      // The gap between two circumferential threads: the axial threads lie
      // at the troughs and crests of the thread beyond this boundary.
      const double q = AxialPitches(across < 0.5 ? thread : thread + 1, phi);
      t.axial = axial(q);
      const double w = q - std::round(q);  // from the nearest axial thread's centre
      if (stray_) t.stray = Stray(phi - view, 0.5 * Round(w / axial_radius_));
      return t;
    }
    const int index = std::clamp(thread - first_thread_, 0, num_threads_ - 1);
    // The point of the thread the ray meets (RenderScene::relief_parallax),
    // and the mean surface's point there otherwise.
    const double seen = scene_.relief_parallax ? VisibleAzimuth(phi, view, index) : phi;
    const double s_mm = radius_mm_ * seen + thread_phase_mm_[index];
    if (scene_.axial_float_width > 0.0) {
      // An axial thread floating over this thread at its trough hides it.
      const double q = AxialPitches(thread, seen);
      const double w = q - 2.0 * std::round(0.5 * q);  // from the nearest trough
      if (std::fabs(w) < 0.5 * scene_.axial_float_width) {
        t.axial = axial(q);
        if (stray_) t.stray = Stray(phi - view, 0.5 + 0.5 * Round(w / (0.5 * scene_.axial_float_width)));
        return t;
      }
    }
    const double slope = ThreadSlope(scene_.model, m_, scene_.wavelength_mm, s_mm,
                                     scene_.corner_share);
    const double beta = -std::atan(slope);
    const double t_mid = (across - 0.5 * g) / (1.0 - g);
    if (stray_) {
      // Relief: half from the undulation (crest high), half from the round
      // cross-section (the thread's middle high, its edges at the gaps low).
      const double height = ThreadHeight(scene_.model, scene_.wavelength_mm, s_mm);
      t.stray = Stray(phi + beta - view, 0.25 * (1.0 + height) + 0.5 * Round(2.0 * t_mid - 1.0));
    }
    const double eps = seen + beta - mirror;
    // Far outside the source's reach: no glint (saves the rest).
    if (std::fabs(eps) > 8.0 * sigma_beta_) return t;
    const double cos_beta = 1.0 / std::sqrt(1.0 + slope * slope);
    // Mirror radiance of a Gaussian source, E0·G(2ε; 2σ_β), times the facet's
    // projected width over the mean surface's (DESIGN.md §3):
    // cos(φ+β−v) / (cos β · cos φ); the thread covers 1 − g of the pitch.
    // That width is cos(φ − v)·(1 + h′·tan(φ − v)) / cos φ, the factor in
    // brackets being how much more of the image a facet of slope h′ takes
    // than the mean surface at φ: where the rays meet the threads
    // themselves, the sampling along the arc already counts it.
    const double width = scene_.relief_parallax
                             ? std::cos(seen - view) / std::max(std::cos(seen), kMinCosAzimuth)
                             : std::max(std::cos(phi + beta - view), 0.0) / (cos_beta * cos_phi);
    const double in_plane = 0.5 * inv_gauss_ *
                            std::exp(-0.5 * eps * eps / (sigma_beta_ * sigma_beta_)) * width /
                            (1.0 - g);
    // Crest factor over this sample's share of the thread's width.
    const double half = 0.5 * dv * mm_per_px_ / pitch_mm_ / (1.0 - g);
    const double crest = CrestFactor(std::max(t_mid - half, 0.0), std::min(t_mid + half, 1.0),
                                     crest_kappa0_ * cos_h) / crest_norm_;
    t.specular = in_plane * crest;
    return t;
  }

 private:
  double Offset(double x, double y) const {
    const double axis_u = cx_ + (cy_ - y) * tan_tilt_;
    return (x - axis_u) * cos_tilt_ / radius_px_;
  }

  // Arc position at azimuth φ in axial pitches (λ/2) from circumferential
  // thread `thread`'s trough: an axial thread at every integer, passing over
  // this thread at the even ones and under it at the odd ones.
  double AxialPitches(int thread, double phi) const {
    const int index = std::clamp(thread - first_thread_, 0, num_threads_ - 1);
    const double s_mm = radius_mm_ * phi + thread_phase_mm_[index];
    return 2.0 * (s_mm / scene_.wavelength_mm - trough_cycles_);
  }

  // The azimuth at which the ray through the mean surface's point `phi`
  // (seen from view angle `view`) meets circumferential thread `index`: a
  // point at height z off the mean cylinder at azimuth ψ is seen where the
  // mean surface's ψ + z·tan(φ − v)/R is, to first order in z/R. Every root
  // lies within h0·|tan(φ − v)|/R of φ; where the relief folds there are
  // several, and the one nearest the camera is seen.
  double VisibleAzimuth(double phi, double view, int index) const {
    const double tan_view = std::tan(phi - view);
    const double reach = h0_mm_ * std::fabs(tan_view) / radius_mm_;
    if (!(reach > 0.0)) return phi;
    auto height = [&](double psi) {
      return h0_mm_ * ThreadHeight(scene_.model, scene_.wavelength_mm,
                                   radius_mm_ * psi + thread_phase_mm_[index]);
    };
    auto miss = [&](double psi) { return psi + height(psi) * tan_view / radius_mm_ - phi; };
    // Steps of a sixteenth of a period bracket every root (the miss turns
    // at most twice a period).
    const double step_rad = scene_.wavelength_mm / 16.0 / radius_mm_;
    const int steps = std::max(2, static_cast<int>(std::ceil(2.0 * reach / step_rad)));
    double best = phi, best_depth = -std::numeric_limits<double>::infinity();
    double a = phi - reach, fa = miss(a);
    for (int i = 1; i <= steps; ++i) {
      const double b = phi - reach + 2.0 * reach * i / steps;
      const double fb = miss(b);
      if ((fa <= 0.0) != (fb <= 0.0) || fb == 0.0) {
        double lo = a, hi = b, flo = fa;
        for (int k = 0; k < 40; ++k) {
          const double mid = 0.5 * (lo + hi);
          const double fm = miss(mid);
          if ((fm <= 0.0) == (flo <= 0.0)) {
            lo = mid;
            flo = fm;
          } else {
            hi = mid;
          }
        }
        const double root = 0.5 * (lo + hi);
        const double depth = (radius_mm_ + height(root)) * std::cos(root - view);
        if (depth > best_depth) {
          best_depth = depth;
          best = root;
        }
      }
      a = b;
      fa = fb;
    }
    return best;
  }

  // Height of a round cross-section at x radii from its middle, 0 to 1.
  static double Round(double x) { return std::sqrt(std::max(0.0, 1.0 - x * x)); }

  // Share of the stray light a facet sends to the camera: (1 + cos θ)/2 of a
  // uniform hemisphere on the camera's side reaches a facet whose normal
  // makes θ with the camera, and the relief (z = 1 at a crest, 0 at the
  // bottom of a gap) shades all but 1 − stray_texture·(1 − z) of it.
  double Stray(double theta, double z) const {
    return 0.5 * (1.0 + std::cos(theta)) * (1.0 - scene_.stray_texture * (1.0 - z));
  }

  const RenderScene& scene_;
  double cx_, cy_, radius_px_, tan_tilt_, cos_tilt_, sin_tilt_, alpha_, m_, sigma_beta_;
  Projection projection_;
  double radius_mm_, mm_per_px_, pitch_mm_, h0_mm_;
  int top_, bottom_;
  double inv_gauss_, crest_kappa0_, crest_norm_;
  bool stray_ = false;              // stray light on: the relief is needed
  bool resolved_lines_ = false;     // axial threads as separate glint lines
  bool axial_coordinates_ = false;  // the gaps need the axial threads' places
  double axial_radius_ = 0.25;      // an axial thread's radius, axial pitches
  double trough_cycles_ = 0.0;
  int num_threads_ = 0;
  int first_thread_ = 0;
  std::vector<double> thread_phase_mm_;
};

// Mirror azimuth of a smooth cylinder: φ = (α + v(φ))/2, by fixed point.
double MirrorAzimuth(double alpha, const Projection& projection) {
  double phi = alpha / 2.0;
  for (int i = 0; i < 50; ++i) phi = 0.5 * (alpha + ViewAngleRad(phi, projection));
  return phi;
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

bool RenderScene::IsColour() const {
  for (int c = 0; c < 3; ++c) {
    if (specular_rgb[c] != 1.0 || axial_rgb[c] != 1.0 || diffuse_rgb[c] != 1.0) return true;
  }
  return false;
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
  if (!(crest_tilt_deg >= 0 && crest_tilt_deg < 90)) {
    return absl::InvalidArgumentError("crest_tilt_deg must be in [0, 90)");
  }
  if (!(optics_blur_px >= 0 && optics_blur_px <= 50)) {
    return absl::InvalidArgumentError("optics_blur_px must be in [0, 50]");
  }
  if (!(vignetting >= 0 && vignetting < 1)) {
    return absl::InvalidArgumentError("vignetting must be in [0, 1)");
  }
  if (!(mount_half_width > 0 && mount_half_width <= 100)) {
    return absl::InvalidArgumentError("mount_half_width must be in (0, 100] radii");
  }
  if (!(stray_light >= 0 && stray_light <= 1)) {
    return absl::InvalidArgumentError("stray_light must be in [0, 1]");
  }
  if (!(stray_texture >= 0 && stray_texture <= 1)) {
    return absl::InvalidArgumentError("stray_texture must be in [0, 1]");
  }
  if (!(axial_glint_width >= 0 && axial_glint_width <= 1)) {
    return absl::InvalidArgumentError("axial_glint_width must be in [0, 1]");
  }
  if (!(corner_share >= 0 && corner_share < 1)) {
    return absl::InvalidArgumentError("corner_share must be in [0, 1)");
  }
  if (!(axial_float_width >= 0 && axial_float_width < 1)) {
    return absl::InvalidArgumentError("axial_float_width must be in [0, 1)");
  }
  if (!(std::fabs(background_gradient) <= 1) || !std::isfinite(background_gradient_deg)) {
    return absl::InvalidArgumentError(
        "background_gradient must be in [-1, 1] and background_gradient_deg finite");
  }
  if (!(black_level >= 0 && black_level <= 0.5)) {
    return absl::InvalidArgumentError("black_level must be in [0, 0.5]");
  }
  if (!(white_level > 0.5 && white_level <= 1)) {
    return absl::InvalidArgumentError("white_level must be in (0.5, 1]");
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

namespace {

// Level of the background at image point (u, v): uniform, or a lit
// backdrop's linear gradient over the frame (never below black).
double BackgroundAt(const RenderScene& scene, double u, double v) {
  if (scene.background_gradient == 0.0) return scene.background;
  const double c = std::cos(scene.background_gradient_deg * kDeg);
  const double s = std::sin(scene.background_gradient_deg * kDeg);
  // The frame's extent along the gradient, corner to corner.
  const double extent = std::fabs(c) * scene.width_px + std::fabs(s) * scene.height_px;
  const double along = (u - 0.5 * (scene.width_px - 1)) * c + (v - 0.5 * (scene.height_px - 1)) * s;
  return std::max(0.0, scene.background + scene.background_gradient * along / extent);
}

// Radiance of one sample in channel c, full-scale units, before the lens.
double SampleRadiance(const RenderScene& scene, const Terms& t, int c, double u, double v) {
  if (!t.on_cylinder) return t.mount ? scene.mount_level : BackgroundAt(scene, u, v);
  double radiance = scene.ambient +
                    scene.exposure * (scene.specular_rgb[c] * t.specular +
                                      scene.axial_reflectance * scene.axial_rgb[c] * t.axial) +
                    scene.diffuse * scene.diffuse_rgb[c] * t.diffuse;
  // Stray light is reflected diffusely: the threads' diffuse colour.
  if (scene.stray_light > 0.0) radiance += scene.stray_light * scene.diffuse_rgb[c] * t.stray;
  return radiance;
}

// The scene's radiance per pixel, supersampled: samples_per_pixel² everywhere,
// four times more along the arc where an in-plane glint may fall. Rows are
// shared among threads; nothing random happens here, so the result does not
// depend on them.
void RenderRadiance(const RenderScene& scene, const Sampler& sampler, Image& image) {
  const int channels = image.channels;
  auto render_rows = [&](int y0, int y1) {
    // Across the threads half as many samples suffice: the crest factor is
    // integrated analytically over each sample's height.
    const int sy_count = std::max(1, scene.samples_per_pixel / 2);
    const double dv = 1.0 / sy_count;
    for (int y = y0; y < y1; ++y) {
      for (int x = 0; x < image.width; ++x) {
        const int sx_count = scene.samples_per_pixel * (sampler.MayGlint(x, y) ? 4 : 1);
        const double du = 1.0 / sx_count;
        double sum[3] = {0.0, 0.0, 0.0};
        for (int j = 0; j < sy_count; ++j) {
          const double v = y - 0.5 + (j + 0.5) * dv;
          for (int i = 0; i < sx_count; ++i) {
            const double u = x - 0.5 + (i + 0.5) / sx_count;
            const Terms t = sampler.Sample(u, v, du, dv);
            for (int c = 0; c < channels; ++c) sum[c] += SampleRadiance(scene, t, c, u, v);
          }
        }
        for (int c = 0; c < channels; ++c) {
          image.pixels[(static_cast<std::size_t>(y) * image.width + x) * channels + c] =
              static_cast<float>(sum[c] / (sx_count * sy_count));
        }
      }
    }
  };
  const int workers = std::max(1u, std::min(8u, std::thread::hardware_concurrency()));
  std::vector<std::thread> threads;
  for (int w = 0; w < workers; ++w) {
    threads.emplace_back(render_rows, image.height * w / workers, image.height * (w + 1) / workers);
  }
  for (std::thread& t : threads) t.join();
}

// Lens: Gaussian PSF, then vignetting (quadratic fall-off to the corners).
void ApplyLens(const RenderScene& scene, Image& image) {
  const int channels = image.channels;
  if (scene.optics_blur_px > 0) {
    cv::Mat mat(image.height, image.width, CV_32FC(channels), image.pixels.data());
    cv::GaussianBlur(mat, mat, cv::Size(0, 0), scene.optics_blur_px, scene.optics_blur_px,
                     cv::BORDER_REPLICATE);
  }
  if (scene.vignetting > 0) {
    const double xc = (image.width - 1) / 2.0;
    const double yc = (image.height - 1) / 2.0;
    const double r2_max = xc * xc + yc * yc;
    for (int y = 0; y < image.height; ++y) {
      for (int x = 0; x < image.width; ++x) {
        const double f = 1.0 - scene.vignetting * ((x - xc) * (x - xc) + (y - yc) * (y - yc)) / r2_max;
        for (int c = 0; c < channels; ++c) {
          image.pixels[(static_cast<std::size_t>(y) * image.width + x) * channels + c] *=
              static_cast<float>(f);
        }
      }
    }
  }
}

// Sensor: Poisson photon noise on the signal, then the black-level pedestal
// and Gaussian read noise of the readout, saturation at full scale and
// quantisation, all stored below the file's white level. The pedestal stays
// in the file, as in a raw-ish lab image.
void ApplySensor(const RenderScene& scene, Image& image) {
  const int channels = image.channels;
  std::mt19937 rng(scene.seed ^ 0x9e3779b9u);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double levels = scene.quantisation_bits > 0 ? std::ldexp(1.0, scene.quantisation_bits) - 1 : 0.0;
  for (std::size_t i = 0; i < image.pixels.size(); ++i) {
    double v = image.pixels[i];
    if (scene.photons_full_scale > 0) {
      std::poisson_distribution<long long> photons(std::max(v, 0.0) * scene.photons_full_scale);
      v = photons(rng) / scene.photons_full_scale;
    }
    if (scene.black_level > 0) v += scene.black_level;
    v += scene.read_noise * normal(rng);
    v = std::clamp(v, 0.0, 1.0);
    if (levels > 0) v = std::round(v * levels) / levels;
    if (v >= 1.0) {
      image.MarkSaturated(static_cast<int>(i / channels % image.width),
                          static_cast<int>(i / channels / image.width));
    }
    image.pixels[i] = static_cast<float>(v * scene.white_level);
  }
}

}  // namespace

absl::StatusOr<Rendered> RenderPhotograph(const RenderScene& scene) {
  if (absl::Status s = scene.Validate(); !s.ok()) return s;
  const Sampler sampler(scene);
  const int channels = scene.IsColour() ? 3 : 1;
  Rendered out;
  Image& image = out.image;
  image.width = scene.width_px;
  image.height = scene.height_px;
  image.channels = channels;
  image.pixels.assign(static_cast<std::size_t>(image.width) * image.height * channels, 0.0f);
  RenderRadiance(scene, sampler, image);
  ApplyLens(scene, image);
  ApplySensor(scene, image);

  RenderTruth& truth = out.truth;
  const double m = sampler.max_slope();
  truth.max_slope = m;
  truth.peak_spacing_deg = PeakSpacingRad(m) / kDeg;
  truth.mirror_azimuth_deg =
      MirrorAzimuth(scene.phase_angle_deg * kDeg,
                    Projection{scene.diameter_mm / 2.0, scene.camera_distance_mm}) / kDeg;
  truth.center_x_px = sampler.cx();
  truth.radius_px = sampler.radius_px();
  truth.axis_angle_deg = scene.axis_angle_deg;
  truth.px_per_period = scene.wavelength_mm / sampler.mm_per_px();
  // A split shows when the peaks stand further apart than about twice the
  // blur's full width at half maximum in azimuth (2.355·σ_β each, the lens
  // blur converted to azimuth at the centre).
  const double lens_rad = scene.optics_blur_px / sampler.radius_px();
  const double sigma = std::hypot(sampler.sigma_beta(), lens_rad);
  truth.split_resolvable = scene.model != ProfileModel::kSmooth &&
                           PeakSpacingRad(m) > 2.0 * 2.355 * sigma;
  // A smooth sample has no thread period to resolve (its thread quantities
  // are not the sample's).
  truth.period_resolvable = scene.model != ProfileModel::kSmooth && truth.px_per_period >= 4.0;
  return out;
}

std::string TruthJson(const RenderScene& s, const RenderTruth& t,
                      const std::string& image_file) {
  auto num = [](double v) { return absl::StrFormat("%.9g", v); };
  auto boolean = [](bool v) { return std::string(v ? "true" : "false"); };
  auto rgb = [&](const double* v) {
    return absl::StrCat("[", num(v[0]), ", ", num(v[1]), ", ", num(v[2]), "]");
  };
  auto object = [](const std::vector<std::pair<std::string, std::string>>& fields) {
    std::string out = "{\n";
    for (std::size_t i = 0; i < fields.size(); ++i) {
      absl::StrAppend(&out, "    \"", fields[i].first, "\": ", fields[i].second,
                      i + 1 < fields.size() ? ",\n" : "\n");
    }
    return out + "  }";
  };
  const std::string model = absl::StrCat("\"", ProfileModelName(s.model), "\"");
  const std::string acquisition = object({
      {"phaseAngleDeg", num(s.phase_angle_deg)},
      {"cylinderDiameterMm", num(s.diameter_mm)},
      {"cameraDistanceMm", num(s.camera_distance_mm)},
  });
  const std::string truth = object({
      {"model", model},
      {"wavelengthMm", num(s.wavelength_mm)},
      {"amplitudeMm", num(s.amplitude_mm)},
      {"maxSlope", num(t.max_slope)},
      {"peakSpacingDeg", num(t.peak_spacing_deg)},
      {"mirrorAzimuthDeg", num(t.mirror_azimuth_deg)},
      {"centerXPx", num(t.center_x_px)},
      {"radiusPx", num(t.radius_px)},
      {"axisAngleDeg", num(t.axis_angle_deg)},
      {"pxPerPeriod", num(t.px_per_period)},
      {"splitResolvable", boolean(t.split_resolvable)},
      {"periodResolvable", boolean(t.period_resolvable)},
  });
  // Keys are the camelCase of the fields, as `weavefit render --scene` reads them.
  std::vector<std::pair<std::string, std::string>> scene_fields = {
      {"widthPx", num(s.width_px)},
      {"heightPx", num(s.height_px)},
      {"model", model},
      {"wavelengthMm", num(s.wavelength_mm)},
      {"amplitudeMm", num(s.amplitude_mm)},
      {"diameterMm", num(s.diameter_mm)},
      {"cameraDistanceMm", num(s.camera_distance_mm)},
      {"phaseAngleDeg", num(s.phase_angle_deg)},
      {"centerXPx", num(s.center_x_px)},
      {"radiusPx", num(s.radius_px)},
      {"axisAngleDeg", num(s.axis_angle_deg)},
      {"topRowPx", num(s.top_row_px)},
      {"bottomRowPx", num(s.bottom_row_px)},
      {"sourceBlurDeg", num(s.source_blur_deg)},
      {"exposure", num(s.exposure)},
      {"axialReflectance", num(s.axial_reflectance)},
      {"diffuse", num(s.diffuse)},
      {"ambient", num(s.ambient)},
      {"background", num(s.background)},
      {"mountLevel", num(s.mount_level)},
      {"gapFraction", num(s.gap_fraction)},
      {"crestTiltDeg", num(s.crest_tilt_deg)},
      {"phaseStep", num(s.phase_step)},
      {"regularWeave", boolean(s.regular_weave)},
      {"phaseJitter", num(s.phase_jitter)},
      {"phaseDrift", num(s.phase_drift)},
      {"opticsBlurPx", num(s.optics_blur_px)},
      {"vignetting", num(s.vignetting)},
      {"specularRgb", rgb(s.specular_rgb)},
      {"axialRgb", rgb(s.axial_rgb)},
      {"diffuseRgb", rgb(s.diffuse_rgb)},
      {"photonsFullScale", num(s.photons_full_scale)},
      {"readNoise", num(s.read_noise)},
      {"quantisationBits", num(s.quantisation_bits)},
      {"samplesPerPixel", num(s.samples_per_pixel)},
      {"seed", num(s.seed)},
  };
  // The lab-photograph conditions of issue 31 are written only when they
  // differ from their defaults (which render as before), so that the
  // sidecars of older scenes stay byte for byte what they were.
  const RenderScene defaults;
  auto optional = [&](const char* key, double value, double default_value) {
    if (value != default_value) scene_fields.emplace_back(key, num(value));
  };
  optional("mountHalfWidth", s.mount_half_width, defaults.mount_half_width);
  optional("strayLight", s.stray_light, defaults.stray_light);
  if (s.stray_light != defaults.stray_light || s.stray_texture != defaults.stray_texture) {
    scene_fields.emplace_back("strayTexture", num(s.stray_texture));
  }
  optional("axialGlintWidth", s.axial_glint_width, defaults.axial_glint_width);
  optional("axialFloatWidth", s.axial_float_width, defaults.axial_float_width);
  optional("cornerShare", s.corner_share, defaults.corner_share);
  optional("backgroundGradient", s.background_gradient, defaults.background_gradient);
  optional("backgroundGradientDeg", s.background_gradient_deg, defaults.background_gradient_deg);
  optional("blackLevel", s.black_level, defaults.black_level);
  optional("whiteLevel", s.white_level, defaults.white_level);
  if (s.relief_parallax) scene_fields.emplace_back("reliefParallax", boolean(true));
  const std::string scene = object(scene_fields);
  return absl::StrCat("{\n  \"image\": \"", image_file, "\",\n  \"acquisition\": ", acquisition,
                      ",\n  \"truth\": ", truth, ",\n  \"scene\": ", scene, "\n}\n");
}

}  // namespace weavefit
