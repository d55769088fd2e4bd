#include "estimator/fit/profile_fit.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <future>
#include <limits>
#include <memory>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "estimator/stats/smooth.h"

namespace weavefit {
namespace {

// Parameters besides the max slope, in order: mirror azimuth (rad), blur σ
// (rad), scale, background level, background slope (per rad), scatter level
// and the diffuse light's dome (below).
//
// The dome: stray light from the room reaches the whole body (DESIGN.md
// §3), and the threads' matte share returns it as a Lambertian surface under
// a sky, ∝ 1 + cos(φ − v) about the line of sight v; a coloured fabric's
// Lambertian term under the lamp is ∝ cos(φ − α); vignetting darkens either
// toward the image's edges. Across a lobe 40-70° wide their curvature is no
// detail: under a baseline of level and slope alone the dome stood between
// the peaks where a sinusoid's glints do, or under its filled valley, and
// the fits preferred the wrong model or fell short of deciding (lab scenes
// 0-160 of scripts/random_scenes.py: four steep sawtooths called sinusoids
// and a sinusoid a sawtooth; with the dome all five right, by 12-562 in BIC
// per independent bin). Any sum of such terms is, across the window,
// level + slope·x + dome·(cos x − 1), x = φ − the start's mirror: the
// centre free through the slope, the dome ≥ 0 (light adds; a bowl toward
// the limbs is the grazing scatter's). Two terms in its place, cos(φ − v)
// and cos(φ − α), are nearly one another over the window: bounded at 0 the
// fits took 1.6 times as long on the shared photographs, free they came
// out large and opposite.
constexpr int kNuisance = 7;
// A sawtooth's share of arc in its rounded corners: fitted from 3 %.
constexpr double kCornerShareStart = 0.03;
// Floor added in quadrature to the blur, so that an unblurred caustic never
// makes the model singular (0.02°).
constexpr double kBlurFloorRad = 0.02 * M_PI / 180.0;

// A solve that ran out of iterations while gaining less than kStallChi2 of
// χ² over its last kStallIterations: it crawls along the floor of its
// optimum (with a parameter pressed against its bound Ceres steps short:
// a sawtooth fit under stray light crawled 700 iterations from χ² 38.21 to
// 38.06 while its max slope moved by 1e-4 of itself), and what it could
// still gain moves no parameter by more than a small share of its error
// (Δχ² = 1 is one standard error). Such a fit is taken as converged.
constexpr int kStallIterations = 10;
constexpr double kStallChi2 = 0.1;

bool Stalled(const ceres::Solver::Summary& summary) {
  const std::vector<ceres::IterationSummary>& it = summary.iterations;
  if (summary.termination_type != ceres::NO_CONVERGENCE ||
      static_cast<int>(it.size()) <= kStallIterations) {
    return false;
  }
  const double before = it[it.size() - 1 - kStallIterations].cost;
  return 2.0 * (before - summary.final_cost) < kStallChi2;
}

// (model − observed)/σ for one azimuth bin of the (smoothed) profile. The
// model is smoothed like the data: the fitted blur and the bin's fixed blur
// (the smoothing, the floor, the lens and pixel in azimuth there) add in
// quadrature (all Gaussian).
//
// Its derivatives: the specular lobe's by automatic differentiation over
// the parameters it depends on (the mirror, the blur and the scale; the max
// slope but for the smooth model, the corners for the sawtooth's alone:
// Specular), the background's, scatter's and dome's, linear, by hand.
// Differentiating all nine parameters through the lobe (AutoDiffCostFunction)
// carried derivatives that are zero or constant through every operation:
// the six fits of a sinusoid's lobe took 121 ms where they now take 104
// (BM_FitProfileModels). The values and derivatives agree to rounding.
class ProfileSampleCost : public ceres::SizedCostFunction<1, 1, kNuisance, 1> {
 public:
  ProfileSampleCost(ProfileModel model, double phi, double value, double sigma, double alpha,
                    double fixed_blur, double sharpest_blur, double phi_center, double view,
                    bool censored)
      : model_(model),
        phi_(phi),
        value_(value),
        sigma_(sigma),
        fixed_blur_(fixed_blur),
        sharpest_blur_(sharpest_blur),
        phi_center_(phi_center),
        view_(view),
        censored_(censored),
        // The scatter's and the dome's shapes at this bin, fixed by its
        // azimuth (computed once: every evaluation of every fit needs them).
        scatter_shape_(std::cos(phi - alpha) > 0.0
                           ? std::cos(alpha / 2.0) / std::max(std::cos(phi), kMinCosAzimuth)
                           : 0.0),
        dome_shape_(std::cos(phi - phi_center) - 1.0) {}

