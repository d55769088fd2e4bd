// The least-squares fits recover the model and its max slope from profiles
// made with the model itself (with noise), and refuse a clipped lobe.
#include "estimator/fit/profile_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "estimator/stats/smooth.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A profile of 0.25° bins holding the model's radiance plus a background and
// Gaussian noise of `noise` per bin, as if from 100 pixels per bin.
Profile MakeProfile(ProfileModel model, double m, double alpha, double noise, unsigned seed) {
  Profile p;
  const double bin = 0.25 * kDeg;
  p.bin_width_rad = bin;
  p.radius_px = 500.0;
  p.num_blocks = 2;
  p.background = 0.01;
  p.background_noise = noise * 10.0;
  RadianceParams<double> rp;
  rp.model = model;
  rp.max_slope = m;
  rp.mirror_rad = alpha / 2.0;
  rp.blur_rad = 0.3 * kDeg;
  rp.scale = 0.004;
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, noise);
  for (int i = -344; i < 344; ++i) {
    const double phi = (i + 0.5) * bin;
    const double value = SpecularRadiance(rp, phi) + 0.03 + normal(rng);
    p.azimuth_rad.push_back(phi);
    p.mean.push_back(value);
    p.stderr_mean.push_back(noise);
    p.count.push_back(100.0);
    p.saturated.push_back(0.0);
  }
  for (int b = 0; b < p.num_blocks; ++b) {
    for (std::size_t i = 0; i < p.mean.size(); ++i) {
      p.block_sum.push_back(50.0 * p.mean[i]);
      p.block_count.push_back(50.0);
    }
  }
  return p;
}

TEST(ProfileFitTest, SinusoidIsChosenAndItsSlopeRecovered) {
  const Profile p = MakeProfile(ProfileModel::kSinusoid, 0.24, 20.0 * kDeg, 0.0005, 1);
  absl::StatusOr<ProfileFitResult> r = FitProfileModels(p, 20.0 * kDeg, Projection(), 0.22, ProfileFitOptions());
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_GE(r->best, 0);
  const ModelFit& best = r->fits[r->best];
  EXPECT_EQ(best.model, ProfileModel::kSinusoid);
  EXPECT_NEAR(best.max_slope, 0.24, 0.003);
  EXPECT_NEAR(best.mirror_rad / kDeg, 10.0, 0.05);
  EXPECT_GT(best.max_slope_stderr, 0.0);
  EXPECT_LT(std::fabs(best.max_slope - 0.24), 4.0 * best.max_slope_stderr + 1e-4);
}

TEST(ProfileFitTest, FitsOnThreadsGiveTheSerialAnswerExactly) {
  const Profile p = MakeProfile(ProfileModel::kSinusoid, 0.3, -40.0 * kDeg, 0.0005, 7);
  ProfileFitOptions serial;
  serial.parallel = false;
  absl::StatusOr<ProfileFitResult> a = FitProfileModels(p, -40.0 * kDeg, Projection(), 0.28, serial);
  absl::StatusOr<ProfileFitResult> b =
      FitProfileModels(p, -40.0 * kDeg, Projection(), 0.28, ProfileFitOptions());
  ASSERT_TRUE(a.ok() && b.ok());
  ASSERT_EQ(a->fits.size(), b->fits.size());
  EXPECT_EQ(a->best, b->best);
  for (std::size_t i = 0; i < a->fits.size(); ++i) {
    EXPECT_EQ(a->fits[i].model, b->fits[i].model);
    EXPECT_EQ(a->fits[i].converged, b->fits[i].converged);
    EXPECT_EQ(a->fits[i].max_slope, b->fits[i].max_slope);
    EXPECT_EQ(a->fits[i].bic, b->fits[i].bic);
    EXPECT_EQ(a->fits[i].max_slope_stderr, b->fits[i].max_slope_stderr);
  }
}

