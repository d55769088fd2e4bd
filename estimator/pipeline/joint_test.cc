// The joint estimate over several photographs of one sample.
#include "estimator/pipeline/joint.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

PhotographEstimate Photo(const std::string& name, ProfileModel model, double m, double m_se,
                         double lambda = 0.0, double lambda_se = 0.0) {
  PhotographEstimate p;
  p.name = name;
  p.model = model;
  p.max_slope = {m, m_se, m_se > 0.0};
  p.wavelength_mm = {lambda, lambda_se, lambda_se > 0.0};
  return p;
}

TEST(JointTest, InverseVarianceMeanWhenThePhotographsAgree) {
  absl::StatusOr<JointEstimate> j = CombineEstimates(
      {Photo("a", ProfileModel::kSinusoid, 0.24, 0.01, 2.0, 0.04),
       Photo("b", ProfileModel::kSinusoid, 0.25, 0.02, 2.02, 0.02),
       Photo("c", ProfileModel::kSinusoid, 0.23, 0.02)});
  ASSERT_TRUE(j.ok()) << j.status();
  EXPECT_EQ(j->model, ProfileModel::kSinusoid);
  // Weights 1/σ²: 10000, 2500, 2500.
  EXPECT_NEAR(j->max_slope.value, (0.24 * 4 + 0.25 + 0.23) / 6.0, 1e-12);
  EXPECT_NEAR(j->max_slope.stderr_value, std::sqrt(1.0 / 15000.0), 1e-12);  // chi2 < 1
  EXPECT_EQ(j->slope_photographs, 3);
  EXPECT_NEAR(j->peak_spacing_rad.value, 2.0 * std::atan(j->max_slope.value), 1e-12);
  ASSERT_TRUE(j->max_inclination_rad.resolved);
  EXPECT_NEAR(j->max_inclination_rad.value, std::atan(j->max_slope.value), 1e-12);
  EXPECT_NEAR(j->max_inclination_rad.stderr_value,
              j->max_slope.stderr_value / (1.0 + j->max_slope.value * j->max_slope.value), 1e-15);
  EXPECT_EQ(j->wavelength_photographs, 2);
  EXPECT_NEAR(j->wavelength_mm.value, (2.0 * 625 + 2.02 * 2500) / 3125.0, 1e-12);
  ASSERT_TRUE(j->amplitude_mm.resolved);
  EXPECT_NEAR(j->amplitude_mm.value, j->max_slope.value * j->wavelength_mm.value / (2 * M_PI),
              1e-12);
  EXPECT_TRUE(j->warnings.empty());
}

TEST(JointTest, DisagreementScalesTheErrorAndSaysSo) {
  absl::StatusOr<JointEstimate> j = CombineEstimates(
      {Photo("a", ProfileModel::kSawtooth, 0.15, 0.002), Photo("b", ProfileModel::kSawtooth, 0.20, 0.002)});
  ASSERT_TRUE(j.ok());
  // chi2 = (0.025/0.002)² · 2 = 312.5 with one degree of freedom.
  EXPECT_NEAR(j->slope_chi2, 312.5, 1e-9);
  EXPECT_NEAR(j->max_slope.stderr_value, std::sqrt(0.5) * 0.002 * std::sqrt(312.5), 1e-12);
  ASSERT_EQ(j->warnings.size(), 1u);
  EXPECT_NE(j->warnings[0].find("scatter"), std::string::npos);
  EXPECT_FALSE(j->wavelength_mm.resolved);
  EXPECT_FALSE(j->amplitude_mm.resolved);
}

