#include "client/plot.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "absl/strings/str_split.h"
#include "estimator/io/decode.h"
#include "estimator/pipeline/estimate.h"
#include "proto/weavefit/v1/convert.h"

namespace weavefit {
namespace {

constexpr int kChartWidth = 1100;
constexpr int kChartHeight = 760;
constexpr int kThumbWidth = 560;
// The thumbnail's key: the strip's height below the photograph, and the
// width of each of its two columns (px).
constexpr int kKeyHeight = 70;
constexpr int kKeyColumn = 250;

// gnuplot's own quoting: a single-quoted string with ' doubled.
std::string Quoted(const std::string& text) {
  return "'" + absl::StrReplaceAll(text, {{"'", "''"}}) + "'";
}

double ToDisplay(double linear) {  // sRGB transfer curve
  linear = std::clamp(linear, 0.0, 1.0);
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

// The photograph for display, BGR: `black` maps to black and `white` to
// white, through the sRGB curve.
cv::Mat ToneMapped(const Image& image, double black, double white) {
  const double range = std::max(1e-9, white - black);
  cv::Mat display(image.height, image.width, CV_8UC3);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      cv::Vec3b& out = display.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) {
        const int from = image.channels == 3 ? 2 - c : 0;  // OpenCV is BGR
        out[c] = static_cast<uchar>(255.0 * ToDisplay((image.At(x, y, from) - black) / range) + 0.5);
      }
    }
  }
  return display;
}

// `display` scaled to fit height × max_width; `scale` is the factor.
cv::Mat Reduced(const cv::Mat& display, int height, int max_width, double* scale) {
  *scale = std::min(static_cast<double>(height) / display.rows,
                    static_cast<double>(max_width) / display.cols);
  cv::Mat thumb;
  cv::resize(display, thumb,
             cv::Size(std::max(1, static_cast<int>(display.cols * *scale)),
                      std::max(1, static_cast<int>(display.rows * *scale))),
             0, 0, *scale < 1.0 ? cv::INTER_AREA : cv::INTER_NEAREST);
  return thumb;
}

// The q-quantile of all of the image's samples.
double Quantile(const Image& image, double q) {
  std::vector<float> sorted = image.pixels;
  if (sorted.empty()) return 0.0;
  const std::size_t k = static_cast<std::size_t>(q * (sorted.size() - 1));
  std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
  return sorted[k];
}

// A temporary folder, removed with everything in it.
struct TempFolder {
  std::string path;
  ~TempFolder() {
    if (!path.empty()) std::system(absl::StrCat("rm -rf '", path, "'").c_str());
  }
};
absl::Status MakeTempFolder(TempFolder* folder) {
  char dir_template[] = "/tmp/weavefit_plot_XXXXXX";
  if (mkdtemp(dir_template) == nullptr) return absl::InternalError("no temporary folder");
  folder->path = dir_template;
  return absl::OkStatus();
}

// Runs gnuplot on `script` (written into `dir`).
absl::Status RunGnuplot(const std::string& dir, const std::string& script) {
  const std::string script_path = dir + "/plot.gp";
  std::ofstream(script_path) << script;
  const std::string command =
      absl::StrCat("gnuplot ", Quoted(script_path), " 2>", Quoted(dir + "/gnuplot.log"));
  if (std::system(command.c_str()) != 0) {
    std::ifstream log(dir + "/gnuplot.log");
    std::string first;
    std::getline(log, first);
    return absl::FailedPreconditionError(absl::StrCat(
        "gnuplot failed or is missing (scripts/setup.sh installs gnuplot-nox): ", first));
  }
  return absl::OkStatus();
}