  // The residual at (slope, p, corner), without derivatives.
  double Residual(const double* slope, const double* p, const double* corner) const {
    RadianceParams<double> rp = Lobe<double>(slope[0], p[0], p[1], p[2], corner[0], p[1]);
    const double residual = (Model(SpecularRadiance(rp, phi_), p) - value_) / sigma_;
    return censored_ && residual > 0.0 ? 0.0 : residual;
  }

  // With bounds on its parameters, Ceres evaluates each trust-region step's
  // end three times over: with the Jacobian in its line search, without it
  // as the candidate, and with it again once the step is taken. So each
  // sample keeps its last point's residual and derivatives (every
  // evaluation computes both) and answers again from them: the same
  // numbers, a third of the work.
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double* slope = parameters[0];
    const double* p = parameters[1];
    const double* corner = parameters[2];
    if (!last_.AtPoint(slope, p, corner)) Compute(slope, p, corner);
    residuals[0] = last_.residual;
    if (jacobians == nullptr) return true;
    if (jacobians[0] != nullptr) jacobians[0][0] = last_.jacobian[0];
    if (jacobians[1] != nullptr) {
      std::copy(last_.jacobian + 1, last_.jacobian + 1 + kNuisance, jacobians[1]);
    }
    if (jacobians[2] != nullptr) jacobians[2][0] = last_.jacobian[1 + kNuisance];
    return true;
  }

 private:
  // The last point evaluated (slope, the nuisance parameters, corner) and
  // its residual and derivatives, in that order of parameters.
  struct Evaluated {
    bool valid = false;
    double point[kNuisance + 2];
    double residual = 0.0;
    double jacobian[kNuisance + 2];
    // Bit for bit (−0 is not +0 to every function of it).
    bool AtPoint(const double* slope, const double* p, const double* corner) const {
      return valid && std::memcmp(point, slope, sizeof(double)) == 0 &&
             std::memcmp(point + 1, p, kNuisance * sizeof(double)) == 0 &&
             std::memcmp(point + 1 + kNuisance, corner, sizeof(double)) == 0;
    }
  };

  void Compute(const double* slope, const double* p, const double* corner) const {
    double d[kSlots] = {};  // a model's lobe leaves the slots it does not use at 0
    double specular;
    switch (model_) {
      case ProfileModel::kSmooth:
        specular = Specular<3>(slope, p, corner, d);
        break;
      case ProfileModel::kSinusoid:
        specular = Specular<4>(slope, p, corner, d);
        break;
      default:
        specular = Specular<5>(slope, p, corner, d);
        break;
    }
    // Divided as a Jet divides (times the inverse), as the automatic
    // differentiation did.
    const double residual = (Model(specular, p) - value_) * (1.0 / sigma_);
    // A censored bin's value is a lower bound: a model above it is as good
    // as the bound itself, and flat there.
    const bool above_bound = censored_ && residual > 0.0;
    const double per = above_bound ? 0.0 : 1.0 / sigma_;
    last_.valid = true;
    last_.point[0] = slope[0];
    std::copy(p, p + kNuisance, last_.point + 1);
    last_.point[1 + kNuisance] = corner[0];
    last_.residual = above_bound ? 0.0 : residual;
    double* j = last_.jacobian;
    j[0] = d[kSlopeSlot] * per;
    j[1] = d[kMirrorSlot] * per;
    j[2] = d[kBlurSlot] * per;
    j[3] = d[kScaleSlot] * per;
    j[4] = per;
    j[5] = (phi_ - phi_center_) * per;
    j[6] = scatter_shape_ * per;
    j[7] = dome_shape_ * per;
    j[1 + kNuisance] = d[kCornerSlot] * per;
  }

