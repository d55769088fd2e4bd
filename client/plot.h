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
#include "weavefit/v1/weavefit.pb.h"

namespace weavefit {

// The photograph reduced for display: decoded, luminance or colour, scaled to
// fit `height` × `max_width` pixels, tone-mapped (linear → sRGB after dividing by the 99.5th
// percentile), with the cylinder's limbs (green when observed, orange when
// inferred), its axis (dashed) and the usable rows drawn on it. PNG bytes.
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

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_PLOT_H_
