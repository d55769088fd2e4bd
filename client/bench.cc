#include "client/bench.h"

#include <google/protobuf/struct.pb.h>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <fstream>
#include <thread>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <tuple>
#include <utility>

#include "absl/status/status.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/files.h"
#include "client/rpc_client.h"
#include "estimator/io/decode.h"
#include "estimator/io/encode.h"
#include "estimator/pipeline/estimate.h"
#include "estimator/render/render.h"

extern char** environ;

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

std::optional<std::string> StructString(const google::protobuf::Struct& s,
                                        const std::string& object, const std::string& field) {
  auto o = s.fields().find(object);
  if (o == s.fields().end() || !o->second.has_struct_value()) return std::nullopt;
  auto f = o->second.struct_value().fields().find(field);
  if (f == o->second.struct_value().fields().end() ||
      f->second.kind_case() != google::protobuf::Value::kStringValue) {
    return std::nullopt;
  }
  return f->second.string_value();
}

// The photographs to run: images given, and every non-sidecar file in the
// folders given, sorted.
std::vector<std::string> ListImages(const std::vector<std::string>& inputs) {
  std::vector<std::string> images;
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (std::filesystem::is_directory(in, ec)) {
      for (const auto& entry : std::filesystem::directory_iterator(in, ec)) {
        const std::string ext = entry.path().extension().string();
        if (!entry.is_regular_file() || ext == ".json" || ext == ".sh" || ext == ".csv" ||
            ext == ".md") {
          continue;
        }
        images.push_back(entry.path().string());
      }
    } else {
      images.push_back(in);
    }
  }
  std::sort(images.begin(), images.end());
  return images;
}

// Linear interpolation between order statistics; NaN for an empty v (an
// empty CSV cell).
double Quantile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double at = p * (v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(at));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (at - lo) * (v[hi] - v[lo]);
}

double Median(std::vector<double> v) { return Quantile(std::move(v), 0.5); }

std::string Num(double x) { return std::isfinite(x) ? absl::StrFormat("%.6g", x) : ""; }

struct MethodStats {
  std::vector<double> ms, spacing_err;
  int images = 0, model_right = 0, compared = 0, covered = 0, errors = 0;
  // The cylinder against the sidecar's truth (centerXPx, radiusPx,
  // axisAngleDeg), where it has one: absolute errors, px and deg.
  std::vector<double> center_err, radius_err, axis_err, detect_ms;
  int refused_at_detection = 0;
  // Radius more than 3 stated errors and 2 px off: a wrong cylinder stated
  // as right.
  int radius_misstated = 0;
  // The threads against the truth, where it gives a wavelength: how many
  // answers, how many resolved it, their relative errors (|error| / truth)
  // and how many lie within 3 stated errors; the same for the amplitude;
  // the glint stage's times.
  int lambda_expected = 0, lambda_resolved = 0, lambda_covered = 0;
  std::vector<double> lambda_err, amplitude_err, glints_ms;
  int amplitude_covered = 0;
};

// A limb's word for the CSV: which were seen, which inferred.
std::string LimbsSeen(const CylinderGeometry& c) {
  if (c.left_observed && c.right_observed) return "both";
  if (c.left_observed) return "right inferred";
  if (c.right_observed) return "left inferred";
  return "none";
}

const char* MethodName(const std::string& mode) {
  if (mode == "fast") return "peak picking (fast)";
  if (mode == "accurate") return "lobe fits from 2 starts + glints (accurate)";
  return "lobe fit + glints (balanced)";
}

}  // namespace

