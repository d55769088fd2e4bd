// Starting and stopping weavefitd's gRPC server: transport security, access
// control, health (liveness and readiness), reflection and metrics.
#ifndef WEAVEFIT_SERVER_SERVER_H_
#define WEAVEFIT_SERVER_SERVER_H_

#include <mutex>
#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include "absl/status/statusor.h"
#include "server/auth.h"
#include "server/metrics.h"
#include "server/service.h"

namespace grpc {
class CallbackGenericService;
class Server;
}  // namespace grpc

namespace weavefit {

// The name under which readiness is reported by grpc.health.v1.Health; the
// empty name ("") is liveness.
inline constexpr char kReadinessService[] = "weavefit.v1.WeaveFit";

struct ServerOptions {
  // host:port; port 0 picks a free port (see RunningServer::port).
  std::string listen = "127.0.0.1:50051";
  // PEM files. With a certificate and key the daemon speaks TLS only; with a
  // client CA as well, every client must present a certificate it signed.
  std::string tls_cert;
  std::string tls_key;
  std::string tls_client_ca;
  // Bearer tokens, one per line; empty = no token check.
  std::string token_file;
  // A non-loopback listen without TLS, or a non-loopback metrics_listen, is
  // refused unless this is set.
  bool insecure_remote = false;
  // Server reflection exposes the whole schema: on for a loopback address,
  // elsewhere only when asked (see ServesReflection).
  bool reflection = false;
  // host:port of the Prometheus endpoint (plaintext HTTP); empty = off. A
  // non-loopback address needs insecure_remote, TLS or not.
  std::string metrics_listen;
  // host:port of a plaintext port that serves only grpc.health.v1 (liveness
  // and readiness), for probes that cannot speak TLS (Kubernetes' grpc
  // probe); empty = off. Allowed on any address: it tells only whether the
  // daemon is up and ready.
  std::string health_listen;
  ServiceOptions service;

  bool tls() const { return !tls_cert.empty(); }
  // On the --listen port only; never on the health port.
  bool ServesReflection() const;
  absl::Status Validate() const;
};

// True for 127.0.0.0/8, ::1 and localhost (with any port).
bool IsLoopbackAddress(const std::string& host_port);

class RunningServer {
 public:
  ~RunningServer();

  int port() const { return port_; }
  int metrics_port() const { return metrics_endpoint_ ? metrics_endpoint_->port() : 0; }
  int health_port() const { return health_port_; }
  // Re-reads the token file (SIGHUP): the number of tokens now in force.
  // On failure the tokens in force stay; FAILED_PRECONDITION without a
  // token file.
  absl::StatusOr<int> ReloadTokens();
  // Readiness goes NOT_SERVING, new calls are refused with UNAVAILABLE,
  // calls in flight get up to `grace` to finish before they are cancelled.
  void Shutdown(std::chrono::milliseconds grace);

 private:
  friend absl::StatusOr<std::unique_ptr<RunningServer>> StartServer(const ServerOptions&);
  RunningServer() = default;
  // Readiness on the main server and on the health port.
  void SetReady(bool ready);

  std::unique_ptr<Authenticator> auth_;
  std::unique_ptr<Metrics> metrics_;
  std::unique_ptr<MetricsEndpoint> metrics_endpoint_;
  std::unique_ptr<WeaveFitService> service_;
  std::unique_ptr<grpc::Server> server_;
  // --health-listen: the server, and what answers it for any other service
  // (declared first so that it outlives the server).
  std::unique_ptr<grpc::CallbackGenericService> health_unimplemented_;
  std::unique_ptr<grpc::Server> health_server_;
  int health_port_ = 0;
  std::thread warm_up_;  // builds the FLANN bank, then declares readiness
  std::mutex readiness_mutex_;  // orders draining_ with SetReady
  bool draining_ = false;
  int port_ = 0;
  bool shut_down_ = false;
};

// Checks the options, reads the certificates and tokens, binds and starts
// serving; readiness follows once the FLANN bank is built. INVALID_ARGUMENT
// for bad options or files, UNAVAILABLE when an address cannot be bound.
absl::StatusOr<std::unique_ptr<RunningServer>> StartServer(const ServerOptions& options);

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_SERVER_H_
