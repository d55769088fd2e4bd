#include "client/rpc_client.h"

#include <arpa/inet.h>
#include <grpcpp/grpcpp.h>
#include <netdb.h>
#include <sys/socket.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "proto/weavefit/v1/keepalive.h"
#include "proto/weavefit/v1/status_util.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit {
namespace {

constexpr int kInitialReconnectBackoffMs = 250;
constexpr int kMaxReconnectBackoffMs = 1000;

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

bool IsIpv4(const std::string& host) {
  in_addr a;
  return inet_pton(AF_INET, host.c_str(), &a) == 1;
}

bool IsIpv6(const std::string& host) {
  in6_addr a;
  return inet_pton(AF_INET6, host.c_str(), &a) == 1;
}

// gRPC's own target schemes (naming.md); a target that starts with one is
// passed on as it is.
bool HasScheme(const std::string& server) {
  if (absl::StrContains(server, "://")) return true;
  for (const char* scheme : {"dns:", "ipv4:", "ipv6:", "unix:", "unix-abstract:", "vsock:"}) {
    if (absl::StartsWith(server, scheme)) return true;
  }
  return false;
}

struct HostPort {
  std::string host;  // without brackets
  std::string port;
};

absl::StatusOr<HostPort> SplitHostPort(const std::string& entry) {
  HostPort out;
  std::string rest;
  if (absl::StartsWith(entry, "[")) {
    const std::size_t close = entry.find(']');
    if (close == std::string::npos) {
      return absl::InvalidArgumentError(absl::StrCat("--server entry '", entry, "' lacks its ']'"));
    }
    out.host = entry.substr(1, close - 1);
    rest = entry.substr(close + 1);
    if (!absl::StartsWith(rest, ":")) rest.clear();
  } else {
    const std::size_t colon = entry.rfind(':');
    if (colon != std::string::npos) {
      out.host = entry.substr(0, colon);
      rest = entry.substr(colon);
    }
    if (absl::StrContains(out.host, ":")) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--server entry '", entry, "': write an IPv6 address in brackets, [addr]:port"));
    }
  }
  int port = 0;
  if (out.host.empty() || rest.size() < 2 || !absl::SimpleAtoi(rest.substr(1), &port) ||
      port < 1 || port > 65535) {
    return absl::InvalidArgumentError(
        absl::StrCat("--server entry '", entry, "' is not host:port (a port 1-65535 is needed)"));
  }
  out.port = rest.substr(1);
  return out;
}

}  // namespace

const char kRoundRobinServiceConfig[] = R"({"loadBalancingConfig":[{"round_robin":{}}]})";

absl::StatusOr<std::vector<std::string>> ResolveHost(const std::string& host) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const int error = getaddrinfo(host.c_str(), nullptr, &hints, &found);
  if (error != 0) {
    return absl::UnavailableError(
        absl::StrCat("cannot resolve '", host, "': ", gai_strerror(error)));
  }
  std::vector<std::string> addresses;
  for (const addrinfo* a = found; a != nullptr; a = a->ai_next) {
    char text[INET6_ADDRSTRLEN] = {0};
    const void* raw = a->ai_family == AF_INET
                          ? static_cast<const void*>(
                                &reinterpret_cast<const sockaddr_in*>(a->ai_addr)->sin_addr)
                          : static_cast<const void*>(
                                &reinterpret_cast<const sockaddr_in6*>(a->ai_addr)->sin6_addr);
    if ((a->ai_family == AF_INET || a->ai_family == AF_INET6) &&
        inet_ntop(a->ai_family, raw, text, sizeof(text)) != nullptr &&
        std::find(addresses.begin(), addresses.end(), text) == addresses.end()) {
      addresses.push_back(text);
    }
  }
  freeaddrinfo(found);
  if (addresses.empty()) {
    return absl::UnavailableError(absl::StrCat("'", host, "' has no TCP address"));
  }
  return addresses;
}