int RunBench(const BenchFlags& flags) {
  const std::vector<std::string> images =
      ListImages(flags.inputs.empty() ? std::vector<std::string>{"fixtures"} : flags.inputs);
  std::error_code ec;
  std::filesystem::create_directories(flags.out_dir, ec);
  if (ec) {
    std::cerr << "weavefit bench: cannot create " << flags.out_dir << ": " << ec.message() << "\n";
    return static_cast<int>(absl::StatusCode::kUnavailable);
  }
  const std::vector<std::string> stages = {"decode", "detect", "profile", "peaks", "fit", "glints"};
  std::string csv =
      "image,method,truth_model,model,model_right,total_ms,decode_ms,detect_ms,profile_ms,"
      "peaks_ms,fit_ms,glints_ms,truth_spacing_deg,spacing_deg,spacing_stderr_deg,"
      "spacing_resolved,spacing_error_deg,max_slope_rel_error,truth_wavelength_mm,"
      "wavelength_mm,wavelength_stderr_mm,wavelength_resolved,wavelength_rel_error,"
      "amplitude_rel_error,mirror_error_deg,center_error_px,radius_error_px,radius_stderr_px,"
      "axis_error_deg,limbs_seen,error\n";
  std::map<std::string, MethodStats> stats;
  int used = 0;
  for (const std::string& image : images) {
    const auto sidecar = ReadSidecar(image);
    const auto phase = sidecar ? StructNumber(*sidecar, "acquisition", "phaseAngleDeg") : std::nullopt;
    const auto truth_model = sidecar ? StructString(*sidecar, "truth", "model") : std::nullopt;
    if (!phase || !truth_model) {
      std::cerr << "weavefit bench: " << image << ": no sidecar with acquisition and truth, skipped\n";
      continue;
    }
    absl::StatusOr<std::string> bytes = ReadFile(image);
    if (!bytes.ok()) {
      std::cerr << "weavefit bench: " << bytes.status().message() << "\n";
      continue;
    }
    ++used;
    Acquisition acquisition;
    acquisition.phase_angle_rad = *phase * kDeg;
    acquisition.cylinder_diameter_mm =
        StructNumber(*sidecar, "acquisition", "cylinderDiameterMm").value_or(0.0);
    acquisition.camera_distance_mm =
        StructNumber(*sidecar, "acquisition", "cameraDistanceMm").value_or(0.0);
    const double truth_spacing = StructNumber(*sidecar, "truth", "peakSpacingDeg").value_or(0.0);
    const double truth_slope = StructNumber(*sidecar, "truth", "maxSlope").value_or(0.0);
    const double truth_lambda = StructNumber(*sidecar, "truth", "wavelengthMm").value_or(0.0);
    const double truth_h0 = StructNumber(*sidecar, "truth", "amplitudeMm").value_or(0.0);
    const double truth_mirror = StructNumber(*sidecar, "truth", "mirrorAzimuthDeg").value_or(0.0);
    const auto truth_cx = StructNumber(*sidecar, "truth", "centerXPx");
    const auto truth_row = StructNumber(*sidecar, "truth", "centerRowPx");
    const auto truth_radius = StructNumber(*sidecar, "truth", "radiusPx");
    const auto truth_axis = StructNumber(*sidecar, "truth", "axisAngleDeg");
    const bool split = StructNumber(*sidecar, "truth", "splitResolvable").has_value()
                           ? true
                           : *truth_model != "SMOOTH";
    const std::string name = std::filesystem::path(image).filename().string();
    for (const std::string& mode : flags.modes) {
      EstimateOptions options;
      options.mode = mode == "fast" ? Mode::kFast : mode == "accurate" ? Mode::kAccurate : Mode::kBalanced;
      MethodStats& st = stats[mode];
      ++st.images;
      std::vector<double> totals;
      absl::StatusOr<Estimate> estimate = absl::UnknownError("not run");
      for (int r = 0; r < std::max(flags.repeats, 1); ++r) {
        const auto start = std::chrono::steady_clock::now();
        estimate = EstimateFromBytes(*bytes, acquisition, options);
        totals.push_back(std::chrono::duration<double, std::milli>(
                             std::chrono::steady_clock::now() - start).count());
      }
      std::vector<std::string> row = {name, mode, *truth_model};
      if (!estimate.ok()) {
        ++st.errors;
        st.refused_at_detection +=
            absl::StartsWith(estimate.status().message(), "no cylinder found");
        row.resize(30);
        row.push_back(absl::StrCat("\"", estimate.status().message(), "\""));
        csv += absl::StrJoin(row, ",") + "\n";
        continue;
      }
      const Estimate& e = *estimate;
      const double total = Median(totals);
      st.ms.push_back(total);
      const std::string model = ProfileModelName(e.model);
      const bool right = model == *truth_model;
      st.model_right += right;
      std::map<std::string, double> stage_ms;
      for (const StageTime& t : e.timings) stage_ms[t.stage] += t.milliseconds;
      row.push_back(model);
      row.push_back(right ? "1" : "0");
      row.push_back(Num(total));
      for (const std::string& s : stages) row.push_back(stage_ms.count(s) ? Num(stage_ms[s]) : "");
      const bool spacing_ok = e.peak_spacing_rad.resolved;
      const double spacing = e.peak_spacing_rad.value / kDeg;
      const double spacing_se = e.peak_spacing_rad.stderr_value / kDeg;
      const double spacing_err = spacing_ok ? spacing - truth_spacing : std::nan("");
      if (spacing_ok && split && *truth_model != "SMOOTH") {
        st.spacing_err.push_back(std::fabs(spacing_err));
        ++st.compared;
        st.covered += std::fabs(spacing_err) <= 3.0 * spacing_se;
      }
      row.push_back(Num(truth_spacing));
      row.push_back(spacing_ok ? Num(spacing) : "");
      row.push_back(spacing_ok ? Num(spacing_se) : "");
      row.push_back(spacing_ok ? "1" : "0");
      row.push_back(Num(spacing_err));
      row.push_back(e.max_slope.resolved && truth_slope > 0 ? Num(e.max_slope.value / truth_slope - 1.0) : "");
      row.push_back(Num(truth_lambda));
      row.push_back(e.wavelength_mm.resolved ? Num(e.wavelength_mm.value) : "");
      row.push_back(e.wavelength_mm.resolved ? Num(e.wavelength_mm.stderr_value) : "");
      row.push_back(e.wavelength_mm.resolved ? "1" : "0");
      row.push_back(e.wavelength_mm.resolved && truth_lambda > 0
                        ? Num(e.wavelength_mm.value / truth_lambda - 1.0) : "");
      row.push_back(e.amplitude_mm.resolved && truth_h0 > 0 ? Num(e.amplitude_mm.value / truth_h0 - 1.0) : "");
      if (truth_lambda > 0.0) {
        ++st.lambda_expected;
        if (e.wavelength_mm.resolved) {
          ++st.lambda_resolved;
          st.lambda_err.push_back(std::fabs(e.wavelength_mm.value / truth_lambda - 1.0));
          st.lambda_covered += std::fabs(e.wavelength_mm.value - truth_lambda) <=
                               3.0 * e.wavelength_mm.stderr_value;
        }
        if (e.amplitude_mm.resolved && truth_h0 > 0.0) {
          st.amplitude_err.push_back(std::fabs(e.amplitude_mm.value / truth_h0 - 1.0));
          st.amplitude_covered += std::fabs(e.amplitude_mm.value - truth_h0) <=
                                  3.0 * e.amplitude_mm.stderr_value;
        }
      }
      if (stage_ms.count("glints")) st.glints_ms.push_back(stage_ms["glints"]);
      row.push_back(e.specular_azimuth_rad.resolved
                        ? Num(e.specular_azimuth_rad.value / kDeg - truth_mirror) : "");
      const CylinderGeometry& c = e.cylinder;
      if (stage_ms.count("detect")) st.detect_ms.push_back(stage_ms["detect"]);
      // Without the truth's row (our own fixtures), the axis's column at the
      // middle row, where an untilted axis is the same.
      const double center_err =
          truth_cx ? c.AxisColumn(truth_row.value_or(c.center_row_px)) - *truth_cx : std::nan("");
      const double radius_err = truth_radius ? c.radius_px - *truth_radius : std::nan("");
      const double axis_err = truth_axis ? c.axis_angle_rad / kDeg - *truth_axis : std::nan("");
      if (std::isfinite(center_err)) st.center_err.push_back(std::fabs(center_err));
      if (std::isfinite(axis_err)) st.axis_err.push_back(std::fabs(axis_err));
      if (std::isfinite(radius_err)) {
        st.radius_err.push_back(std::fabs(radius_err));
        st.radius_misstated += std::fabs(radius_err) > std::max(2.0, 3.0 * c.radius_stderr_px);
      }
      row.push_back(Num(center_err));
      row.push_back(Num(radius_err));
      row.push_back(Num(c.radius_stderr_px));
      row.push_back(Num(axis_err));
      row.push_back(LimbsSeen(c));
      row.push_back("");
      csv += absl::StrJoin(row, ",") + "\n";
    }
    std::cerr << "." << std::flush;
  }
  std::cerr << "\n";
  if (used == 0) {
    std::cerr << "weavefit bench: no photograph with a truth sidecar found\n";
    return static_cast<int>(absl::StatusCode::kInvalidArgument);
  }
  const std::string csv_path = flags.out_dir + "/bench.csv";
  if (absl::Status s = WriteFile(csv_path, csv); !s.ok()) {
    std::cerr << "weavefit bench: " << s.message() << "\n";
    return static_cast<int>(s.code());
  }
  // Summary: one row per method, the chart's data.
  std::string summary =
      "method,label,images,errors,model_right,median_ms,ms_p25,ms_p75,median_spacing_error_deg,"
      "spacing_error_p25,spacing_error_p75,within_3_stderr,compared\n";
  std::cout << absl::StrFormat("%-34s %7s %10s %18s %10s %8s\n", "method", "images", "median ms",
                               "|spacing err| deg", "model ok", "<=3 se");
  for (const std::string& mode : flags.modes) {
    const MethodStats& st = stats[mode];
    summary += absl::StrCat(mode, ",\"", MethodName(mode), "\",", st.images, ",", st.errors, ",",
                            st.model_right, ",", Num(Median(st.ms)), ",", Num(Quantile(st.ms, 0.25)),
                            ",", Num(Quantile(st.ms, 0.75)), ",", Num(Median(st.spacing_err)), ",",
                            Num(Quantile(st.spacing_err, 0.25)), ",",
                            Num(Quantile(st.spacing_err, 0.75)), ",", st.covered, ",", st.compared,
                            "\n");
    std::cout << absl::StrFormat("%-34s %7d %10.1f %18.3f %7d/%-2d %5d/%-2d\n", MethodName(mode),
                                 st.images, Median(st.ms), Median(st.spacing_err), st.model_right,
                                 st.images, st.covered, st.compared);
  }
  // The cylinder, where the sidecars give its truth.
  for (const std::string& mode : flags.modes) {
    const MethodStats& st = stats[mode];
    if (st.center_err.empty()) continue;
    std::cout << absl::StrFormat(
        "cylinder (%s): %d of %d refused at detection; |centre err| px median %.2f p90 %.2f; "
        "|radius err| px median %.2f p90 %.2f; |axis err| deg median %.3f; radius >3 se and "
        ">2 px off: %d; detect ms median %.1f\n",
        mode, st.refused_at_detection, st.images, Median(st.center_err),
        Quantile(st.center_err, 0.9), Median(st.radius_err), Quantile(st.radius_err, 0.9),
        Median(st.axis_err), st.radius_misstated, Median(st.detect_ms));
  }
  // The threads, where the sidecars give a wavelength.
  for (const std::string& mode : flags.modes) {
    const MethodStats& st = stats[mode];
    if (st.lambda_expected == 0) continue;
    std::cout << absl::StrFormat(
        "threads (%s): wavelength resolved in %d of %d answers with a true wavelength; |error| %% "
        "median %.2f p90 %.2f; within 3 se %d/%d; amplitude |error| %% median %.2f, within 3 se "
        "%d/%zu; glints ms median %.1f\n",
        mode, st.lambda_resolved, st.lambda_expected, 100.0 * Median(st.lambda_err),
        100.0 * Quantile(st.lambda_err, 0.9), st.lambda_covered, st.lambda_resolved,
        100.0 * Median(st.amplitude_err), st.amplitude_covered, st.amplitude_err.size(),
        Median(st.glints_ms));
  }
  const std::string summary_path = flags.out_dir + "/summary.csv";
  if (absl::Status s = WriteFile(summary_path, summary); !s.ok()) {
    std::cerr << "weavefit bench: " << s.message() << "\n";
    return static_cast<int>(s.code());
  }
  std::cout << "wrote " << csv_path << " and " << summary_path << "\n";
  if (flags.no_chart) return 0;
  // The chart: median time against median |spacing error|, the bars from the
  // quartiles, one point per method, both axes logarithmic; the labels
  // alternately above and below their points, which may lie close.
  const std::string plot = flags.out_dir + "/speed_accuracy";
  std::string script = absl::StrCat(
      "set datafile separator ','\n"
      "set key off\n"
      "set logscale xy\n"
      "set xlabel 'median time per photograph, ms (in-process, decode included; bars: quartiles)'\n"
      "set ylabel 'median |peak spacing error|, deg (bars: quartiles)'\n"
      "set title 'weavefit: speed against accuracy over ", used, " photographs'\n"
      "set grid\n"
      "set offsets graph 0.1, graph 0.6, graph 0.3, graph 0.3\n"
      "plot_it = \"plot '", summary_path,
      "' every ::1 using 6:9:7:8:10:11 with xyerrorbars pt 7 ps 1.5 lw 2, '", summary_path,
      "' every ::1 using 6:($9*(int($0)%2 == 0 ? 1.7 : 0.55)):2 with labels left offset 1.5,0 "
      "font ',10'\"\n"
      "set terminal pngcairo size 900,600\n"
      "set output '", plot, ".png'\n"
      "eval plot_it\n"
      "set terminal svg size 900,600\n"
      "set output '", plot, ".svg'\n"
      "eval plot_it\n");
  const std::string script_path = flags.out_dir + "/speed_accuracy.gp";
  if (absl::Status s = WriteFile(script_path, script); !s.ok()) {
    std::cerr << "weavefit bench: " << s.message() << "\n";
    return static_cast<int>(s.code());
  }
  const std::string command = absl::StrCat("gnuplot '", script_path, "'");
  if (std::system(command.c_str()) != 0) {
    std::cerr << "weavefit bench: gnuplot failed or is missing (scripts/setup.sh installs "
                 "gnuplot-nox); the CSVs are written, the chart is not\n";
    return static_cast<int>(absl::StatusCode::kUnavailable);
  }
  std::cout << "wrote " << plot << ".png and " << plot << ".svg\n";
  return 0;
}

