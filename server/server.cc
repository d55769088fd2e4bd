#include "server/server.h"

#include <glog/logging.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/server.h>
#include <grpcpp/server_builder.h>

#include "absl/strings/str_cat.h"

namespace weavefit {

absl::Status ServerOptions::Validate() const {
  if (listen.empty() || listen.find(':') == std::string::npos) {
    return absl::InvalidArgumentError(
        absl::StrCat("listen must be host:port, got '", listen, "'"));
  }
  return service.Validate();
}

RunningServer::RunningServer(std::unique_ptr<WeaveFitService> service,
                             std::unique_ptr<grpc::Server> server, int port)
    : service_(std::move(service)), server_(std::move(server)), port_(port) {}

RunningServer::~RunningServer() { Shutdown(std::chrono::milliseconds(0)); }

void RunningServer::Shutdown(std::chrono::milliseconds grace) {
  if (shut_down_) return;
  shut_down_ = true;
  if (auto* health = server_->GetHealthCheckService()) {
    health->Shutdown();  // every service now answers NOT_SERVING
  }
  server_->Shutdown(std::chrono::system_clock::now() + grace);
  server_->Wait();
}

absl::StatusOr<std::unique_ptr<RunningServer>> StartServer(
    const ServerOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  grpc::EnableDefaultHealthCheckService(true);
  // Debian's gRPC 1.51 serves grpc.reflection.v1alpha; the plugin must be
  // initialised explicitly before the builder is made.
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  auto service = std::make_unique<WeaveFitService>(options.service);
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort(options.listen, grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(service.get());
  // A chunk is at most 1 MiB; leave room for the envelope.
  builder.SetMaxReceiveMessageSize(
      static_cast<int>(options.service.max_chunk_bytes + (64 << 10)));
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  if (!server || port == 0) {
    return absl::UnavailableError(
        absl::StrCat("could not listen on ", options.listen));
  }
  server->GetHealthCheckService()->SetServingStatus(true);
  LOG(INFO) << "weavefitd listening on " << options.listen << " (port " << port
            << "), " << options.service.workers << " workers, upload limit "
            << options.service.max_upload_bytes << " bytes";
  return std::make_unique<RunningServer>(std::move(service), std::move(server), port);
}

}  // namespace weavefit
