// Unit tests of pipeline/given_cylinder: a given cylinder's checks, the
// geometry made of it, the series' combined cylinder, and the estimate read
// through a given cylinder against the one read through its own detection.
#include "estimator/pipeline/given_cylinder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "estimator/pipeline/estimate.h"
#include "estimator/render/render.h"

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

GivenCylinder Given(double cx, double r, double tilt_deg = 0.0) {
  GivenCylinder g;
  g.center_x_px = cx;
  g.radius_px = r;
  g.axis_angle_rad = tilt_deg * kDeg;
  return g;
}

void ExpectInvalidNaming(const absl::Status& s, const std::string& field) {
  EXPECT_EQ(s.code(), absl::StatusCode::kInvalidArgument) << s;
  EXPECT_NE(std::string(s.message()).find(field), std::string::npos) << s;
}

TEST(GivenCylinderTest, ValidateNamesTheField) {
  EXPECT_TRUE(Given(160, 100).Validate().ok());
  ExpectInvalidNaming(Given(kNaN, 100).Validate(), "given_cylinder.center_x_px");
  ExpectInvalidNaming(Given(160, kInf).Validate(), "given_cylinder.radius_px");
  ExpectInvalidNaming(Given(160, 0).Validate(), "given_cylinder.radius_px");
  ExpectInvalidNaming(Given(160, -5).Validate(), "given_cylinder.radius_px");
  ExpectInvalidNaming(Given(160, 100, 50).Validate(), "given_cylinder.axis_angle_deg");
  ExpectInvalidNaming(Given(160, 100, kNaN).Validate(), "given_cylinder.axis_angle_deg");
  GivenCylinder g = Given(160, 100);
  g.radius_stderr_px = -1;
  ExpectInvalidNaming(g.Validate(), "given_cylinder.radius_stderr_px");
  g = Given(160, 100);
  g.center_stderr_px = 100;
  ExpectInvalidNaming(g.Validate(), "given_cylinder.center_stderr_px");
  g = Given(160, 100);
  g.lens_blur_px = kNaN;
  ExpectInvalidNaming(g.Validate(), "given_cylinder.lens_blur_px");
  g = Given(160, 100);
  g.source = CylinderSource::kDetected;
  ExpectInvalidNaming(g.Validate(), "given_cylinder.source");
}

TEST(GivenCylinderTest, GeometryIsCheckedAgainstTheImage) {
  // 320 × 240: a cylinder of radius 100 about column 160 fits.
  EXPECT_TRUE(GeometryFromGiven(Given(160, 100), 320, 240, {}).ok());
  ExpectInvalidNaming(GeometryFromGiven(Given(400, 100), 320, 240, {}).status(),
                      "given_cylinder.center_x_px");
  ExpectInvalidNaming(GeometryFromGiven(Given(-1, 100), 320, 240, {}).status(),
                      "given_cylinder.center_x_px");
  ExpectInvalidNaming(GeometryFromGiven(Given(160, 170), 320, 240, {}).status(),
                      "given_cylinder.radius_px");
  ExpectInvalidNaming(GeometryFromGiven(Given(100, 110), 320, 240, {}).status(),
                      "left limb");
  // Tilted 20°, the axis moves 0.36 px a row: the top row's right limb
  // (axis 160 + 119.5·0.36 = 203.5, half-width 127.7) leaves the frame.
  ExpectInvalidNaming(GeometryFromGiven(Given(160, 120, 20), 320, 240, {}).status(),
                      "right limb");
  // Read over rows 100–139 only, it fits.
  EXPECT_TRUE(GeometryFromGiven(Given(160, 120, 20), 320, 240, {0, 100, 320, 40}).ok());
  // Values far out of range are refused, not overflowed into a pass.
  EXPECT_FALSE(GeometryFromGiven(Given(1e308, 1e308), 320, 240, {}).ok());
  EXPECT_FALSE(GeometryFromGiven(Given(-1e308, 100, 44.9), 320, 240, {}).ok());
}