namespace {

struct SweepAxis {
  std::string name;   // CSV and chart label
  std::string unit;
  std::vector<double> values;
  void (*apply)(RenderScene&, double);
  bool log_x = false;
};

std::vector<SweepAxis> SweepAxes() {
  return {
      {"max_slope", "max slope m", {0.01, 0.02, 0.04, 0.08, 0.16, 0.24, 0.4},
       [](RenderScene& s, double m) { s.amplitude_mm = m * s.wavelength_mm / (2.0 * M_PI); }, true},
      {"noise", "photons at full scale (fewer = noisier)", {200000, 20000, 5000, 2000, 800, 300},
       [](RenderScene& s, double photons) {
         s.photons_full_scale = photons;
         s.read_noise = 0.002 * std::sqrt(20000.0 / photons);
       }, true},
      {"blur", "source blur sigma, deg", {0.3, 0.6, 1.2, 2.4, 4.0, 6.0},
       [](RenderScene& s, double b) { s.source_blur_deg = b; }, true},
      {"px_per_period", "pixels per thread period", {32, 16, 8, 5, 3, 2},
       [](RenderScene& s, double px) {
         const double m = s.MaxSlope();
         const double mm_per_px = (s.diameter_mm / 2.0) / (0.4 * s.width_px);
         s.wavelength_mm = px * mm_per_px;
         s.amplitude_mm = m * s.wavelength_mm / (2.0 * M_PI);
       }, true},
      {"phase_angle", "phase angle, deg", {10, 40, 70, 100, 120, 140},
       [](RenderScene& s, double a) { s.phase_angle_deg = a; }, false},
      {"tilt", "axis tilt, deg", {0, 1, 2, 3, 4, 5},
       [](RenderScene& s, double t) { s.axis_angle_deg = t; }, false},
      // Overexposure: glints clip at the sensor's maximum, as they often do
      // in the lab (issue 4); the saturated pixels are masked.
      {"exposure", "exposure, times the default (glints clip)", {1, 10, 30, 100, 300},
       [](RenderScene& s, double f) { s.exposure *= f; }, true},
      // Stray light (issue 31): a broad source lights the whole body, so the
      // side away from the lamp shows the weave's texture, from darker than
      // the background (0.01) through as bright to far brighter, and the
      // lobe sits on a textured level (the default ambient 0.03 is kept).
      {"stray_light", "stray light, full-scale level of a lit crest", {0, 0.01, 0.02, 0.04, 0.08, 0.16},
       [](RenderScene& s, double level) { s.stray_light = level; }, false},
  };
}

// One sweep point's summary for one mode.
struct SweepPoint {
  std::string axis, mode;
  double value = 0.0, median_error = 0.0, failure_rate = 0.0;
};

// Writes the gnuplot script for one 2×3 panel chart (the error, or the
// failure rate, against each axis; one line per mode, the data inline) and
// runs it.
absl::Status SweepChart(const std::string& out_dir, const std::vector<SweepPoint>& points,
                        const std::vector<SweepAxis>& axes, const std::vector<std::string>& modes,
                        const std::string& stem, bool error_chart, const std::string& ylabel) {
  std::string data;
  for (const SweepAxis& axis : axes) {
    for (const std::string& mode : modes) {
      absl::StrAppend(&data, "$", axis.name, "_", mode, " << EOD\n");
      for (const SweepPoint& p : points) {
        if (p.axis != axis.name || p.mode != mode) continue;
        const double y = error_chart ? p.median_error : p.failure_rate;
        if (std::isfinite(y)) absl::StrAppend(&data, Num(p.value), " ", Num(y), "\n");
      }
      absl::StrAppend(&data, "EOD\n");
    }
  }
  std::string body = absl::StrCat(
      "set multiplot layout 2,4 title 'weavefit stability: ", ylabel,
      " (a sinusoid, m 0.24, 1.44 mm = 16 px per period, 320x240, alpha 30 deg; one axis varied "
      "at a time)'\nset grid\nset key top left\n");
  for (const SweepAxis& axis : axes) {
    absl::StrAppend(&body, axis.log_x ? "set logscale x\n" : "unset logscale x\n",
                    error_chart ? "set logscale y\nset yrange [0.0005:30]\n"
                                : "unset logscale y\nset yrange [-0.05:1.05]\n",
                    "set xlabel '", axis.unit, "'\nplot ");
    for (std::size_t m = 0; m < modes.size(); ++m) {
      absl::StrAppend(&body, m ? ", " : "", "$", axis.name, "_", modes[m],
                      " using 1:2 with linespoints lw 2 pt ", 5 + 2 * static_cast<int>(m),
                      " title '", MethodName(modes[m]), "'");
    }
    absl::StrAppend(&body, "\n");
  }
  absl::StrAppend(&body, "unset multiplot\n");
  const std::string script = absl::StrCat(
      data, "set terminal pngcairo size 1900,850 font ',10'\nset output '", out_dir, "/", stem,
      ".png'\n", body, "set terminal svg size 1900,850\nset output '", out_dir, "/", stem,
      ".svg'\n", body);
  const std::string path = absl::StrCat(out_dir, "/", stem, ".gp");
  if (absl::Status s = WriteFile(path, script); !s.ok()) return s;
  if (std::system(absl::StrCat("gnuplot '", path, "'").c_str()) != 0) {
    return absl::UnavailableError("gnuplot failed or is missing (scripts/setup.sh installs gnuplot-nox)");
  }
  return absl::OkStatus();
}

}  // namespace

