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
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_replace.h"
#include "estimator/io/decode.h"

namespace weavefit {
namespace {

constexpr int kChartWidth = 1100;
constexpr int kChartHeight = 760;
constexpr int kThumbWidth = 560;

// gnuplot's own quoting: a single-quoted string with ' doubled.
std::string Quoted(const std::string& text) {
  return "'" + absl::StrReplaceAll(text, {{"'", "''"}}) + "'";
}

double ToDisplay(double linear) {  // sRGB transfer curve
  linear = std::clamp(linear, 0.0, 1.0);
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

const v1::Curve* Find(const v1::EstimateReply& reply, const std::string& label) {
  for (const v1::Curve& c : reply.curves()) {
    if (c.label() == label) return &c;
  }
  return nullptr;
}

}  // namespace

absl::StatusOr<std::string> AnnotatedThumbnail(const std::string& image_bytes,
                                               const v1::EstimateReply& reply, int height,
                                               int max_width) {
  DecodeOptions decode;
  absl::StatusOr<Image> image = DecodeImage(image_bytes, decode);
  if (!image.ok()) return image.status();
  // Tone-map: the 99.5th percentile of all samples maps to white.
  std::vector<float> sorted = image->pixels;
  const std::size_t k = static_cast<std::size_t>(0.995 * (sorted.size() - 1));
  std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
  const double white = std::max(1e-6, static_cast<double>(sorted[k]));
  cv::Mat display(image->height, image->width, CV_8UC3);
  for (int y = 0; y < image->height; ++y) {
    for (int x = 0; x < image->width; ++x) {
      cv::Vec3b& out = display.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) {
        const int from = image->channels == 3 ? 2 - c : 0;  // OpenCV is BGR
        out[c] = static_cast<uchar>(255.0 * ToDisplay(image->At(x, y, from) / white) + 0.5);
      }
    }
  }
  // The cylinder (DESIGN.md §2): the axis passes through center_x at the
  // middle row and leans right at the top by axis_angle; the limbs are the
  // lines at ±radius perpendicular to it.
  const v1::Cylinder& cyl = reply.cylinder();
  const double scale = std::min(static_cast<double>(height) / image->height,
                                static_cast<double>(max_width) / image->width);
  const double t = cyl.axis_angle_deg() * M_PI / 180.0;
  const double mid = 0.5 * (image->height - 1);
  auto line_at = [&](double offset_px, int y) {  // column of a line parallel to the axis
    return cyl.center_x_px() + offset_px / std::cos(t) - (y - mid) * std::tan(t);
  };
  cv::Mat thumb;
  cv::resize(display, thumb,
             cv::Size(std::max(1, static_cast<int>(image->width * scale)),
                      std::max(1, static_cast<int>(image->height * scale))),
             0, 0, scale < 1.0 ? cv::INTER_AREA : cv::INTER_NEAREST);
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
  char dir_template[] = "/tmp/weavefit_plot_XXXXXX";
  if (mkdtemp(dir_template) == nullptr) return absl::InternalError("no temporary folder");
  const std::string dir = dir_template;
  struct Cleanup {
    std::string dir;
    ~Cleanup() { std::system(absl::StrCat("rm -rf '", dir, "'").c_str()); }
  } cleanup{dir};

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
  // Chart and thumbnail side by side.
  cv::Mat left = cv::imread(chart, cv::IMREAD_COLOR);
  const std::vector<uchar> thumb_bytes(thumbnail->begin(), thumbnail->end());
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

}  // namespace weavefit