// The chart (a PNG file) and the thumbnail (PNG bytes) side by side, written
// to `png_path` whole or not at all.
absl::Status WriteSideBySide(const std::string& chart, const std::string& thumbnail,
                             const std::string& dir, const std::string& png_path) {
  cv::Mat left = cv::imread(chart, cv::IMREAD_COLOR);
  const std::vector<uchar> thumb_bytes(thumbnail.begin(), thumbnail.end());
  cv::Mat right = cv::imdecode(thumb_bytes, cv::IMREAD_COLOR);
  if (left.empty() || right.empty()) return absl::InternalError("plot images not readable");
  if (right.rows < left.rows) {  // centred on white
    const int above = (left.rows - right.rows) / 2;
    cv::copyMakeBorder(right, right, above, left.rows - right.rows - above, 8, 8,
                       cv::BORDER_CONSTANT, cv::Scalar(255, 255, 255));
  }
  cv::Mat both;
  cv::hconcat(left, right, both);
  // A name of this process and folder: concurrent plots never share it.
  const std::string tmp = absl::StrCat(png_path, ".", getpid(), ".",
                                       dir.substr(dir.find_last_of('_') + 1), ".tmp.png");
  if (!cv::imwrite(tmp, both, {cv::IMWRITE_PNG_COMPRESSION, 9}) ||
      std::rename(tmp.c_str(), png_path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return absl::InternalError(absl::StrCat("cannot write ", png_path));
  }
  return absl::OkStatus();
}

const v1::Curve* Find(const v1::EstimateReply& reply, const std::string& label) {
  for (const v1::Curve& c : reply.curves()) {
    if (c.label() == label) return &c;
  }
  return nullptr;
}

// The level shown white: the measured profile's highest (the lobe's column
// mean), so that the lobe stands out of the body in every photograph; a
// quantile of the whole frame put a lobe a few columns wide, under 0.5 % of
// the pixels, among the body's greys. Without a profile (a reply without
// curves), the 99.5th percentile of all samples.
double DisplayWhite(const Image& image, const v1::EstimateReply& reply) {
  double white = 0.0;
  if (const v1::Curve* measured = Find(reply, "measured profile")) {
    for (double v : measured->value()) white = std::max(white, v);
  }
  if (!(white > 0.0)) white = Quantile(image, 0.995);
  return std::max(1e-6, white);
}

// The azimuths (deg) the thumbnail marks: the two peaks of a resolved split
// (mirror ± half the spacing), else the mirror azimuth.
std::vector<double> PeakAzimuthsDeg(const v1::EstimateReply& reply) {
  const double mirror = reply.specular_azimuth_deg().value();
  const v1::Measurement& spacing = reply.peak_spacing_deg();
  if (!spacing.resolved()) return {mirror};
  return {mirror - 0.5 * spacing.value(), mirror + 0.5 * spacing.value()};
}

// One entry of the thumbnail's key: a line's colour, whether it is dashed,
// and what it marks.
struct KeyEntry {
  cv::Scalar colour;
  bool dashed = false;
  std::string label;
};

// `thumb` with a white strip of kKeyHeight below it holding the key, two
// entries a row.
cv::Mat WithKey(const cv::Mat& thumb, const std::vector<KeyEntry>& entries) {
  const int width = std::max(thumb.cols, 2 * kKeyColumn);
  cv::Mat out(thumb.rows + kKeyHeight, width, thumb.type(), cv::Scalar(255, 255, 255));
  thumb.copyTo(out(cv::Rect((width - thumb.cols) / 2, 0, thumb.cols, thumb.rows)));
  for (std::size_t i = 0; i < entries.size(); ++i) {
    const int x = 8 + static_cast<int>(i % 2) * kKeyColumn;
    const int y = thumb.rows + 18 + static_cast<int>(i / 2) * 20;
    const KeyEntry& e = entries[i];
    for (int dx = 0; dx < 28; dx += e.dashed ? 8 : 28) {
      cv::line(out, cv::Point(x + dx, y - 4), cv::Point(x + std::min(28, dx + (e.dashed ? 4 : 28)), y - 4),
               e.colour, 2, cv::LINE_AA);
    }
    cv::putText(out, e.label, cv::Point(x + 36, y), cv::FONT_HERSHEY_SIMPLEX, 0.45,
                cv::Scalar(40, 40, 40), 1, cv::LINE_AA);
  }
  return out;
}

}  // namespace

