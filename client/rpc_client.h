// The typed wrapper around the WeaveFit stub: one call, one StatusOr.
#ifndef WEAVEFIT_CLIENT_RPC_CLIENT_H_
#define WEAVEFIT_CLIENT_RPC_CLIENT_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "weavefit/v1/weavefit.pb.h"

namespace weavefit {

constexpr std::size_t kChunkBytes = 1 << 20;  // the contract's chunk limit

// Streams `header` then `bytes` in chunks to the daemon at `server`
// (host:port) and returns its reply; the gRPC status is carried over as an
// absl::Status with the same code.
absl::StatusOr<v1::EstimateReply> SubmitEstimate(const std::string& server,
                                                 v1::RequestHeader header,
                                                 const std::string& bytes,
                                                 double timeout_s);

// Streams several photographs of one sample (each header then its bytes) to
// the daemon's EstimateJoint and returns each photograph's estimate and the
// joint one.
absl::StatusOr<v1::JointEstimateReply> SubmitJoint(const std::string& server,
                                                   std::vector<v1::RequestHeader> headers,
                                                   const std::vector<std::string>& bytes,
                                                   double timeout_s);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_RPC_CLIENT_H_
