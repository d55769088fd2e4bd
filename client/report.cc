#include "client/report.h"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "proto/weavefit/v1/convert.h"

namespace weavefit {
namespace {

// Pads to a display width: UTF-8 continuation bytes (the ± sign) take no
// column of their own.
std::string Pad(const std::string& text, int width) {
  int shown = 0;
  for (unsigned char c : text) shown += (c & 0xC0) != 0x80;
  return text + std::string(std::max(0, width - shown), ' ');
}

// "value ± stderr" with `digits` decimals and a unit suffix; "≤ bound" for
// an unresolved value with a bound (e.g. a split hidden in the blur), else
// "unresolved".
std::string Cell(const v1::Measurement& m, int digits, const char* unit = "") {
  if (!m.resolved()) {
    if (m.upper_bound() <= 0.0) return "unresolved";
    return absl::StrFormat("≤ %.*f%s", digits, m.upper_bound(), unit);
  }
  return absl::StrFormat("%.*f ± %.*f%s", digits, m.value(), digits, m.stderr(), unit);
}

// A number for CSV: enough digits to carry a double's meaning (10
// significant), no locale.
std::string Number(double value) { return absl::StrFormat("%.10g", value); }

// X, X_stderr, X_upper_bound, X_statistical, X_systematic of one
// measurement.
void AppendMeasurement(const v1::Measurement& m, std::vector<std::string>* cells) {
  cells->push_back(m.resolved() ? Number(m.value()) : "");
  cells->push_back(m.resolved() ? Number(m.stderr()) : "");
  cells->push_back(!m.resolved() && m.upper_bound() > 0.0 ? Number(m.upper_bound()) : "");
  cells->push_back(m.resolved() ? Number(m.statistical()) : "");
  cells->push_back(m.resolved() ? Number(m.systematic()) : "");
}

// Free text for a CSV cell that splits on commas alone (CsvRow).
std::string CsvText(std::string text) {
  for (char& c : text) {
    if (c == ',') c = ';';
    if (c == '"') c = '\'';
    if (c == '\n' || c == '\r') c = ' ';
  }
  return text;
}

// phase_angle_deg, cylinder_diameter_mm, camera_distance_mm, mode and
// weavefit_version: what was asked (all but the version empty where
// nothing was, as for a photograph without a phase angle).
void AppendAsked(const v1::Acquisition& a, v1::Mode mode, const std::string& version, bool asked,
                 std::vector<std::string>* cells) {
  cells->push_back(asked ? Number(a.phase_angle_deg()) : "");
  cells->push_back(asked && a.cylinder_diameter_mm() > 0.0 ? Number(a.cylinder_diameter_mm())
                                                           : "");
  cells->push_back(asked ? Number(a.camera_distance_mm()) : "");
  const v1::Mode named = mode == v1::MODE_UNSPECIFIED ? v1::BALANCED : mode;
  cells->push_back(asked ? absl::AsciiStrToLower(v1::Mode_Name(named)) : "");
  cells->push_back(version);
}

constexpr const char* kCsvMeasurements[] = {"peak_spacing_deg", "max_slope",
                                            "max_inclination_deg", "wavelength_mm",
                                            "amplitude_mm", "specular_azimuth_deg"};

}  // namespace

std::string FormatTable(const std::vector<ReportRow>& rows) {
  std::size_t name_width = 5;
  for (const ReportRow& row : rows) name_width = std::max(name_width, row.image.size());
  const int w = static_cast<int>(name_width);
  std::string out = absl::StrCat(Pad("image", w), "  ", Pad("model", 10), Pad("spacing (deg)", 18),
                                 Pad("max slope", 20), Pad("umax (deg)", 18), Pad("mirror (deg)", 17),
                                 Pad("wavelength (mm)", 17), "truth spacing\n");
  // Each distinct warning once, with the images it applies to.
  std::vector<std::pair<std::string, std::vector<std::string>>> notes;
  for (const ReportRow& row : rows) {
    if (!row.reply) {
      absl::StrAppendFormat(&out, "%-*s  ERROR %s\n", w, row.image, row.error);
      continue;
    }
    const v1::EstimateReply& r = *row.reply;
    const std::string truth =
        row.truth_spacing_deg ? absl::StrFormat("%.2f", *row.truth_spacing_deg) : "-";
    absl::StrAppend(&out, Pad(row.image, w), "  ", Pad(v1::ProfileModel_Name(r.model()), 10),
                    Pad(Cell(r.peak_spacing_deg(), 2), 18),
                    Pad(Cell(r.max_slope(), 4), 20),
                    Pad(Cell(r.max_inclination_deg(), 2), 18),
                    Pad(Cell(r.specular_azimuth_deg(), 2), 17),
                    Pad(Cell(r.wavelength_mm(), 3), 17), truth, "\n");
    for (const std::string& warning : r.warnings()) {
      auto it = std::find_if(notes.begin(), notes.end(),
                             [&](const auto& n) { return n.first == warning; });
      if (it == notes.end()) {
        notes.push_back({warning, {row.image}});
      } else {
        it->second.push_back(row.image);
      }
    }
  }
  if (!notes.empty()) absl::StrAppend(&out, "\nwarnings:\n");
  for (const auto& [warning, images] : notes) {
    absl::StrAppend(&out, "- ", warning, "\n  (",
                    images.size() == rows.size() && rows.size() > 1
                        ? std::string("all images")
                        : absl::StrJoin(images, ", "),
                    ")\n");
  }
  return out;
}

std::string FormatJoint(const v1::JointEstimate& j) {
  std::string out = absl::StrCat("\njoint estimate over ", j.photographs_size(),
                                 " photographs (", absl::StrJoin(j.photographs(), ", "), "):\n");
  absl::StrAppend(&out, "  model          ", v1::ProfileModel_Name(j.model()), "\n");
  absl::StrAppend(&out, "  spacing (deg)  ", Cell(j.peak_spacing_deg(), 2), "\n");
  absl::StrAppendFormat(&out, "  max slope      %s  (%d photographs, reduced chi-square %.2f)\n",
                        Cell(j.max_slope(), 4), j.slope_photographs(), j.slope_chi2());
  absl::StrAppend(&out, "  umax (deg)     ", Cell(j.max_inclination_deg(), 2),
                  "  (arctan of the max slope)\n");
  absl::StrAppendFormat(&out, "  wavelength     %s  (%d photographs, reduced chi-square %.2f)\n",
                        Cell(j.wavelength_mm(), 3, " mm"), j.wavelength_photographs(),
                        j.wavelength_chi2());
  absl::StrAppend(&out, "  amplitude      ", Cell(j.amplitude_mm(), 4, " mm"), "\n");
  for (const std::string& w : j.warnings()) absl::StrAppend(&out, "  - ", w, "\n");
  return out;
}

std::string JsonLine(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  std::string json;
  // Cannot fail for a well-formed generated message.
  (void)google::protobuf::util::MessageToJsonString(message, &json, options);
  return json;
}

std::string JointJsonLine(const v1::JointEstimate& joint) {
  return absl::StrCat("{\"joint\":", JsonLine(joint), "}\n");
}

std::vector<std::string> CsvColumns() {
  std::vector<std::string> columns = {"image",
                                      "sample_name",
                                      "status",
                                      "model",
                                      "method",
                                      "phase_angle_deg",
                                      "cylinder_diameter_mm",
                                      "camera_distance_mm",
                                      "mode",
                                      "weavefit_version"};
  for (const char* m : kCsvMeasurements) {
    columns.push_back(m);
    columns.push_back(absl::StrCat(m, "_stderr"));
    columns.push_back(absl::StrCat(m, "_upper_bound"));
    columns.push_back(absl::StrCat(m, "_statistical"));
    columns.push_back(absl::StrCat(m, "_systematic"));
  }
  for (const char* c : {"center_x_px", "radius_px", "axis_angle_deg", "warnings"}) {
    columns.push_back(c);
  }
  return columns;
}

std::string CsvHeader() { return absl::StrCat(absl::StrJoin(CsvColumns(), ","), "\n"); }

std::string CsvField(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

std::string CsvRow(const ReportRow& row) {
  std::vector<std::string> cells = {row.image};
  if (!row.reply) {
    cells.push_back(row.header ? row.header->sample_name() : "");
    cells.push_back(CsvText(row.error));
    cells.push_back("");
    cells.push_back("");
    const v1::RequestHeader none;
    const v1::RequestHeader& h = row.header ? *row.header : none;
    AppendAsked(h.acquisition(), h.options().mode(), WeavefitVersion(), row.header.has_value(),
                &cells);
    cells.resize(CsvColumns().size());
  } else {
    const v1::EstimateReply& r = *row.reply;
    cells.push_back(r.sample_name());
    cells.push_back("OK");
    cells.push_back(v1::ProfileModel_Name(r.model()));
    cells.push_back(r.method());
    AppendAsked(r.acquisition(), r.mode(), r.version(), true, &cells);
    for (const v1::Measurement* m :
         {&r.peak_spacing_deg(), &r.max_slope(), &r.max_inclination_deg(), &r.wavelength_mm(),
          &r.amplitude_mm(), &r.specular_azimuth_deg()}) {
      AppendMeasurement(*m, &cells);
    }
    cells.push_back(Number(r.cylinder().center_x_px()));
    cells.push_back(Number(r.cylinder().radius_px()));
    cells.push_back(Number(r.cylinder().axis_angle_deg()));
    cells.push_back(CsvText(absl::StrJoin(r.warnings(), " | ")));
  }
  std::string line;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (i > 0) line += ',';
    line += CsvField(cells[i]);
  }
  return line + "\n";
}

std::string StatusLine(const absl::Status& status) {
  return absl::StrCat(absl::StatusCodeToString(status.code()), ": ", status.message());
}

std::string ImageErrorJson(const std::string& image, const absl::Status& status) {
  google::protobuf::Struct root;
  google::protobuf::Struct* error = (*root.mutable_fields())["error"].mutable_struct_value();
  (*error->mutable_fields())["code"].set_string_value(absl::StatusCodeToString(status.code()));
  (*error->mutable_fields())["message"].set_string_value(std::string(status.message()));
  (*root.mutable_fields())["image"].set_string_value(image);
  std::string json;
  (void)google::protobuf::util::MessageToJsonString(root, &json);
  return json;
}

}  // namespace weavefit
