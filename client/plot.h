// Fit plots: one PNG per photograph that shows the measured profile with its
// error band, the fitted models, the two peaks and their spacing, the
// residuals underneath, and a thumbnail of the photograph with the detected
// limbs and axis. Drawn from the reply alone (plus the photograph for the
// thumbnail), so a plot made from a daemon's reply and one made in-process
// are the same.
#ifndef WEAVEFIT_CLIENT_PLOT_H_
#define WEAVEFIT_CLIENT_PLOT_H_

#include <string>

#include "absl/status/statusor.h"
#include "estimator/cylinder/cylinder_detection.h"
#include "estimator/pipeline/estimate.h"
#include "weavefit/v1/weavefit.pb.h"

namespace weavefit {

// The photograph reduced for display: decoded, luminance or colour, scaled to
// fit `height` × `max_width` pixels with a key below it, tone-mapped (linear
// → sRGB, the measured profile's highest level white, so that the lobe
// shows; the 99.5th percentile without curves), with the cylinder's limbs
// (green when observed, orange when inferred), its axis (dashed), the first
// and last rows read, and ticks at the peaks read (or the mirror azimuth)
// drawn on it. PNG bytes.
absl::StatusOr<std::string> AnnotatedThumbnail(const std::string& image_bytes,
                                               const v1::EstimateReply& reply, int height,
                                               int max_width);

// Writes the fit plot of `reply` (which must carry curves: ask with
// EstimateOptions.include_curves) to `png_path`, via gnuplot for the chart and
// OpenCV for the thumbnail beside it. FAILED_PRECONDITION without curves or
// when gnuplot fails. The file appears complete or not at all.
absl::Status WriteFitPlot(const v1::EstimateReply& reply, const std::string& image_bytes,
                          const std::string& title, const std::string& png_path);

// The plot file name of each of `images` (same order), distinct within the
// batch: the file stem (`a/x.png` -> `x.png`); where stems repeat, the stem
// and extension (`x.exr.png`); where those repeat too (one name in two
// folders), the path with '/' as '_' (`a_x.png.png`, `b_x.png.png`). Names
// depend on the whole list only, so a re-run over the same inputs writes the
// same files.
std::vector<std::string> PlotFileNames(const std::vector<std::string>& images);

// The plot of one photograph for `weavefit estimate/submit --plot DIR`: makes
// DIR if needed, writes DIR/`file_name` (from PlotFileNames), titled with the
// image's file name, the model and the method, and then drops the curves from
// the reply (they are in the plot; printed or saved results stay small).
absl::Status PlotInto(const std::string& dir, const std::string& file_name,
                      const std::string& image, const std::string& image_bytes,
                      v1::EstimateReply* reply);

// The picture of a refused photograph, for `--plot DIR`: detection is run
// again here on `image_bytes` with the header's acquisition (as the daemon
// or the in-process estimate ran it, DetectCylinderInBytes) and, when it
// refuses, DIR/`file_name` shows what it saw (WriteDetectionPlot). Writes
// nothing, and returns false, when the refusal came after detection, the
// header gives the cylinder, or `refusal` is not INVALID_ARGUMENT; true
// when written. Errors are the plot's own.
absl::StatusOr<bool> PlotRefusalInto(const std::string& dir, const std::string& file_name,
                                     const std::string& image, const std::string& image_bytes,
                                     const v1::RequestHeader& header,
                                     const absl::Status& refusal);

// The cylinder of one photograph as its estimate would detect it (the
// header's acquisition; a given cylinder is ignored), for `weavefit detect`;
// with a non-empty `dir`, also the picture of what detection saw, found or
// refused, in DIR/`file_name` (WriteDetectionPlot; `drawn` says whether it
// was, which needs detection to have read the photograph; the picture's own
// error goes to `plot_error`, and the detection's result stands).
absl::StatusOr<DetectedCylinder> DetectWithPicture(const std::string& dir,
                                                   const std::string& file_name,
                                                   const std::string& image,
                                                   const std::string& image_bytes,
                                                   const v1::RequestHeader& header,
                                                   absl::Status* plot_error, bool* drawn);

// PlotRefusalInto for `estimate` and `submit`: says on stderr what it wrote
// or why it could not (a refusal's own error is the caller's to report).
void ReportRefusalPlot(const std::string& dir, const std::string& file_name,
                       const std::string& image, const std::string& image_bytes,
                       const v1::RequestHeader& header, const absl::Status& refusal);

// What detection saw, drawn to `png_path`: the column means over all rows
// (whole, and near the background), the side strips read as background,
// the edges all rows placed, each cylinder tried with its limbs and the
// figures that judged it, `message` (the refusal), and beside it the
// photograph, contrast-stretched, with each band's edges and each
// cylinder's limbs drawn. The file appears complete or not at all.
absl::Status WriteDetectionPlot(const DetectionTrace& trace, const std::string& image_bytes,
                                const std::string& title, const std::string& message,
                                const std::string& png_path);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_PLOT_H_