absl::StatusOr<std::string> AnnotatedThumbnail(const std::string& image_bytes,
                                               const v1::EstimateReply& reply, int height,
                                               int max_width) {
  DecodeOptions decode;
  absl::StatusOr<Image> image = DecodeImage(image_bytes, decode);
  if (!image.ok()) return image.status();
  const cv::Mat display = ToneMapped(*image, 0.0, DisplayWhite(*image, reply));
  // The cylinder (DESIGN.md §2): the axis passes through center_x at the
  // middle row and leans right at the top by axis_angle; the limbs are the
  // lines at ±radius perpendicular to it.
  const v1::Cylinder& cyl = reply.cylinder();
  double scale = 1.0;
  cv::Mat thumb = Reduced(display, height - kKeyHeight, max_width, &scale);
  const double t = cyl.axis_angle_deg() * M_PI / 180.0;
  const double mid = 0.5 * (image->height - 1);
  auto line_at = [&](double offset_px, int y) {  // column of a line parallel to the axis
    return cyl.center_x_px() + offset_px / std::cos(t) - (y - mid) * std::tan(t);
  };
  const int top = std::max(0, cyl.top_row_px());
  const int bottom = cyl.bottom_row_px() > 0 ? cyl.bottom_row_px() : image->height - 1;
  auto to_thumb = [&](double x, int y) {
    return cv::Point(static_cast<int>(std::lround(x * scale)), static_cast<int>(std::lround(y * scale)));
  };
  const cv::Scalar observed(80, 220, 80), inferred(0, 150, 255), axis(255, 200, 0);
  const int width = std::max(1, thumb.rows / 300);
  cv::line(thumb, to_thumb(line_at(-cyl.radius_px(), top), top),
           to_thumb(line_at(-cyl.radius_px(), bottom), bottom),
           cyl.left_limb_observed() ? observed : inferred, width, cv::LINE_AA);
  cv::line(thumb, to_thumb(line_at(cyl.radius_px(), top), top),
           to_thumb(line_at(cyl.radius_px(), bottom), bottom),
           cyl.right_limb_observed() ? observed : inferred, width, cv::LINE_AA);
  for (int y = top; y < bottom; y += 12) {  // dashed axis
    cv::line(thumb, to_thumb(line_at(0, y), y), to_thumb(line_at(0, std::min(bottom, y + 6)), std::min(bottom, y + 6)),
             axis, width, cv::LINE_AA);
  }
  for (int row : {top, bottom}) {  // the usable rows
    cv::line(thumb, to_thumb(line_at(-cyl.radius_px(), row), row),
             to_thumb(line_at(cyl.radius_px(), row), row), axis, 1, cv::LINE_AA);
  }
  // The peaks read (or the mirror azimuth, where the split is unresolved):
  // ticks at both ends of the rows read, so that they hide little of the
  // lobe, at x = R·sin φ from the axis (orthographic, as the chart's
  // markers).
  const cv::Scalar peak(200, 0, 200);
  const int tick = std::max(6, (bottom - top) / 16);
  for (double phi : PeakAzimuthsDeg(reply)) {
    const double offset = cyl.radius_px() * std::sin(phi * M_PI / 180.0);
    cv::line(thumb, to_thumb(line_at(offset, top), top),
             to_thumb(line_at(offset, top + tick), top + tick), peak, width + 2, cv::LINE_AA);
    cv::line(thumb, to_thumb(line_at(offset, bottom - tick), bottom - tick),
             to_thumb(line_at(offset, bottom), bottom), peak, width + 2, cv::LINE_AA);
  }
  thumb = WithKey(thumb, {{observed, false, "limb seen"},
                          {inferred, false, "limb inferred"},
                          {axis, true, "axis"},
                          {axis, false, "first and last row read"},
                          {peak, false, reply.peak_spacing_deg().resolved()
                                            ? "the two peaks read"
                                            : "the mirror azimuth (one peak)"}});
  std::vector<uchar> png;
  if (!cv::imencode(".png", thumb, png)) return absl::InternalError("thumbnail not encoded");
  return std::string(png.begin(), png.end());
}

