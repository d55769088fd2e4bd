#include "client/report.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace weavefit {
namespace {

// Pads to a display width: UTF-8 continuation bytes (the ± sign) take no
// column of their own.
std::string Pad(const std::string& text, int width) {
  int shown = 0;
  for (unsigned char c : text) shown += (c & 0xC0) != 0x80;
  return text + std::string(std::max(0, width - shown), ' ');
}

std::string Cell(const v1::Measurement& m, const char* format) {
  if (!m.resolved()) return "unresolved";
  return absl::StrFormat(format, m.value(), m.stderr());
}

}  // namespace

std::string FormatTable(const std::vector<ReportRow>& rows) {
  std::size_t name_width = 5;
  for (const ReportRow& row : rows) name_width = std::max(name_width, row.image.size());
  const int w = static_cast<int>(name_width);
  std::string out = absl::StrCat(Pad("image", w), "  ", Pad("model", 10), Pad("spacing (deg)", 18),
                                 Pad("max slope", 20), Pad("mirror (deg)", 17),
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
                    Pad(Cell(r.peak_spacing_deg(), "%.2f ± %.2f"), 18),
                    Pad(Cell(r.max_slope(), "%.4f ± %.4f"), 20),
                    Pad(Cell(r.specular_azimuth_deg(), "%.2f ± %.2f"), 17),
                    Pad(Cell(r.wavelength_mm(), "%.3f ± %.3f"), 17), truth, "\n");
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
  absl::StrAppend(&out, "  spacing (deg)  ", Cell(j.peak_spacing_deg(), "%.2f ± %.2f"), "\n");
  absl::StrAppendFormat(&out, "  max slope      %s  (%d photographs, reduced chi-square %.2f)\n",
                        Cell(j.max_slope(), "%.4f ± %.4f"), j.slope_photographs(), j.slope_chi2());
  absl::StrAppendFormat(&out, "  wavelength     %s  (%d photographs, reduced chi-square %.2f)\n",
                        Cell(j.wavelength_mm(), "%.3f ± %.3f mm"), j.wavelength_photographs(),
                        j.wavelength_chi2());
  absl::StrAppend(&out, "  amplitude      ", Cell(j.amplitude_mm(), "%.4f ± %.4f mm"), "\n");
  for (const std::string& w : j.warnings()) absl::StrAppend(&out, "  - ", w, "\n");
  return out;
}

}  // namespace weavefit
