#include "server/server.h"

#include <arpa/inet.h>
#include <glog/logging.h>
#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/generic/async_generic_service.h>
#include <grpcpp/health_check_service_interface.h>
#include <grpcpp/impl/server_builder_option.h>
#include <grpcpp/security/server_credentials.h>
#include <grpcpp/server.h>
#include <grpcpp/server_builder.h>

#include <algorithm>
#include <fstream>
#include <sstream>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "estimator/init/profile_bank.h"
#include "proto/weavefit/v1/keepalive.h"

namespace weavefit {
namespace {

absl::StatusOr<std::string> ReadPem(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InvalidArgumentError(absl::StrCat("cannot read ", what, " ", path));
  std::ostringstream text;
  text << in.rdbuf();
  if (!absl::StrContains(text.str(), "-----BEGIN")) {
    return absl::InvalidArgumentError(absl::StrCat(what, " ", path, " is not PEM"));
  }
  return text.str();
}

absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> Credentials(
    const ServerOptions& options) {
  if (!options.tls()) return grpc::InsecureServerCredentials();
  grpc::SslServerCredentialsOptions ssl;
  absl::StatusOr<std::string> cert = ReadPem(options.tls_cert, "TLS certificate");
  if (!cert.ok()) return cert.status();
  absl::StatusOr<std::string> key = ReadPem(options.tls_key, "TLS key");
  if (!key.ok()) return key.status();
  ssl.pem_key_cert_pairs.push_back({*key, *cert});
  if (!options.tls_client_ca.empty()) {
    absl::StatusOr<std::string> ca = ReadPem(options.tls_client_ca, "client CA");
    if (!ca.ok()) return ca.status();
    ssl.pem_root_certs = *ca;
    ssl.client_certificate_request = GRPC_SSL_REQUEST_AND_REQUIRE_CLIENT_CERTIFICATE_AND_VERIFY;
  }
  return grpc::SslServerCredentials(ssl);
}

// Takes server reflection out of one builder. Debian's libgrpc++_reflection
// registers its plugin from a static initialiser when the library is loaded,
// so every ServerBuilder in the process serves reflection whether or not
// InitProtoReflectionServerBuilderPlugin() was called: it cannot be left off
// by not asking for it.
class WithoutReflection : public grpc::ServerBuilderOption {
 public:
  void UpdateArguments(grpc::ChannelArguments*) override {}
  void UpdatePlugins(std::vector<std::unique_ptr<grpc::ServerBuilderPlugin>>* plugins) override {
    auto is_reflection = [](const std::unique_ptr<grpc::ServerBuilderPlugin>& plugin) {
      return dynamic_cast<grpc::reflection::ProtoServerReflectionPlugin*>(plugin.get()) != nullptr;
    };
    plugins->erase(std::remove_if(plugins->begin(), plugins->end(), is_reflection),
                   plugins->end());
  }
};

// INVALID_ARGUMENT unless `address` (the value of `flag`) is host:port.
absl::Status CheckHostPort(const char* flag, const std::string& address) {
  if (!address.empty() && address.find(':') != std::string::npos) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(flag, " must be host:port, got '", address, "'"));
}

// The plaintext --health-listen server: grpc.health.v1 and nothing else.
// gRPC 1.51's default health service is a callback service that
// Server::Start adds only after BuildAndStart has refused a server without a
// frequently polled queue; the reflection plugin's service used to supply
// one unseen. `unimplemented` (a bare generic service, which answers every
// method UNIMPLEMENTED as gRPC's own fallback does) supplies it now.
std::unique_ptr<grpc::Server> StartHealthServer(const std::string& address,
                                                grpc::CallbackGenericService* unimplemented,
                                                int* port) {
  grpc::ServerBuilder builder;
  builder.SetOption(std::make_unique<WithoutReflection>());
  builder.RegisterCallbackGenericService(unimplemented);
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddListeningPort(address, grpc::InsecureServerCredentials(), port);
  return builder.BuildAndStart();
}

// The --listen server: WeaveFit, health, and reflection when it is on.
std::unique_ptr<grpc::Server> StartMainServer(
    const ServerOptions& options, std::shared_ptr<grpc::ServerCredentials> credentials,
    grpc::Service* service, int* port) {
  grpc::ServerBuilder builder;
  if (!options.ServesReflection()) builder.SetOption(std::make_unique<WithoutReflection>());
  builder.AddListeningPort(options.listen, std::move(credentials), port);
  builder.RegisterService(service);
  // A chunk is at most 1 MiB; leave room for the envelope.
  builder.SetMaxReceiveMessageSize(
      static_cast<int>(options.service.max_chunk_bytes + (64 << 10)));
  // A port another process holds is an error, not a port to share
  // (gRPC sets SO_REUSEPORT by default).
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddChannelArgument(GRPC_ARG_HTTP2_MIN_RECV_PING_INTERVAL_WITHOUT_DATA_MS,
                             kServerMinPingIntervalMs);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_PERMIT_WITHOUT_CALLS, 1);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIME_MS, kServerKeepaliveTimeMs);
  builder.AddChannelArgument(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, kServerKeepaliveTimeoutMs);
  return builder.BuildAndStart();
}

}  // namespace

