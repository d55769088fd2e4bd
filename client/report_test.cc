// Unit tests of client/report: the CSV (columns, quoting, the inclination
// next to the max slope, unresolved values) and the table's umax column.
#include "client/report.h"
#include "proto/weavefit/v1/convert.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"

namespace weavefit {
namespace {

v1::EstimateReply GauzeReply() {
  v1::EstimateReply r;
  r.set_sample_name("gauze");
  r.set_model(v1::SINUSOID);
  r.set_method("comb-fit");
  r.set_version("0.1.0-test");
  r.set_mode(v1::BALANCED);
  r.mutable_acquisition()->set_phase_angle_deg(10.0);
  r.mutable_acquisition()->set_cylinder_diameter_mm(46.0);
  const double m = 0.2356;
  auto set = [](v1::Measurement* out, double value, double se) {
    out->set_value(value);
    out->set_stderr(se);
    out->set_resolved(true);
    out->set_statistical(0.6 * se);
    out->set_systematic(0.8 * se);
  };
  set(r.mutable_peak_spacing_deg(), 2.0 * std::atan(m) * 180.0 / M_PI, 0.05);
  set(r.mutable_max_slope(), m, 0.001);
  set(r.mutable_max_inclination_deg(), std::atan(m) * 180.0 / M_PI,
      0.001 / (1.0 + m * m) * 180.0 / M_PI);
  set(r.mutable_wavelength_mm(), 2.88, 0.002);
  set(r.mutable_amplitude_mm(), 0.108, 0.0001);
  set(r.mutable_specular_azimuth_deg(), 5.0, 0.01);
  r.mutable_cylinder()->set_center_x_px(160.25);
  r.mutable_cylinder()->set_radius_px(128.0);
  r.add_warnings("first, with a comma");
  r.add_warnings("second \"quoted\"");
  return r;
}

std::vector<std::string> Cells(const std::string& line) {
  // Only for lines without quoted commas.
  return absl::StrSplit(line.substr(0, line.size() - 1), ',');
}

TEST(CsvTest, HeaderNamesEveryColumnOnce) {
  const std::vector<std::string> columns = CsvColumns();
  EXPECT_EQ(CsvHeader(), absl::StrJoin(columns, ",") + "\n");
  EXPECT_EQ(columns.front(), "image");
  const auto at = [&](const std::string& name) {
    return std::find(columns.begin(), columns.end(), name) - columns.begin();
  };
  EXPECT_EQ(at("max_inclination_deg"), at("max_slope_systematic") + 1);
  EXPECT_EQ(at("max_inclination_deg_stderr"), at("max_inclination_deg") + 1);
  EXPECT_EQ(at("max_inclination_deg_upper_bound"), at("max_inclination_deg") + 2);
  EXPECT_EQ(at("max_inclination_deg_statistical"), at("max_inclination_deg") + 3);
  EXPECT_EQ(at("max_inclination_deg_systematic"), at("max_inclination_deg") + 4);
  EXPECT_EQ(columns.back(), "warnings");
}

TEST(CsvTest, ARowCarriesTheInclinationWithItsError) {
  ReportRow row;
  row.image = "fixtures/gauze.png";
  row.reply = GauzeReply();
  const std::string line = CsvRow(row);
  ASSERT_EQ(line.back(), '\n');
  const std::vector<std::string> columns = CsvColumns();
  // Every cell splits on commas alone: the warnings' own commas and quotes
  // became ';' and "'".
  const std::vector<std::string> cells = absl::StrSplit(line.substr(0, line.size() - 1), ',');
  ASSERT_EQ(cells.size(), columns.size()) << line;
  const auto cell = [&](const std::string& name) {
    return cells[std::find(columns.begin(), columns.end(), name) - columns.begin()];
  };
  EXPECT_EQ(cell("image"), "fixtures/gauze.png");
  EXPECT_EQ(cell("status"), "OK");
  EXPECT_EQ(cell("model"), "SINUSOID");
  EXPECT_NEAR(std::stod(cell("max_inclination_deg")),
              std::atan(std::stod(cell("max_slope"))) * 180.0 / M_PI, 1e-8);
  EXPECT_NEAR(std::stod(cell("max_inclination_deg")), 13.2571, 1e-4);
  EXPECT_NEAR(std::stod(cell("max_inclination_deg_stderr")),
              0.001 / (1.0 + 0.2356 * 0.2356) * 180.0 / M_PI, 1e-10);
  EXPECT_EQ(cell("max_inclination_deg_upper_bound"), "");
  EXPECT_NEAR(std::stod(cell("wavelength_mm_statistical")), 0.0012, 1e-12);
  EXPECT_NEAR(std::stod(cell("wavelength_mm_systematic")), 0.0016, 1e-12);
  EXPECT_EQ(cell("warnings"), "first; with a comma | second 'quoted'");
  // What was asked, and by which version.
  EXPECT_EQ(cell("mode"), "balanced");
  EXPECT_EQ(cell("weavefit_version"), GauzeReply().version());
}

TEST(CsvTest, UnresolvedValuesAreEmptyAndTheBoundIsGiven) {
  v1::EstimateReply r;
  r.set_model(v1::SMOOTH);
  r.mutable_max_slope()->set_upper_bound(0.05);
  r.mutable_max_inclination_deg()->set_upper_bound(std::atan(0.05) * 180.0 / M_PI);
  ReportRow row;
  row.image = "smooth.png";
  row.reply = r;
  const std::vector<std::string> cells = Cells(CsvRow(row));
  const std::vector<std::string> columns = CsvColumns();
  ASSERT_EQ(cells.size(), columns.size());
  const auto cell = [&](const std::string& name) {
    return cells[std::find(columns.begin(), columns.end(), name) - columns.begin()];
  };
  EXPECT_EQ(cell("max_slope"), "");
  EXPECT_EQ(cell("max_slope_stderr"), "");
  EXPECT_EQ(cell("max_slope_upper_bound"), "0.05");
  EXPECT_EQ(cell("max_slope_statistical"), "");
  EXPECT_EQ(cell("max_slope_systematic"), "");
  EXPECT_EQ(cell("max_inclination_deg"), "");
  EXPECT_NEAR(std::stod(cell("max_inclination_deg_upper_bound")), 2.862405226, 1e-8);
  EXPECT_EQ(cell("wavelength_mm_upper_bound"), "");
}

TEST(CsvTest, AFailedImageHasItsStatusAndEmptyCells) {
  ReportRow row;
  row.image = "bad.png";
  row.error = "INVALID_ARGUMENT: no cylinder found";
  const std::vector<std::string> cells = Cells(CsvRow(row));
  ASSERT_EQ(cells.size(), CsvColumns().size());
  EXPECT_EQ(cells[0], "bad.png");
  EXPECT_EQ(cells[2], "INVALID_ARGUMENT: no cylinder found");
  // Nothing was asked (no phase angle, say): only this client's version.
  const std::vector<std::string> columns = CsvColumns();
  for (std::size_t i = 3; i < cells.size(); ++i) {
    EXPECT_EQ(cells[i], columns[i] == "weavefit_version" ? WeavefitVersion() : "") << columns[i];
  }
}

TEST(CsvTest, FieldsAreQuotedOnlyWhenTheyMustBe) {
  EXPECT_EQ(CsvField("plain.png"), "plain.png");
  EXPECT_EQ(CsvField("a,b"), "\"a,b\"");
  EXPECT_EQ(CsvField("say \"hi\""), "\"say \"\"hi\"\"\"");
  EXPECT_EQ(CsvField("two\nlines"), "\"two\nlines\"");
}

TEST(TableTest, UmaxColumnAndBounds) {
  ReportRow gauze;
  gauze.image = "gauze.png";
  gauze.reply = GauzeReply();
  ReportRow smooth;
  smooth.image = "smooth.png";
  smooth.reply = v1::EstimateReply();
  smooth.reply->set_model(v1::SMOOTH);
  smooth.reply->mutable_max_inclination_deg()->set_upper_bound(2.86);
  const std::string table = FormatTable({gauze, smooth});
  EXPECT_NE(table.find("umax (deg)"), std::string::npos) << table;
  EXPECT_NE(table.find("13.26 ± 0.05"), std::string::npos) << table;
  EXPECT_NE(table.find("≤ 2.86"), std::string::npos) << table;
  EXPECT_NE(table.find("unresolved"), std::string::npos) << table;  // no bound: the wavelength
}

}  // namespace
}  // namespace weavefit
