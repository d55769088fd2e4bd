// weavefit: the command-line client. One Run<Subcommand> per subcommand.
//
//   weavefit estimate IMAGE... --phase-angle DEG     in-process
//   weavefit submit INPUT... --server HOST:PORT[,..] through weavefitd (client/submit.cc)
//   weavefit detect IMAGE... --phase-angle DEG       the cylinder only (a set-up check)
//   weavefit render --out FILE [scene flags]         a photograph with truth
//
// Exit status: 0 when every image succeeded; otherwise the gRPC/absl status
// code of the first failure (3 INVALID_ARGUMENT, 8 RESOURCE_EXHAUSTED,
// 14 UNAVAILABLE, ...); CLI11 usage errors exit with its own codes.
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <CLI/CLI.hpp>
#include <glog/logging.h>
#include <cmath>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <type_traits>
#include <variant>
#include <algorithm>
#include <cctype>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/batch.h"
#include "client/bench.h"
#include "client/files.h"
#include "client/plot.h"
#include "client/report.h"
#include "client/submit.h"
#include "estimator/io/encode.h"
#include "estimator/pipeline/estimate.h"
#include "estimator/render/render.h"
#include "proto/weavefit/v1/convert.h"

namespace weavefit {
namespace {

// Flags of estimate (in-process).
struct EstimateFlags {
  std::vector<std::string> images;
  MetadataFlags metadata;
  bool joint = false;  // also the joint estimate over the images
  bool same_cylinder = false;  // one cylinder for all images (SharesCylinder)
  bool own_cylinders = false;  // each image its own, even with --joint
  std::string format = "table";  // table, json or csv
  bool json = false;             // --json: --format json
  std::string profile_csv;       // write the azimuthal profile here
  std::string plot_dir;          // a fit plot per image here (PlotInto)
};

// azimuth_deg,mean,stderr,count per bin, for plotting and diagnostics.
std::string ProfileCsv(const Profile& p) {
  std::string out = "azimuth_deg,mean,stderr,count\n";
  for (int i = 0; i < p.NumBins(); ++i) {
    absl::StrAppend(&out, p.azimuth_rad[i] * 180.0 / M_PI, ",", p.mean[i], ",",
                    p.stderr_mean[i], ",", p.count[i], "\n");
  }
  return out;
}

absl::StatusOr<v1::EstimateReply> EstimateInProcess(const v1::RequestHeader& header,
                                                    const std::string& bytes,
                                                    const std::string& profile_csv) {
  absl::StatusOr<Acquisition> acquisition = AcquisitionFromProto(header.acquisition());
  if (!acquisition.ok()) return acquisition.status();
  absl::StatusOr<EstimateOptions> options = OptionsFromProto(header.options(), EstimateOptions());
  if (!options.ok()) return options.status();
  absl::StatusOr<Estimate> estimate = EstimateFromBytes(bytes, *acquisition, *options);
  if (!estimate.ok()) return estimate.status();
  if (!profile_csv.empty()) {
    if (absl::Status s = WriteFile(profile_csv, ProfileCsv(estimate->profile)); !s.ok()) return s;
  }
  v1::EstimateReply reply = ReplyFromEstimate(*estimate, header.sample_name());
  reply.set_filename(header.filename());
  return reply;
}

// weavefit estimate: each image in turn, in this process.
int RunEstimates(EstimateFlags flags) {
  absl::Status usage;
  if (flags.json && flags.format != "table" && flags.format != "json") {
    usage = absl::InvalidArgumentError("--json is --format json; give one of them");
  } else if (flags.json) {
    flags.format = "json";
  }
  const bool json = flags.format == "json";
  const std::size_t angles = flags.metadata.phase_angles_deg.size();
  if (usage.ok() && angles > 1 && angles != flags.images.size()) {
    usage = absl::InvalidArgumentError(absl::StrCat(
        "--phase-angle gives ", angles, " angles for ", flags.images.size(),
        " images: give one for all or one per image"));
  }
  if (usage.ok() && flags.joint && flags.format == "csv") {
    usage = absl::InvalidArgumentError("--joint prints a table or JSON, not CSV");
  }
  absl::StatusOr<bool> share = SharesCylinder(flags.same_cylinder, flags.joint,
                                              flags.own_cylinders, flags.metadata,
                                              flags.images.size());
  if (usage.ok()) usage = share.status();
  // The series' cylinder, detected on every image before any is estimated.
  absl::StatusOr<SeriesCylinder> series = SeriesCylinder();
  if (usage.ok() && *share) {
    series = ShareCylinderOfFiles(flags.metadata, flags.images, {});
    usage = series.status();
  }
  if (!usage.ok()) {
    std::cerr << "weavefit: " << usage.message() << "\n";
    if (json) std::cout << ErrorToJson(usage) << "\n";
    return static_cast<int>(usage.code());
  }
  if (!series->summary.empty()) std::cerr << "weavefit: " << series->summary << "\n";
  if (flags.format == "csv") std::cout << CsvHeader();
  std::vector<ReportRow> rows;
  std::vector<PhotographEstimate> photographs;
  std::vector<std::string> names;
  absl::Status first_error;
  const std::vector<std::string> plot_names = PlotFileNames(flags.images);
  for (std::size_t index = 0; index < flags.images.size(); ++index) {
    const std::string& image = flags.images[index];
    ReportRow row;
    row.image = image;
    absl::StatusOr<v1::EstimateReply> reply = [&]() -> absl::StatusOr<v1::EstimateReply> {
      absl::StatusOr<std::string> bytes = ReadFile(image);
      if (!bytes.ok()) return bytes.status();
      absl::StatusOr<v1::RequestHeader> header = HeaderFor(flags.metadata, image, index, nullptr);
      if (!header.ok()) return header.status();
      if (!flags.plot_dir.empty()) header->mutable_options()->set_include_curves(true);
      if (series->given) {
        *header->mutable_acquisition()->mutable_given_cylinder() = *series->given;
      }
      row.header = *header;
      absl::StatusOr<v1::EstimateReply> estimated =
          EstimateInProcess(*header, *bytes, flags.profile_csv);
      if (!estimated.ok() && !flags.plot_dir.empty()) {
        ReportRefusalPlot(flags.plot_dir, plot_names[index], image, *bytes, *header,
                          estimated.status());
      }
      if (estimated.ok() && series->given) AddSeriesNote(series->notes[index], &*estimated);
      if (estimated.ok() && !flags.plot_dir.empty()) {
        if (absl::Status s = PlotInto(flags.plot_dir, plot_names[index], image, *bytes, &*estimated);
            !s.ok()) {
          return s;
        }
      }
      return estimated;
    }();
    if (reply.ok()) {
      if (json) std::cout << JsonLine(*reply) << "\n";
      row.reply = *reply;
      photographs.push_back(PhotographFromReply(*reply));
      names.push_back(reply->sample_name());
    } else {
      if (first_error.ok()) first_error = reply.status();
      std::cerr << "weavefit: " << image << ": "
                << absl::StatusCodeToString(reply.status().code()) << ": "
                << reply.status().message() << "\n";
      if (json) std::cout << ImageErrorJson(image, reply.status()) << "\n";
      row.error = StatusLine(reply.status());
    }
    if (flags.format == "csv") std::cout << CsvRow(row);
    if (auto sidecar = ReadSidecar(image)) {
      row.truth_spacing_deg = StructNumber(*sidecar, "truth", "peakSpacingDeg");
    }
    rows.push_back(std::move(row));
  }
  if (flags.format == "table") std::cout << FormatTable(rows);
  if (flags.joint) {
    absl::StatusOr<JointEstimate> joint = CombineEstimates(photographs);
    if (!joint.ok()) {
      if (first_error.ok()) first_error = joint.status();
      std::cerr << "weavefit: joint estimate: " << joint.status().message() << "\n";
      if (json) std::cout << ErrorToJson(joint.status()) << "\n";
    } else {
      v1::JointEstimate out = JointToProto(*joint, names);
      if (series->given) out.add_warnings(series->summary);
      std::cout << (json ? JointJsonLine(out) : FormatJoint(out));
    }
  }
  return first_error.ok() ? 0 : static_cast<int>(first_error.code());
}

// Flags of detect.
struct DetectFlags {
  std::vector<std::string> images;
  MetadataFlags metadata;
  bool json = false;
  std::string plot_dir;
};

// One line of `weavefit detect --json`: {"image", "cylinder"} (the reply's
// Cylinder field names, and the image's size) or {"image", "error"}.
std::string DetectionJson(const std::string& image,
                          const absl::StatusOr<DetectedCylinder>& detected) {
  google::protobuf::Struct root;
  auto& fields = *root.mutable_fields();
  fields["image"].set_string_value(image);
  if (!detected.ok()) {
    auto& error = *fields["error"].mutable_struct_value()->mutable_fields();
    error["code"].set_string_value(absl::StatusCodeToString(detected.status().code()));
    error["message"].set_string_value(std::string(detected.status().message()));
  } else {
    const CylinderGeometry& c = detected->cylinder;
    auto& out = *fields["cylinder"].mutable_struct_value()->mutable_fields();
    out["centerXPx"].set_number_value(c.center_x_px);
    out["centerRowPx"].set_number_value(c.center_row_px);
    out["radiusPx"].set_number_value(c.radius_px);
    out["radiusStderrPx"].set_number_value(c.radius_stderr_px);
    out["axisAngleDeg"].set_number_value(c.axis_angle_rad * 180.0 / M_PI);
    out["topRowPx"].set_number_value(c.top_row);
    out["bottomRowPx"].set_number_value(c.bottom_row);
    out["leftLimbObserved"].set_bool_value(c.left_observed);
    out["rightLimbObserved"].set_bool_value(c.right_observed);
    out["imageWidthPx"].set_number_value(detected->width);
    out["imageHeightPx"].set_number_value(detected->height);
  }
  std::string json;
  (void)google::protobuf::util::MessageToJsonString(root, &json);
  return json;
}

// weavefit detect: the cylinder of each image as its estimate would detect
// it, and with --plot the picture of what detection saw; for checking a
// set-up (framing, background, the phase angle's sign) before a series.
int RunDetect(const DetectFlags& flags) {
  const std::size_t angles = flags.metadata.phase_angles_deg.size();
  if (angles > 1 && angles != flags.images.size()) {
    std::cerr << "weavefit: --phase-angle gives " << angles << " angles for "
              << flags.images.size() << " images: give one for all or one per image\n";
    return static_cast<int>(absl::StatusCode::kInvalidArgument);
  }
  const std::vector<std::string> plot_names = PlotFileNames(flags.images);
  absl::Status first_error;
  if (!flags.json) {
    std::cout << absl::StrFormat("%-40s %10s %16s %9s %11s %s\n", "image", "axis (px)",
                                 "radius (px)", "tilt (deg)", "rows", "limbs");
  }
  for (std::size_t index = 0; index < flags.images.size(); ++index) {
    const std::string& image = flags.images[index];
    absl::Status plot_error;
    bool drawn = false;
    absl::StatusOr<DetectedCylinder> detected = [&]() -> absl::StatusOr<DetectedCylinder> {
      absl::StatusOr<std::string> bytes = ReadFile(image);
      if (!bytes.ok()) return bytes.status();
      absl::StatusOr<v1::RequestHeader> header = HeaderFor(flags.metadata, image, index, nullptr);
      if (!header.ok()) return header.status();
      return DetectWithPicture(flags.plot_dir, plot_names[index], image, *bytes, *header,
                               &plot_error, &drawn);
    }();
    if (!plot_error.ok()) {
      std::cerr << "weavefit: " << image << ": " << plot_error.message() << "\n";
    } else if (drawn) {
      std::cerr << "weavefit: " << image << ": what detection saw is in " << flags.plot_dir << "/"
                << plot_names[index] << "\n";
    }
    if (!detected.ok()) {
      if (first_error.ok()) first_error = detected.status();
      std::cerr << "weavefit: " << image << ": "
                << absl::StatusCodeToString(detected.status().code()) << ": "
                << detected.status().message() << "\n";
      if (flags.json) std::cout << DetectionJson(image, detected) << "\n";
      continue;
    }
    const CylinderGeometry& c = detected->cylinder;
    const double tilt = c.axis_angle_rad * 180.0 / M_PI;
    if (flags.json) {
      std::cout << DetectionJson(image, detected) << "\n";
    } else {
      std::cout << absl::StrFormat(
          "%-40s %10.2f %8.2f ± %5.2f %9.3f %5d-%-5d %s/%s\n", image, c.center_x_px, c.radius_px,
          c.radius_stderr_px, tilt, c.top_row, c.bottom_row, c.left_observed ? "seen" : "inferred",
          c.right_observed ? "seen" : "inferred");
    }
  }
  return first_error.ok() ? 0 : static_cast<int>(first_error.code());
}

// The acquisition flags of estimate and submit.
void AddMetadataFlags(CLI::App* app, MetadataFlags* flags) {
  app->add_option("--phase-angle", flags->phase_angles_deg,
                  "signed phase angle, deg, in (-180, 180); positive = light on "
                  "the image's right; one for all images or one per image, comma-separated "
                  "(default: each sidecar's acquisition.phaseAngleDeg)")
      ->delimiter(',')
      ->allow_extra_args(false);
  app->add_option("--diameter-mm", flags->diameter_mm,
                  "cylinder diameter, mm (default: each sidecar's "
                  "acquisition.cylinderDiameterMm; without any, the wavelength and amplitude "
                  "are reported in cylinder radii in a warning, unresolved in mm)");
  app->add_option("--distance-mm", flags->distance_mm,
                  "camera distance from the axis, mm; 0 = orthographic")
      ->capture_default_str();
  app->add_flag("--linear", flags->linear, "pixels are already linear (no sRGB decoding)");
  app->add_option("--saturation-level", flags->saturation_level,
                  "saturation level in file units; 0 = the format's maximum, or a clip "
                  "plateau below it (many samples at the file's largest value)")
      ->capture_default_str();
  app->add_option("--cylinder", flags->cylinder,
                  "CX,R,TILT[,RADIUS_STDERR]: use this cylinder instead of detecting it, for "
                  "photographs that cannot show it: the axis column at the image's middle row "
                  "(px), the radius (px), the axis tilt (deg, > 0 = top toward the right) and "
                  "the radius's standard error (px, default 0.5); the rows read are the whole "
                  "image's or the region's")
      ->delimiter(',')
      ->allow_extra_args(false);
  app->add_option("--roi", flags->roi,
                  "X,Y,W,H: read only this region of each image, px (e.g. to leave out the "
                  "cylinder's ends; with --cylinder, its rows are the rows read)")
      ->delimiter(',')
      ->allow_extra_args(false);
  app->add_option("--mode", flags->mode, "fast, balanced or accurate")
      ->check(CLI::IsMember({"fast", "balanced", "accurate"}))->capture_default_str();
}

// --same-cylinder and --own-cylinders (SharesCylinder).
void AddCylinderSharingFlags(CLI::App* app, bool* same_cylinder, bool* own_cylinders) {
  app->add_flag("--same-cylinder", *same_cylinder,
                "the images are one set-up (the lamp moves, camera and sample stay): detect "
                "the cylinder on each, combine the detections that show it best (both limbs "
                "seen, inverse-variance weighted) and read every image through it, including "
                "those whose own detection fails; on by default with --joint");
  app->add_flag("--own-cylinders", *own_cylinders,
                "each image is read through its own detected cylinder, also with --joint");
}

void AddFormatFlags(CLI::App* app, std::string* format, bool* json) {
  app->add_option("--format", *format,
                  "stdout: table, json (protobuf's JSON mapping of each reply, one per line) or "
                  "csv (one row per image; columns in client/report.h)")
      ->check(CLI::IsMember({"table", "json", "csv"}))
      ->capture_default_str();
  app->add_flag("--json", *json, "the same as --format json");
}

void AddEstimateFlags(CLI::App* app, EstimateFlags* flags) {
  app->add_option("images", flags->images, "photographs (PNG, TIFF, JPEG, EXR)")->required();
  AddMetadataFlags(app, &flags->metadata);
  app->add_flag("--joint", flags->joint,
                "also combine the images, photographs of one sample, into a joint estimate "
                "of the thread parameters (with one cylinder for all: --same-cylinder)");
  AddCylinderSharingFlags(app, &flags->same_cylinder, &flags->own_cylinders);
  AddFormatFlags(app, &flags->format, &flags->json);
  app->add_option("--profile-csv", flags->profile_csv,
                  "write the azimuthal profile (azimuth_deg,mean,stderr,count) of the last image");
  app->add_option("--plot", flags->plot_dir,
                  "write a fit plot per image into this folder (DIR/<image stem>.png, made "
                  "distinct where stems repeat): the "
                  "profile with its error band, every model's fit, the peaks, the residuals and "
                  "the photograph with the detected limbs; for an image refused at detection, "
                  "the picture of what detection saw");
}

void AddSubmitFlags(CLI::App* app, SubmitFlags* flags) {
  app->add_option("inputs", flags->inputs,
                  "photographs (PNG, TIFF, JPEG, EXR), folders (their images, sorted) and glob "
                  "patterns (quoted: expanded here)");
  AddMetadataFlags(app, &flags->metadata);
  app->add_option("--manifest", flags->manifest,
                  "CSV with a header row: path (relative to the manifest's folder), "
                  "phase_angle_deg, diameter_mm, distance_mm, sample_name; its images are "
                  "submitted too, its cells override flags and sidecars")
      ->check(CLI::ExistingFile);
  app->add_flag("--joint", flags->joint,
                "send the images, photographs of one sample, in one call for the daemon's joint "
                "estimate of the thread parameters (with one cylinder for all: --same-cylinder)");
  AddCylinderSharingFlags(app, &flags->same_cylinder, &flags->own_cylinders);
  AddFormatFlags(app, &flags->format, &flags->json);
  app->add_option("--out", flags->out,
                  "also append each result to this file (.csv: CSV, else JSON lines "
                  "{\"image\", \"reply\"}); images whose results it holds are skipped");
  app->add_flag("--no-skip", flags->no_skip,
                "estimate images whose results --out already holds again (their old records are "
                "dropped as the run starts)");
  app->add_option("--jobs", flags->jobs, "uploads in flight at once")
      ->check(CLI::Range(1, 64))
      ->capture_default_str();
  app->add_option("--retries", flags->retry.max_retries,
                  "retries per image on UNAVAILABLE, RESOURCE_EXHAUSTED and DEADLINE_EXCEEDED, "
                  "with exponential backoff and jitter (a daemon that is gone is waited for "
                  "instead: --reconnect-window-s)")
      ->check(CLI::Range(0, 20))
      ->capture_default_str();
  app->add_option("--reconnect-window-s", flags->retry.reconnect_window_s,
                  "when the daemon is gone (UNAVAILABLE, not connected), wait up to this long, "
                  "s, from when it was found gone, for it to be back, spending no retries; an "
                  "image is lost only when it is not back by then (0 = plain retries)")
      ->check(CLI::Range(0.0, 3600.0))
      ->capture_default_str();
  app->add_flag("--quiet", flags->quiet, "no progress or retry lines on stderr");
  app->add_option("--plot", flags->plot_dir,
                  "write a fit plot per image into this folder (DIR/<image stem>.png, made "
                  "distinct where stems repeat; the daemon "
                  "returns the curves, the photograph is drawn from the local file); for an "
                  "image refused at detection, the picture of what detection saw (detected "
                  "again here)");
  Connection& c = flags->connection;
  app->add_option("--server", c.server,
                  "weavefitd address host:port; several, host1:port,host2:port, or a DNS name "
                  "with several addresses (dns:///name:port), share the work (round_robin)")
      ->capture_default_str();
  app->add_option("--timeout-s", c.timeout_s, "deadline per image and attempt, s")
      ->capture_default_str()->check(CLI::PositiveNumber);
  app->add_option("--tls-ca", c.tls_ca,
                  "CA certificate (PEM) that signed the daemon's; turns TLS on")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-cert", c.tls_cert, "client certificate (PEM), for mutual TLS")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-key", c.tls_key, "client private key (PEM), for mutual TLS")
      ->check(CLI::ExistingFile);
  app->add_option("--token-file", flags->token_file,
                  "file whose first line is the bearer token (default: $WEAVEFIT_TOKEN)")
      ->check(CLI::ExistingFile);
}

struct RenderFlags {
  RenderScene scene;
  std::string model = "sinusoid";
  std::string out;
  std::string format;
  std::string scene_file;
  std::vector<double> specular_rgb;
  std::vector<double> axial_rgb;
  std::vector<double> diffuse_rgb;
};

// One scene parameter: its flag, its key in a scene JSON file (the sidecar's
// "scene" object uses the same keys), its help text, and where it lives.
struct SceneParam {
  const char* flag;
  const char* key;
  const char* help;
  std::variant<double*, int*, bool*, std::uint32_t*> target;
};

std::vector<SceneParam> SceneParams(RenderScene& s) {
  return {
      {"--width", "widthPx", "image width, px", &s.width_px},
      {"--height", "heightPx", "image height, px", &s.height_px},
      {"--wavelength-mm", "wavelengthMm", "thread undulation period lambda, mm", &s.wavelength_mm},
      {"--amplitude-mm", "amplitudeMm", "undulation amplitude h0, mm (sawtooth: half peak-to-peak)", &s.amplitude_mm},
      {"--diameter-mm", "diameterMm", "cylinder diameter, mm", &s.diameter_mm},
      {"--distance-mm", "cameraDistanceMm", "camera distance from the axis, mm; 0 = orthographic", &s.camera_distance_mm},
      {"--phase-angle", "phaseAngleDeg", "signed phase angle, deg; > 0 = light on the image's right", &s.phase_angle_deg},
      {"--center-x", "centerXPx", "axis column at the middle row, px; < 0 = image centre", &s.center_x_px},
      {"--radius-px", "radiusPx", "cylinder limb half-width, px; < 0 = 40% of the width", &s.radius_px},
      {"--tilt-deg", "axisAngleDeg", "axis tilt, deg; > 0 = top toward the right", &s.axis_angle_deg},
      {"--top-row", "topRowPx", "first row of the cylinder (its upper end); < 0 = beyond the frame", &s.top_row_px},
      {"--bottom-row", "bottomRowPx", "last row of the cylinder (its lower end); < 0 = beyond the frame", &s.bottom_row_px},
      {"--source-blur-deg", "sourceBlurDeg", "angular sigma of the light source, deg (blur in facet tilt is half)", &s.source_blur_deg},
      {"--exposure", "exposure", "E0: source irradiance times gain, full-scale units", &s.exposure},
      {"--axial-reflectance", "axialReflectance", "reflectance of the threads along the axis (grazing scatter), relative", &s.axial_reflectance},
      {"--diffuse", "diffuse", "Lambertian level (coloured fabrics)", &s.diffuse},
      {"--ambient", "ambient", "uniform level of the cylinder body", &s.ambient},
      {"--background", "background", "level outside the cylinder", &s.background},
      {"--mount-level", "mountLevel", "level of a mount beyond the cylinder's ends; < 0 = none", &s.mount_level},
      {"--mount-half-width", "mountHalfWidth", "half-width of the mount, cylinder radii", &s.mount_half_width},
      {"--stray-light", "strayLight", "diffuse stray light on the whole body: level of a fully exposed crest facing the camera; 0 = none", &s.stray_light},
      {"--stray-texture", "strayTexture", "share of the stray light the weave's relief shades in its deepest gaps (0 = uniform)", &s.stray_texture},
      {"--axial-glint-width", "axialGlintWidth", "axial threads one by one: glint line width, share of lambda/2; 0 = a uniform lobe", &s.axial_glint_width},
      {"--corner-share", "cornerShare", "a sawtooth's share of arc in its rounded (circular-arc) corners; 0 = sharp", &s.corner_share},
      {"--axial-float-width", "axialFloatWidth", "arc share of lambda/2 where an axial thread floats over a circumferential one's trough; 0 = gaps only", &s.axial_float_width},
      {"--background-gradient", "backgroundGradient", "change of the background level across the frame, full-scale units", &s.background_gradient},
      {"--background-gradient-deg", "backgroundGradientDeg", "direction the background brightens toward, deg; 0 = right, 90 = down", &s.background_gradient_deg},
      {"--black-level", "blackLevel", "sensor pedestal kept in the file, full-scale units", &s.black_level},
      {"--white-level", "whiteLevel", "file value of a saturated sample, share of full scale (12-bit data in a 16-bit file: 0.99977)", &s.white_level},
      {"--gap-fraction", "gapFraction", "share of each thread pitch showing axial threads", &s.gap_fraction},
      {"--crest-tilt-deg", "crestTiltDeg", "out-of-plane tilt at a thread's edges, deg; 0 = flat ribbons", &s.crest_tilt_deg},
      {"--phase-step", "phaseStep", "weave phase between neighbouring threads, periods (0.5 = plain weave)", &s.phase_step},
      {"--regular-weave", "regularWeave", "no drift or jitter of the weave phase", &s.regular_weave},
      {"--relief-parallax", "reliefParallax", "rays meet the threads' relief, not the mean cylinder: glints near the limb move by up to h0*tan(phi - v)", &s.relief_parallax},
      {"--phase-jitter", "phaseJitter", "per-thread random phase shift, periods", &s.phase_jitter},
      {"--phase-drift", "phaseDrift", "random-walk step of the weave phase per thread, periods", &s.phase_drift},
      {"--optics-blur-px", "opticsBlurPx", "Gaussian sigma of the lens PSF, px", &s.optics_blur_px},
      {"--vignetting", "vignetting", "relative fall-off at the image corners", &s.vignetting},
      {"--photons", "photonsFullScale", "photons at full scale (shot noise); 0 = none", &s.photons_full_scale},
      {"--read-noise", "readNoise", "Gaussian read noise, full-scale units", &s.read_noise},
      {"--bits", "quantisationBits", "ADC bits; 0 = no quantisation", &s.quantisation_bits},
      {"--samples", "samplesPerPixel", "samples per pixel per axis (4x along the arc in the lobe)", &s.samples_per_pixel},
      {"--seed", "seed", "random seed (weave irregularity and noise)", &s.seed},
  };
}

// Applies a scene JSON file: the "scene" object of a truth sidecar, or a
// plain object with the same keys. Unknown keys are an error.
absl::Status LoadSceneFile(const std::string& path, RenderFlags& flags) {
  absl::StatusOr<std::string> text = ReadFile(path);
  if (!text.ok()) return text.status();
  google::protobuf::Struct root;
  if (!google::protobuf::util::JsonStringToMessage(*text, &root).ok()) {
    return absl::InvalidArgumentError(absl::StrCat(path, " is not a JSON object"));
  }
  const google::protobuf::Struct* scene = &root;
  if (auto it = root.fields().find("scene"); it != root.fields().end() && it->second.has_struct_value()) {
    scene = &it->second.struct_value();
  }
  std::vector<SceneParam> params = SceneParams(flags.scene);
  for (const auto& field : scene->fields()) {
    // Named copies: a lambda may not capture a structured binding in C++17.
    const std::string& key = field.first;
    const google::protobuf::Value& value = field.second;
    if (key == "model") {
      std::string m = value.string_value();
      for (char& c : m) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      flags.model = m;
      continue;
    }
    if (key == "specularRgb" || key == "axialRgb" || key == "diffuseRgb") {
      std::vector<double>& rgb = key == "specularRgb" ? flags.specular_rgb
                                 : key == "axialRgb"  ? flags.axial_rgb
                                                      : flags.diffuse_rgb;
      rgb.clear();
      for (const auto& v : value.list_value().values()) rgb.push_back(v.number_value());
      continue;
    }
    auto param = std::find_if(params.begin(), params.end(),
                              [&](const SceneParam& p) { return key == p.key; });
    if (param == params.end()) {
      return absl::InvalidArgumentError(absl::StrCat(path, ": unknown scene key '", key, "'"));
    }
    std::visit([&](auto* target) {
      using T = std::remove_pointer_t<decltype(target)>;
      if constexpr (std::is_same_v<T, bool>) {
        *target = value.bool_value();
      } else {
        *target = static_cast<T>(value.number_value());
      }
    }, param->target);
  }
  return absl::OkStatus();
}

absl::Status ApplyRgb(const std::vector<double>& from, double* to, const char* name) {
  if (from.empty()) return absl::OkStatus();
  if (from.size() != 3) {
    return absl::InvalidArgumentError(absl::StrCat(name, " takes three numbers (R G B)"));
  }
  std::copy(from.begin(), from.end(), to);
  return absl::OkStatus();
}

int RunRender(RenderFlags& flags) {
  absl::Status status = ApplyRgb(flags.specular_rgb, flags.scene.specular_rgb, "--specular-rgb");
  if (status.ok()) status = ApplyRgb(flags.axial_rgb, flags.scene.axial_rgb, "--axial-rgb");
  if (status.ok()) status = ApplyRgb(flags.diffuse_rgb, flags.scene.diffuse_rgb, "--diffuse-rgb");
  if (flags.model == "smooth") {
    flags.scene.model = ProfileModel::kSmooth;
  } else if (flags.model == "sawtooth") {
    flags.scene.model = ProfileModel::kSawtooth;
  } else if (flags.model == "sinusoid") {
    flags.scene.model = ProfileModel::kSinusoid;
  } else if (status.ok()) {
    status = absl::InvalidArgumentError(absl::StrCat("unknown model '", flags.model, "'"));
  }
  std::string format = flags.format;
  if (format.empty()) {
    const std::size_t dot = flags.out.find_last_of('.');
    format = dot == std::string::npos ? "png" : flags.out.substr(dot + 1);
  }
  absl::StatusOr<EncodeFormat> encode_format = ParseEncodeFormat(format);
  if (status.ok()) status = encode_format.status();
  absl::StatusOr<Rendered> rendered = status.ok() ? RenderPhotograph(flags.scene)
                                                  : absl::StatusOr<Rendered>(status);
  absl::StatusOr<std::string> bytes = rendered.ok()
      ? EncodeImage(rendered->image, *encode_format)
      : absl::StatusOr<std::string>(rendered.status());
  status = bytes.status();
  if (status.ok()) status = WriteFile(flags.out, *bytes);
  if (status.ok()) {
    const std::size_t slash = flags.out.find_last_of('/');
    const std::string name = slash == std::string::npos ? flags.out : flags.out.substr(slash + 1);
    status = WriteFile(SidecarPath(flags.out), TruthJson(flags.scene, rendered->truth, name));
  }
  if (!status.ok()) {
    std::cerr << "weavefit render: " << status.message() << "\n";
    return static_cast<int>(status.code());
  }
  const RenderScene& s = flags.scene;
  std::cout << absl::StrFormat(
      "wrote %s (%dx%d %s, %s, phase angle %g deg, max slope %.4f, peak spacing %.3f deg) and "
      "its truth %s\n",
      flags.out, rendered->image.width, rendered->image.height, format,
      ProfileModelName(s.model), s.phase_angle_deg, rendered->truth.max_slope,
      rendered->truth.peak_spacing_deg, SidecarPath(flags.out));
  return 0;
}

void AddRenderFlags(CLI::App* app, RenderFlags* f) {
  app->add_option("--out", f->out, "output image; its extension picks the format")->required();
  app->add_option("--format", f->format, "png (16-bit linear), png8 (8-bit sRGB), tiff (16-bit), exr (float), jpeg (sRGB)");
  app->add_option("--scene", f->scene_file,
                  "scene JSON (a sidecar's \"scene\" object or the same keys); flags given too override it");
  app->add_option("--model", f->model, "thread profile: smooth, sinusoid or sawtooth")->capture_default_str();
  for (const SceneParam& p : SceneParams(f->scene)) {
    std::visit([&](auto* target) {
      using T = std::remove_pointer_t<decltype(target)>;
      if constexpr (std::is_same_v<T, bool>) {
        app->add_flag(p.flag, *target, p.help);
      } else {
        app->add_option(p.flag, *target, p.help)->capture_default_str();
      }
    }, p.target);
  }
  app->add_option("--specular-rgb", f->specular_rgb, "R G B factors of the circumferential threads (colour render)")->expected(3);
  app->add_option("--axial-rgb", f->axial_rgb, "R G B factors of the axial threads")->expected(3);
  app->add_option("--diffuse-rgb", f->diffuse_rgb, "R G B diffuse albedo")->expected(3);
}

}  // namespace
}  // namespace weavefit