absl::Status WriteFitPlot(const v1::EstimateReply& reply, const std::string& image_bytes,
                          const std::string& title, const std::string& png_path) {
  const v1::Curve* measured = Find(reply, "measured profile");
  if (measured == nullptr || measured->azimuth_deg_size() == 0 || measured->value_size() == 0 ||
      measured->stderr_size() == 0) {
    return absl::FailedPreconditionError("the reply carries no curves (ask with include_curves)");
  }
  // The reply's arrays are trusted only as far as they agree in length.
  const int measured_bins = std::min({measured->azimuth_deg_size(), measured->value_size(),
                                      measured->stderr_size()});
  TempFolder folder;
  if (absl::Status s = MakeTempFolder(&folder); !s.ok()) return s;
  const std::string& dir = folder.path;

  // Data: the measured profile with its band, each curve, the residuals of
  // the measured profile about the selected model's fit.
  {
    std::ofstream out(dir + "/measured.dat");
    for (int i = 0; i < measured_bins; ++i) {
      out << measured->azimuth_deg(i) << " " << measured->value(i) << " " << measured->stderr(i)
          << "\n";
    }
  }
  std::vector<std::string> plots;
  std::map<double, double> fit_at;  // selected fit by azimuth (the same bins)
  int index = 0;
  for (const v1::Curve& c : reply.curves()) {
    if (&c == measured) continue;
    const std::string file = absl::StrCat(dir, "/curve", index++, ".dat");
    std::ofstream out(file);
    const int points = std::min(c.azimuth_deg_size(), c.value_size());
    for (int i = 0; i < points; ++i) out << c.azimuth_deg(i) << " " << c.value(i) << "\n";
    const bool smoothed = c.label() == "smoothed profile";
    const bool selected = c.selected() && !smoothed;
    if (selected) {
      for (int i = 0; i < points; ++i) fit_at[c.azimuth_deg(i)] = c.value(i);
    }
    plots.push_back(absl::StrCat(
        Quoted(file), " using 1:2 with lines ",
        smoothed   ? "lw 1.5 lc rgb '#555555' dt 2"
        : selected ? "lw 3 lc rgb '#d62728'"
                   : "lw 1.5 lc rgb '#1f77b4' dt 4",
        " title ", Quoted(c.label() + (selected ? " (reported)" : ""))));
  }
  {
    std::ofstream out(dir + "/residual.dat");
    for (int i = 0; i < measured_bins; ++i) {
      const auto f = fit_at.find(measured->azimuth_deg(i));
      if (f == fit_at.end()) continue;
      out << measured->azimuth_deg(i) << " " << measured->value(i) - f->second << " "
          << measured->stderr(i) << "\n";
    }
  }
  absl::StatusOr<std::string> thumbnail = AnnotatedThumbnail(image_bytes, reply, kChartHeight, kThumbWidth);
  if (!thumbnail.ok()) return thumbnail.status();

  // The peaks sit at the mirror azimuth ± half the spacing (orthographic
  // view; the perspective shift is below a line's width at lab distances).
  const double mirror = reply.specular_azimuth_deg().value();
  const v1::Measurement& spacing = reply.peak_spacing_deg();
  std::string peaks;
  if (spacing.resolved()) {
    const double left = mirror - 0.5 * spacing.value(), right = mirror + 0.5 * spacing.value();
    peaks = absl::StrFormat(
        "set arrow 1 from %.6f, graph 0 to %.6f, graph 1 nohead lc rgb '#2ca02c' dt 3 lw 1.5\n"
        "set arrow 2 from %.6f, graph 0 to %.6f, graph 1 nohead lc rgb '#2ca02c' dt 3 lw 1.5\n"
        "set arrow 3 from %.6f, graph 0.93 to %.6f, graph 0.93 heads lc rgb '#2ca02c' lw 1.5\n"
        "set label 1 %s at %.6f, graph 0.96 center tc rgb '#2ca02c'\n",
        left, left, right, right, left, right,
        Quoted(absl::StrFormat("spacing %.2f ± %.2f°", spacing.value(), spacing.stderr())), mirror);
  } else if (spacing.upper_bound() > 0) {
    peaks = absl::StrFormat("set label 1 %s at %.6f, graph 0.96 center tc rgb '#2ca02c'\n",
                            Quoted(absl::StrFormat("split unresolved: spacing ≤ %.1f°",
                                                   spacing.upper_bound())),
                            mirror);
  }
  // The x range: where the measured profile is, within ±90°.
  const double lo = std::max(-90.0, measured->azimuth_deg(0));
  const double hi = std::min(90.0, measured->azimuth_deg(measured_bins - 1));
  const std::string chart = dir + "/chart.png";
  const std::string script = absl::StrCat(
      "set terminal pngcairo noenhanced size ", kChartWidth, ",", kChartHeight,
      " font 'Sans,11'\n",
      "set output ", Quoted(chart), "\n",
      "set multiplot\n",
      "set lmargin at screen 0.1\nset rmargin at screen 0.97\n",
      "set xrange [", lo, ":", hi, "]\n",
      "set tmargin at screen 0.93\nset bmargin at screen 0.36\n",
      "set title ", Quoted(title), "\n",
      "set ylabel 'radiance (full scale = 1)'\nset format x ''\nset grid\n",
      // The key on the side away from the lobe.
      "set key ", mirror < 0.5 * (lo + hi) ? "top right" : "top left", " box opaque\n", peaks,
      "plot ", Quoted(dir + "/measured.dat"),
      " using 1:($2-$3):($2+$3) with filledcurves lc rgb '#c6dbef' title 'measured ± 1 s.e.', ",
      Quoted(dir + "/measured.dat"), " using 1:2 with lines lw 1 lc rgb '#08306b' title 'measured profile'",
      plots.empty() ? "" : ", ", absl::StrJoin(plots, ", "), "\n",
      "unset arrow\nunset label\nunset title\nset format x '%g'\n",
      "set tmargin at screen 0.33\nset bmargin at screen 0.08\n",
      "set xlabel 'azimuth φ (deg)'\nset ylabel 'measured − fit'\nunset key\n",
      fit_at.empty() ? "set label 1 'no fit to subtract' at graph 0.5, graph 0.5 center\nplot 0 lc rgb '#888888'\n"
                     : absl::StrCat("plot ", Quoted(dir + "/residual.dat"),
                                    " using 1:($2-$3):($2+$3) with filledcurves lc rgb '#eeeeee', ",
                                    Quoted(dir + "/residual.dat"),
                                    " using 1:2 with lines lc rgb '#d62728', 0 lc rgb '#444444'\n"),
      "unset multiplot\n");
  if (absl::Status s = RunGnuplot(dir, script); !s.ok()) return s;
  return WriteSideBySide(chart, *thumbnail, dir, png_path);
}

