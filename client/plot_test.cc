// Fit plots from an in-process estimate of a fixture: the reply carries the
// curves, the PNG is written with the chart and the thumbnail side by side.
#include "client/plot.h"

#include <gtest/gtest.h>

#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "estimator/pipeline/estimate.h"
#include "proto/weavefit/v1/convert.h"
#include "tests/temp_dir.h"

namespace weavefit {
namespace {

std::string Read(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

v1::EstimateReply ReplyFor(const std::string& bytes, double phase_deg, bool curves) {
  Acquisition acquisition;
  acquisition.phase_angle_rad = phase_deg * M_PI / 180.0;
  EstimateOptions options;
  options.include_curves = curves;
  absl::StatusOr<Estimate> estimate = EstimateFromBytes(bytes, acquisition, options);
  EXPECT_TRUE(estimate.ok()) << estimate.status();
  return estimate.ok() ? ReplyFromEstimate(*estimate, "plot test") : v1::EstimateReply();
}

TEST(FitPlotTest, CurvesComeOnlyWhenAskedAndLeaveTheEstimateUnchanged) {
  const std::string bytes = Read(std::string(FIXTURES_DIR) + "/gauze_sinusoid_p10.png");
  const v1::EstimateReply plain = ReplyFor(bytes, 10.0, false);
  const v1::EstimateReply with = ReplyFor(bytes, 10.0, true);
  EXPECT_EQ(plain.curves_size(), 0);
  ASSERT_GE(with.curves_size(), 4);  // measured, smoothed, three fits
  EXPECT_EQ(with.curves(0).label(), "measured profile");
  EXPECT_EQ(with.curves(0).stderr_size(), with.curves(0).value_size());
  int selected = 0;
  for (const v1::Curve& c : with.curves()) {
    EXPECT_EQ(c.azimuth_deg_size(), c.value_size()) << c.label();
    selected += c.selected();
  }
  EXPECT_EQ(selected, 1) << "one fit is the reported model's";
  EXPECT_EQ(with.peak_spacing_deg().value(), plain.peak_spacing_deg().value());
  EXPECT_EQ(with.max_slope().value(), plain.max_slope().value());
}

TEST(FitPlotTest, WritesChartAndThumbnailSideBySide) {
  const std::string image = std::string(FIXTURES_DIR) + "/gauze_sinusoid_p10.png";
  const std::string bytes = Read(image);
  const v1::EstimateReply reply = ReplyFor(bytes, 10.0, true);
  const std::string out = testing::MakeTempDir() + "/fit_plot_test.png";
  const absl::Status written = WriteFitPlot(reply, bytes, "gauze_sinusoid_p10.png", out);
  ASSERT_TRUE(written.ok()) << written;
  const cv::Mat plot = cv::imread(out, cv::IMREAD_COLOR);
  ASSERT_FALSE(plot.empty());
  EXPECT_EQ(plot.rows, 760);
  EXPECT_GT(plot.cols, 1100 + 300) << "chart plus a thumbnail";
  EXPECT_LE(plot.cols, 1100 + 560 + 16);
  EXPECT_EQ(WriteFitPlot(ReplyFor(bytes, 10.0, false), bytes, "x", out).code(),
            absl::StatusCode::kFailedPrecondition);
}

// A photograph refused at detection (the phase angle's sign wrong): the
// picture of what detection saw, chart and stretched photograph side by
// side; nothing for a refusal that is not detection's.
TEST(RefusalPlotTest, ARefusalAtDetectionIsDrawnAndNothingElseIs) {
  const std::string image = std::string(FIXTURES_DIR) + "/gauze_sinusoid_p60.png";
  const std::string bytes = Read(image);
  v1::RequestHeader header;
  header.mutable_acquisition()->set_phase_angle_deg(-60.0);
  const std::string dir = testing::MakeTempDir() + "/plots";
  const absl::Status refusal = absl::InvalidArgumentError("no cylinder found");
  absl::StatusOr<bool> written =
      PlotRefusalInto(dir, "refused.png", image, bytes, header, refusal);
  ASSERT_TRUE(written.ok()) << written.status();
  EXPECT_TRUE(*written);
  const cv::Mat plot = cv::imread(dir + "/refused.png", cv::IMREAD_COLOR);
  ASSERT_FALSE(plot.empty());
  EXPECT_EQ(plot.rows, 760 + 140);
  EXPECT_GT(plot.cols, 1100 + 300) << "chart plus the photograph";
  // The right phase angle: detection finds the cylinder, nothing is drawn.
  header.mutable_acquisition()->set_phase_angle_deg(60.0);
  written = PlotRefusalInto(dir, "found.png", image, bytes, header, refusal);
  ASSERT_TRUE(written.ok()) << written.status();
  EXPECT_FALSE(*written);
  EXPECT_TRUE(cv::imread(dir + "/found.png").empty());
  // Not an argument error (a daemon gone): nothing either.
  header.mutable_acquisition()->set_phase_angle_deg(-60.0);
  written = PlotRefusalInto(dir, "gone.png", image, bytes, header,
                            absl::UnavailableError("daemon gone"));
  ASSERT_TRUE(written.ok());
  EXPECT_FALSE(*written);
  // A given cylinder: detection did not run.
  header.mutable_acquisition()->mutable_given_cylinder()->set_radius_px(100.0);
  written = PlotRefusalInto(dir, "given.png", image, bytes, header, refusal);
  ASSERT_TRUE(written.ok());
  EXPECT_FALSE(*written);
}

TEST(PlotFileNamesTest, DistinctWithinTheBatchAndStable) {
  // Unique stems keep the plain stem.
  EXPECT_EQ(PlotFileNames({"a/x.png", "b/y.tiff", "z.exr"}),
            (std::vector<std::string>{"x.png", "y.png", "z.png"}));
  // One stem in two formats: the extension tells them apart; the rest stay.
  EXPECT_EQ(PlotFileNames({"x.png", "x.exr", "y.png"}),
            (std::vector<std::string>{"x.png.png", "x.exr.png", "y.png"}));
  // One file name in two folders: the path.
  EXPECT_EQ(PlotFileNames({"./a/x.png", "/data/b/x.png"}),
            (std::vector<std::string>{"a_x.png.png", "data_b_x.png.png"}));
  // A stem that equals another input's stem-with-extension does not collide.
  const std::vector<std::string> tricky = PlotFileNames({"x.exr.png", "a/x.exr", "b/x.png"});
  EXPECT_EQ(std::set<std::string>(tricky.begin(), tricky.end()).size(), 3u);
  // The same path twice (a joint call may repeat one): numbered.
  const std::vector<std::string> twice = PlotFileNames({"x.png", "x.png"});
  EXPECT_NE(twice[0], twice[1]);
  // Only the list decides: the same inputs give the same names.
  EXPECT_EQ(PlotFileNames({"x.png", "x.exr"}), PlotFileNames({"x.png", "x.exr"}));
}

}  // namespace
}  // namespace weavefit
