#include "client/rpc_client.h"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "proto/weavefit/v1/keepalive.h"
#include "proto/weavefit/v1/status_util.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit {
namespace {

absl::StatusOr<std::string> ReadText(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return absl::InvalidArgumentError(absl::StrCat("cannot read ", what, " ", path));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void PrepareContext(const Connection& connection, double timeout_s,
                    grpc::ClientContext* context) {
  context->set_deadline(std::chrono::system_clock::now() +
                        std::chrono::milliseconds(static_cast<long long>(timeout_s * 1000)));
  context->set_wait_for_ready(false);
  if (!connection.token.empty()) {
    context->AddMetadata("authorization", "Bearer " + connection.token);
  }
}

}  // namespace

absl::Status Connection::LoadToken(const std::string& token_file) {
  std::string text;
  if (!token_file.empty()) {
    absl::StatusOr<std::string> read = ReadText(token_file, "token file");
    if (!read.ok()) return read.status();
    text = *read;
  } else if (const char* env = std::getenv("WEAVEFIT_TOKEN")) {
    text = env;
  } else {
    return absl::OkStatus();
  }
  std::string first = text.substr(0, text.find('\n'));
  absl::StripAsciiWhitespace(&first);
  if (first.empty()) {
    return absl::InvalidArgumentError(absl::StrCat(
        token_file.empty() ? std::string("WEAVEFIT_TOKEN") : token_file, " holds no token"));
  }
  token = first;
  return absl::OkStatus();
}

absl::StatusOr<std::shared_ptr<grpc::Channel>> MakeChannel(const Connection& connection) {
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (!connection.tls_ca.empty() || !connection.tls_cert.empty()) {
    grpc::SslCredentialsOptions ssl;
    if (!connection.tls_ca.empty()) {
      absl::StatusOr<std::string> ca = ReadText(connection.tls_ca, "TLS CA");
      if (!ca.ok()) return ca.status();
      ssl.pem_root_certs = *ca;
    }
    if (connection.tls_cert.empty() != connection.tls_key.empty()) {
      return absl::InvalidArgumentError("--tls-cert and --tls-key go together");
    }
    if (!connection.tls_cert.empty()) {
      absl::StatusOr<std::string> cert = ReadText(connection.tls_cert, "TLS certificate");
      if (!cert.ok()) return cert.status();
      absl::StatusOr<std::string> key = ReadText(connection.tls_key, "TLS key");
      if (!key.ok()) return key.status();
      ssl.pem_cert_chain = *cert;
      ssl.pem_private_key = *key;
    }
    credentials = grpc::SslCredentials(ssl);
  }
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, kClientKeepaliveTimeMs);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, kClientKeepaliveTimeoutMs);
  args.SetInt(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  return grpc::CreateCustomChannel(connection.server, credentials, args);
}

absl::StatusOr<v1::EstimateReply> SubmitEstimate(const Connection& connection,
                                                 v1::RequestHeader header,
                                                 const std::string& bytes) {
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = MakeChannel(connection);
  if (!channel.ok()) return channel.status();
  auto stub = v1::WeaveFit::NewStub(*channel);
  grpc::ClientContext context;
  PrepareContext(connection, connection.timeout_s, &context);
  v1::EstimateReply reply;
  std::unique_ptr<grpc::ClientWriter<v1::EstimateRequest>> writer =
      stub->Estimate(&context, &reply);
  header.set_total_bytes(bytes.size());
  v1::EstimateRequest message;
  *message.mutable_header() = std::move(header);
  bool open = writer->Write(message);
  for (std::size_t at = 0; open && at < bytes.size(); at += kChunkBytes) {
    message.set_chunk(bytes.substr(at, std::min(kChunkBytes, bytes.size() - at)));
    open = writer->Write(message);
  }
  // A closed stream means the server already answered (an early error):
  // Finish() then returns that status.
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  if (!status.ok()) return FromGrpcStatus(status);
  return reply;
}

absl::StatusOr<v1::JointEstimateReply> SubmitJoint(const Connection& connection,
                                                   std::vector<v1::RequestHeader> headers,
                                                   const std::vector<std::string>& bytes) {
  if (headers.size() != bytes.size()) {
    return absl::InvalidArgumentError("one header per photograph is needed");
  }
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = MakeChannel(connection);
  if (!channel.ok()) return channel.status();
  auto stub = v1::WeaveFit::NewStub(*channel);
  grpc::ClientContext context;
  PrepareContext(connection, connection.timeout_s * static_cast<double>(headers.size()),
                 &context);
  v1::JointEstimateReply reply;
  std::unique_ptr<grpc::ClientWriter<v1::EstimateRequest>> writer =
      stub->EstimateJoint(&context, &reply);
  bool open = true;
  for (std::size_t i = 0; open && i < headers.size(); ++i) {
    headers[i].set_total_bytes(bytes[i].size());
    v1::EstimateRequest message;
    *message.mutable_header() = std::move(headers[i]);
    open = writer->Write(message);
    for (std::size_t at = 0; open && at < bytes[i].size(); at += kChunkBytes) {
      message.set_chunk(bytes[i].substr(at, std::min(kChunkBytes, bytes[i].size() - at)));
      open = writer->Write(message);
    }
  }
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  if (!status.ok()) return FromGrpcStatus(status);
  return reply;
}

}  // namespace weavefit
