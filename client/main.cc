// weavefit: the command-line client. One Run<Subcommand> per subcommand.
//
//   weavefit estimate IMAGE... --phase-angle DEG     in-process
//   weavefit submit IMAGE... --server HOST:PORT      through weavefitd
//   weavefit render --out FILE [scene flags]         a photograph with truth
//
// Exit status: 0 when every image succeeded; otherwise the gRPC/absl status
// code of the first failure (3 INVALID_ARGUMENT, 8 RESOURCE_EXHAUSTED,
// 14 UNAVAILABLE, ...); CLI11 usage errors exit with its own codes.
#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "client/report.h"
#include "client/rpc_client.h"
#include "estimator/io/encode.h"
#include "estimator/pipeline/estimate.h"
#include "estimator/render/render.h"
#include "proto/weavefit/v1/convert.h"

namespace weavefit {
namespace {

// Flags shared by estimate and submit.
struct EstimateFlags {
  std::vector<std::string> images;
  std::optional<double> phase_angle_deg;
  double diameter_mm = 46.0;
  double distance_mm = 0.0;
  bool linear = false;
  double saturation_level = 0.0;
  std::string mode = "balanced";
  bool json = false;
  std::string server = "127.0.0.1:50051";
  double timeout_s = 120.0;
  std::string profile_csv;  // estimate only: write the azimuthal profile here
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

absl::StatusOr<std::string> ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::NotFoundError(absl::StrCat("cannot open ", path));
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) return absl::DataLossError(absl::StrCat("cannot read ", path));
  return buffer.str();
}

// Writes via a temporary file and a rename, so nothing is half-written.
absl::Status WriteFile(const std::string& path, const std::string& bytes) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!out) return absl::UnavailableError(absl::StrCat("cannot write ", tmp));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    return absl::UnavailableError(absl::StrCat("cannot rename ", tmp, " to ", path));
  }
  return absl::OkStatus();
}

std::string SidecarPath(const std::string& image) {
  const std::size_t dot = image.find_last_of('.');
  const std::size_t slash = image.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) {
    return image + ".json";
  }
  return image.substr(0, dot) + ".json";
}

// The sidecar IMAGE-stem.json, parsed, when it exists and is JSON.
std::optional<google::protobuf::Struct> ReadSidecar(const std::string& image) {
  absl::StatusOr<std::string> text = ReadFile(SidecarPath(image));
  if (!text.ok()) return std::nullopt;
  google::protobuf::Struct sidecar;
  if (!google::protobuf::util::JsonStringToMessage(*text, &sidecar).ok()) {
    return std::nullopt;
  }
  return sidecar;
}

std::optional<double> StructNumber(const google::protobuf::Struct& s,
                                   const std::string& object,
                                   const std::string& field) {
  auto o = s.fields().find(object);
  if (o == s.fields().end() || !o->second.has_struct_value()) return std::nullopt;
  auto f = o->second.struct_value().fields().find(field);
  if (f == o->second.struct_value().fields().end() ||
      f->second.kind_case() != google::protobuf::Value::kNumberValue) {
    return std::nullopt;
  }
  return f->second.number_value();
}

// The request header for one image: flags, or the sidecar's "acquisition"
// object when the phase angle is not given on the command line.
absl::StatusOr<v1::RequestHeader> HeaderFor(const EstimateFlags& flags,
                                            const std::string& image) {
  v1::RequestHeader header;
  v1::Acquisition* acq = header.mutable_acquisition();
  acq->set_cylinder_diameter_mm(flags.diameter_mm);
  acq->set_camera_distance_mm(flags.distance_mm);
  acq->set_pixels_linear(flags.linear);
  acq->set_saturation_level(flags.saturation_level);
  if (flags.phase_angle_deg) {
    acq->set_phase_angle_deg(*flags.phase_angle_deg);
  } else {
    const auto sidecar = ReadSidecar(image);
    const auto phase = sidecar ? StructNumber(*sidecar, "acquisition", "phaseAngleDeg")
                               : std::nullopt;
    if (!phase) {
      return absl::InvalidArgumentError(absl::StrCat(
          "no phase angle for ", image, ": give --phase-angle or a sidecar ",
          SidecarPath(image), " with acquisition.phaseAngleDeg"));
    }
    acq->set_phase_angle_deg(*phase);
    if (auto d = StructNumber(*sidecar, "acquisition", "cylinderDiameterMm")) {
      acq->set_cylinder_diameter_mm(*d);
    }
    if (auto d = StructNumber(*sidecar, "acquisition", "cameraDistanceMm")) {
      acq->set_camera_distance_mm(*d);
    }
  }
  if (flags.mode == "fast") {
    header.mutable_options()->set_mode(v1::FAST);
  } else if (flags.mode == "accurate") {
    header.mutable_options()->set_mode(v1::ACCURATE);
  } else {
    header.mutable_options()->set_mode(v1::BALANCED);
  }
  const std::size_t slash = image.find_last_of('/');
  header.set_filename(slash == std::string::npos ? image : image.substr(slash + 1));
  header.set_sample_name(header.filename());
  return header;
}

