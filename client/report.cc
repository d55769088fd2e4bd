#include "client/report.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"

namespace weavefit {
namespace {

std::string Cell(const v1::Measurement& m, const char* format) {
  if (!m.resolved()) return "unresolved";
  return absl::StrFormat(format, m.value(), m.stderr());
}

}  // namespace

std::string FormatTable(const std::vector<ReportRow>& rows) {
  std::size_t name_width = 5;
  for (const ReportRow& row : rows) name_width = std::max(name_width, row.image.size());
  const int w = static_cast<int>(name_width);
  std::string out = absl::StrFormat("%-*s  %-9s %-17s %-19s %-16s %-12s %s\n", w,
                                    "image", "model", "spacing (deg)", "max slope",
                                    "mirror (deg)", "wavelength", "truth spacing");
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
    absl::StrAppendFormat(
        &out, "%-*s  %-9s %-17s %-19s %-16s %-12s %s\n", w, row.image,
        v1::ProfileModel_Name(r.model()), Cell(r.peak_spacing_deg(), "%.2f ± %.2f"),
        Cell(r.max_slope(), "%.4f ± %.4f"), Cell(r.specular_azimuth_deg(), "%.2f ± %.2f"),
        Cell(r.wavelength_mm(), "%.3f ± %.3f"), truth);
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

}  // namespace weavefit