  // The specular lobe's parameters in the order of their Jet slots: a
  // model differentiates the first N of them (the smooth model's lobe does
  // not depend on the max slope, nor any but the sawtooth's on corners).
  enum Slot { kMirrorSlot, kBlurSlot, kScaleSlot, kSlopeSlot, kCornerSlot, kSlots };

  // The lobe's parameters for SpecularRadiance, in T (p1 the fitted blur,
  // whose value sizes the sinusoid's quadrature).
  template <typename T>
  RadianceParams<T> Lobe(const T& slope, const T& p0, const T& p1, const T& p2, const T& corner,
                         double p1_value) const {
    using std::sqrt;
    RadianceParams<T> rp;
    rp.model = model_;
    rp.max_slope = slope;
    rp.corner_share = corner;
    // The facet normal that mirrors the light into the camera is (α + v)/2
    // (DESIGN.md §2): p[0] stands for α/2, v is this sample's view angle.
    rp.mirror_rad = p0 + T(0.5 * view_);
    rp.blur_rad = sqrt(p1 * p1 + T(fixed_blur_ * fixed_blur_));
    // Every bin's sinusoid quadrature sized for the sharpest bin's blur.
    rp.quadrature_blur_rad = std::hypot(p1_value, sharpest_blur_);
    rp.scale = p2;
    return rp;
  }

  // The specular lobe at this bin and its derivatives by the slots below N
  // (the rest 0) into d.
  template <int N>
  double Specular(const double* slope, const double* p, const double* corner,
                  double d[kSlots]) const {
    using J = ceres::Jet<double, N>;
    auto variable = [](double x, int slot) { return slot < N ? J(x, slot) : J(x); };
    const RadianceParams<J> rp = Lobe<J>(
        variable(slope[0], kSlopeSlot), variable(p[0], kMirrorSlot), variable(p[1], kBlurSlot),
        variable(p[2], kScaleSlot), variable(corner[0], kCornerSlot), p[1]);
    const J specular = SpecularRadiance(rp, J(phi_));
    for (int k = 0; k < kSlots; ++k) d[k] = k < N ? specular.v[k] : 0.0;
    return specular.a;
  }

  // The lobe plus the background's level and slope, the dome and the
  // grazing scatter (linear in their parameters).
  double Model(double specular, const double* p) const {
    double scatter = 0.0;
    if (scatter_shape_ != 0.0) scatter = p[5] * scatter_shape_;
    return specular + p[3] + p[4] * (phi_ - phi_center_) + p[6] * dome_shape_ + scatter;
  }