TEST(ProfileFitTest, SawtoothIsNotReportedAsASinusoid) {
  const Profile p = MakeProfile(ProfileModel::kSawtooth, 0.15, -30.0 * kDeg, 0.0005, 2);
  absl::StatusOr<ProfileFitResult> r = FitProfileModels(p, -30.0 * kDeg, Projection(), 0.14, ProfileFitOptions());
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_GE(r->best, 0);
  EXPECT_EQ(r->fits[r->best].model, ProfileModel::kSawtooth);
  EXPECT_NEAR(r->fits[r->best].max_slope, 0.15, 0.002);
}

// Stray light from the camera's side on the whole body, ∝ 1 + cos φ, under
// a steep sawtooth's lobe 44° wide, smoothed as a comb of glints is: its
// dome lies between the caustics where a sinusoid's glints would. A
// baseline that does not bend with it leaves a misfit of 49 χ² per bin
// (and a sinusoid closer); with the stray light in the model the sawtooth
// explains the profile to its noise, and gives its slope.
TEST(ProfileFitTest, StrayLightsDomeUnderASawtoothIsFittedAsLight) {
  Profile p = MakeProfile(ProfileModel::kSawtooth, 0.4, -50.0 * kDeg, 0.0005, 3);
  for (int i = 0; i < p.NumBins(); ++i) p.mean[i] += 0.1 * (1.0 + std::cos(p.azimuth_rad[i]));
  ProfileFitOptions options;
  options.smoothing_rad = 2.5 * kDeg;
  absl::StatusOr<ProfileFitResult> r =
      FitProfileModels(p, -50.0 * kDeg, Projection(), 0.38, options);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_GE(r->best, 0);
  const ModelFit& best = r->fits[r->best];
  EXPECT_EQ(best.model, ProfileModel::kSawtooth);
  EXPECT_LT(best.chi2, best.num_residuals);
  EXPECT_NEAR(best.max_slope, 0.4, 0.006);
}

// A profile like MakeProfile's whose tilt density is sampled from a slope
// function h′(θ) over one period (θ in [0, 2π)), blurred like the models.
Profile ProfileFromSlopes(const std::function<double(double)>& slope, double alpha,
                          double noise, unsigned seed) {
  Profile p = MakeProfile(ProfileModel::kSmooth, 0.0, alpha, noise, seed);
  const int nodes = 20000;
  std::vector<double> tilts(nodes);
  for (int k = 0; k < nodes; ++k) tilts[k] = std::atan(slope(2.0 * M_PI * (k + 0.5) / nodes));
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, noise);
  const double blur = 0.3 * kDeg;
  for (int i = 0; i < p.NumBins(); ++i) {
    const double phi = p.azimuth_rad[i];
    const double beta = alpha / 2.0 - phi;
    double density = 0.0;
    for (double t : tilts) density += GaussianDensity(beta - t, blur);
    density /= nodes;
    p.mean[i] = 0.004 * std::cos(alpha / 2.0) * density / (std::cos(phi) * std::cos(beta)) +
                0.03 + normal(rng);
  }
  return p;
}

// A sawtooth whose corners are round (slope m·tanh(8·cos θ)/tanh 8, about
// 12 % of its arc turning from one flank to the other), smoothed as a comb
// of glints is: the ideal sawtooth's fit can only fill the level between its
// peaks by pulling them inward (2.0 % short); the fitted corners take that
// level, and the slope comes back within 1.5 % (1.2 % short: these corners'
// tilts crowd toward the flanks', which the evenly spread corner model
// leaves to kSawtoothShapeFloor).
TEST(ProfileFitTest, RoundedSawtoothCornersAreFittedNotPulledIn) {
  const double m = 0.15;
  const Profile p = ProfileFromSlopes(
      [m](double t) { return m * std::tanh(8.0 * std::cos(t)) / std::tanh(8.0); },
      40.0 * kDeg, 0.0005, 5);
  // Smoothed as peak picking smooths a comb of glints.
  ProfileFitOptions options;
  options.smoothing_rad = 2.0 * kDeg;
  absl::StatusOr<ProfileFitResult> r = FitProfileModels(p, 40.0 * kDeg, Projection(), 0.14, options);
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_GE(r->best, 0);
  const ModelFit& best = r->fits[r->best];
  EXPECT_EQ(best.model, ProfileModel::kSawtooth);
  EXPECT_NEAR(best.max_slope / m, 1.0, 0.015) << best.max_slope;
  EXPECT_GT(best.corner_share, 0.03);
  EXPECT_LT(best.corner_share, 0.5);
  // The seven nuisance parameters (the diffuse dome among them), the slope
  // and the corners.
  EXPECT_EQ(best.num_params, 9);
}

