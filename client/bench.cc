#include "client/bench.h"

#include <google/protobuf/struct.pb.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "absl/strings/str_join.h"
#include "client/files.h"
#include "estimator/pipeline/estimate.h"

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

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double Quantile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double at = p * (v.size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(at));
  const std::size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (at - lo) * (v[hi] - v[lo]);
}

std::string Num(double x) { return std::isfinite(x) ? absl::StrFormat("%.6g", x) : ""; }

struct MethodStats {
  std::vector<double> ms, spacing_err;
  int images = 0, model_right = 0, compared = 0, covered = 0, errors = 0;
};

const char* MethodName(const std::string& mode) {
  if (mode == "fast") return "peak picking (fast)";
  if (mode == "accurate") return "least squares + comb (accurate)";
  return "comb fit or peaks (balanced)";
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
      "amplitude_rel_error,mirror_error_deg,error\n";
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
        StructNumber(*sidecar, "acquisition", "cylinderDiameterMm").value_or(46.0);
    acquisition.camera_distance_mm =
        StructNumber(*sidecar, "acquisition", "cameraDistanceMm").value_or(0.0);
    const double truth_spacing = StructNumber(*sidecar, "truth", "peakSpacingDeg").value_or(0.0);
    const double truth_slope = StructNumber(*sidecar, "truth", "maxSlope").value_or(0.0);
    const double truth_lambda = StructNumber(*sidecar, "truth", "wavelengthMm").value_or(0.0);
    const double truth_h0 = StructNumber(*sidecar, "truth", "amplitudeMm").value_or(0.0);
    const double truth_mirror = StructNumber(*sidecar, "truth", "mirrorAzimuthDeg").value_or(0.0);
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
        row.resize(25);
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
      row.push_back(e.specular_azimuth_rad.resolved
                        ? Num(e.specular_azimuth_rad.value / kDeg - truth_mirror) : "");
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
  const std::string summary_path = flags.out_dir + "/summary.csv";
  if (absl::Status s = WriteFile(summary_path, summary); !s.ok()) {
    std::cerr << "weavefit bench: " << s.message() << "\n";
    return static_cast<int>(s.code());
  }
  std::cout << "wrote " << csv_path << " and " << summary_path << "\n";
  if (flags.no_chart) return 0;
  // The chart: median time against median |spacing error|, the bars from the
  // quartiles, one point per method, both axes logarithmic.
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
      "' every ::1 using 6:9:2 with labels left offset 1.5,0.8 font ',10'\"\n"
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

}  // namespace weavefit