  ProfileModel model_;
  double phi_, value_, sigma_, fixed_blur_, sharpest_blur_, phi_center_, view_;
  bool censored_;
  double scatter_shape_, dome_shape_;
  // One cost per residual block, which Ceres never evaluates from two threads at once.
  mutable Evaluated last_;
};

// Each bin's mean with its clipped pixels counted at the clip level, where
// the profile left them out: a lower bound on what the sensor saw there,
// and the plain mean where nothing clipped.
std::vector<double> LowerBounds(const Profile& profile) {
  std::vector<double> bound = profile.mean;
  for (int i = 0; i < profile.NumBins(); ++i) {
    const double clipped = i < static_cast<int>(profile.saturated.size()) ? profile.saturated[i] : 0.0;
    if (!(clipped > 0.0) || i >= static_cast<int>(profile.saturated_sum.size())) continue;
    bound[i] = (profile.mean[i] * profile.count[i] + profile.saturated_sum[i]) /
               (profile.count[i] + clipped);
  }
  return bound;
}

// The integrated autocorrelation of a fit's residuals, 1 + 2·Σ ρ_k over
// lags k ≥ 1, summed while the pairs of neighbouring lags stay positive
// (Geyer's initial positive sequence). Residuals correlated over τ bins
// carry the information of n/τ independent ones, so the covariance, which
// counts n, is τ too small: the smoothing correlates about 2√π·σ bins, and
// a comb of glints the fit's smooth lobe cannot follow leaves residuals
// correlated over its tooth spacing. At least 1.
double IntegratedCorrelation(const std::vector<double>& r) {
  const int n = static_cast<int>(r.size());
  if (n < 8) return 1.0;
  double mean = 0.0;
  for (double x : r) mean += x;
  mean /= n;
  double c0 = 0.0;
  for (double x : r) c0 += (x - mean) * (x - mean);
  if (!(c0 > 0.0)) return 1.0;
  auto rho = [&](int k) {
    double c = 0.0;
    for (int i = 0; i + k < n; ++i) c += (r[i] - mean) * (r[i + k] - mean);
    return c / c0;
  };
  double tau = 1.0;
  for (int k = 1; k + 1 < n / 4; k += 2) {
    const double pair = rho(k) + rho(k + 1);
    if (!(pair > 0.0)) break;
    tau += 2.0 * pair;
  }
  return std::max(tau, 1.0);
}

}  // namespace

absl::Status ProfileFitOptions::Validate() const {
  if (!(smoothing_rad >= 0.0)) return absl::InvalidArgumentError("smoothing_rad must be >= 0");
  if (!(lens_blur_px >= 0.0)) return absl::InvalidArgumentError("lens_blur_px must be >= 0");
  if (!(half_width_px >= 0.0)) return absl::InvalidArgumentError("half_width_px must be >= 0");
  if (!(margin_rad > 0.0)) return absl::InvalidArgumentError("margin_rad must be > 0");
  if (!(window_max_slope >= 0.0)) return absl::InvalidArgumentError("window_max_slope must be >= 0");
  if (max_iterations < 1) return absl::InvalidArgumentError("max_iterations must be >= 1");
  return absl::OkStatus();
}