std::vector<std::string> PlotFileNames(const std::vector<std::string>& images) {
  auto base = [](const std::string& image) { return image.substr(image.find_last_of('/') + 1); };
  auto stem = [&](const std::string& image) {
    std::string name = base(image);
    if (const std::size_t dot = name.find_last_of('.'); dot != std::string::npos && dot > 0) {
      name = name.substr(0, dot);
    }
    return name;
  };
  auto flat = [](std::string path) {
    while (path.rfind("./", 0) == 0) path = path.substr(2);
    while (!path.empty() && path.front() == '/') path = path.substr(1);
    std::replace(path.begin(), path.end(), '/', '_');
    return path;
  };
  // Each rule in turn, for the names the ones before it left repeated.
  const std::vector<std::function<std::string(const std::string&)>> rules = {stem, base, flat};
  std::vector<std::string> names(images.size());
  std::vector<bool> settled(images.size(), false);
  for (std::size_t r = 0; r <= rules.size(); ++r) {
    std::map<std::string, int> count;
    for (std::size_t i = 0; i < images.size(); ++i) {
      if (!settled[i] && r < rules.size()) names[i] = rules[r](images[i]);
      // Past the rules (the same path given twice), the input's position.
      if (!settled[i] && r == rules.size()) names[i] = absl::StrCat(flat(images[i]), "_", i + 1);
      ++count[names[i]];
    }
    for (std::size_t i = 0; i < images.size(); ++i) {
      if (!settled[i]) settled[i] = count[names[i]] == 1 || r == rules.size();
    }
  }
  for (std::string& name : names) name += ".png";
  return names;
}

absl::Status PlotInto(const std::string& dir, const std::string& file_name,
                      const std::string& image, const std::string& image_bytes,
                      v1::EstimateReply* reply) {
  if (mkdir(dir.c_str(), 0755) != 0 && errno != EEXIST) {
    return absl::InvalidArgumentError(absl::StrCat("cannot make the plot folder ", dir));
  }
  const std::string name = image.substr(image.find_last_of('/') + 1);
  const std::string title = absl::StrCat(name, "  —  ", v1::ProfileModel_Name(reply->model()),
                                         " (", reply->method(), ")");
  absl::Status written = WriteFitPlot(*reply, image_bytes, title, dir + "/" + file_name);
  reply->clear_curves();
  if (!written.ok()) {
    return absl::Status(written.code(), absl::StrCat("plot: ", written.message()));
  }
  return absl::OkStatus();
}

