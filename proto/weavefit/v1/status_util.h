// absl::Status ↔ grpc::Status: the codes map one to one.
#ifndef WEAVEFIT_PROTO_WEAVEFIT_V1_STATUS_UTIL_H_
#define WEAVEFIT_PROTO_WEAVEFIT_V1_STATUS_UTIL_H_

#include <grpcpp/support/status.h>

#include <string>

#include "absl/status/status.h"

namespace weavefit {

inline grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()),
                      std::string(status.message()));
}

inline absl::Status FromGrpcStatus(const grpc::Status& status) {
  if (status.ok()) return absl::OkStatus();
  return absl::Status(static_cast<absl::StatusCode>(status.error_code()),
                      status.error_message());
}

}  // namespace weavefit

#endif  // WEAVEFIT_PROTO_WEAVEFIT_V1_STATUS_UTIL_H_