absl::StatusOr<ProfileFitResult> FitProfileModels(const Profile& profile,
                                                  double phase_angle_rad,
                                                  const Projection& projection,
                                                  double max_slope0,
                                                  const ProfileFitOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  const int n = profile.NumBins();
  if (n < 8) return absl::InvalidArgumentError("profile too short to fit");
  const double bin = profile.bin_width_rad;
  const double mirror0 = phase_angle_rad / 2.0;
  const double reach = std::atan(std::max({max_slope0, options.window_max_slope, 0.0})) +
                       options.margin_rad +
                       2.0 * options.smoothing_rad;
  const double limit = 84.0 * M_PI / 180.0;
  // The data: the profile smoothed like the model, with standard errors
  // from the row blocks (they carry the comb's scatter), shrunk by the
  // smoothing and floored by pixel noise.
  //
  // Clipped pixels: a bin that holds any is known from below. Its pixels at
  // the clip level give a lower bound on its mean (LowerBounds), and
  // smoothing, a positive average, keeps a bound a bound. How far above the
  // bound the bin's mean lies is the light its clipped pixels hide: each
  // clipped pixel is taken at one to 1 + kClipExcessLevels clip levels (a
  // caustic's glints can stand several times above the level they clip at),
  // so the smoothed bin's mean lies between the bound and the bound plus
  // `hidden`, its clipped pixels' share times kClipExcessLevels clip levels:
  // it is read at the middle, with half that range added to its error.
  // Where the range exceeds kCensorHiddenSigmas of the bin's own error, the
  // bin is censored: the model must reach the bound and may stand above it
  // at no cost. (Left out, such bins took a clipped lobe's caustics with
  // them; read at the bound as levels, they would flatten them. Censored
  // wherever a clipped pixel lay within 3σ of smoothing, a few hundred
  // clipped glint pixels on a large photograph censored most of the lobe
  // and the fits refused it.)
  constexpr double kCensorHiddenSigmas = 2.0;
  constexpr double kClipExcessLevels = 4.0;
  const double sigma_bins = options.smoothing_rad / bin;
  std::vector<double> smoothed = Smooth(LowerBounds(profile), sigma_bins);
  std::vector<double> hidden_raw(n, 0.0);
  for (int i = 0; i < n && i < static_cast<int>(profile.saturated_sum.size()); ++i) {
    const double pixels = profile.count[i] + profile.saturated[i];
    if (profile.saturated[i] > 0.0 && pixels > 0.0) {
      hidden_raw[i] = kClipExcessLevels * profile.saturated_sum[i] / pixels;
    }
  }
  const std::vector<double> hidden = Smooth(hidden_raw, sigma_bins);
  const double gain = sigma_bins >= 0.3 ? 1.0 / std::sqrt(2.0 * std::sqrt(M_PI) * sigma_bins) : 1.0;
  auto noise_of = [&](int i) {
    const double pixels = std::max(profile.count[i] + profile.saturated[i], 1.0);
    const double noise = std::max(profile.PixelNoise(i), 1e-6) / std::sqrt(pixels);
    return std::max(profile.stderr_mean[i], noise) * gain;
  };
  std::vector<int> used;
  std::vector<bool> censored(n, false);
  std::vector<double> sigma(n, 0.0);
  for (int i = 0; i < n; ++i) {
    const double phi = profile.azimuth_rad[i];
    if (profile.count[i] + profile.saturated[i] <= 0.0 || std::fabs(phi - mirror0) > reach ||
        std::fabs(phi) > limit) {
      continue;
    }
    sigma[i] = noise_of(i);
    if (hidden[i] > kCensorHiddenSigmas * sigma[i]) {
      censored[i] = true;
    } else if (hidden[i] > 0.0) {
      smoothed[i] += 0.5 * hidden[i];
      sigma[i] = std::hypot(sigma[i], 0.5 * hidden[i]);
    }
    used.push_back(i);
  }
  if (used.size() < 12) return absl::InvalidArgumentError("too few profile bins around the mirror azimuth to fit");
  int num_censored = 0;
  for (int i : used) num_censored += censored[i] ? 1 : 0;
  if (num_censored > static_cast<int>(used.size()) / 2) {
    return absl::InvalidArgumentError(absl::StrCat(
        num_censored, " of ", used.size(),
        " profile bins around the mirror azimuth hold clipped pixels that may hide more light "
        "than their noise: over half the lobe known only from below does not fix its shape"));
  }
  auto sigma_of = [&](int i) { return sigma[i]; };
  // The blur fixed at each bin: the smoothing and the floor, constant in
  // azimuth, and the lens PSF and the pixel's footprint (a box, σ² = 1/12
  // px²), constant in pixels: in azimuth they grow as 1/cos φ toward the
  // limbs, where one fitted blur cannot follow them.
  const double px2 = options.lens_blur_px * options.lens_blur_px + 1.0 / 12.0;
  auto fixed_blur_of = [&](double phi) {
    double lens2 = 0.0;
    if (options.half_width_px > 0.0) {
      const double du = OffsetPerRadian(phi, projection);
      const double rad_per_px = 1.0 / (options.half_width_px * std::max(du, 1e-3));
      lens2 = px2 * rad_per_px * rad_per_px;
    }
    return std::sqrt(options.smoothing_rad * options.smoothing_rad +
                     kBlurFloorRad * kBlurFloorRad + lens2);
  };
  // The sharpest bin's fixed blur, which sizes every bin's sinusoid
  // quadrature (ProfileSampleCost).
  double sharpest_blur = std::numeric_limits<double>::infinity();
  for (int i : used) {
    sharpest_blur = std::min(sharpest_blur, fixed_blur_of(profile.azimuth_rad[i]));
  }
  // Starting values: background from the window's ends, scale from the peak.
  double lo_level = smoothed[used.front()];
  double hi_level = smoothed[used.back()];
  double peak = 0.0;
  for (int i : used) peak = std::max(peak, smoothed[i] - std::min(lo_level, hi_level));

  ProfileFitResult result;
  const ProfileModel models[] = {ProfileModel::kSmooth, ProfileModel::kSinusoid, ProfileModel::kSawtooth};
  // One model from one starting blur.
  auto fit_from = [&](ProfileModel model, double blur0_rad) {
    ModelFit fit;
    fit.model = model;
    double slope[1] = {model == ProfileModel::kSmooth ? 0.0 : std::max(max_slope0, 0.02)};
    double p[kNuisance] = {mirror0, blur0_rad, 1.0, std::min(lo_level, hi_level), 0.0, 0.0, 0.0};
    // A sawtooth's rounded corners (SawtoothTiltDensity), from a few
    // percent of its arc; the other models have none.
    const bool rounded = model == ProfileModel::kSawtooth;
    double corner[1] = {rounded ? kCornerShareStart : 0.0};
    // Scale so that the model's highest point matches the data's.
    {
      RadianceParams<double> rp;
      rp.model = model;
      rp.max_slope = slope[0];
      rp.mirror_rad = mirror0;
      rp.blur_rad = std::hypot(p[1], options.smoothing_rad);
      double top = 0.0;
      for (int i : used) top = std::max(top, SpecularRadiance(rp, profile.azimuth_rad[i]));
      p[2] = top > 0 ? peak / top : 1.0;
    }
    ceres::Problem problem;
    for (int i : used) {
      problem.AddResidualBlock(
          new ProfileSampleCost(model, profile.azimuth_rad[i], smoothed[i], sigma_of(i),
                                phase_angle_rad, fixed_blur_of(profile.azimuth_rad[i]),
                                sharpest_blur, mirror0,
                                ViewAngleRad(profile.azimuth_rad[i], projection), censored[i]),
          new ceres::HuberLoss(3.0), slope, p, corner);
    }
    if (rounded) {
      problem.SetParameterLowerBound(corner, 0, 0.0);
      problem.SetParameterUpperBound(corner, 0, kMaxCornerShare);
    } else {
      problem.SetParameterBlockConstant(corner);
    }
    if (model == ProfileModel::kSmooth) {
      problem.SetParameterBlockConstant(slope);
    } else {
      problem.SetParameterLowerBound(slope, 0, 1e-3);
      problem.SetParameterUpperBound(slope, 0, 3.0);
    }
    problem.SetParameterLowerBound(p, 0, mirror0 - 0.3);
    problem.SetParameterUpperBound(p, 0, mirror0 + 0.3);
    problem.SetParameterLowerBound(p, 2, 0.0);
    problem.SetParameterLowerBound(p, 6, 0.0);
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_QR;
    solver.max_num_iterations = options.max_iterations;
    solver.num_threads = 1;
    solver.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &problem, &summary);
    fit.converged = summary.IsSolutionUsable() && (summary.termination_type == ceres::CONVERGENCE ||
                                                   Stalled(summary));
    if (!fit.converged) fit.message = summary.message;
    fit.max_slope = slope[0];
    fit.mirror_rad = p[0] + 0.5 * ViewAngleRad(p[0], projection);
    fit.blur_rad = std::fabs(p[1]);
    fit.num_residuals = static_cast<int>(used.size());
    fit.num_censored = num_censored;
    fit.corner_share = corner[0];
    fit.num_params = kNuisance + (model == ProfileModel::kSmooth ? 0 : 1) + (rounded ? 1 : 0);
    fit.chi2 = 2.0 * summary.final_cost;
    std::vector<double> residuals;
    for (int i : used) {
      const double view = ViewAngleRad(profile.azimuth_rad[i], projection);
      const ProfileSampleCost cost(model, profile.azimuth_rad[i], smoothed[i], sigma_of(i),
                                   phase_angle_rad, fixed_blur_of(profile.azimuth_rad[i]),
                                   sharpest_blur, mirror0, view, censored[i]);
      const double r = cost.Residual(slope, p, corner);
      fit.curve_azimuth_rad.push_back(profile.azimuth_rad[i]);
      fit.curve.push_back(smoothed[i] + r * sigma_of(i));
      residuals.push_back(r);
    }
    fit.correlation_bins = IntegratedCorrelation(residuals);
    fit.bic = fit.chi2 + fit.num_params * std::log(static_cast<double>(fit.num_residuals));
    // Standard errors from the covariance, scaled by the reduced chi-square
    // when the residuals say the noise model is too small.
    // A blur the fixed one explains leaves the fitted one at 0, where the
    // model is flat in it (it enters squared): its direction is dropped
    // (a pseudo-inverse) rather than the fit.
    ceres::Covariance::Options cov_options;
    cov_options.algorithm_type = ceres::DENSE_SVD;
    cov_options.null_space_rank = -1;
    ceres::Covariance covariance(cov_options);
    std::vector<std::pair<const double*, const double*>> blocks = {{p, p}};
    if (model != ProfileModel::kSmooth) blocks.push_back({slope, slope});
    if (fit.converged && covariance.Compute(blocks, &problem)) {
      const int dof = std::max(fit.num_residuals - fit.num_params, 1);
      const double inflate = std::max(1.0, fit.chi2 / dof) * fit.correlation_bins;
      double cp[kNuisance * kNuisance];
      covariance.GetCovarianceBlock(p, p, cp);
      fit.mirror_stderr_rad = std::sqrt(std::max(cp[0], 0.0) * inflate);
      if (model != ProfileModel::kSmooth) {
        double cs = 0.0;
        covariance.GetCovarianceBlock(slope, slope, &cs);
        fit.max_slope_stderr = std::sqrt(std::max(cs, 0.0) * inflate);
      }
    } else if (fit.converged) {
      fit.converged = false;
      fit.message = "covariance could not be computed (parameters not identifiable)";
    }
    return fit;
  };
  // Two starting blurs, the better fit kept: from 0.3° a sawtooth whose outer
  // caustic the lens blurs 2.9° (320×240, 2 px, at −73°) slid to a 6.4° blur
  // that filled its valley (χ² 65,200, above the smooth model's), from 1° it
  // found its peaks (χ² 9,560).
  //
  // The six fits are independent (each its own problem over the same read-only
  // data), so they run side by side, one thread each; their results are
  // taken in a fixed order, so the answer does not depend on the threads.
  constexpr double kStartBlursRad[] = {0.3 * M_PI / 180.0, 1.0 * M_PI / 180.0};
  std::vector<std::future<ModelFit>> running;
  for (ProfileModel model : models) {
    for (double blur0 : kStartBlursRad) {
      running.push_back(std::async(options.parallel ? std::launch::async : std::launch::deferred,
                                   fit_from, model, blur0));
    }
  }
  for (std::size_t m = 0; m < std::size(models); ++m) {
    ModelFit fit = running[2 * m].get();
    ModelFit wide = running[2 * m + 1].get();
    if (wide.converged && (!fit.converged || wide.chi2 < fit.chi2)) fit = std::move(wide);
    result.fits.push_back(std::move(fit));
  }
  for (std::size_t i = 0; i < result.fits.size(); ++i) {
    if (!result.fits[i].converged) continue;
    if (result.best < 0 || result.fits[i].bic < result.fits[result.best].bic) {
      result.best = static_cast<int>(i);
    }
  }
  return result;
}

}  // namespace weavefit