bool IsLoopbackAddress(const std::string& host_port) {
  const std::size_t colon = host_port.rfind(':');
  std::string host = host_port.substr(0, colon == std::string::npos ? host_port.size() : colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  if (host == "localhost") return true;
  // Numeric addresses only: a name such as 127.example.org may resolve anywhere.
  in_addr v4{};
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6{};
  return inet_pton(AF_INET6, host.c_str(), &v6) == 1 && IN6_IS_ADDR_LOOPBACK(&v6);
}

bool ServerOptions::ServesReflection() const {
  return reflection || IsLoopbackAddress(listen);
}

absl::Status ServerOptions::Validate() const {
  if (absl::Status s = CheckHostPort("--listen", listen); !s.ok()) return s;
  if (tls_cert.empty() != tls_key.empty()) {
    return absl::InvalidArgumentError("--tls-cert and --tls-key go together");
  }
  if (!tls_client_ca.empty() && !tls()) {
    return absl::InvalidArgumentError("--tls-client-ca needs --tls-cert and --tls-key");
  }
  if (!IsLoopbackAddress(listen) && !tls() && !insecure_remote) {
    return absl::InvalidArgumentError(absl::StrCat(
        "refusing to listen on ", listen, " without TLS: give --tls-cert and --tls-key, "
        "or --insecure-remote on a network you trust"));
  }
  // The health port may be anywhere: the kubelet probes it from the node,
  // and it serves nothing but grpc.health.v1.
  if (!health_listen.empty()) {
    if (absl::Status s = CheckHostPort("--health-listen", health_listen); !s.ok()) return s;
  }
  if (!metrics_listen.empty()) {
    if (absl::Status s = CheckHostPort("--metrics-listen", metrics_listen); !s.ok()) return s;
    // Metrics have no TLS, so TLS on the gRPC port does not cover them.
    if (!IsLoopbackAddress(metrics_listen) && !insecure_remote) {
      return absl::InvalidArgumentError(absl::StrCat(
          "refusing to serve metrics in plaintext on ", metrics_listen,
          ": give --metrics-listen a loopback address, or --insecure-remote on a network "
          "you trust"));
    }
  }
  return service.Validate();
}

RunningServer::~RunningServer() {
  Shutdown(std::chrono::milliseconds(0));
  // The metrics endpoint reads the service's queue depth: stop it first.
  metrics_endpoint_.reset();
}

absl::StatusOr<int> RunningServer::ReloadTokens() {
  if (!auth_ || !auth_->enabled()) {
    return absl::FailedPreconditionError("no --token-file to re-read");
  }
  if (absl::Status s = auth_->Reload(); !s.ok()) return s;
  return auth_->token_count();
}

void RunningServer::SetReady(bool ready) {
  std::lock_guard<std::mutex> lock(readiness_mutex_);
  if (ready && draining_) return;  // warm-up finishing after a drain began
  for (grpc::Server* server : {server_.get(), health_server_.get()}) {
    if (server == nullptr) continue;
    if (auto* health = server->GetHealthCheckService()) {
      health->SetServingStatus(kReadinessService, ready);
    }
  }
}

void RunningServer::Shutdown(std::chrono::milliseconds grace) {
  if (shut_down_) return;
  shut_down_ = true;
  {
    std::lock_guard<std::mutex> lock(readiness_mutex_);
    draining_ = true;
  }
  SetReady(false);
  if (server_) {  // null when StartServer failed before it was built
    // Calls still in flight when the grace ends are cancelled by gRPC: the
    // service logs them as cut by the shutdown.
    service_->BeginShutdown(std::chrono::steady_clock::now() + grace);
    server_->Shutdown(std::chrono::system_clock::now() + grace);
    server_->Wait();
  }
  if (health_server_) {
    health_server_->Shutdown(std::chrono::system_clock::now());
    health_server_->Wait();
  }
  if (warm_up_.joinable()) warm_up_.join();
}

absl::StatusOr<std::unique_ptr<RunningServer>> StartServer(const ServerOptions& options) {
  if (absl::Status s = options.Validate(); !s.ok()) return s;
  absl::StatusOr<std::shared_ptr<grpc::ServerCredentials>> credentials = Credentials(options);
  if (!credentials.ok()) return credentials.status();

  std::unique_ptr<RunningServer> running(new RunningServer());
  if (!options.token_file.empty()) {
    absl::StatusOr<std::unique_ptr<Authenticator>> auth =
        Authenticator::FromFile(options.token_file);
    if (!auth.ok()) return absl::InvalidArgumentError(auth.status().message());
    running->auth_ = *std::move(auth);
  }
  running->metrics_ = std::make_unique<Metrics>();
  if (!options.metrics_listen.empty()) {
    absl::StatusOr<std::unique_ptr<MetricsEndpoint>> endpoint =
        MetricsEndpoint::Start(options.metrics_listen, running->metrics_.get());
    if (!endpoint.ok()) return endpoint.status();
    running->metrics_endpoint_ = *std::move(endpoint);
  }
  running->service_ = std::make_unique<WeaveFitService>(
      options.service, running->auth_.get(), running->metrics_.get());

  grpc::EnableDefaultHealthCheckService(true);
  // Every builder made from here on carries the reflection plugin: Debian's
  // library registers it when loaded, and registering it here as well makes
  // that so for any build of gRPC. WithoutReflection takes it out again
  // wherever reflection must be off.
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  if (!options.health_listen.empty()) {
    running->health_unimplemented_ = std::make_unique<grpc::CallbackGenericService>();
    running->health_server_ = StartHealthServer(
        options.health_listen, running->health_unimplemented_.get(), &running->health_port_);
    if (!running->health_server_ || running->health_port_ == 0) {
      return absl::UnavailableError(
          absl::StrCat("could not listen on ", options.health_listen, " (health)"));
    }
  }
  running->server_ = StartMainServer(options, *credentials, running->service_.get(),
                                     &running->port_);
  if (!running->server_ || running->port_ == 0) {
    return absl::UnavailableError(absl::StrCat("could not listen on ", options.listen));
  }
  for (grpc::Server* server : {running->server_.get(), running->health_server_.get()}) {
    if (server == nullptr) continue;
    server->GetHealthCheckService()->SetServingStatus("", true);  // liveness
  }
  running->SetReady(false);  // readiness, below
  RunningServer* self = running.get();
  running->warm_up_ = std::thread([self] {
    ProfileBank::Default();  // built once, shared by every request
    self->SetReady(true);  // not once draining has begun
    LOG(INFO) << "weavefitd ready (FLANN bank built)";
  });
  LOG(INFO) << "weavefitd listening on " << options.listen << " (port " << running->port_
            << (options.tls() ? ", TLS" : ", plaintext")
            << (options.tls_client_ca.empty() ? "" : ", client certificates required")
            << (running->auth_ ? ", bearer tokens" : "")
            << (options.ServesReflection() ? ", reflection on" : ", reflection off")
            << "), " << options.service.workers << " workers, queue "
            << options.service.max_queue << ", memory budget "
            << options.service.memory_budget_bytes / (1 << 20) << " MiB, upload limit "
            << options.service.max_upload_bytes << " bytes, " << options.service.max_uploads
            << " uploads holding at most " << options.service.max_upload_memory_bytes / (1 << 20)
            << " MiB, idle limit " << options.service.upload_idle_s << " s, deadline "
            << options.service.deadline_s << " s";
  if (running->health_server_) {
    LOG(INFO) << "health only (no reflection), plaintext, on " << options.health_listen
              << " (port " << running->health_port_ << ")";
  }
  if (running->metrics_endpoint_) {
    LOG(INFO) << "metrics on " << options.metrics_listen << " (port "
              << running->metrics_endpoint_->port() << ") /metrics";
  }
  return running;
}

}  // namespace weavefit