absl::Status WriteFile(const std::string& path, const std::string& bytes);

absl::StatusOr<v1::EstimateReply> EstimateInProcess(const v1::RequestHeader& header,
                                                    const std::string& bytes,
                                                    const std::string& profile_csv) {
  absl::StatusOr<Acquisition> acquisition = AcquisitionFromProto(header.acquisition());
  if (!acquisition.ok()) return acquisition.status();
  const EstimateOptions options = OptionsFromProto(header.options(), EstimateOptions());
  absl::StatusOr<Estimate> estimate = EstimateFromBytes(bytes, *acquisition, options);
  if (!estimate.ok()) return estimate.status();
  if (!profile_csv.empty()) {
    if (absl::Status s = WriteFile(profile_csv, ProfileCsv(estimate->profile)); !s.ok()) return s;
  }
  return ReplyFromEstimate(*estimate, header.sample_name());
}

// estimate and submit differ only in where the work is done.
int RunEstimates(const EstimateFlags& flags, bool remote) {
  std::vector<ReportRow> rows;
  absl::Status first_error;
  for (const std::string& image : flags.images) {
    ReportRow row;
    row.image = image;
    absl::StatusOr<v1::EstimateReply> reply = [&]() -> absl::StatusOr<v1::EstimateReply> {
      absl::StatusOr<v1::RequestHeader> header = HeaderFor(flags, image);
      if (!header.ok()) return header.status();
      absl::StatusOr<std::string> bytes = ReadFile(image);
      if (!bytes.ok()) return bytes.status();
      if (remote) return SubmitEstimate(flags.server, *header, *bytes, flags.timeout_s);
      return EstimateInProcess(*header, *bytes, flags.profile_csv);
    }();
    if (reply.ok()) {
      if (flags.json) {
        google::protobuf::util::JsonPrintOptions options;
        options.always_print_primitive_fields = true;
        std::string json;
        (void)google::protobuf::util::MessageToJsonString(*reply, &json, options);
        std::cout << json << "\n";
      }
      row.reply = *reply;
    } else {
      if (first_error.ok()) first_error = reply.status();
      std::cerr << "weavefit: " << image << ": "
                << absl::StatusCodeToString(reply.status().code()) << ": "
                << reply.status().message() << "\n";
      if (flags.json) std::cout << ErrorToJson(reply.status()) << "\n";
      row.error = absl::StrCat(absl::StatusCodeToString(reply.status().code()), ": ",
                               reply.status().message());
    }
    if (auto sidecar = ReadSidecar(image)) {
      row.truth_spacing_deg = StructNumber(*sidecar, "truth", "peakSpacingDeg");
    }
    rows.push_back(std::move(row));
  }
  if (!flags.json) std::cout << FormatTable(rows);
  return first_error.ok() ? 0 : static_cast<int>(first_error.code());
}

void AddEstimateFlags(CLI::App* app, EstimateFlags* flags, bool remote) {
  app->add_option("images", flags->images, "photographs (PNG, TIFF, JPEG, EXR)")
      ->required();
  app->add_option("--phase-angle", flags->phase_angle_deg,
                  "signed phase angle, deg, in (-180, 180); positive = light on "
                  "the image's right (default: the sidecar's acquisition.phaseAngleDeg)");
  app->add_option("--diameter-mm", flags->diameter_mm, "cylinder diameter, mm")
      ->capture_default_str();
  app->add_option("--distance-mm", flags->distance_mm,
                  "camera distance from the axis, mm; 0 = orthographic")
      ->capture_default_str();
  app->add_flag("--linear", flags->linear, "pixels are already linear (no sRGB decoding)");
  app->add_option("--saturation-level", flags->saturation_level,
                  "saturation level in file units; 0 = the format's maximum")
      ->capture_default_str();
  app->add_option("--mode", flags->mode, "fast, balanced or accurate")
      ->check(CLI::IsMember({"fast", "balanced", "accurate"}))->capture_default_str();
  app->add_flag("--json", flags->json,
                "print protobuf's JSON mapping of each reply, one per line");
  if (!remote) {
    app->add_option("--profile-csv", flags->profile_csv,
                    "write the azimuthal profile (azimuth_deg,mean,stderr,count) of the last image");
  }
  if (remote) {
    app->add_option("--server", flags->server, "weavefitd address host:port")
        ->capture_default_str();
    app->add_option("--timeout-s", flags->timeout_s, "deadline per image, s")
        ->capture_default_str()->check(CLI::PositiveNumber);
  }
}

struct RenderFlags {
  RenderScene scene;
  std::string model = "sinusoid";
  std::string out;
  std::string format;
};

int RunRender(RenderFlags& flags) {
  if (flags.model == "smooth") {
    flags.scene.model = ProfileModel::kSmooth;
  } else if (flags.model == "sawtooth") {
    flags.scene.model = ProfileModel::kSawtooth;
  } else {
    flags.scene.model = ProfileModel::kSinusoid;
  }
  std::string format = flags.format;
  if (format.empty()) {
    const std::size_t dot = flags.out.find_last_of('.');
    format = dot == std::string::npos ? "png" : flags.out.substr(dot + 1);
  }
  absl::StatusOr<EncodeFormat> encode_format = ParseEncodeFormat(format);
  absl::StatusOr<Rendered> rendered = encode_format.ok()
      ? RenderPhotograph(flags.scene) : absl::StatusOr<Rendered>(encode_format.status());
  absl::StatusOr<std::string> bytes = rendered.ok()
      ? EncodeImage(rendered->image, *encode_format)
      : absl::StatusOr<std::string>(rendered.status());
  absl::Status status = bytes.status();
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
  return 0;
}