absl::StatusOr<ChannelTarget> ChannelTargetFor(const std::string& server,
                                               const HostResolver& resolve) {
  const std::string trimmed(absl::StripAsciiWhitespace(server));
  if (trimmed.empty()) return absl::InvalidArgumentError("--server is empty");
  if (HasScheme(trimmed) || !absl::StrContains(trimmed, ',')) return ChannelTarget{trimmed, ""};
  // Per entry: its IPv4 and its IPv6 addresses, each with the port.
  struct Resolved {
    std::string entry;
    std::vector<std::string> v4;
    std::vector<std::string> v6;
  };
  std::vector<std::string> list;
  for (absl::string_view piece : absl::StrSplit(trimmed, ',', absl::SkipWhitespace())) {
    list.emplace_back(absl::StripAsciiWhitespace(piece));
  }
  if (list.size() == 1) return ChannelTarget{list[0], ""};
  std::vector<Resolved> entries;
  for (const std::string& entry : list) {
    absl::StatusOr<HostPort> hp = SplitHostPort(entry);
    if (!hp.ok()) return hp.status();
    std::vector<std::string> addresses;
    if (IsIpv4(hp->host) || IsIpv6(hp->host)) {
      addresses.push_back(hp->host);
    } else {
      absl::StatusOr<std::vector<std::string>> found = resolve(hp->host);
      if (!found.ok()) return found.status();
      addresses = *std::move(found);
    }
    Resolved r{entry, {}, {}};
    for (const std::string& a : addresses) {
      if (IsIpv4(a)) r.v4.push_back(absl::StrCat(a, ":", hp->port));
      if (IsIpv6(a)) r.v6.push_back(absl::StrCat("[", a, "]:", hp->port));
    }
    entries.push_back(std::move(r));
  }
  const bool all_v4 = std::all_of(entries.begin(), entries.end(),
                                  [](const Resolved& r) { return !r.v4.empty(); });
  const bool all_v6 = std::all_of(entries.begin(), entries.end(),
                                  [](const Resolved& r) { return !r.v6.empty(); });
  if (!all_v4 && !all_v6) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--server ", trimmed, " mixes IPv4-only and IPv6-only entries; gRPC takes one address "
        "family per target: list addresses of one family"));
  }
  std::vector<std::string> addresses;
  for (const Resolved& r : entries) {
    const std::vector<std::string>& family = all_v4 ? r.v4 : r.v6;
    addresses.insert(addresses.end(), family.begin(), family.end());
  }
  return ChannelTarget{absl::StrCat(all_v4 ? "ipv4:" : "ipv6:", absl::StrJoin(addresses, ",")),
                       entries[0].entry};
}

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
  if (!connection.tls_ca.empty() || !connection.tls_cert.empty() ||
      !connection.tls_key.empty()) {
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
  absl::StatusOr<ChannelTarget> target = ChannelTargetFor(connection.server);
  if (!target.ok()) return target.status();
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_KEEPALIVE_TIME_MS, kClientKeepaliveTimeMs);
  args.SetInt(GRPC_ARG_KEEPALIVE_TIMEOUT_MS, kClientKeepaliveTimeoutMs);
  args.SetInt(GRPC_ARG_HTTP2_MAX_PINGS_WITHOUT_DATA, 0);
  // gRPC's reconnect backoff starts at 1 s and grows ×1.6 to 120 s: a
  // daemon restarted after a second was found 2.4 s after the batch began
  // waiting for it, 0.9 s with these. A connect attempt a second costs a
  // loopback or LAN daemon nothing.
  args.SetInt(GRPC_ARG_INITIAL_RECONNECT_BACKOFF_MS, kInitialReconnectBackoffMs);
  args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, kMaxReconnectBackoffMs);
  // Our load-balancing policy, whatever a DNS TXT record might say.
  args.SetServiceConfigJSON(kRoundRobinServiceConfig);
  args.SetInt(GRPC_ARG_SERVICE_CONFIG_DISABLE_RESOLUTION, 1);
  if (!target->authority.empty()) args.SetString(GRPC_ARG_DEFAULT_AUTHORITY, target->authority);
  return grpc::CreateCustomChannel(target->target, credentials, args);
}

bool Client::Connected() const {
  return channel_->GetState(/*try_to_connect=*/true) == GRPC_CHANNEL_READY;
}

bool Client::WaitForConnected(double timeout_s) const {
  // Blocks in WaitForStateChange between states (no polling), and asks the
  // channel to connect after each: gRPC 1.51's subchannel reports IDLE once
  // its backoff has passed and stays so, while fail-fast calls keep failing,
  // until someone asks (seen in a kill-and-restart: 9 s down for a daemon
  // back after 1 s).
  return channel_->WaitForConnected(
      std::chrono::system_clock::now() +
      std::chrono::milliseconds(static_cast<long long>(std::max(0.0, timeout_s) * 1000)));
}

absl::StatusOr<Client> Client::Connect(const Connection& connection) {
  absl::StatusOr<std::shared_ptr<grpc::Channel>> channel = MakeChannel(connection);
  if (!channel.ok()) return channel.status();
  return Client(connection, *std::move(channel));
}

absl::StatusOr<v1::EstimateReply> SubmitEstimate(const Connection& connection,
                                                 v1::RequestHeader header,
                                                 const std::string& bytes) {
  absl::StatusOr<Client> client = Client::Connect(connection);
  if (!client.ok()) return client.status();
  return client->Estimate(std::move(header), bytes);
}

absl::StatusOr<v1::JointEstimateReply> SubmitJoint(const Connection& connection,
                                                   std::vector<v1::RequestHeader> headers,
                                                   const std::vector<std::string>& bytes) {
  absl::StatusOr<Client> client = Client::Connect(connection);
  if (!client.ok()) return client.status();
  return client->EstimateJoint(std::move(headers), bytes);
}

absl::StatusOr<v1::EstimateReply> Client::Estimate(v1::RequestHeader header,
                                                   const std::string& bytes) const {
  const Connection& connection = connection_;
  auto stub = v1::WeaveFit::NewStub(channel_);
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

absl::StatusOr<v1::JointEstimateReply> Client::EstimateJoint(
    std::vector<v1::RequestHeader> headers, const std::vector<std::string>& bytes) const {
  if (headers.size() != bytes.size()) {
    return absl::InvalidArgumentError("one header per photograph is needed");
  }
  const Connection& connection = connection_;
  auto stub = v1::WeaveFit::NewStub(channel_);
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