int RunSweep(const BenchFlags& flags) {
  std::error_code ec;
  std::filesystem::create_directories(flags.out_dir, ec);
  if (ec) {
    std::cerr << "weavefit bench: cannot create " << flags.out_dir << ": " << ec.message() << "\n";
    return static_cast<int>(absl::StatusCode::kUnavailable);
  }
  const std::vector<SweepAxis> axes = SweepAxes();
  std::string csv =
      "axis,value,seed,mode,truth_spacing_deg,split_resolvable,model_right,spacing_resolved,"
      "spacing_error_deg,spacing_stderr_deg,wrong,unresolved,ms\n";
  std::string summary = "axis,value,mode,median_abs_spacing_error_deg,wrong_rate,unresolved_rate,failure_rate,draws\n";
  std::vector<SweepPoint> points;
  for (const SweepAxis& axis : axes) {
    for (double value : axis.values) {
      std::map<std::string, std::vector<double>> errors;
      std::map<std::string, int> wrong, unresolved, draws;
      for (int seed = 1; seed <= flags.seeds; ++seed) {
        RenderScene scene;
        scene.width_px = 320;
        scene.height_px = 240;
        scene.model = ProfileModel::kSinusoid;
        scene.wavelength_mm = 1.44;
        scene.amplitude_mm = 0.24 * scene.wavelength_mm / (2.0 * M_PI);
        scene.phase_angle_deg = 30.0;
        scene.seed = static_cast<std::uint32_t>(1000 * seed + 17);
        axis.apply(scene, value);
        absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
        if (!rendered.ok()) {
          std::cerr << "weavefit bench --sweep: " << axis.name << " " << value << ": "
                    << rendered.status().message() << "\n";
          continue;
        }
        Acquisition acquisition;
        acquisition.phase_angle_rad = scene.phase_angle_deg * kDeg;
        acquisition.cylinder_diameter_mm = scene.diameter_mm;
        acquisition.camera_distance_mm = scene.camera_distance_mm;
        const RenderTruth& truth = rendered->truth;
        for (const std::string& mode : flags.modes) {
          EstimateOptions options;
          options.mode =
              mode == "fast" ? Mode::kFast : mode == "accurate" ? Mode::kAccurate : Mode::kBalanced;
          const auto start = std::chrono::steady_clock::now();
          absl::StatusOr<Estimate> e = EstimateFromImage(rendered->image, acquisition, options);
          const double ms = std::chrono::duration<double, std::milli>(
                                std::chrono::steady_clock::now() - start).count();
          ++draws[mode];
          const bool ok = e.ok();
          const bool model_right = ok && e->model == scene.model;
          const bool resolved = ok && e->peak_spacing_rad.resolved;
          const double err = resolved ? e->peak_spacing_rad.value / kDeg - truth.peak_spacing_deg
                                      : std::nan("");
          const double se = resolved ? e->peak_spacing_rad.stderr_value / kDeg : std::nan("");
          // Wrong: a wrong model where the split shows, or a spacing more
          // than 3 stated errors off. Unresolved: no spacing, or an error
          // reply (a refusal, which says why), where the truth's split is
          // resolvable.
          const bool is_wrong = (ok && truth.split_resolvable && resolved && !model_right) ||
                                (resolved && std::fabs(err) > 3.0 * se);
          const bool is_unresolved = (!ok || !resolved) && truth.split_resolvable;
          wrong[mode] += is_wrong;
          unresolved[mode] += is_unresolved;
          if (resolved) errors[mode].push_back(std::fabs(err));
          absl::StrAppend(&csv, axis.name, ",", Num(value), ",", seed, ",", mode, ",",
                          Num(truth.peak_spacing_deg), ",", truth.split_resolvable ? 1 : 0, ",",
                          model_right ? 1 : 0, ",", resolved ? 1 : 0, ",", Num(err), ",", Num(se),
                          ",", is_wrong ? 1 : 0, ",", is_unresolved ? 1 : 0, ",", Num(ms), "\n");
        }
      }
      for (const std::string& mode : flags.modes) {
        const double n = std::max(draws[mode], 1);
        points.push_back({axis.name, mode, value, Median(errors[mode]),
                          (wrong[mode] + unresolved[mode]) / n});
        absl::StrAppend(&summary, axis.name, ",", Num(value), ",", mode, ",",
                        Num(Median(errors[mode])), ",", Num(wrong[mode] / n), ",",
                        Num(unresolved[mode] / n), ",", Num((wrong[mode] + unresolved[mode]) / n),
                        ",", draws[mode], "\n");
      }
      std::cerr << "." << std::flush;
    }
  }
  std::cerr << "\n";
  const std::string csv_path = flags.out_dir + "/sweep.csv";
  const std::string summary_path = flags.out_dir + "/sweep_summary.csv";
  for (const auto& [path, text] : {std::pair{csv_path, csv}, std::pair{summary_path, summary}}) {
    if (absl::Status s = WriteFile(path, text); !s.ok()) {
      std::cerr << "weavefit bench --sweep: " << s.message() << "\n";
      return static_cast<int>(s.code());
    }
  }
  std::cout << "wrote " << csv_path << " and " << summary_path << "\n";
  if (flags.no_chart) return 0;
  for (const auto& [stem, error_chart, label] :
       {std::tuple{std::string("sweep_error"), true, std::string("median |peak spacing error|, deg")},
        std::tuple{std::string("sweep_failures"), false,
                   std::string("share of wrong (model, or > 3 stated errors off) or unresolved answers")}}) {
    if (absl::Status s = SweepChart(flags.out_dir, points, axes, flags.modes, stem, error_chart, label);
        !s.ok()) {
      std::cerr << "weavefit bench --sweep: " << s.message() << "; the CSVs are written\n";
      return static_cast<int>(s.code());
    }
    std::cout << "wrote " << flags.out_dir << "/" << stem << ".png and .svg\n";
  }
  return 0;
}