namespace {

// `text` broken into lines of at most `width` characters, at spaces.
std::vector<std::string> Wrapped(const std::string& text, std::size_t width) {
  std::vector<std::string> lines;
  std::string line;
  for (const absl::string_view word : absl::StrSplit(text, ' ', absl::SkipEmpty())) {
    if (!line.empty() && line.size() + 1 + word.size() > width) {
      lines.push_back(line);
      line.clear();
    }
    absl::StrAppend(&line, line.empty() ? "" : " ", word);
  }
  if (!line.empty()) lines.push_back(line);
  return lines;
}

// A cylinder's limb column at image row y (side −1 left, +1 right).
double LimbColumn(const CylinderGeometry& c, int side, double y) {
  return c.AxisColumn(y) + side * c.radius_px / std::cos(c.axis_angle_rad);
}

// The colour of the k-th cylinder tried: green when kept; the rejected in
// red, orange, purple.
const char* HypothesisColour(const DetectionTrace::Hypothesis& h, std::size_t k) {
  static const char* const kRejected[] = {"#d62728", "#ff7f0e", "#9467bd"};
  return h.kept ? "#2ca02c" : kRejected[k % 3];
}

cv::Scalar Bgr(const char* hex) {
  const long v = std::strtol(hex + 1, nullptr, 16);
  return cv::Scalar(v & 0xff, (v >> 8) & 0xff, (v >> 16) & 0xff);
}

// The photograph stretched so that faint limbs show (the 1st to the 99th
// percentile of its samples over the display range), with each band's two
// edges (cyan dots), the edges all rows placed (dashed cyan) and each
// cylinder tried (its colour; an inferred limb dashed).
absl::StatusOr<std::string> DetectionThumbnail(const DetectionTrace& trace,
                                               const std::string& image_bytes, int height,
                                               int max_width) {
  absl::StatusOr<Image> image = DecodeImage(image_bytes, DecodeOptions());
  if (!image.ok()) return image.status();
  double scale = 1.0;
  cv::Mat thumb = Reduced(ToneMapped(*image, Quantile(*image, 0.01), Quantile(*image, 0.99)),
                          height, max_width, &scale);
  auto at = [&](double x, double y) {
    return cv::Point(static_cast<int>(std::lround((x + 0.5) * scale - 0.5)),
                     static_cast<int>(std::lround((y + 0.5) * scale - 0.5)));
  };
  const int width = std::max(1, thumb.rows / 300);
  auto dashed = [&](cv::Point a, cv::Point b, const cv::Scalar& colour) {
    const double length = std::hypot(b.x - a.x, b.y - a.y);
    for (double t = 0.0; t < length; t += 12.0) {
      const double u = std::min(length, t + 6.0);
      cv::line(thumb, a + (b - a) * (t / length), a + (b - a) * (u / length), colour, width,
               cv::LINE_AA);
    }
  };
  const cv::Scalar cyan(255, 255, 0);
  const int top = trace.region.y;
  const int bottom = trace.region.y + trace.region.height - 1;
  for (std::size_t k = 0; k < trace.hypotheses.size(); ++k) {
    const DetectionTrace::Hypothesis& h = trace.hypotheses[k];
    const CylinderGeometry& c = h.cylinder;
    if (!(c.radius_px > 0.0)) continue;
    const cv::Scalar colour = Bgr(HypothesisColour(h, k));
    for (int side : {-1, 1}) {
      const cv::Point a = at(LimbColumn(c, side, top), top);
      const cv::Point b = at(LimbColumn(c, side, bottom), bottom);
      const bool seen = side < 0 ? c.left_observed : c.right_observed;
      if (seen) {
        cv::line(thumb, a, b, colour, width, cv::LINE_AA);
      } else {
        dashed(a, b, colour);
      }
    }
  }
  for (const DetectionTrace::BandEdge& e : trace.band_edges) {
    cv::circle(thumb, at(e.left_x, e.row), width + 2, cyan, -1, cv::LINE_AA);
    cv::circle(thumb, at(e.right_x, e.row), width + 2, cyan, -1, cv::LINE_AA);
  }
  std::vector<uchar> png;
  if (!cv::imencode(".png", thumb, png)) return absl::InternalError("thumbnail not encoded");
  return std::string(png.begin(), png.end());
}

// The gnuplot commands that mark each cylinder's limbs at the reference row
// (vertical lines in its colour, an inferred limb dashed) and, for the first,
// where the phase angle puts the terminator and the mirror azimuth α/2.
std::string HypothesisMarks(const DetectionTrace& trace) {
  std::string marks;
  int arrow = 1;
  for (std::size_t k = 0; k < trace.hypotheses.size(); ++k) {
    const DetectionTrace::Hypothesis& h = trace.hypotheses[k];
    const CylinderGeometry& c = h.cylinder;
    if (!(c.radius_px > 0.0)) continue;
    for (int side : {-1, 1}) {
      const bool seen = side < 0 ? c.left_observed : c.right_observed;
      const double x = LimbColumn(c, side, c.center_row_px);
      absl::StrAppend(&marks, absl::StrFormat(
          "set arrow %d from %.3f, graph 0 to %.3f, graph 1 nohead lc rgb '%s' lw 2 dt %d\n",
          arrow++, x, x, HypothesisColour(h, k), seen ? 1 : 2));
    }
  }
  if (!trace.hypotheses.empty() && std::isfinite(trace.phase_angle_rad)) {
    const CylinderGeometry& c = trace.hypotheses.front().cylinder;
    const double a = trace.phase_angle_rad;
    const double half = c.radius_px / std::cos(c.axis_angle_rad);
    const double terminator = c.center_x_px + half * std::sin(a - std::copysign(M_PI / 2, a));
    const double mirror = c.center_x_px + half * std::sin(a / 2);
    absl::StrAppend(&marks, absl::StrFormat(
        "set arrow %d from %.3f, graph 0 to %.3f, graph 1 nohead lc rgb '#555555' dt 3\n"
        "set label %d 'terminator' at %.3f, graph 0.04 center front\n"
        "set arrow %d from %.3f, graph 0 to %.3f, graph 1 nohead lc rgb '#555555' dt 3\n"
        "set label %d 'α/2' at %.3f, graph 0.04 center front\n",
        arrow, terminator, terminator, 1, terminator, arrow + 1, mirror, mirror, 2, mirror));
  }
  return marks;
}

}  // namespace

