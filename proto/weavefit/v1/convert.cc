#include "proto/weavefit/v1/convert.h"

#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"

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

void SetMeasurement(const Quantity& q, double scale, v1::Measurement* out) {
  if (!q.resolved) {
    out->Clear();
    out->set_upper_bound(q.upper_bound * scale);
    return;
  }
  out->set_value(q.value * scale);
  out->set_stderr(q.stderr_value * scale);
  out->set_resolved(true);
  out->set_statistical(q.Statistical() * scale);
  out->set_systematic(std::min(q.systematic, q.stderr_value) * scale);
  out->set_systematic_common(std::min({q.common, q.systematic, q.stderr_value}) * scale);
}

}  // namespace

absl::StatusOr<Acquisition> AcquisitionFromProto(const v1::Acquisition& proto) {
  Acquisition acq;
  if (!std::isfinite(proto.phase_angle_deg())) {
    return absl::InvalidArgumentError("phase_angle_deg must be a finite number");
  }
  acq.phase_angle_rad = proto.phase_angle_deg() * kDeg;
  acq.cylinder_diameter_mm =
      proto.cylinder_diameter_mm() == 0.0 ? 46.0 : proto.cylinder_diameter_mm();
  acq.camera_distance_mm = proto.camera_distance_mm();
  acq.region = {proto.roi().x_px(), proto.roi().y_px(), proto.roi().width_px(),
                proto.roi().height_px()};
  acq.pixels_linear = proto.pixels_linear();
  acq.saturation_level = proto.saturation_level();
  if (absl::Status s = acq.Validate(); !s.ok()) return s;
  return acq;
}

EstimateOptions OptionsFromProto(const v1::EstimateOptions& proto,
                                 const EstimateOptions& base) {
  EstimateOptions options = base;
  switch (proto.mode()) {
    case v1::FAST:
      options.mode = Mode::kFast;
      break;
    case v1::ACCURATE:
      options.mode = Mode::kAccurate;
      break;
    default:
      options.mode = Mode::kBalanced;
      break;
  }
  options.include_curves = proto.include_curves();
  return options;
}

v1::EstimateReply ReplyFromEstimate(const Estimate& e,
                                    const std::string& sample_name) {
  v1::EstimateReply reply;
  reply.set_model(ModelToProto(e.model));
  SetMeasurement(e.peak_spacing_rad, 1.0 / kDeg, reply.mutable_peak_spacing_deg());
  SetMeasurement(e.max_slope, 1.0, reply.mutable_max_slope());
  SetMeasurement(e.max_inclination_rad, 1.0 / kDeg, reply.mutable_max_inclination_deg());
  SetMeasurement(e.wavelength_mm, 1.0, reply.mutable_wavelength_mm());
  SetMeasurement(e.amplitude_mm, 1.0, reply.mutable_amplitude_mm());
  SetMeasurement(e.specular_azimuth_rad, 1.0 / kDeg,
                 reply.mutable_specular_azimuth_deg());
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
  for (const CandidateScore& candidate : e.candidates) {
    v1::Candidate* out = reply.add_candidates();
    out->set_model(ModelToProto(candidate.model));
    out->set_method(candidate.method);
    out->set_score(candidate.score);
    out->set_selected(candidate.selected);
  }
  for (const std::string& w : e.warnings) reply.add_warnings(w);
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
    SetMeasurement(c.peak_spacing_rad, 1.0 / kDeg, out->mutable_peak_spacing_deg());
    SetMeasurement(c.specular_azimuth_rad, 1.0 / kDeg, out->mutable_specular_azimuth_deg());
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
  reply.set_version(WEAVEFIT_VERSION);
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
  SetMeasurement(joint.peak_spacing_rad, 1.0 / kDeg, out.mutable_peak_spacing_deg());
  SetMeasurement(joint.max_slope, 1.0, out.mutable_max_slope());
  SetMeasurement(joint.max_inclination_rad, 1.0 / kDeg, out.mutable_max_inclination_deg());
  SetMeasurement(joint.wavelength_mm, 1.0, out.mutable_wavelength_mm());
  SetMeasurement(joint.amplitude_mm, 1.0, out.mutable_amplitude_mm());
  for (const std::string& p : photographs) out.add_photographs(p);
  out.set_slope_photographs(joint.slope_photographs);
  out.set_wavelength_photographs(joint.wavelength_photographs);
  out.set_slope_chi2(joint.slope_chi2);
  out.set_wavelength_chi2(joint.wavelength_chi2);
  for (const std::string& w : joint.warnings) out.add_warnings(w);
  return out;
}

}  // namespace weavefit
