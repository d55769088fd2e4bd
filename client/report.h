// Human-readable output of the client.
#ifndef WEAVEFIT_CLIENT_REPORT_H_
#define WEAVEFIT_CLIENT_REPORT_H_

#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "weavefit/v1/weavefit.pb.h"

namespace google::protobuf {
class Message;
}  // namespace google::protobuf

namespace weavefit {

// One row of the result table: an image and its reply, or the error.
struct ReportRow {
  std::string image;
  std::optional<v1::EstimateReply> reply;
  std::string error;  // "CODE: message" when !reply
  // What was asked, where a request was made: a failed row's acquisition
  // and mode come from it (a reply carries its own).
  std::optional<v1::RequestHeader> header;
  // Truth peak spacing from a rendered image's sidecar, when there is one.
  std::optional<double> truth_spacing_deg;
};

// A fixed-width table, one line per image, then the warnings per image.
std::string FormatTable(const std::vector<ReportRow>& rows);

// A message in protobuf's JSON mapping on one line, every field printed.
std::string JsonLine(const google::protobuf::Message& message);

// {"joint": {...}} and a line end: the last line of a joint estimate in JSON.
std::string JointJsonLine(const v1::JointEstimate& joint);

// CSV (RFC 4180, "\n" line ends): the header line, then one line per image,
// failed ones included. Columns: image, sample_name, status ("OK" or
// "CODE: message"), model, method; what was asked: phase_angle_deg,
// cylinder_diameter_mm (empty where none was given), camera_distance_mm,
// mode, weavefit_version (the daemon's, or this client's for a failed row);
// for each measurement X of peak_spacing_deg, max_slope, max_inclination_deg
// (arctan of the max slope: Irawan & Marschner's umax), wavelength_mm,
// amplitude_mm and specular_azimuth_deg the columns X, X_stderr (both
// empty when unresolved), X_upper_bound (empty unless an unresolved X has
// a bound), X_statistical and X_systematic; center_x_px, radius_px,
// axis_angle_deg; and warnings (joined with " | "). The free text (status
// and warnings) holds no comma, double quote or line break (they become
// ";", "'" and " "), so that a row splits on commas alone:
// numpy.genfromtxt(f, delimiter=",", names=True, dtype=None,
// encoding=None) reads it as pandas.read_csv(f) and csv.reader do. Only an
// image path or sample name holding one is quoted.
std::string CsvHeader();
std::string CsvRow(const ReportRow& row);
// The column names of CsvHeader(), in order.
std::vector<std::string> CsvColumns();
// One CSV field, quoted when it holds a comma, a quote or a line break.
std::string CsvField(const std::string& text);

// "CODE: message" of a status, as the CSV's status column and the
// client's messages give it.
std::string StatusLine(const absl::Status& status);

// {"error": {"code": ..., "message": ...}, "image": ...}: ErrorToJson's
// object, and which image it is about (one JSON line per image).
std::string ImageErrorJson(const std::string& image, const absl::Status& status);

// The joint estimate over several photographs of one sample, a few lines.
std::string FormatJoint(const v1::JointEstimate& joint);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_REPORT_H_
