// The FLANN bank of model lobe shapes.
#include "estimator/init/profile_bank.h"

#include <gtest/gtest.h>

#include <cmath>

#include "estimator/pipeline/estimate.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A noiseless profile of one model (specular lobe plus a flat body level)
// on a 0.25° grid.
Profile ModelProfile(ProfileModel model, double slope, double blur_rad, double alpha_rad) {
  Profile p;
  RadianceParams<double> params;
  params.model = model;
  params.max_slope = slope;
  params.mirror_rad = alpha_rad / 2.0;
  params.blur_rad = blur_rad;
  params.scale = 0.01;
  for (double phi = -85.0 * kDeg; phi <= 85.0 * kDeg; phi += 0.25 * kDeg) {
    p.azimuth_rad.push_back(phi);
    p.mean.push_back(0.03 + SpecularRadiance(params, phi));
    p.count.push_back(100.0);
  }
  p.bin_width_rad = 0.25 * kDeg;
  return p;
}

TEST(ProfileBankTest, BuildsEveryModelSlopeAndBlur) {
  const ProfileBank& bank = ProfileBank::Default();
  const ProfileBankOptions& o = bank.options();
  // Every entry whose lobe falls inside the sampled window (a sawtooth's
  // caustics at ±arctan m, sharper than the grid, can fall between samples).
  EXPECT_GT(bank.size(), 0.98 * o.num_blurs * (1 + 2 * o.num_slopes));
  EXPECT_LE(bank.size(), o.num_blurs * (1 + 2 * o.num_slopes));
}

TEST(ProfileBankTest, FindsTheModelOfANoiselessLobe) {
  const ProfileBank& bank = ProfileBank::Default();
  struct Case {
    ProfileModel model;
    double slope;
    double blur_deg;
    double alpha_deg;
  };
  for (const Case& c : {Case{ProfileModel::kSawtooth, 0.15, 0.5, 10.0},
                        Case{ProfileModel::kSinusoid, 0.2356, 0.4, 60.0},
                        Case{ProfileModel::kSinusoid, 0.5, 1.0, -30.0},
                        Case{ProfileModel::kSmooth, 0.0, 1.5, 20.0}}) {
    SCOPED_TRACE(std::string(ProfileModelName(c.model)) + " " + std::to_string(c.slope));
    const Profile p = ModelProfile(c.model, c.slope, c.blur_deg * kDeg, c.alpha_deg * kDeg);
    absl::StatusOr<std::vector<BankMatch>> near = bank.Nearest(p, c.alpha_deg * kDeg / 2.0, c.alpha_deg * kDeg, 3);
    ASSERT_TRUE(near.ok()) << near.status();
    ASSERT_FALSE(near->empty());
    const BankMatch& best = near->front();
    EXPECT_EQ(best.entry.model, c.model);
    if (c.model != ProfileModel::kSmooth) {
      // The slope grid steps by 8 %; the nearest entry is within a step.
      EXPECT_NEAR(best.entry.max_slope / c.slope, 1.0, 0.09);
    }
    // Unrelated unit vectors are √2 apart.
    EXPECT_LT(best.distance, 0.4);
  }
}

TEST(ProfileBankTest, RenderedPhotographsMatchTheirModel) {
  const ProfileBank& bank = ProfileBank::Default();
  for (ProfileModel model : {ProfileModel::kSawtooth, ProfileModel::kSinusoid}) {
    RenderScene scene;
    scene.width_px = 320;
    scene.height_px = 240;
    scene.radius_px = 128.0;
    scene.model = model;
    scene.wavelength_mm = 1.0;  // many threads in view: a lobe more than a comb
    scene.amplitude_mm = model == ProfileModel::kSawtooth ? 0.05 : 0.2 / (2 * M_PI);  // m 0.2
    scene.regular_weave = true;
    scene.phase_step = 1.0 / 16.0;
    scene.phase_angle_deg = 20.0;
    scene.seed = 5;
    absl::StatusOr<Rendered> r = RenderPhotograph(scene);
    ASSERT_TRUE(r.ok());
    Acquisition acquisition;
    acquisition.phase_angle_rad = scene.phase_angle_deg * kDeg;
    acquisition.pixels_linear = true;
    EstimateOptions options;
    options.mode = Mode::kFast;
    absl::StatusOr<Estimate> e = EstimateFromImage(r->image, acquisition, options);
    ASSERT_TRUE(e.ok()) << e.status();
    absl::StatusOr<std::vector<BankMatch>> near =
        bank.Nearest(e->profile, e->specular_azimuth_rad.value, acquisition.phase_angle_rad, 1);
    ASSERT_TRUE(near.ok()) << near.status();
    EXPECT_EQ(near->front().entry.model, model) << ProfileModelName(near->front().entry.model);
    EXPECT_NEAR(near->front().entry.max_slope, r->truth.max_slope, 0.15 * r->truth.max_slope);
  }
}

TEST(ProfileBankTest, AFlatProfileHasNoLobe) {
  Profile p;
  for (double phi = -80.0 * kDeg; phi <= 80.0 * kDeg; phi += 0.25 * kDeg) {
    p.azimuth_rad.push_back(phi);
    p.mean.push_back(0.03);
    p.count.push_back(10.0);
  }
  absl::StatusOr<std::vector<BankMatch>> near = ProfileBank::Default().Nearest(p, 0.1, 0.2, 3);
  ASSERT_FALSE(near.ok());
  EXPECT_EQ(near.status().code(), absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace weavefit
