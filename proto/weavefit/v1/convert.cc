#include "proto/weavefit/v1/convert.h"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"

#ifndef WEAVEFIT_VERSION
#define WEAVEFIT_VERSION "unknown"
#endif

namespace weavefit {
namespace {

constexpr double kDeg = M_PI / 180.0;

v1::ProfileModel ModelToProto(ProfileModel model) {
  switch (model) {
    case ProfileModel::kSmooth:
      return v1::SMOOTH;
    case ProfileModel::kSinusoid:
      return v1::SINUSOID;
    case ProfileModel::kSawtooth:
      return v1::SAWTOOTH;
  }
  return v1::PROFILE_MODEL_UNSPECIFIED;
}

ProfileModel ModelFromProto(v1::ProfileModel model) {
  switch (model) {
    case v1::SINUSOID:
      return ProfileModel::kSinusoid;
    case v1::SAWTOOTH:
      return ProfileModel::kSawtooth;
    default:
      return ProfileModel::kSmooth;
  }
}

Quantity QuantityFromProto(const v1::Measurement& m) {
  return m.resolved() ? Quantity{m.value(), m.stderr(), true, 0.0, m.systematic(),
                                 m.systematic_common()}
                      : Quantity{0.0, 0.0, false, m.upper_bound()};
}

using Warnings = google::protobuf::RepeatedPtrField<std::string>;

// Sets `out` to `q` times `scale`. A resolved quantity whose value or errors
// are not finite (NaN or infinity: a stage broke down without saying so) is
// sent unresolved, with a warning naming `field`, never as a measurement:
// a client must be able to trust every number marked resolved.
void SetMeasurement(const Quantity& q, double scale, const std::string& field,
                    v1::Measurement* out, Warnings* warnings) {
  out->Clear();
  const double value = q.value * scale;
  const double stderr_value = q.stderr_value * scale;
  const double systematic = std::min(q.systematic, q.stderr_value) * scale;
  const double common = std::min({q.common, q.systematic, q.stderr_value}) * scale;
  const double statistical = q.Statistical() * scale;
  if (!q.resolved) {
    const double bound = q.upper_bound * scale;
    out->set_upper_bound(std::isfinite(bound) ? bound : 0.0);  // 0 = none
    return;
  }
  if (!std::isfinite(value) || !std::isfinite(stderr_value) || !std::isfinite(systematic) ||
      !std::isfinite(common) || !std::isfinite(statistical)) {
    *warnings->Add() = absl::StrFormat(
        "%s came out as %g +- %g, not a finite number: left unresolved. Check the acquisition "
        "metadata (phase angle, cylinder diameter, camera distance) against the photograph, "
        "and report the photograph if it is right",
        field, value, stderr_value);
    return;
  }
  out->set_value(value);
  out->set_stderr(stderr_value);
  out->set_resolved(true);
  out->set_statistical(statistical);
  out->set_systematic(systematic);
  out->set_systematic_common(common);
}

// The wire's mode: MODE_UNSPECIFIED is the server's default, BALANCED.
absl::StatusOr<Mode> ModeFromProto(int mode) {
  switch (mode) {
    case v1::MODE_UNSPECIFIED:
    case v1::BALANCED:
      return Mode::kBalanced;
    case v1::FAST:
      return Mode::kFast;
    case v1::ACCURATE:
      return Mode::kAccurate;
    default:
      return absl::InvalidArgumentError(absl::StrFormat(
          "options.mode %d is not a known mode (FAST, BALANCED, ACCURATE)", mode));
  }
}

v1::CylinderSource SourceToProto(CylinderSource source) {
  switch (source) {
    case CylinderSource::kDetected:
      return v1::DETECTED;
    case CylinderSource::kGiven:
      return v1::GIVEN;
    case CylinderSource::kShared:
      return v1::SHARED;
  }
  return v1::CYLINDER_SOURCE_UNSPECIFIED;
}

}  // namespace

absl::StatusOr<GivenCylinder> GivenCylinderFromProto(const v1::GivenCylinder& proto) {
  GivenCylinder given;
  given.center_x_px = proto.center_x_px();
  given.radius_px = proto.radius_px();
  given.axis_angle_rad = proto.axis_angle_deg() * kDeg;
  if (proto.radius_stderr_px() != 0.0) given.radius_stderr_px = proto.radius_stderr_px();
  if (proto.center_stderr_px() != 0.0) given.center_stderr_px = proto.center_stderr_px();
  given.lens_blur_px = proto.lens_blur_px();
  switch (proto.source()) {
    case v1::CYLINDER_SOURCE_UNSPECIFIED:
    case v1::GIVEN:
      given.source = CylinderSource::kGiven;
      break;
    case v1::SHARED:
      given.source = CylinderSource::kShared;
      break;
    default:
      return absl::InvalidArgumentError(absl::StrFormat(
          "given_cylinder.source %d must be GIVEN or SHARED (a given cylinder is not detected)",
          static_cast<int>(proto.source())));
  }
  return given;
}

v1::GivenCylinder GivenCylinderToProto(const GivenCylinder& given) {
  v1::GivenCylinder proto;
  proto.set_center_x_px(given.center_x_px);
  proto.set_radius_px(given.radius_px);
  proto.set_axis_angle_deg(given.axis_angle_rad / kDeg);
  proto.set_radius_stderr_px(given.radius_stderr_px);
  proto.set_center_stderr_px(given.center_stderr_px);
  proto.set_lens_blur_px(given.lens_blur_px);
  proto.set_source(SourceToProto(given.source));
  return proto;
}

v1::Acquisition AcquisitionToProto(const Acquisition& acq) {
  v1::Acquisition proto;
  proto.set_phase_angle_deg(acq.phase_angle_rad / kDeg);
  proto.set_cylinder_diameter_mm(acq.cylinder_diameter_mm);
  proto.set_camera_distance_mm(acq.camera_distance_mm);
  v1::RegionOfInterest* roi = proto.mutable_roi();
  roi->set_x_px(acq.region.x);
  roi->set_y_px(acq.region.y);
  roi->set_width_px(acq.region.width);
  roi->set_height_px(acq.region.height);
  proto.set_pixels_linear(acq.pixels_linear);
  proto.set_saturation_level(acq.saturation_level);
  if (acq.given_cylinder) *proto.mutable_given_cylinder() = GivenCylinderToProto(*acq.given_cylinder);
  return proto;
}

const char* WeavefitVersion() { return WEAVEFIT_VERSION; }

absl::StatusOr<Acquisition> AcquisitionFromProto(const v1::Acquisition& proto) {
  Acquisition acq;
  acq.phase_angle_rad = proto.phase_angle_deg() * kDeg;
  acq.cylinder_diameter_mm = proto.cylinder_diameter_mm();  // 0 = not given
  acq.camera_distance_mm = proto.camera_distance_mm();
  acq.region = {proto.roi().x_px(), proto.roi().y_px(), proto.roi().width_px(),
                proto.roi().height_px()};
  acq.pixels_linear = proto.pixels_linear();
  acq.saturation_level = proto.saturation_level();
  if (proto.has_given_cylinder()) {
    absl::StatusOr<GivenCylinder> given = GivenCylinderFromProto(proto.given_cylinder());
    if (!given.ok()) return given.status();
    acq.given_cylinder = *given;
  }
  // Every range is checked in Acquisition::Validate alone (NaN and infinite
  // phase angles included), so the daemon and the in-process client agree.
  if (absl::Status s = acq.Validate(); !s.ok()) return s;
  return acq;
}

absl::StatusOr<EstimateOptions> OptionsFromProto(const v1::EstimateOptions& proto,
                                                 const EstimateOptions& base) {
  absl::StatusOr<Mode> mode = ModeFromProto(proto.mode());
  if (!mode.ok()) return mode.status();
  EstimateOptions options = base;
  options.mode = *mode;
  options.include_curves = proto.include_curves();
  return options;
}

v1::EstimateReply ReplyFromEstimate(const Estimate& e,
                                    const std::string& sample_name) {
  v1::EstimateReply reply;
  reply.set_model(ModelToProto(e.model));
  for (const std::string& w : e.warnings) reply.add_warnings(w);
  Warnings* warnings = reply.mutable_warnings();
  SetMeasurement(e.peak_spacing_rad, 1.0 / kDeg, "peak_spacing_deg",
                 reply.mutable_peak_spacing_deg(), warnings);
  SetMeasurement(e.max_slope, 1.0, "max_slope", reply.mutable_max_slope(), warnings);
  SetMeasurement(e.max_inclination_rad, 1.0 / kDeg, "max_inclination_deg",
                 reply.mutable_max_inclination_deg(), warnings);
  SetMeasurement(e.wavelength_mm, 1.0, "wavelength_mm", reply.mutable_wavelength_mm(), warnings);
  SetMeasurement(e.amplitude_mm, 1.0, "amplitude_mm", reply.mutable_amplitude_mm(), warnings);
  SetMeasurement(e.specular_azimuth_rad, 1.0 / kDeg, "specular_azimuth_deg",
                 reply.mutable_specular_azimuth_deg(), warnings);
  v1::Cylinder* c = reply.mutable_cylinder();
  c->set_center_x_px(e.cylinder.center_x_px);
  c->set_radius_px(e.cylinder.radius_px);
  c->set_axis_angle_deg(e.cylinder.axis_angle_rad / kDeg);
  c->set_top_row_px(e.cylinder.top_row);
  c->set_bottom_row_px(e.cylinder.bottom_row);
  c->set_left_limb_observed(e.cylinder.left_observed);
  c->set_right_limb_observed(e.cylinder.right_observed);
  c->set_radius_stderr_px(e.cylinder.radius_stderr_px);
  c->set_radius_systematic_px(e.cylinder.radius_systematic_px);
  c->set_source(SourceToProto(e.cylinder_source));
  for (const CandidateScore& candidate : e.candidates) {
    v1::Candidate* out = reply.add_candidates();
    out->set_model(ModelToProto(candidate.model));
    out->set_method(candidate.method);
    out->set_score(candidate.score);
    out->set_selected(candidate.selected);
  }
  for (const StageTime& t : e.timings) {
    v1::StageTiming* out = reply.add_timings();
    out->set_stage(t.stage);
    out->set_milliseconds(t.milliseconds);
  }
  v1::ImageInfo* image = reply.mutable_image();
  image->set_width_px(e.image.width);
  image->set_height_px(e.image.height);
  image->set_channels(e.image.channels);
  image->set_format(e.image.format);
  image->set_bit_depth(e.image.bit_depth);
  image->set_saturated_pixels(e.image.saturated_pixels);
  for (const ChannelSummary& c : e.channels) {
    v1::ChannelSummary* out = reply.add_channels();
    out->set_channel(c.channel);
    out->set_model(ModelToProto(c.model));
    const std::string channel = absl::StrCat("channels[", c.channel, "].");
    SetMeasurement(c.peak_spacing_rad, 1.0 / kDeg, channel + "peak_spacing_deg",
                   out->mutable_peak_spacing_deg(), warnings);
    SetMeasurement(c.specular_azimuth_rad, 1.0 / kDeg, channel + "specular_azimuth_deg",
                   out->mutable_specular_azimuth_deg(), warnings);
    out->set_lobe_level(c.lobe_level);
    out->set_grazing_level(c.grazing_level);
  }
  if (!e.curves.empty()) {
    v1::Curve* measured = reply.add_curves();
    measured->set_label("measured profile");
    measured->set_model(ModelToProto(e.model));
    for (int i = 0; i < e.profile.NumBins(); ++i) {
      if (e.profile.count[i] <= 0) continue;  // no unmasked sample in the bin
      measured->add_azimuth_deg(e.profile.azimuth_rad[i] / kDeg);
      measured->add_value(e.profile.mean[i]);
      measured->add_stderr(e.profile.stderr_mean[i]);
    }
    for (const ModelCurve& c : e.curves) {
      v1::Curve* out = reply.add_curves();
      out->set_label(c.label);
      out->set_model(ModelToProto(c.model));
      out->set_selected(c.selected);
      for (std::size_t i = 0; i < c.azimuth_rad.size(); ++i) {
        out->add_azimuth_deg(c.azimuth_rad[i] / kDeg);
        out->add_value(c.value[i]);
      }
    }
  }
  reply.set_sample_name(sample_name);
  reply.set_method(e.method);
  reply.set_version(WeavefitVersion());
  *reply.mutable_acquisition() = AcquisitionToProto(e.acquisition);
  reply.set_mode(static_cast<v1::Mode>(static_cast<int>(e.mode)));
  return reply;
}

std::string ReplyToJson(const v1::EstimateReply& reply) {
  google::protobuf::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  options.add_whitespace = true;
  std::string json;
  // Cannot fail for a well-formed generated message.
  (void)google::protobuf::util::MessageToJsonString(reply, &json, options);
  return json;
}

absl::StatusOr<v1::EstimateReply> ReplyFromJson(const std::string& json) {
  v1::EstimateReply reply;
  const auto status = google::protobuf::util::JsonStringToMessage(json, &reply);
  if (!status.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("not an EstimateReply in JSON: ", status.ToString()));
  }
  return reply;
}