absl::Status WriteDetectionPlot(const DetectionTrace& trace, const std::string& image_bytes,
                                const std::string& title, const std::string& message,
                                const std::string& png_path) {
  if (!trace.Filled()) return absl::FailedPreconditionError("detection saw no columns");
  TempFolder folder;
  if (absl::Status s = MakeTempFolder(&folder); !s.ok()) return s;
  const std::string& dir = folder.path;
  const int x0 = trace.region.x;
  const int x1 = trace.region.x + trace.region.width - 1;
  {
    std::ofstream out(dir + "/columns.dat");
    for (std::size_t i = 0; i < trace.column_means.size(); ++i) {
      out << x0 + static_cast<int>(i) << " " << trace.column_means[i] << "\n";
    }
  }
  // The zoom: the background's level ± 25 times the noise of the column
  // means (over the rows read, trace.region's at most), or ± a tenth of the
  // profile's range, whichever is wider, so that a faint limb's step shows.
  const auto [lo_it, hi_it] =
      std::minmax_element(trace.column_means.begin(), trace.column_means.end());
  const double background = 0.5 * (trace.left_background + trace.right_background);
  const double column_noise = trace.noise / std::sqrt(std::max(1, trace.region.height));
  // (A flat frame has neither: then a hair's width, for gnuplot's range.)
  const double zoom = std::max({25.0 * column_noise, 0.1 * (*hi_it - *lo_it),
                                1e-6 * std::max(1.0, std::fabs(background))});
  // The side strips, shaded; the edges all rows placed.
  std::string strips = absl::StrFormat(
      "set object 1 rect from %d, graph 0 to %d, graph 1 fc rgb '#eeeeee' fs solid noborder behind\n"
      "set object 2 rect from %d, graph 0 to %d, graph 1 fc rgb '#eeeeee' fs solid noborder behind\n",
      x0, x0 + trace.side_px, x1 - trace.side_px, x1);
  const std::string marks = HypothesisMarks(trace);
  std::string all_rows;
  for (double x : {trace.all_rows_left_x, trace.all_rows_right_x}) {
    if (std::isfinite(x)) {
      absl::StrAppend(&all_rows, absl::StrFormat(
          ", '+' using (%.3f):(%.6g) with points pt 9 ps 2 lc rgb '#17becf' notitle", x,
          background));
    }
  }
  // The key: one entry per cylinder tried (drawn as empty plots).
  std::string keys;
  for (std::size_t k = 0; k < trace.hypotheses.size(); ++k) {
    const DetectionTrace::Hypothesis& h = trace.hypotheses[k];
    absl::StrAppend(&keys, ", NaN with lines lw 2 lc rgb '", HypothesisColour(h, k), "' title ",
                    Quoted(absl::StrCat(k + 1, ": ", h.name, h.kept ? " (kept)" : " (rejected)")));
  }
  // The text: the refusal, then each cylinder's verdict.
  std::vector<std::string> text = Wrapped(message, 150);
  for (std::size_t k = 0; k < trace.hypotheses.size(); ++k) {
    const DetectionTrace::Hypothesis& h = trace.hypotheses[k];
    for (const std::string& line : Wrapped(absl::StrCat(k + 1, ": ", h.verdict), 150)) {
      text.push_back(line);
    }
  }
  constexpr std::size_t kTextLines = 12;  // the room below the charts
  if (text.size() > kTextLines) {
    text.resize(kTextLines);
    text.back() += " …";
  }
  std::string labels;
  for (std::size_t i = 0; i < text.size(); ++i) {
    absl::StrAppend(&labels, absl::StrFormat("set label %d %s at screen 0.02, screen %.4f font 'Sans,9'\n",
                                             100 + static_cast<int>(i), Quoted(text[i]),
                                             0.205 - 0.017 * i));
  }
  const std::string chart = dir + "/chart.png";
  const std::string columns = Quoted(dir + "/columns.dat");
  const std::string script = absl::StrCat(
      "set terminal pngcairo noenhanced size ", kChartWidth, ",", kChartHeight + 140,
      " font 'Sans,11'\n", "set output ", Quoted(chart), "\n", "set multiplot\n",
      "set lmargin at screen 0.1\nset rmargin at screen 0.97\n", "set xrange [", x0, ":", x1,
      "]\n", strips, marks, "set grid\nset format x ''\n",
      "set tmargin at screen 0.95\nset bmargin at screen 0.62\n", "set title ", Quoted(title),
      "\n", "set ylabel 'column mean'\nset key top left box opaque font 'Sans,9'\n",
      "plot ", columns, " using 1:2 with lines lw 1 lc rgb '#08306b' title 'all rows'",
      absl::StrFormat(", %.6g with lines dt 2 lc rgb '#777777' title 'background'", background),
      ", NaN with points pt 7 lc rgb '#17becf' title 'edges each band found (on the photograph), all rows found (▲)'", keys,
      "\n", "unset title\nunset key\nset format x '%g'\n",
      "set tmargin at screen 0.58\nset bmargin at screen 0.28\n",
      absl::StrFormat("set yrange [%.6g:%.6g]\n", background - zoom, background + zoom),
      "set xlabel 'image column (px)'\nset ylabel 'near the background'\n", "plot ", columns,
      " using 1:2 with lines lw 1 lc rgb '#08306b'",
      absl::StrFormat(", %.6g with lines dt 2 lc rgb '#777777'", background), all_rows, "\n",
      "unset label\nunset arrow\nunset object\nunset xlabel\nunset ylabel\nunset grid\n",
      "unset border\nunset tics\nset xrange [0:1]\nset yrange [0:1]\n", labels,
      "set tmargin at screen 0.22\nset bmargin at screen 0.0\nplot NaN notitle\n",
      "unset multiplot\n");
  if (absl::Status s = RunGnuplot(dir, script); !s.ok()) return s;
  absl::StatusOr<std::string> thumbnail =
      DetectionThumbnail(trace, image_bytes, kChartHeight + 140, kThumbWidth);
  if (!thumbnail.ok()) return thumbnail.status();
  return WriteSideBySide(chart, *thumbnail, dir, png_path);
}

