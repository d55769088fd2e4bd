// Starting and stopping weavefitd's gRPC server.
#ifndef WEAVEFIT_SERVER_SERVER_H_
#define WEAVEFIT_SERVER_SERVER_H_

#include <chrono>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/service.h"

namespace grpc {
class Server;
}  // namespace grpc

namespace weavefit {

struct ServerOptions {
  // host:port; port 0 picks a free port (see RunningServer::port).
  std::string listen = "127.0.0.1:50051";
  ServiceOptions service;

  absl::Status Validate() const;
};

class RunningServer {
 public:
  RunningServer(std::unique_ptr<WeaveFitService> service,
                std::unique_ptr<grpc::Server> server, int port);
  ~RunningServer();

  int port() const { return port_; }
  // Health goes NOT_SERVING, new calls are refused, calls in flight get up
  // to `grace` to finish before they are cancelled.
  void Shutdown(std::chrono::milliseconds grace);

 private:
  std::unique_ptr<WeaveFitService> service_;
  std::unique_ptr<grpc::Server> server_;
  int port_;
  bool shut_down_ = false;
};

// Binds, registers the service, health checking and reflection, and starts
// serving. UNAVAILABLE when the address cannot be bound.
absl::StatusOr<std::unique_ptr<RunningServer>> StartServer(
    const ServerOptions& options);

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_SERVER_H_