std::string ErrorToJson(const absl::Status& status) {
  google::protobuf::Struct root;
  google::protobuf::Struct* error =
      (*root.mutable_fields())["error"].mutable_struct_value();
  (*error->mutable_fields())["code"].set_string_value(
      absl::StatusCodeToString(status.code()));
  (*error->mutable_fields())["message"].set_string_value(
      std::string(status.message()));
  std::string json;
  (void)google::protobuf::util::MessageToJsonString(root, &json);
  return json;
}

PhotographEstimate PhotographFromReply(const v1::EstimateReply& reply) {
  return {reply.sample_name(), ModelFromProto(reply.model()), QuantityFromProto(reply.max_slope()),
          QuantityFromProto(reply.wavelength_mm())};
}

v1::JointEstimate JointToProto(const JointEstimate& joint,
                               const std::vector<std::string>& photographs) {
  v1::JointEstimate out;
  out.set_model(ModelToProto(joint.model));
  for (const std::string& w : joint.warnings) out.add_warnings(w);
  Warnings* warnings = out.mutable_warnings();
  SetMeasurement(joint.peak_spacing_rad, 1.0 / kDeg, "peak_spacing_deg",
                 out.mutable_peak_spacing_deg(), warnings);
  SetMeasurement(joint.max_slope, 1.0, "max_slope", out.mutable_max_slope(), warnings);
  SetMeasurement(joint.max_inclination_rad, 1.0 / kDeg, "max_inclination_deg",
                 out.mutable_max_inclination_deg(), warnings);
  SetMeasurement(joint.wavelength_mm, 1.0, "wavelength_mm", out.mutable_wavelength_mm(),
                 warnings);
  SetMeasurement(joint.amplitude_mm, 1.0, "amplitude_mm", out.mutable_amplitude_mm(), warnings);
  for (const std::string& p : photographs) out.add_photographs(p);
  out.set_slope_photographs(joint.slope_photographs);
  out.set_wavelength_photographs(joint.wavelength_photographs);
  out.set_slope_chi2(joint.slope_chi2);
  out.set_wavelength_chi2(joint.wavelength_chi2);
  return out;
}

}  // namespace weavefit