// Noise correlated over about 12 bins (white noise smoothed by a σ of 3.5
// bins) carries a twelfth of the information: the residuals' correlation
// says so, and the stated error grows by its root.
TEST(ProfileFitTest, CorrelatedResidualsWidenTheError) {
  Profile white = MakeProfile(ProfileModel::kSinusoid, 0.24, 20.0 * kDeg, 0.0, 1);
  Profile correlated = white;
  std::mt19937 rng(9);
  std::normal_distribution<double> normal(0.0, 0.002);
  std::vector<double> noise(white.NumBins());
  for (double& x : noise) x = normal(rng);
  const std::vector<double> smooth = Smooth(noise, 3.5);
  std::normal_distribution<double> fresh(0.0, 0.0005);
  // Each bin's stated error is its own noise's; only the correlation is left
  // for the fit to find.
  double spread = 0.0;
  for (double x : smooth) spread += x * x;
  spread = std::sqrt(spread / smooth.size());
  for (int i = 0; i < white.NumBins(); ++i) {
    correlated.mean[i] += smooth[i];
    correlated.stderr_mean[i] = spread;
    white.mean[i] += fresh(rng);
    white.stderr_mean[i] = 0.0005;
  }
  absl::StatusOr<ProfileFitResult> a =
      FitProfileModels(white, 20.0 * kDeg, Projection(), 0.22, ProfileFitOptions());
  absl::StatusOr<ProfileFitResult> b =
      FitProfileModels(correlated, 20.0 * kDeg, Projection(), 0.22, ProfileFitOptions());
  ASSERT_TRUE(a.ok() && b.ok());
  const ModelFit& fa = a->fits[1];
  const ModelFit& fb = b->fits[1];
  ASSERT_TRUE(fa.converged && fb.converged);
  EXPECT_LT(fa.correlation_bins, 2.0);
  EXPECT_GT(fb.correlation_bins, 6.0);
  EXPECT_LT(std::fabs(fb.max_slope - 0.24), 3.0 * fb.max_slope_stderr);
}

TEST(ProfileFitTest, SmoothCylinderComesBackSmooth) {
  const Profile p = MakeProfile(ProfileModel::kSmooth, 0.0, 10.0 * kDeg, 0.0005, 3);
  absl::StatusOr<ProfileFitResult> r = FitProfileModels(p, 10.0 * kDeg, Projection(), 0.2, ProfileFitOptions());
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_GE(r->best, 0);
  EXPECT_EQ(r->fits[r->best].model, ProfileModel::kSmooth);
  EXPECT_NEAR(r->fits[r->best].mirror_rad / kDeg, 5.0, 0.05);
}