TEST(GivenCylinderTest, GeometryReadsTheRegionsRowsWithNeitherLimbObserved) {
  GivenCylinder given = Given(160, 100, 2.0);
  given.radius_stderr_px = 0.3;
  given.center_stderr_px = 0.4;
  given.lens_blur_px = 1.2;
  absl::StatusOr<CylinderGeometry> g = GeometryFromGiven(given, 320, 240, {10, 40, 300, 100});
  ASSERT_TRUE(g.ok()) << g.status();
  EXPECT_EQ(g->top_row, 40);
  EXPECT_EQ(g->bottom_row, 139);
  EXPECT_DOUBLE_EQ(g->center_row_px, 89.5);
  // The same axis: at the image's middle row it is the given column.
  EXPECT_NEAR(g->AxisColumn(119.5), 160.0, 1e-12);
  EXPECT_FALSE(g->left_observed);
  EXPECT_FALSE(g->right_observed);
  EXPECT_DOUBLE_EQ(g->radius_stderr_px, 0.3);
  EXPECT_DOUBLE_EQ(g->radius_systematic_px, 0.3);
  EXPECT_DOUBLE_EQ(g->left_limb_stderr_px, 0.5);
  EXPECT_DOUBLE_EQ(g->right_limb_systematic_px, 0.5);
  EXPECT_DOUBLE_EQ(g->lens_blur_px, 1.2);
  EXPECT_NEAR(CenterStderrPx(*g), 0.4, 1e-12);
  // And back.
  const GivenCylinder back = GivenFromGeometry(*g, 240, CylinderSource::kShared);
  EXPECT_NEAR(back.center_x_px, 160.0, 1e-12);
  EXPECT_NEAR(back.center_stderr_px, 0.4, 1e-12);
  EXPECT_DOUBLE_EQ(back.radius_stderr_px, 0.3);
  EXPECT_EQ(back.source, CylinderSource::kShared);
}

CylinderGeometry Detection(double cx, double r, double limb_se, double limb_sys,
                           bool both = true) {
  CylinderGeometry g;
  g.center_row_px = 119.5;
  g.center_x_px = cx;
  g.radius_px = r;
  g.top_row = 0;
  g.bottom_row = 239;
  g.left_observed = true;
  g.right_observed = both;
  g.left_limb_stderr_px = g.right_limb_stderr_px = limb_se;
  g.left_limb_systematic_px = g.right_limb_systematic_px = limb_sys;
  g.radius_stderr_px = limb_se / std::sqrt(2.0);
  g.radius_systematic_px = limb_sys / std::sqrt(2.0);
  g.lens_blur_px = 0.5;
  return g;
}

