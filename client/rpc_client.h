// The typed wrapper around the WeaveFit stub: one call, one StatusOr.
#ifndef WEAVEFIT_CLIENT_RPC_CLIENT_H_
#define WEAVEFIT_CLIENT_RPC_CLIENT_H_

#include <functional>
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
  // host:port; or several, host1:port,host2:port; or any gRPC target such
  // as dns:///name:port (every address the name resolves to is used).
  std::string server = "127.0.0.1:50051";
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

// What gRPC is given for a --server value.
struct ChannelTarget {
  std::string target;     // for grpc::CreateCustomChannel
  std::string authority;  // the :authority and TLS name; empty = gRPC's own
};

// The numeric addresses (IPv4 dotted, IPv6 without brackets) of a host name.
using HostResolver =
    std::function<absl::StatusOr<std::vector<std::string>>(const std::string& host)>;

// getaddrinfo(3): every TCP address of `host`; UNAVAILABLE when it has none.
absl::StatusOr<std::vector<std::string>> ResolveHost(const std::string& host);

// The gRPC target for `server`:
// - one address, or a target with a scheme (dns:///name:port, ipv4:...,
//   unix:...), is passed on as it is; gRPC resolves it, and round_robin uses
//   every address a name resolves to;
// - a comma-separated list host1:port,host2:port ([v6]:port for IPv6
//   literals) is resolved here, names through `resolve`, into one ipv4: or
//   ipv6: target (gRPC's schemes that take several addresses; one family per
//   target, so IPv4 when every entry has an IPv4 address, else IPv6 when
//   every entry has one). Its authority, the name TLS checks, is the first
//   entry's host:port: under TLS every daemon's certificate must carry that
//   name (or use one DNS name for all of them).
// INVALID_ARGUMENT for an entry without a port or a bare IPv6 address;
// UNAVAILABLE when a name does not resolve; what `resolve` returns otherwise.
absl::StatusOr<ChannelTarget> ChannelTargetFor(const std::string& server,
                                               const HostResolver& resolve = ResolveHost);

// gRPC's service config for the channel: round_robin over every address of
// the target (a dead backend drops out of the rotation until it reconnects).
extern const char kRoundRobinServiceConfig[];

// A channel with the credentials and keepalive settings the daemon expects,
// spread over every address of the target with round_robin, which tries to
// reconnect to a lost daemon every 0.25 s at first and every 1 s at most.
absl::StatusOr<std::shared_ptr<grpc::Channel>> MakeChannel(const Connection& connection);

// One channel for many calls: a batch sets its connections up once and
// round_robin spreads the calls over every daemon. Thread-safe: calls may
// run concurrently.
class Client {
 public:
  static absl::StatusOr<Client> Connect(const Connection& connection);

  // Streams `header` then `bytes` in chunks to a daemon and returns its
  // reply; the gRPC status is carried over as an absl::Status with the same
  // code. The deadline is the connection's timeout_s.
  absl::StatusOr<v1::EstimateReply> Estimate(v1::RequestHeader header,
                                             const std::string& bytes) const;

  // Streams several photographs of one sample (each header then its bytes)
  // to EstimateJoint and returns each photograph's estimate and the joint
  // one. The deadline is the connection's timeout_s per photograph.
  absl::StatusOr<v1::JointEstimateReply> EstimateJoint(std::vector<v1::RequestHeader> headers,
                                                       const std::vector<std::string>& bytes) const;

  // True when the channel has a connection ready for calls (to any daemon
  // of the target); asks it to connect when it is idle.
  bool Connected() const;

  // Blocks until the channel is connected or `timeout_s` has passed (0 =
  // one look); true when connected. Asks it to connect, and it retries
  // every second at most (MakeChannel), so a daemon that comes back is
  // found within about a second. Many threads may wait at once.
  bool WaitForConnected(double timeout_s) const;

 private:
  Client(Connection connection, std::shared_ptr<grpc::Channel> channel)
      : connection_(std::move(connection)), channel_(std::move(channel)) {}

  Connection connection_;
  std::shared_ptr<grpc::Channel> channel_;
};

// One call on a channel of its own (Client::Connect, then Estimate).
absl::StatusOr<v1::EstimateReply> SubmitEstimate(const Connection& connection,
                                                 v1::RequestHeader header,
                                                 const std::string& bytes);

// One EstimateJoint call on a channel of its own.
absl::StatusOr<v1::JointEstimateReply> SubmitJoint(const Connection& connection,
                                                   std::vector<v1::RequestHeader> headers,
                                                   const std::vector<std::string>& bytes);

}  // namespace weavefit

#endif  // WEAVEFIT_CLIENT_RPC_CLIENT_H_