namespace {

// WriteDetectionPlot into DIR/file_name, titled with the image's name and
// `outcome`.
absl::Status WriteTracePicture(const std::string& dir, const std::string& file_name,
                               const std::string& image, const std::string& image_bytes,
                               const DetectionTrace& trace, const std::string& outcome,
                               const std::string& message) {
  if (mkdir(dir.c_str(), 0755) != 0 && errno != EEXIST) {
    return absl::InvalidArgumentError(absl::StrCat("cannot make the plot folder ", dir));
  }
  const std::string name = image.substr(image.find_last_of('/') + 1);
  if (absl::Status s = WriteDetectionPlot(trace, image_bytes, absl::StrCat(name, "  —  ", outcome),
                                          message, dir + "/" + file_name);
      !s.ok()) {
    return absl::Status(s.code(), absl::StrCat("plot: ", s.message()));
  }
  return absl::OkStatus();
}

}  // namespace

absl::StatusOr<DetectedCylinder> DetectWithPicture(const std::string& dir,
                                                   const std::string& file_name,
                                                   const std::string& image,
                                                   const std::string& image_bytes,
                                                   const v1::RequestHeader& header,
                                                   absl::Status* plot_error, bool* drawn) {
  *drawn = false;
  absl::StatusOr<Acquisition> acquisition = AcquisitionFromProto(header.acquisition());
  if (!acquisition.ok()) return acquisition.status();
  DetectionTrace trace;
  absl::StatusOr<DetectedCylinder> detected = DetectCylinderInBytes(
      image_bytes, *acquisition, EstimateOptions(), dir.empty() ? nullptr : &trace);
  if (dir.empty() || !trace.Filled()) return detected;
  std::string message;
  if (detected.ok()) {
    const CylinderGeometry& c = detected->cylinder;
    message = absl::StrFormat(
        "cylinder found: axis at column %.2f (row %.1f), radius %.2f ± %.2f px, tilt %.3f deg, "
        "rows %d-%d, left limb %s, right limb %s",
        c.center_x_px, c.center_row_px, c.radius_px, c.radius_stderr_px,
        c.axis_angle_rad * 180.0 / M_PI, c.top_row, c.bottom_row,
        c.left_observed ? "seen" : "inferred", c.right_observed ? "seen" : "inferred");
  } else {
    message = std::string(detected.status().message());
  }
  *plot_error = WriteTracePicture(dir, file_name, image, image_bytes, trace,
                                  detected.ok() ? "cylinder found" : "cylinder not found", message);
  *drawn = plot_error->ok();
  return detected;
}

absl::StatusOr<bool> PlotRefusalInto(const std::string& dir, const std::string& file_name,
                                     const std::string& image, const std::string& image_bytes,
                                     const v1::RequestHeader& header,
                                     const absl::Status& refusal) {
  if (refusal.code() != absl::StatusCode::kInvalidArgument ||
      header.acquisition().has_given_cylinder()) {
    return false;
  }
  absl::StatusOr<Acquisition> acquisition = AcquisitionFromProto(header.acquisition());
  if (!acquisition.ok()) return false;
  DetectionTrace trace;
  absl::StatusOr<DetectedCylinder> detected =
      DetectCylinderInBytes(image_bytes, *acquisition, EstimateOptions(), &trace);
  if (detected.ok() || !trace.Filled()) return false;
  if (absl::Status s = WriteTracePicture(dir, file_name, image, image_bytes, trace,
                                         "cylinder not found",
                                         std::string(detected.status().message()));
      !s.ok()) {
    return s;
  }
  return true;
}

void ReportRefusalPlot(const std::string& dir, const std::string& file_name,
                       const std::string& image, const std::string& image_bytes,
                       const v1::RequestHeader& header, const absl::Status& refusal) {
  absl::StatusOr<bool> written =
      PlotRefusalInto(dir, file_name, image, image_bytes, header, refusal);
  if (!written.ok()) {
    std::cerr << "weavefit: " << image << ": " << written.status().message() << "\n";
  } else if (*written) {
    std::cerr << "weavefit: " << image << ": what detection saw is in " << dir << "/"
              << file_name << "\n";
  }
}

}  // namespace weavefit