// A lobe clipped at the sensor's maximum: its caustics are known only from
// below, and the censored fit, which asks the model only to reach them,
// recovers the slope; read as levels, the flattened caustics would not give
// it. Clipped over most of the window, the lobe is refused.
TEST(ProfileFitTest, ClippedCausticsAreFittedAsLowerBounds) {
  Profile p = MakeProfile(ProfileModel::kSinusoid, 0.24, 20.0 * kDeg, 0.0005, 4);
  double top = 0.0;
  for (double v : p.mean) top = std::max(top, v);
  const double clip = 0.03 + 0.4 * (top - 0.03);
  p.saturated_sum.assign(p.NumBins(), 0.0);
  int clipped = 0;
  for (int i = 0; i < p.NumBins(); ++i) {
    if (p.mean[i] <= clip) continue;
    // Half the bin's 100 pixels above the clip level: decoded at it.
    p.saturated[i] = 50.0;
    p.saturated_sum[i] = 50.0 * clip;
    p.count[i] = 50.0;
    p.mean[i] = clip - 0.2 * (p.mean[i] - clip);  // the unclipped half, lower
    ++clipped;
  }
  ASSERT_GT(clipped, 8);
  absl::StatusOr<ProfileFitResult> r =
      FitProfileModels(p, 20.0 * kDeg, Projection(), 0.22, ProfileFitOptions());
  ASSERT_TRUE(r.ok()) << r.status();
  const ModelFit& sinusoid = r->fits[1];
  ASSERT_TRUE(sinusoid.converged);
  EXPECT_GT(sinusoid.num_censored, 0);
  EXPECT_NEAR(sinusoid.max_slope, 0.24, 0.006);
  EXPECT_EQ(r->fits[r->best].model, ProfileModel::kSinusoid);
  // The same bounds read as levels: the flattened caustics.
  Profile levels = p;
  for (int i = 0; i < levels.NumBins(); ++i) {
    if (!(levels.saturated[i] > 0.0)) continue;
    levels.mean[i] = 0.5 * (levels.mean[i] + clip);
    levels.count[i] = 100.0;
    levels.saturated[i] = 0.0;
    levels.saturated_sum[i] = 0.0;
  }
  absl::StatusOr<ProfileFitResult> flat =
      FitProfileModels(levels, 20.0 * kDeg, Projection(), 0.22, ProfileFitOptions());
  ASSERT_TRUE(flat.ok()) << flat.status();
  EXPECT_GT(std::fabs(flat->fits[1].max_slope - 0.24), 2.0 * std::fabs(sinusoid.max_slope - 0.24))
      << flat->fits[1].max_slope << " " << sinusoid.max_slope;

  // Half of every bin's pixels clipped across the window: refused.
  for (std::size_t i = 0; i < p.azimuth_rad.size(); ++i) {
    if (std::fabs(p.azimuth_rad[i] - 10.0 * kDeg) < 30.0 * kDeg) {
      p.saturated[i] = 50.0;
      p.saturated_sum[i] = 50.0 * clip;
      p.count[i] = 50.0;
    }
  }
  EXPECT_FALSE(FitProfileModels(p, 20.0 * kDeg, Projection(), 0.22, ProfileFitOptions()).ok());
}

// A few clipped glint pixels among many (a large photograph): the light they
// can hide is within the bins' noise, so no bin is censored and the fit
// stands; the same pixels censored every bin within 3σ of smoothing before.
TEST(ProfileFitTest, AFewClippedPixelsAmongManyDoNotCensorTheLobe) {
  Profile p = MakeProfile(ProfileModel::kSinusoid, 0.24, 20.0 * kDeg, 0.0005, 4);
  double top = 0.0;
  for (double v : p.mean) top = std::max(top, v);
  p.saturated_sum.assign(p.NumBins(), 0.0);
  int clipped = 0;
  for (int i = 0; i < p.NumBins(); i += 7) {
    if (std::fabs(p.azimuth_rad[i] - 10.0 * kDeg) > 20.0 * kDeg) continue;
    // One pixel in 4,000 clipped, at the level of the lobe's top.
    p.count[i] = 3999.0;
    p.saturated[i] = 1.0;
    p.saturated_sum[i] = top;
    ++clipped;
  }
  ASSERT_GT(clipped, 5);
  ProfileFitOptions options;
  options.smoothing_rad = 2.0 * kDeg;
  absl::StatusOr<ProfileFitResult> r =
      FitProfileModels(p, 20.0 * kDeg, Projection(), 0.22, options);
  ASSERT_TRUE(r.ok()) << r.status();
  const ModelFit& sinusoid = r->fits[1];
  ASSERT_TRUE(sinusoid.converged);
  EXPECT_EQ(sinusoid.num_censored, 0);
  EXPECT_NEAR(sinusoid.max_slope, 0.24, 0.01);
}

}  // namespace
}  // namespace weavefit
