// Conversions between the wire contract (weavefit.v1) and the library's
// plain structs. Pure functions: the daemon and the in-process client use
// the same ones, so their replies are identical.
#ifndef WEAVEFIT_PROTO_WEAVEFIT_V1_CONVERT_H_
#define WEAVEFIT_PROTO_WEAVEFIT_V1_CONVERT_H_

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "estimator/pipeline/estimate.h"
#include "estimator/pipeline/joint.h"
#include "weavefit/v1/weavefit.pb.h"

namespace weavefit {

// Degrees → radians (a 0 diameter stays 0: not given), and validation of
// the result.
// INVALID_ARGUMENT naming the wire field that is wrong.
absl::StatusOr<Acquisition> AcquisitionFromProto(const v1::Acquisition& proto);
// The acquisition as the wire carries it (AcquisitionFromProto's inverse).
v1::Acquisition AcquisitionToProto(const Acquisition& acquisition);
// A given cylinder on the wire and in the library (degrees ↔ radians; a 0
// error is the default, 0.5 px; CYLINDER_SOURCE_UNSPECIFIED is GIVEN). The
// fields are checked by Acquisition::Validate (GivenCylinder::Validate),
// against the image by the pipeline. DETECTED, or a source the enum does
// not know, is INVALID_ARGUMENT naming given_cylinder.source.
absl::StatusOr<GivenCylinder> GivenCylinderFromProto(const v1::GivenCylinder& proto);
v1::GivenCylinder GivenCylinderToProto(const GivenCylinder& given);
// The library's options for a request (mode), on top of `base`.
// MODE_UNSPECIFIED is BALANCED; a value the enum does not know (a newer
// client's, or a corrupt one) is INVALID_ARGUMENT naming options.mode.
absl::StatusOr<EstimateOptions> OptionsFromProto(const v1::EstimateOptions& proto,
                                                 const EstimateOptions& base);

// The reply for an estimate (radians → degrees). A quantity that is resolved
// but not finite is sent unresolved with a warning (also in JointToProto).
v1::EstimateReply ReplyFromEstimate(const Estimate& estimate,
                                    const std::string& sample_name);

// Protobuf's JSON mapping with every field printed, including defaults.
std::string ReplyToJson(const v1::EstimateReply& reply);
absl::StatusOr<v1::EstimateReply> ReplyFromJson(const std::string& json);

// weavefit's version (the project's, from CMake), as every binary's
// --version and every reply's `version` give it.
const char* WeavefitVersion();

// {"error": {"code": "INVALID_ARGUMENT", "message": "..."}} for a status.
std::string ErrorToJson(const absl::Status& status);

// A reply's thread quantities for the joint estimate, and the joint estimate
// on the wire.
PhotographEstimate PhotographFromReply(const v1::EstimateReply& reply);
v1::JointEstimate JointToProto(const JointEstimate& joint,
                               const std::vector<std::string>& photographs);

}  // namespace weavefit

#endif  // WEAVEFIT_PROTO_WEAVEFIT_V1_CONVERT_H_