void AddRenderFlags(CLI::App* app, RenderFlags* f) {
  RenderScene& s = f->scene;
  app->add_option("--out", f->out, "output image; its extension picks the format")->required();
  app->add_option("--format", f->format, "png (16-bit), png8 (sRGB), tiff, exr, jpeg");
  app->add_option("--model", f->model, "thread profile")
      ->check(CLI::IsMember({"smooth", "sinusoid", "sawtooth"}))->capture_default_str();
  app->add_option("--width", s.width_px, "image width, px")->capture_default_str();
  app->add_option("--height", s.height_px, "image height, px")->capture_default_str();
  app->add_option("--wavelength-mm", s.wavelength_mm, "thread undulation period λ, mm")->capture_default_str();
  app->add_option("--amplitude-mm", s.amplitude_mm, "undulation amplitude h0, mm")->capture_default_str();
  app->add_option("--diameter-mm", s.diameter_mm, "cylinder diameter, mm")->capture_default_str();
  app->add_option("--distance-mm", s.camera_distance_mm, "camera distance from the axis, mm; 0 = orthographic")->capture_default_str();
  app->add_option("--phase-angle", s.phase_angle_deg, "signed phase angle, deg")->capture_default_str();
  app->add_option("--center-x", s.center_x_px, "axis column at the middle row, px; <0 = image centre")->capture_default_str();
  app->add_option("--radius-px", s.radius_px, "cylinder limb half-width, px; <0 = 40% of the width")->capture_default_str();
  app->add_option("--tilt-deg", s.axis_angle_deg, "axis tilt, deg; >0 = top toward the right")->capture_default_str();
  app->add_option("--top-row", s.top_row_px, "first row of the cylinder; <0 = beyond the frame")->capture_default_str();
  app->add_option("--bottom-row", s.bottom_row_px, "last row of the cylinder; <0 = beyond the frame")->capture_default_str();
  app->add_option("--source-blur-deg", s.source_blur_deg, "angular sigma of the light source, deg")->capture_default_str();
  app->add_option("--exposure", s.exposure, "E0, full-scale units")->capture_default_str();
  app->add_option("--scatter", s.scatter, "grazing scatter level of the axial threads")->capture_default_str();
  app->add_option("--diffuse", s.diffuse, "Lambertian level")->capture_default_str();
  app->add_option("--ambient", s.ambient, "uniform level of the cylinder body")->capture_default_str();
  app->add_option("--background", s.background, "level outside the cylinder")->capture_default_str();
  app->add_option("--gap-fraction", s.gap_fraction, "share of each thread pitch showing axial threads")->capture_default_str();
  app->add_flag("--regular-weave", s.regular_weave, "no drift or jitter of the weave phase");
  app->add_option("--phase-jitter", s.phase_jitter, "per-thread phase jitter, periods")->capture_default_str();
  app->add_option("--phase-drift", s.phase_drift, "random-walk step of the weave phase, periods")->capture_default_str();
  app->add_option("--photons", s.photons_full_scale, "photons at full scale (shot noise); 0 = none")->capture_default_str();
  app->add_option("--read-noise", s.read_noise, "Gaussian read noise, full-scale units")->capture_default_str();
  app->add_option("--bits", s.quantisation_bits, "ADC bits; 0 = no quantisation")->capture_default_str();
  app->add_option("--samples", s.samples_per_pixel, "samples per pixel per axis (4x along the arc)")->capture_default_str();
  app->add_option("--seed", s.seed, "random seed")->capture_default_str();
}

}  // namespace
}  // namespace weavefit

int main(int argc, char** argv) {
  CLI::App app{"weavefit: thread geometry of glossy woven materials from one photograph"};
  app.require_subcommand(1);
  weavefit::EstimateFlags estimate_flags;
  weavefit::EstimateFlags submit_flags;
  weavefit::RenderFlags render_flags;
  CLI::App* estimate = app.add_subcommand("estimate", "estimate in-process");
  weavefit::AddEstimateFlags(estimate, &estimate_flags, false);
  CLI::App* submit = app.add_subcommand("submit", "estimate through a weavefitd daemon");
  weavefit::AddEstimateFlags(submit, &submit_flags, true);
  CLI::App* render = app.add_subcommand("render", "render a cylinder photograph with a truth sidecar");
  weavefit::AddRenderFlags(render, &render_flags);
  CLI11_PARSE(app, argc, argv);
  if (*estimate) return weavefit::RunEstimates(estimate_flags, false);
  if (*submit) return weavefit::RunEstimates(submit_flags, true);
  if (*render) return weavefit::RunRender(render_flags);
  return 0;
}