TEST(CombineCylindersTest, InverseVarianceMeanWithTheSystematicShareKept) {
  // Two detections, one twice as precise: weights 4 : 1.
  const std::vector<CylinderGeometry> d = {Detection(160.0, 128.0, 0.2, 0.07),
                                           Detection(160.2, 128.2, 0.4, 0.07)};
  absl::StatusOr<SharedCylinder> s = CombineCylinders(d);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(s->used, (std::vector<int>{0, 1}));
  EXPECT_NEAR(s->cylinder.center_x_px, 160.04, 1e-9);
  EXPECT_NEAR(s->cylinder.radius_px, 128.04, 1e-9);
  EXPECT_LT(s->chi2, 1.0);
  EXPECT_TRUE(s->warnings.empty());
  // Smaller than the better one's error, never below the allowance.
  EXPECT_LT(s->cylinder.radius_stderr_px, d[0].radius_stderr_px);
  EXPECT_GE(s->cylinder.radius_stderr_px, s->cylinder.radius_systematic_px);
  EXPECT_NEAR(s->cylinder.radius_systematic_px, 0.07 / std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(s->cylinder.lens_blur_px, 0.5, 1e-12);
}

TEST(CombineCylindersTest, LeavesOutInferredLimbsAndMisdetections) {
  const std::vector<CylinderGeometry> d = {
      Detection(160.0, 128.0, 0.3, 0.07), Detection(150.0, 140.0, 0.3, 0.07),  // a terminator
      Detection(160.2, 128.2, 0.3, 0.07), Detection(161.0, 127.0, 1.0, 0.5, false)};
  absl::StatusOr<SharedCylinder> s = CombineCylinders(d);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_EQ(s->used, (std::vector<int>{0, 2}));
  EXPECT_NEAR(s->cylinder.center_x_px, 160.1, 1e-9);
  ASSERT_EQ(s->warnings.size(), 2u);
  EXPECT_NE(s->warnings[0].find("inferred"), std::string::npos) << s->warnings[0];
  EXPECT_NE(s->warnings[1].find("detection 2 of 4"), std::string::npos) << s->warnings[1];
}

TEST(CombineCylindersTest, DisagreementBeyondTheErrorsScalesThem) {
  const std::vector<CylinderGeometry> d = {Detection(160.0, 128.0, 0.1, 0.0),
                                           Detection(161.0, 129.0, 0.1, 0.0)};
  absl::StatusOr<SharedCylinder> s = CombineCylinders(d);
  ASSERT_TRUE(s.ok()) << s.status();
  EXPECT_GT(s->chi2, 10.0);
  // Scaled, the error covers the spread.
  EXPECT_GT(s->cylinder.radius_stderr_px, 0.3);
  ASSERT_FALSE(s->warnings.empty());
}

TEST(CombineCylindersTest, NoDetectionIsRefused) {
  EXPECT_EQ(CombineCylinders({}).status().code(), absl::StatusCode::kInvalidArgument);
}

// The pipeline through a given cylinder ---------------------------------

RenderScene GauzeScene(double phase_deg) {
  RenderScene scene;
  scene.width_px = 400;
  scene.height_px = 300;
  scene.samples_per_pixel = 2;
  scene.model = ProfileModel::kSinusoid;
  // The paper's coarse copper gauze: λ 2.88 mm, h0 0.108 mm (m 0.2356).
  scene.wavelength_mm = 2.88;
  scene.amplitude_mm = 0.108;
  scene.phase_angle_deg = phase_deg;
  scene.center_x_px = 201.2;
  scene.radius_px = 160.0;
  scene.seed = 3;
  return scene;
}

Acquisition Lab(double phase_deg) {
  Acquisition acquisition;
  acquisition.phase_angle_rad = phase_deg * kDeg;
  acquisition.cylinder_diameter_mm = 46.0;
  acquisition.pixels_linear = true;
  return acquisition;
}

TEST(GivenCylinderEstimateTest, ItsOwnDetectionGivenReproducesTheEstimate) {
  absl::StatusOr<Rendered> r = RenderPhotograph(GauzeScene(10.0));
  ASSERT_TRUE(r.ok()) << r.status();
  absl::StatusOr<Estimate> detected = EstimateFromImage(r->image, Lab(10.0), EstimateOptions());
  ASSERT_TRUE(detected.ok()) << detected.status();
  EXPECT_EQ(detected->cylinder_source, CylinderSource::kDetected);
  Acquisition given = Lab(10.0);
  given.given_cylinder =
      GivenFromGeometry(detected->cylinder, r->image.height, CylinderSource::kGiven);
  absl::StatusOr<Estimate> e = EstimateFromImage(r->image, given, EstimateOptions());
  ASSERT_TRUE(e.ok()) << e.status();
  EXPECT_EQ(e->cylinder_source, CylinderSource::kGiven);
  EXPECT_FALSE(e->cylinder.left_observed);
  EXPECT_EQ(e->model, detected->model);
  ASSERT_TRUE(e->max_slope.resolved);
  ASSERT_TRUE(detected->max_slope.resolved);
  EXPECT_NEAR(e->max_slope.value, detected->max_slope.value,
              0.25 * detected->max_slope.stderr_value);
  ASSERT_TRUE(detected->wavelength_mm.resolved) << detected->BriefReport();
  ASSERT_TRUE(e->wavelength_mm.resolved)
      << detected->BriefReport() << "\n" << e->BriefReport() << "\n"
      << ::testing::PrintToString(e->warnings);
  EXPECT_NEAR(e->wavelength_mm.value, detected->wavelength_mm.value,
              0.25 * detected->wavelength_mm.stderr_value);
  bool said = false;
  for (const std::string& w : e->warnings) said = said || w.find("was given") != std::string::npos;
  EXPECT_TRUE(said);
}

TEST(GivenCylinderEstimateTest, TheTruthGivenMeasuresTheTruth) {
  absl::StatusOr<Rendered> r = RenderPhotograph(GauzeScene(30.0));
  ASSERT_TRUE(r.ok()) << r.status();
  Acquisition acquisition = Lab(30.0);
  acquisition.given_cylinder = Given(r->truth.center_x_px, r->truth.radius_px);
  absl::StatusOr<Estimate> e = EstimateFromImage(r->image, acquisition, EstimateOptions());
  ASSERT_TRUE(e.ok()) << e.status();
  ASSERT_TRUE(e->max_slope.resolved);
  EXPECT_NEAR(e->max_slope.value, r->truth.max_slope, 3.0 * e->max_slope.stderr_value);
  // The given radius's 0.5 px is all systematic and common.
  EXPECT_GT(e->max_slope.common, 0.0);
}

TEST(GivenCylinderEstimateTest, AGivenCylinderOutsideTheImageIsRefused) {
  absl::StatusOr<Rendered> r = RenderPhotograph(GauzeScene(10.0));
  ASSERT_TRUE(r.ok()) << r.status();
  Acquisition acquisition = Lab(10.0);
  acquisition.given_cylinder = Given(201.2, 250.0);
  ExpectInvalidNaming(EstimateFromImage(r->image, acquisition, EstimateOptions()).status(),
                      "given_cylinder.radius_px");
  acquisition.given_cylinder = Given(201.2, kNaN);
  ExpectInvalidNaming(EstimateFromImage(r->image, acquisition, EstimateOptions()).status(),
                      "given_cylinder.radius_px");
}

}  // namespace
}  // namespace weavefit
