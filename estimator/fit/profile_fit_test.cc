// The least-squares fits recover the model and its max slope from profiles
// made with the model itself (with noise), and refuse a clipped lobe.
#include "estimator/fit/profile_fit.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

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

TEST(ProfileFitTest, SawtoothIsNotReportedAsASinusoid) {
  const Profile p = MakeProfile(ProfileModel::kSawtooth, 0.15, -30.0 * kDeg, 0.0005, 2);
  absl::StatusOr<ProfileFitResult> r = FitProfileModels(p, -30.0 * kDeg, Projection(), 0.14, ProfileFitOptions());
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_GE(r->best, 0);
  EXPECT_EQ(r->fits[r->best].model, ProfileModel::kSawtooth);
  EXPECT_NEAR(r->fits[r->best].max_slope, 0.15, 0.002);
}

TEST(ProfileFitTest, SmoothCylinderComesBackSmooth) {
  const Profile p = MakeProfile(ProfileModel::kSmooth, 0.0, 10.0 * kDeg, 0.0005, 3);
  absl::StatusOr<ProfileFitResult> r = FitProfileModels(p, 10.0 * kDeg, Projection(), 0.2, ProfileFitOptions());
  ASSERT_TRUE(r.ok()) << r.status();
  ASSERT_GE(r->best, 0);
  EXPECT_EQ(r->fits[r->best].model, ProfileModel::kSmooth);
  EXPECT_NEAR(r->fits[r->best].mirror_rad / kDeg, 5.0, 0.05);
}

TEST(ProfileFitTest, ClippedLobeIsRefused) {
  Profile p = MakeProfile(ProfileModel::kSinusoid, 0.24, 20.0 * kDeg, 0.0005, 4);
  for (std::size_t i = 0; i < p.azimuth_rad.size(); i += 3) {
    if (std::fabs(p.azimuth_rad[i] - 10.0 * kDeg) < 15.0 * kDeg) p.saturated[i] = 1.0;
  }
  absl::StatusOr<ProfileFitResult> r = FitProfileModels(p, 20.0 * kDeg, Projection(), 0.22, ProfileFitOptions());
  EXPECT_FALSE(r.ok());
}

}  // namespace
}  // namespace weavefit
