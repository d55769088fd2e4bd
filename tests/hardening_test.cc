// weavefitd under the conditions of issue 7, through the real binaries:
// TLS and mutual TLS, bearer tokens and their reload on SIGHUP, metrics,
// readiness, refusing a plaintext non-loopback address, and draining.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <string>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "tests/test_support.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit::testing {
namespace {

using grpc::health::v1::HealthCheckResponse;
const std::string kFixtures = FIXTURES_DIR;
const std::string kImage = kFixtures + "/smooth_p10.png";

HealthCheckResponse::ServingStatus Health(std::shared_ptr<grpc::Channel> channel,
                                          const std::string& service) {
  auto stub = grpc::health::v1::Health::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  grpc::health::v1::HealthCheckRequest request;
  request.set_service(service);
  grpc::health::v1::HealthCheckResponse response;
  if (!stub->Check(&context, request, &response).ok()) return HealthCheckResponse::UNKNOWN;
  return response.status();
}

std::shared_ptr<grpc::Channel> Plain(const Daemon& daemon) {
  return grpc::CreateChannel(daemon.address(), grpc::InsecureChannelCredentials());
}

// Waits until readiness is SERVING (the FLANN bank is built).
bool AwaitReady(std::shared_ptr<grpc::Channel> channel) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (std::chrono::steady_clock::now() < deadline) {
    if (Health(channel, "weavefit.v1.WeaveFit") == HealthCheckResponse::SERVING) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

CommandResult Submit(const Daemon& daemon, std::vector<std::string> args) {
  args.insert(args.begin(), {WEAVEFIT_PATH, "submit", "--server", daemon.address(),
                             "--timeout-s", "60", kImage, "--json"});
  return RunCommand(args);
}

// A CA, a server certificate for 127.0.0.1 and a client certificate, made by
// openssl into `dir` (EC keys: quick to make).
bool MakeCertificates(const std::string& dir) {
  const std::string script = absl::StrCat(
      "set -e; cd '", dir, "'\n",
      "ec='-newkey ec -pkeyopt ec_paramgen_curve:prime256v1 -nodes'\n",
      "openssl req -x509 $ec -keyout ca.key -out ca.pem -days 3650 -subj /CN=weavefit-test-ca\n",
      "printf 'subjectAltName=IP:127.0.0.1,DNS:localhost\\n' > server.ext\n",
      "openssl req $ec -keyout server.key -out server.csr -subj /CN=localhost\n",
      "openssl x509 -req -in server.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 3650 "
      "-extfile server.ext -out server.pem\n",
      "openssl req $ec -keyout client.key -out client.csr -subj /CN=lab-machine\n",
      "openssl x509 -req -in client.csr -CA ca.pem -CAkey ca.key -CAcreateserial -days 3650 "
      "-out client.pem\n");
  const CommandResult made = RunCommand({"/bin/sh", "-c", script});
  EXPECT_EQ(made.exit_code, 0) << made.err;
  return made.exit_code == 0;
}

TEST(Hardening, HelpListsEveryLimitAndAccessFlag) {
  const CommandResult help = RunCommand({WEAVEFITD_PATH, "--help"});
  EXPECT_EQ(help.exit_code, 0);
  for (const char* flag :
       {"--max-upload-mb", "--max-megapixels", "--max-chunks", "--max-concurrent", "--max-queue",
        "--deadline-s", "--max-joint-photographs", "--max-call-mb", "--tls-cert", "--tls-key", "--tls-client-ca",
        "--token-file", "--insecure-remote", "--reflection", "--metrics-listen", "--health-listen",
        "--shutdown-grace-s"}) {
    EXPECT_TRUE(absl::StrContains(help.out, flag)) << flag << " missing from --help";
  }
}

TEST(Hardening, APlaintextNonLoopbackAddressIsRefusedUnlessInsecureRemote) {
  const CommandResult refused = RunCommand({WEAVEFITD_PATH, "--listen", "0.0.0.0:0"});
  EXPECT_EQ(refused.exit_code, 1);
  EXPECT_TRUE(absl::StrContains(refused.err, "--insecure-remote")) << refused.err;
  Daemon allowed({"--listen", "0.0.0.0:0", "--insecure-remote"});
  EXPECT_TRUE(allowed.running());
  EXPECT_GT(allowed.port(), 0);
}

// Metrics are plaintext HTTP, so a non-loopback --metrics-listen follows the
// gRPC port's rule even when that port has TLS. `timeout` keeps a daemon that
// wrongly starts from holding the test until ctest's limit.
TEST(Hardening, APlaintextNonLoopbackMetricsAddressIsRefusedUnlessInsecureRemote) {
  const CommandResult refused = RunCommand({"/usr/bin/timeout", "20", WEAVEFITD_PATH, "--listen",
                                            "127.0.0.1:0", "--metrics-listen", "0.0.0.0:0"});
  EXPECT_EQ(refused.exit_code, 1) << refused.err;
  EXPECT_TRUE(absl::StrContains(refused.err, "--metrics-listen")) << refused.err;
  EXPECT_TRUE(absl::StrContains(refused.err, "--insecure-remote")) << refused.err;
  Daemon allowed({"--metrics-listen", "0.0.0.0:0", "--insecure-remote"});
  EXPECT_TRUE(allowed.running()) << allowed.Log();
  EXPECT_TRUE(absl::StartsWith(HttpGet(allowed.metrics_port(), "/metrics"), "HTTP/1.1 200"));
}

// Startup failures are reported and exit 1; none may crash the daemon.
TEST(Hardening, StartupFailuresExitWithTheirReason) {
  const std::string dir = MakeTempDir();
  WriteFileOrDie(dir + "/empty_tokens", "# nothing but a comment\n");
  const CommandResult no_token = RunCommand({WEAVEFITD_PATH, "--listen", "127.0.0.1:0",
                                             "--token-file", dir + "/empty_tokens"});
  EXPECT_EQ(no_token.exit_code, 1) << no_token.err;
  EXPECT_TRUE(absl::StrContains(no_token.err, "holds no token")) << no_token.err;
  Daemon holder;
  const CommandResult busy = RunCommand({WEAVEFITD_PATH, "--listen", holder.address()});
  EXPECT_EQ(busy.exit_code, 1) << busy.err;
  EXPECT_TRUE(absl::StrContains(busy.err, "could not listen")) << busy.err;
  const CommandResult busy_metrics =
      RunCommand({WEAVEFITD_PATH, "--listen", "127.0.0.1:0", "--metrics-listen",
                  holder.address()});
  EXPECT_EQ(busy_metrics.exit_code, 1) << busy_metrics.err;
}

TEST(Hardening, LivenessAtOnceReadinessOnceTheBankIsBuiltAndMetricsCountCalls) {
  Daemon daemon({"--metrics-listen", "127.0.0.1:0"});
  ASSERT_GT(daemon.metrics_port(), 0);
  EXPECT_EQ(Health(Plain(daemon), ""), HealthCheckResponse::SERVING);
  ASSERT_TRUE(AwaitReady(Plain(daemon)));
  ASSERT_EQ(Submit(daemon, {}).exit_code, 0);
  const CommandResult bad = RunCommand({WEAVEFIT_PATH, "submit", "--server", daemon.address(),
                                        "--phase-angle", "10", kFixtures + "/make_fixtures.sh"});
  EXPECT_NE(bad.exit_code, 0);
  const std::string metrics = HttpGet(daemon.metrics_port(), "/metrics");
  EXPECT_TRUE(absl::StartsWith(metrics, "HTTP/1.1 200")) << metrics;
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_requests_total{method=\"Estimate\",code=\"OK\"} 1"))
      << metrics;
  EXPECT_TRUE(absl::StrContains(metrics, "code=\"INVALID_ARGUMENT\"} 1")) << metrics;
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_decode_seconds_count 1")) << metrics;
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_fit_seconds_count 1")) << metrics;
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_request_seconds_count 2")) << metrics;
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_requests_in_flight 0")) << metrics;
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_queue_depth 0")) << metrics;
  EXPECT_TRUE(absl::StartsWith(HttpGet(daemon.metrics_port(), "/other"), "HTTP/1.1 404"));
  // Malformed HTTP gets an error status; the daemon is not hurt.
  EXPECT_TRUE(absl::StartsWith(RawHttp(daemon.metrics_port(), "GARBAGE\r\n\r\n"), "HTTP/1.1 400"));
  EXPECT_TRUE(absl::StartsWith(HttpGet(daemon.metrics_port(), "/metrics"), "HTTP/1.1 200"));
  EXPECT_TRUE(daemon.running());
}

TEST(Hardening, MutualTlsAndBearerTokensReloadedOnSighup) {
  const std::string dir = MakeTempDir();
  ASSERT_TRUE(MakeCertificates(dir));
  const std::string tokens = dir + "/tokens";
  WriteFileOrDie(tokens, "# lab tokens\nfirst-token\n");
  WriteFileOrDie(dir + "/first", "first-token\n");
  WriteFileOrDie(dir + "/second", "second-token\n");
  Daemon daemon({"--tls-cert", dir + "/server.pem", "--tls-key", dir + "/server.key",
                 "--tls-client-ca", dir + "/ca.pem", "--token-file", tokens,
                 "--health-listen", "127.0.0.1:0"});
  ASSERT_TRUE(daemon.running()) << daemon.Log();
  const std::vector<std::string> tls = {"--tls-ca", dir + "/ca.pem", "--tls-cert",
                                        dir + "/client.pem", "--tls-key", dir + "/client.key"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = tls;
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  };
  // The health check needs the client certificate but no token.
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = ReadFileOrDie(dir + "/ca.pem");
  ssl.pem_cert_chain = ReadFileOrDie(dir + "/client.pem");
  ssl.pem_private_key = ReadFileOrDie(dir + "/client.key");
  auto secure = grpc::CreateChannel(daemon.address(), grpc::SslCredentials(ssl));
  ASSERT_TRUE(AwaitReady(secure));

  // The plaintext health port answers probes and serves nothing else.
  ASSERT_GT(daemon.health_port(), 0);
  auto probe = grpc::CreateChannel(absl::StrCat("127.0.0.1:", daemon.health_port()),
                                   grpc::InsecureChannelCredentials());
  EXPECT_EQ(Health(probe, ""), HealthCheckResponse::SERVING);
  EXPECT_EQ(Health(probe, "weavefit.v1.WeaveFit"), HealthCheckResponse::SERVING);
  {
    auto stub = v1::WeaveFit::NewStub(probe);
    grpc::ClientContext context;
    v1::EstimateReply reply;
    auto writer = stub->Estimate(&context, &reply);
    writer->WritesDone();
    EXPECT_EQ(writer->Finish().error_code(), grpc::StatusCode::UNIMPLEMENTED);
  }

  const CommandResult ok = Submit(daemon, with({"--token-file", dir + "/first"}));
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_EQ(Submit(daemon, with({})).exit_code, 16) << "no token: UNAUTHENTICATED";
  EXPECT_EQ(Submit(daemon, with({"--token-file", dir + "/second"})).exit_code, 16);
  EXPECT_EQ(Submit(daemon, {"--token-file", dir + "/first"}).exit_code, 14)
      << "plaintext to a TLS daemon: UNAVAILABLE";
  EXPECT_EQ(Submit(daemon, {"--tls-ca", dir + "/ca.pem", "--token-file", dir + "/first"}).exit_code,
            14)
      << "no client certificate under mutual TLS: UNAVAILABLE";
  EXPECT_FALSE(absl::StrContains(daemon.Log(), "second-token")) << "a refused token was logged";

  // SIGHUP: the token file is read again; a broken one keeps the old tokens.
  WriteFileOrDie(tokens, "second-token\n");
  daemon.Signal(SIGHUP);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!absl::StrContains(daemon.Log(), "token file re-read") &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(Submit(daemon, with({"--token-file", dir + "/first"})).exit_code, 16);
  EXPECT_EQ(Submit(daemon, with({"--token-file", dir + "/second"})).exit_code, 0);
  WriteFileOrDie(tokens, "# emptied by mistake\n");
  daemon.Signal(SIGHUP);
  while (!absl::StrContains(daemon.Log(), "previous tokens stay in force") &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_EQ(Submit(daemon, with({"--token-file", dir + "/second"})).exit_code, 0);
  EXPECT_TRUE(daemon.running());
}

// Waits up to 10 s for `text` in the daemon's log.
bool AwaitLog(const Daemon& daemon, const std::string& text) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!absl::StrContains(daemon.Log(), text)) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

// The SIGHUP log line says what happened: nothing without a token file, the
// number of tokens in force with one.
TEST(Hardening, SighupLogsWhatItDid) {
  Daemon open;
  open.Signal(SIGHUP);
  EXPECT_TRUE(AwaitLog(open, "SIGHUP: no --token-file to re-read")) << open.Log();
  EXPECT_FALSE(absl::StrContains(open.Log(), "token file re-read")) << open.Log();

  const std::string dir = MakeTempDir();
  WriteFileOrDie(dir + "/tokens", "first-token\n");
  Daemon guarded({"--token-file", dir + "/tokens"});
  WriteFileOrDie(dir + "/tokens", "first-token\n# a comment\nsecond-token\nthird-token\n");
  guarded.Signal(SIGHUP);
  EXPECT_TRUE(AwaitLog(guarded, "re-read: 3 tokens in force")) << guarded.Log();
  EXPECT_TRUE(guarded.running());
}

TEST(Hardening, SigtermDrainsCallsInFlightAndRefusesNewOnes) {
  Daemon daemon({"--shutdown-grace-s", "20"});
  ASSERT_TRUE(AwaitReady(Plain(daemon)));
  // A call in flight: its header is sent, its image not yet.
  auto stub = v1::WeaveFit::NewStub(Plain(daemon));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  v1::EstimateReply reply;
  auto writer = stub->Estimate(&context, &reply);
  v1::EstimateRequest message;
  message.mutable_header()->mutable_acquisition()->set_phase_angle_deg(10.0);
  ASSERT_TRUE(writer->Write(message));
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  daemon.Signal(SIGTERM);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  // New calls are refused while the one in flight finishes (the client is
  // told not to wait for a daemon to come back: this one will not).
  const CommandResult refused = Submit(daemon, {"--reconnect-window-s", "0"});
  EXPECT_EQ(refused.exit_code, 14) << refused.out << refused.err;
  message.set_chunk(ReadFileOrDie(kImage));
  ASSERT_TRUE(writer->Write(message));
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  EXPECT_TRUE(status.ok()) << status.error_message();
  ExpectFiniteReply(reply);
  EXPECT_EQ(reply.model(), v1::SMOOTH);
  EXPECT_EQ(daemon.Stop(), 0);
}

}  // namespace
}  // namespace weavefit::testing