// Three photographs each stating 0.0005 in m, of which 0.0004 is the
// models' allowance: averaging shrinks the statistical share by √3, not the
// systematic one, and the reply keeps the two apart.
TEST(JointTest, TheSystematicShareDoesNotAverageAway) {
  std::vector<PhotographEstimate> photos;
  for (const char* name : {"10", "60", "110"}) {
    PhotographEstimate p = Photo(name, ProfileModel::kSinusoid, 0.2356, 0.0005, 2.88, 0.002);
    p.max_slope.systematic = 0.0004;
    p.max_slope.common = 0.0004;
    p.wavelength_mm.systematic = 0.0012;
    p.wavelength_mm.common = 0.0012;
    photos.push_back(p);
  }
  absl::StatusOr<JointEstimate> j = CombineEstimates(photos);
  ASSERT_TRUE(j.ok()) << j.status();
  EXPECT_NEAR(j->max_slope.systematic, 0.0004, 1e-15);
  EXPECT_NEAR(j->max_slope.Statistical(), 0.0003 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(j->max_slope.stderr_value, std::hypot(0.0003 / std::sqrt(3.0), 0.0004), 1e-12);
  EXPECT_NEAR(j->wavelength_mm.Statistical(), 0.0016 / std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(j->wavelength_mm.systematic, 0.0012, 1e-15);
  // Carried to the spacing, the inclination and the amplitude.
  const double d = 2.0 / (1.0 + 0.2356 * 0.2356);
  EXPECT_NEAR(j->peak_spacing_rad.systematic, 0.0004 * d, 1e-15);
  EXPECT_NEAR(j->max_inclination_rad.systematic, 0.0002 * d, 1e-15);
  ASSERT_TRUE(j->amplitude_mm.resolved);
  EXPECT_NEAR(j->amplitude_mm.systematic / j->amplitude_mm.value,
              std::hypot(0.0004 / 0.2356, 0.0012 / 2.88), 1e-12);
  EXPECT_LT(j->amplitude_mm.systematic, j->amplitude_mm.stderr_value);
  EXPECT_NEAR(j->amplitude_mm.common, j->amplitude_mm.systematic, 1e-15);
}

// Peaks located on the profile's bins fall elsewhere on the pixel grid at
// each phase angle: that systematic share averages like noise, the common
// one (the blur's pull) does not.
TEST(JointTest, OnlyTheCommonShareOfTheSystematicOneStays) {
  std::vector<PhotographEstimate> photos;
  for (const char* name : {"10", "60", "110", "150"}) {
    PhotographEstimate p = Photo(name, ProfileModel::kSawtooth, 0.2, 0.005);
    p.max_slope.systematic = 0.004;  // statistical 0.003
    p.max_slope.common = 0.002;      // moving with the geometry sqrt(0.004² − 0.002²)
    photos.push_back(p);
  }
  absl::StatusOr<JointEstimate> j = CombineEstimates(photos);
  ASSERT_TRUE(j.ok()) << j.status();
  EXPECT_NEAR(j->max_slope.Statistical(), 0.003 / 2.0, 1e-12);
  EXPECT_NEAR(j->max_slope.common, 0.002, 1e-15);
  EXPECT_NEAR(j->max_slope.systematic, std::hypot(std::sqrt(0.004 * 0.004 - 0.002 * 0.002) / 2.0, 0.002),
              1e-12);
  EXPECT_LT(j->max_slope.stderr_value, 0.005);
}

TEST(JointTest, TheMajorityModelWinsAndTheOthersAreLeftOut) {
  absl::StatusOr<JointEstimate> j = CombineEstimates(
      {Photo("a", ProfileModel::kSinusoid, 0.24, 0.01), Photo("b", ProfileModel::kSinusoid, 0.24, 0.01),
       Photo("c", ProfileModel::kSawtooth, 0.15, 0.001)});
  ASSERT_TRUE(j.ok());
  EXPECT_EQ(j->model, ProfileModel::kSinusoid);
  EXPECT_EQ(j->slope_photographs, 2);
  EXPECT_NEAR(j->max_slope.value, 0.24, 1e-12);
  ASSERT_FALSE(j->warnings.empty());
  EXPECT_NE(j->warnings[0].find("disagree on the thread profile"), std::string::npos);
}

// Two photographs whose small split hides in their blur read SMOOTH; the one
// that resolves it decides, and the others' bounds are checked against it.
TEST(JointTest, HiddenSplitsDoNotOutvoteAResolvedOne) {
  PhotographEstimate hidden_a = Photo("60", ProfileModel::kSmooth, 0, 0);
  hidden_a.max_slope.upper_bound = 0.06;
  PhotographEstimate hidden_b = Photo("110", ProfileModel::kSmooth, 0, 0);
  hidden_b.max_slope.upper_bound = 0.03;
  absl::StatusOr<JointEstimate> j =
      CombineEstimates({Photo("10", ProfileModel::kSinusoid, 0.05, 0.003), hidden_a, hidden_b});
  ASSERT_TRUE(j.ok());
  EXPECT_EQ(j->model, ProfileModel::kSinusoid);
  ASSERT_TRUE(j->max_slope.resolved);
  EXPECT_NEAR(j->max_slope.value, 0.05, 1e-12);
  bool bound_warned = false;
  for (const std::string& w : j->warnings) {
    bound_warned = bound_warned || (w.find("110") != std::string::npos &&
                                    w.find("exceeds the bound") != std::string::npos);
  }
  EXPECT_TRUE(bound_warned);  // 0.05 > 0.03 + 2·0.003
}

TEST(JointTest, SmoothSamplesHaveNoSlope) {
  absl::StatusOr<JointEstimate> j =
      CombineEstimates({Photo("a", ProfileModel::kSmooth, 0, 0), Photo("b", ProfileModel::kSmooth, 0, 0)});
  ASSERT_TRUE(j.ok());
  EXPECT_EQ(j->model, ProfileModel::kSmooth);
  EXPECT_FALSE(j->max_slope.resolved);
  EXPECT_FALSE(j->peak_spacing_rad.resolved);
  EXPECT_FALSE(j->max_inclination_rad.resolved);
}

TEST(JointTest, OnePhotographIsNotAJointEstimate) {
  absl::StatusOr<JointEstimate> j = CombineEstimates({Photo("a", ProfileModel::kSinusoid, 0.24, 0.01)});
  ASSERT_FALSE(j.ok());
  EXPECT_EQ(j.status().code(), absl::StatusCode::kInvalidArgument);
}

// One sawtooth sample (m = 0.2) photographed at the paper's three phase
// angles: the joint's independent share (what does not repeat from one
// photograph to the next) is smaller than the photographs' mean, its error
// bar no larger than the best one's, and the joint value lies within 3 of
// its standard errors of the truth.
double Independent(const Quantity& q) {
  const double s2 = q.stderr_value * q.stderr_value - q.common * q.common;
  return s2 > 0.0 ? std::sqrt(s2) : 0.0;
}

TEST(JointTest, ThreePhaseAnglesOfOneRenderedSample) {
  std::vector<PhotographEstimate> photos;
  double truth = 0.0;
  double smallest_se = 1e9;
  double mean_independent = 0.0;
  for (double alpha : {10.0, 60.0, 110.0}) {
    RenderScene scene;
    scene.width_px = 320;
    scene.height_px = 240;
    scene.radius_px = 128.0;
    scene.model = ProfileModel::kSawtooth;
    scene.wavelength_mm = 2.0;
    scene.amplitude_mm = 0.1;  // m = 4·h0/λ = 0.2
    scene.phase_angle_deg = alpha;
    scene.seed = 7 + static_cast<int>(alpha);
    absl::StatusOr<Rendered> r = RenderPhotograph(scene);
    ASSERT_TRUE(r.ok()) << r.status();
    truth = r->truth.max_slope;
    Acquisition acquisition;
    acquisition.phase_angle_rad = alpha * kDeg;
    acquisition.pixels_linear = true;
    absl::StatusOr<Estimate> e = EstimateFromImage(r->image, acquisition, EstimateOptions());
    ASSERT_TRUE(e.ok()) << e.status();
    ASSERT_TRUE(e->max_slope.resolved) << alpha;
    smallest_se = std::min(smallest_se, e->max_slope.stderr_value);
    mean_independent += Independent(e->max_slope) / 3.0;
    photos.push_back(PhotographFrom(*e, "alpha " + std::to_string(alpha)));
  }
  absl::StatusOr<JointEstimate> j = CombineEstimates(photos);
  ASSERT_TRUE(j.ok()) << j.status();
  EXPECT_EQ(j->model, ProfileModel::kSawtooth);
  EXPECT_EQ(j->slope_photographs, 3);
  // What does not repeat from one photograph to the next averages down; the
  // sawtooth's shape allowance (kSawtoothShapeFloor, 1 % of the spacing),
  // common to the sample, does not, and where it dominates, as in these
  // noise-free renders, the joint error stays at the best photograph's.
  EXPECT_LT(Independent(j->max_slope), mean_independent);
  EXPECT_LE(j->max_slope.stderr_value, 1.01 * smallest_se);
  EXPECT_NEAR(j->max_slope.value, truth, 3.0 * j->max_slope.stderr_value);
}

}  // namespace
}  // namespace weavefit
