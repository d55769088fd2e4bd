// Human-readable output of the client.
#ifndef WEAVEFIT_CLIENT_REPORT_H_
#define WEAVEFIT_CLIENT_REPORT_H_

#include <optional>
#include <string>
#include <vector>

#include "weavefit/v1/weavefit.pb.h"

namespace weavefit {

// One row of the result table: an image and its reply, or the error.
struct ReportRow {
  std::string image;
  std::optional<v1::EstimateReply> reply;
  std::string error;  // "CODE: message" when !reply
  // Truth peak spacing from a rendered image's sidecar, when there is one.
  std::optional<double> truth_spacing_deg;
};

// A fixed-width table, one line per image, then the warnings per image.
std::string FormatTable(const std::vector<ReportRow>& rows);

// The joint estimate over several photographs of one sample, a few lines.
std::string FormatJoint(const v1::JointEstimate& joint);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_REPORT_H_
