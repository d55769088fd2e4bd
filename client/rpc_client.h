// The typed wrapper around the WeaveFit stub: one call, one StatusOr.
#ifndef WEAVEFIT_CLIENT_RPC_CLIENT_H_
#define WEAVEFIT_CLIENT_RPC_CLIENT_H_

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "weavefit/v1/weavefit.pb.h"

namespace grpc {
class Channel;
}  // namespace grpc

namespace weavefit {

constexpr std::size_t kChunkBytes = 1 << 20;  // the contract's chunk limit

// Where and how to reach a daemon.
struct Connection {
  std::string server = "127.0.0.1:50051";  // host:port
  // TLS: the CA (PEM file) that signed the daemon's certificate; empty =
  // plaintext. A client certificate and key (PEM files) for mutual TLS.
  std::string tls_ca;
  std::string tls_cert;
  std::string tls_key;
  // The bearer token sent as "authorization: Bearer <token>"; empty = none.
  std::string token;
  double timeout_s = 120.0;  // deadline per call, s

  // The token from `token_file`, or else from the environment variable
  // WEAVEFIT_TOKEN; the first line, trimmed. INVALID_ARGUMENT when the file
  // cannot be read or holds no token.
  absl::Status LoadToken(const std::string& token_file);
};

// A channel with the credentials and keepalive settings the daemon expects.
absl::StatusOr<std::shared_ptr<grpc::Channel>> MakeChannel(const Connection& connection);

// Streams `header` then `bytes` in chunks to the daemon and returns its
// reply; the gRPC status is carried over as an absl::Status with the same code.
absl::StatusOr<v1::EstimateReply> SubmitEstimate(const Connection& connection,
                                                 v1::RequestHeader header,
                                                 const std::string& bytes);

// Streams several photographs of one sample (each header then its bytes) to
// the daemon's EstimateJoint and returns each photograph's estimate and the
// joint one. The deadline is the connection's per photograph.
absl::StatusOr<v1::JointEstimateReply> SubmitJoint(const Connection& connection,
                                                   std::vector<v1::RequestHeader> headers,
                                                   const std::vector<std::string>& bytes);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_RPC_CLIENT_H_