namespace {

// A weavefitd child on a free loopback port; stopped on destruction.
class ChildDaemon {
 public:
  ChildDaemon(const std::string& path, const std::string& dir, int workers) {
    const std::string port_file = dir + "/perf_daemon.port";
    std::remove(port_file.c_str());
    std::vector<std::string> argv = {path, "--listen", "127.0.0.1:0", "--port-file", port_file,
                                     "--workers", std::to_string(workers)};
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    const std::string log = dir + "/perf_daemon.log";
    posix_spawn_file_actions_addopen(&actions, 2, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (posix_spawn(&pid_, args[0], &actions, nullptr, args.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (pid_ > 0 && port_ == 0 && std::chrono::steady_clock::now() < deadline) {
      std::ifstream in(port_file);
      if (!(in >> port_)) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
  ~ChildDaemon() {
    if (pid_ > 0) {
      kill(pid_, SIGTERM);
      int status = 0;
      waitpid(pid_, &status, 0);
    }
  }
  bool ok() const { return pid_ > 0 && port_ > 0; }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  // Peak resident memory so far (VmHWM), bytes; 0 when unknown.
  double PeakBytes() const {
    std::ifstream in("/proc/" + std::to_string(pid_) + "/status");
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("VmHWM:", 0) == 0) return std::atof(line.c_str() + 6) * 1024.0;
    }
    return 0.0;
  }

 private:
  pid_t pid_ = -1;
  int port_ = 0;
};

template <typename F>
double MedianMs(int repeats, F&& run) {
  std::vector<double> ms;
  for (int i = 0; i < std::max(repeats, 1); ++i) {
    const auto start = std::chrono::steady_clock::now();
    run();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                     .count());
  }
  return Median(ms);
}

std::string DefaultDaemonPath() {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return "weavefitd";
  return (self.parent_path().parent_path() / "server" / "weavefitd").string();
}

}  // namespace

int RunPerf(const BenchFlags& flags) {
  std::error_code ec;
  std::filesystem::create_directories(flags.out_dir, ec);
  // A lab's photograph: the axial threads glinting one by one, a plain
  // weave's floats, stray light on the whole body and the weave's phase
  // wandering along the axis (RenderScene's default drift and jitter).
  const std::string png_path = flags.out_dir + "/perf_4096x3072_lab.png";
  const std::string exr_path = flags.out_dir + "/perf_4096x3072_lab.exr";
  RenderScene scene;
  scene.width_px = 4096;
  scene.height_px = 3072;
  scene.radius_px = 1600;
  scene.wavelength_mm = 2.0;
  scene.amplitude_mm = 0.0764;
  scene.phase_angle_deg = 10.0;
  scene.axial_glint_width = 0.15;
  scene.axial_float_width = 0.3;
  scene.stray_light = 0.02;
  if (!std::filesystem::exists(png_path) || !std::filesystem::exists(exr_path)) {
    std::cerr << "weavefit bench --perf: rendering the 4096x3072 test image once (about 15 s)\n";
    absl::StatusOr<Rendered> rendered = RenderPhotograph(scene);
    if (!rendered.ok()) {
      std::cerr << "weavefit bench --perf: " << rendered.status().message() << "\n";
      return static_cast<int>(rendered.status().code());
    }
    for (const auto& [path, format] :
         {std::pair{png_path, EncodeFormat::kPng16}, std::pair{exr_path, EncodeFormat::kExr}}) {
      absl::StatusOr<std::string> bytes = EncodeImage(rendered->image, format);
      absl::Status s = bytes.ok() ? WriteFile(path, *bytes) : bytes.status();
      if (!s.ok()) {
        std::cerr << "weavefit bench --perf: " << s.message() << "\n";
        return static_cast<int>(s.code());
      }
    }
  }
  Acquisition acquisition;
  acquisition.phase_angle_rad = scene.phase_angle_deg * kDeg;
  acquisition.cylinder_diameter_mm = scene.diameter_mm;
  const int n = std::max(flags.repeats, 1);
  std::string csv = "figure,format,value,target,unit,meets\n";
  std::cout << absl::StrFormat("%-58s %10s %10s  %s\n", "figure (medians of " + std::to_string(n) + " runs)",
                               "measured", "target", "");
  auto report = [&](const std::string& figure, const std::string& format, double value,
                    double target, const std::string& unit, bool lower_is_better) {
    const bool has_target = std::isfinite(target);
    const bool meets = lower_is_better ? value <= target : value >= target;
    std::cout << absl::StrFormat("%-58s %10.3g %10s  %-2s %s\n", figure + " [" + format + "]", value,
                                 has_target ? absl::StrFormat("%.3g", target) : "-", unit,
                                 has_target ? (meets ? "ok" : "MISSED") : "");
    absl::StrAppend(&csv, "\"", figure, "\",", format, ",", Num(value), ",", Num(target), ",", unit,
                    ",", has_target ? (meets ? "1" : "0") : "", "\n");
  };
  double decoded_bytes = 0.0;
  double png_in_process_ms = 0.0;
  std::string png_bytes;
  for (const std::string& path : {png_path, exr_path}) {
    const std::string format = path.substr(path.size() - 3);
    absl::StatusOr<std::string> bytes = ReadFile(path);
    if (!bytes.ok()) {
      std::cerr << "weavefit bench --perf: " << bytes.status().message() << "\n";
      return static_cast<int>(bytes.status().code());
    }
    if (format == "png") png_bytes = *bytes;
    DecodeOptions decode;
    decode.max_pixels = 1LL << 26;
    absl::StatusOr<Image> image = DecodeImage(*bytes, decode);
    if (!image.ok()) {
      std::cerr << "weavefit bench --perf: " << image.status().message() << "\n";
      return static_cast<int>(image.status().code());
    }
    decoded_bytes = static_cast<double>(image->pixels.size()) * sizeof(float);
    const double decode_ms = MedianMs(n, [&] { (void)DecodeImage(*bytes, decode); });
    report("decode alone", format, decode_ms, std::nan(""), "ms", true);
    for (const std::string mode : {"fast", "balanced"}) {
      EstimateOptions options;
      options.mode = mode == std::string("fast") ? Mode::kFast : Mode::kBalanced;
      std::vector<double> after;
      std::vector<double> detect;
      const double whole = MedianMs(n, [&] {
        absl::StatusOr<Estimate> e = EstimateFromBytes(*bytes, acquisition, options);
        if (!e.ok()) return;
        double sum = 0.0;
        for (const StageTime& t : e->timings) {
          sum += t.stage == "decode" ? 0.0 : t.milliseconds;
          if (t.stage == "detect") detect.push_back(t.milliseconds);
        }
        after.push_back(sum);
      });
      if (mode == std::string("balanced")) {
        report("cylinder detection (balanced)", format, Median(detect), 30.0, "ms", true);
      }
      if (mode == std::string("balanced")) {
        report("in-process estimate / decode alone (balanced)", format, whole / decode_ms, 1.25,
               "x", true);
        if (format == "png") png_in_process_ms = whole;
      }
      report(absl::StrCat("all stages after decoding (", mode, ")"), format, Median(after),
             mode == std::string("fast") ? 10.0 : 50.0, "ms", true);
    }
  }
  const std::string daemon = flags.daemon_path.empty() ? DefaultDaemonPath() : flags.daemon_path;
  {
    ChildDaemon child(daemon, flags.out_dir, 2);
    if (!child.ok()) {
      std::cerr << "weavefit bench --perf: cannot start " << daemon
                << " (give --daemon PATH); the daemon figures are left out\n";
    } else {
      v1::RequestHeader header;
      header.mutable_acquisition()->set_phase_angle_deg(scene.phase_angle_deg);
      header.mutable_acquisition()->set_cylinder_diameter_mm(scene.diameter_mm);
      header.mutable_options()->set_mode(v1::BALANCED);
      header.set_filename("perf_4096x3072_lab.png");
      Connection connection;
      connection.server = child.address();
      (void)SubmitEstimate(connection, header, png_bytes);  // warm-up
      const double remote = MedianMs(n, [&] {
        (void)SubmitEstimate(connection, header, png_bytes);
      });
      report("through the daemon on loopback / in-process (balanced)", "png",
             remote / png_in_process_ms, 1.15, "x", true);
      report("daemon peak memory / decoded image", "png", child.PeakBytes() / decoded_bytes, 3.0,
             "x", true);
      // Throughput: 2·n requests from one client, then from two at once.
      const int requests = 2 * n;
      const double one = MedianMs(1, [&] {
        for (int i = 0; i < requests; ++i) (void)SubmitEstimate(connection, header, png_bytes);
      });
      const double two = MedianMs(1, [&] {
        std::thread a([&] {
          for (int i = 0; i < n; ++i) (void)SubmitEstimate(connection, header, png_bytes);
        });
        for (int i = 0; i < n; ++i) (void)SubmitEstimate(connection, header, png_bytes);
        a.join();
      });
      report("two concurrent clients / one (throughput, 2 workers)", "png", one / two, 1.7, "x",
             false);
    }
  }
  const std::string path = flags.out_dir + "/perf.csv";
  if (absl::Status s = WriteFile(path, csv); !s.ok()) {
    std::cerr << "weavefit bench --perf: " << s.message() << "\n";
    return static_cast<int>(s.code());
  }
  std::cout << "wrote " << path << "\n";
  return 0;
}

}  // namespace weavefit