int main(int argc, char** argv) {
  // Ceres logs through glog; the client's output is its table or JSON, so
  // only errors reach stderr (a rank-deficient nuisance covariance in
  // accurate mode is expected, not news).
  FLAGS_logtostderr = true;
  FLAGS_minloglevel = google::GLOG_ERROR;
  google::InitGoogleLogging(argv[0]);
  CLI::App app{"weavefit: thread geometry of glossy woven materials from one photograph"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("weavefit ") + weavefit::WeavefitVersion());
  weavefit::EstimateFlags estimate_flags;
  weavefit::SubmitFlags submit_flags;
  weavefit::RenderFlags render_flags;
  CLI::App* estimate = app.add_subcommand("estimate", "estimate in-process");
  weavefit::AddEstimateFlags(estimate, &estimate_flags);
  CLI::App* submit = app.add_subcommand(
      "submit", "estimate through weavefitd daemons: files, folders, globs or a manifest, "
                "several at once, with retries");
  weavefit::AddSubmitFlags(submit, &submit_flags);
  weavefit::DetectFlags detect_flags;
  CLI::App* detect = app.add_subcommand(
      "detect", "find the cylinder only, as estimate would (check a set-up before a series)");
  detect->add_option("images", detect_flags.images, "photographs (PNG, TIFF, JPEG, EXR)")
      ->required();
  weavefit::AddMetadataFlags(detect, &detect_flags.metadata);
  // Detection alone: no cylinder to give, no mode to choose.
  detect->remove_option(detect->get_option("--cylinder"));
  detect->remove_option(detect->get_option("--mode"));
  detect->add_flag("--json", detect_flags.json,
                   "one JSON object per image: {\"image\", \"cylinder\"} or {\"image\", \"error\"}");
  detect->add_option("--plot", detect_flags.plot_dir,
                     "write the picture of what detection saw per image into this folder "
                     "(DIR/<image stem>.png): the column profile, the edges found, each cylinder "
                     "tried and the figures that judged it, and the photograph");
  CLI::App* render = app.add_subcommand("render", "render a cylinder photograph with a truth sidecar");
  weavefit::AddRenderFlags(render, &render_flags);
  weavefit::BenchFlags bench_flags;
  CLI::App* bench = app.add_subcommand(
      "bench", "every mode over photographs with truth sidecars: CSV of times and errors, and a "
               "speed-against-accuracy chart (gnuplot)");
  bench->add_option("inputs", bench_flags.inputs, "images or folders (default: fixtures)");
  bench->add_option("--out", bench_flags.out_dir, "output folder")->capture_default_str();
  bench->add_option("--modes", bench_flags.modes, "modes to run, comma-separated")
      ->delimiter(',')
      ->check(CLI::IsMember({"fast", "balanced", "accurate"}))
      ->capture_default_str();
  bench->add_option("--repeats", bench_flags.repeats, "timed runs per image and mode (median kept)")
      ->check(CLI::Range(1, 100))
      ->capture_default_str();
  bench->add_flag("--no-chart", bench_flags.no_chart, "write the CSVs only");
  bench->add_flag("--sweep", bench_flags.sweep,
                  "the stability study: render scenes along the axes where methods fail and "
                  "chart error and failure rate per mode (ignores inputs)");
  bench->add_flag("--perf", bench_flags.perf,
                  "the speed report: a 4096x3072 16-bit PNG and EXR (rendered once into --out), "
                  "decode, in-process, daemon, memory and concurrency against their targets");
  bench->add_option("--daemon", bench_flags.daemon_path,
                    "weavefitd for --perf (default: beside this client's build)");
  bench->add_option("--seeds", bench_flags.seeds, "noise draws per sweep point")
      ->check(CLI::Range(1, 50))
      ->capture_default_str();
  // A scene file sets the defaults; flags on the command line override it.
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::string(argv[i]) == "render") {
      for (int k = i + 1; k + 1 < argc; ++k) {
        if (std::string(argv[k]) == "--scene") {
          if (absl::Status s = weavefit::LoadSceneFile(argv[k + 1], render_flags); !s.ok()) {
            std::cerr << "weavefit render: " << s.message() << "\n";
            return static_cast<int>(s.code());
          }
        }
      }
      break;
    }
  }
  CLI11_PARSE(app, argc, argv);
  if (*estimate) return weavefit::RunEstimates(estimate_flags);
  if (*detect) return weavefit::RunDetect(detect_flags);
  if (*submit) return weavefit::RunSubmit(submit_flags);
  if (*render) return weavefit::RunRender(render_flags);
  if (*bench) {
    if (bench_flags.perf) return weavefit::RunPerf(bench_flags);
    return bench_flags.sweep ? weavefit::RunSweep(bench_flags) : weavefit::RunBench(bench_flags);
  }
  return 0;
}
