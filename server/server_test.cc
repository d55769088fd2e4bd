// weavefitd's pieces alone (tokens, admission, metrics, options) and the
// service through an in-process channel: access control, the bounded queue,
// deadlines and cancellation, without a network.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <thread>

#include "absl/strings/match.h"
#include "server/admission.h"
#include "server/auth.h"
#include "server/metrics.h"
#include "server/server.h"
#include "server/service.h"
#include "server/watchdog.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit {
namespace {

using std::chrono::milliseconds;
using Clock = std::chrono::steady_clock;

std::string TempPath(const std::string& name) {
  return ::testing::TempDir() + "/" + name + std::to_string(::getpid());
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

TEST(TokenSetTest, ParsesTokensSkippingCommentsAndBlanks) {
  absl::StatusOr<TokenSet> set = TokenSet::Parse("# lab tokens\n\n  alpha \nbeta\r\n");
  ASSERT_TRUE(set.ok()) << set.status();
  EXPECT_EQ(set->size(), 2);
  EXPECT_TRUE(set->Accepts("alpha"));
  EXPECT_TRUE(set->Accepts("beta"));
  EXPECT_FALSE(set->Accepts("alph"));
  EXPECT_FALSE(set->Accepts("alphaa"));
  EXPECT_FALSE(set->Accepts(""));
  EXPECT_FALSE(set->Accepts("# lab tokens"));
}

TEST(TokenSetTest, RefusesAFileWithoutTokensOrWithInnerBlanks) {
  EXPECT_EQ(TokenSet::Parse("# only a comment\n\n").status().code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(TokenSet::Parse("two words\n").status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(TokenSet::FromFile("/nonexistent/tokens").status().code(),
            absl::StatusCode::kNotFound);
}

TEST(AuthenticatorTest, ChecksTheBearerTokenAndReloadsKeepingTokensOnError) {
  const std::string path = TempPath("tokens");
  WriteText(path, "first\n");
  absl::StatusOr<std::unique_ptr<Authenticator>> auth = Authenticator::FromFile(path);
  ASSERT_TRUE(auth.ok()) << auth.status();
  const Authenticator& a = **auth;
  EXPECT_TRUE(a.Check("Bearer first", true).ok());
  EXPECT_TRUE(a.Check("bearer first", true).ok());  // the scheme is case-insensitive
  EXPECT_EQ(a.Check("", false).code(), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(a.Check("first", true).code(), absl::StatusCode::kUnauthenticated);
  EXPECT_EQ(a.Check("Basic Zmlyc3Q=", true).code(), absl::StatusCode::kUnauthenticated);
  const absl::Status wrong = a.Check("Bearer second", true);
  EXPECT_EQ(wrong.code(), absl::StatusCode::kUnauthenticated);
  EXPECT_FALSE(absl::StrContains(wrong.message(), "second")) << "echoes the presented token";

  EXPECT_EQ(a.token_count(), 1);
  WriteText(path, "second\nthird\n");
  ASSERT_TRUE((*auth)->Reload().ok());
  EXPECT_EQ(a.token_count(), 2);
  EXPECT_EQ(a.Check("Bearer first", true).code(), absl::StatusCode::kUnauthenticated);
  EXPECT_TRUE(a.Check("Bearer second", true).ok());

  WriteText(path, "# emptied by mistake\n");
  EXPECT_FALSE((*auth)->Reload().ok());
  EXPECT_TRUE(a.Check("Bearer second", true).ok()) << "a bad reload must keep the old tokens";
  EXPECT_EQ(a.token_count(), 2);
  std::remove(path.c_str());
}

TEST(AuthenticatorTest, WithoutATokenFileEveryCallIsLetThrough) {
  Authenticator open;
  EXPECT_FALSE(open.enabled());
  EXPECT_EQ(open.token_count(), 0);
  EXPECT_TRUE(open.Check("", false).ok());
}

TEST(AdmissionTest, RefusesBeyondRunningPlusQueuedAndFreesOnDestruction) {
  Admission admission(1, 1);
  Admission::Ticket a, b, c;
  ASSERT_TRUE(admission.Enter(&a).ok());
  ASSERT_TRUE(admission.Enter(&b).ok());
  EXPECT_EQ(admission.Enter(&c).code(), absl::StatusCode::kResourceExhausted);
  EXPECT_FALSE(c.admitted());
  EXPECT_EQ(admission.queued(), 2);
  ASSERT_TRUE(a.AwaitSlot(Clock::now() + milliseconds(100), nullptr).ok());
  EXPECT_EQ(admission.running(), 1);
  EXPECT_EQ(admission.queued(), 1);
  // b waits for the one slot: it gives up at its deadline.
  const auto start = Clock::now();
  EXPECT_EQ(b.AwaitSlot(start + milliseconds(60), nullptr).code(),
            absl::StatusCode::kDeadlineExceeded);
  EXPECT_GE(Clock::now() - start, milliseconds(60));
  EXPECT_EQ(b.AwaitSlot(Clock::now() + milliseconds(500), [] { return true; }).code(),
            absl::StatusCode::kCancelled);
  a = Admission::Ticket();  // done: slot and place given back
  EXPECT_EQ(admission.running(), 0);
  ASSERT_TRUE(admission.Enter(&c).ok());
}

TEST(AdmissionTest, AFreedSlotWakesTheWaiter) {
  Admission admission(1, 4);
  Admission::Ticket a, b;
  ASSERT_TRUE(admission.Enter(&a).ok());
  ASSERT_TRUE(admission.Enter(&b).ok());
  ASSERT_TRUE(a.AwaitSlot(Clock::now() + milliseconds(100), nullptr).ok());
  std::thread release([&a] {
    std::this_thread::sleep_for(milliseconds(30));
    a.ReleaseSlot();
  });
  EXPECT_TRUE(b.AwaitSlot(Clock::now() + std::chrono::seconds(5), nullptr).ok());
  release.join();
  EXPECT_EQ(admission.running(), 1);
}

TEST(AdmissionTest, EstimatesShareTheMemoryBudgetAndOneAloneAlwaysRuns) {
  Admission admission(4, 4, 100);
  Admission::Ticket a, b, c;
  ASSERT_TRUE(admission.Enter(&a).ok());
  ASSERT_TRUE(admission.Enter(&b).ok());
  ASSERT_TRUE(a.AwaitSlot(Clock::now() + milliseconds(100), nullptr, 80).ok());
  EXPECT_EQ(admission.memory_in_use(), 80);
  // b's 50 would pass the budget beside a's 80: it waits, though slots are free.
  EXPECT_EQ(b.AwaitSlot(Clock::now() + milliseconds(60), nullptr, 50).code(),
            absl::StatusCode::kDeadlineExceeded);
  std::thread release([&a] {
    std::this_thread::sleep_for(milliseconds(30));
    a.ReleaseSlot();
  });
  EXPECT_TRUE(b.AwaitSlot(Clock::now() + std::chrono::seconds(5), nullptr, 50).ok());
  release.join();
  EXPECT_EQ(admission.memory_in_use(), 50);
  b = Admission::Ticket();
  EXPECT_EQ(admission.memory_in_use(), 0);
  // Alone, a call is never starved by the budget (the service refuses one
  // that could never fit before it gets here).
  ASSERT_TRUE(admission.Enter(&c).ok());
  EXPECT_TRUE(c.AwaitSlot(Clock::now() + milliseconds(100), nullptr, 150).ok());
}

TEST(UploadLimitsTest, CountsUploadsAndTheBytesTheyHold) {
  UploadLimits limits(2, 100);
  UploadLimits::Pass a, b, c;
  ASSERT_TRUE(limits.Enter(&a).ok());
  ASSERT_TRUE(limits.Enter(&b).ok());
  EXPECT_EQ(limits.Enter(&c).code(), absl::StatusCode::kResourceExhausted);
  ASSERT_TRUE(a.Hold(60).ok());
  EXPECT_EQ(b.Hold(41).code(), absl::StatusCode::kResourceExhausted);
  EXPECT_TRUE(b.Hold(40).ok());
  // A complete upload gives back its place but holds its bytes until decoded.
  a.EndUpload();
  EXPECT_EQ(limits.uploads(), 1);
  EXPECT_EQ(limits.held_bytes(), 100);
  ASSERT_TRUE(limits.Enter(&c).ok());
  a.Release(60);
  EXPECT_EQ(limits.held_bytes(), 40);
  b = UploadLimits::Pass();
  EXPECT_EQ(limits.held_bytes(), 0);
  EXPECT_EQ(limits.uploads(), 1);
}

TEST(WatchdogTest, AMovedDeadlineFiresAtItsNewTime) {
  Watchdog watchdog;
  std::atomic<int> expired{0};
  Watchdog::Guard guard(&watchdog, Clock::now() + milliseconds(50), [&] { ++expired; });
  guard.MoveTo(Clock::now() + std::chrono::seconds(60));
  std::this_thread::sleep_for(milliseconds(150));
  EXPECT_EQ(expired.load(), 0);
  guard.MoveTo(Clock::now() + milliseconds(10));
  std::this_thread::sleep_for(milliseconds(150));
  EXPECT_EQ(expired.load(), 1);
}

TEST(WatchdogTest, ExpiresOnlyGuardsStillAliveAtTheirDeadline) {
  Watchdog watchdog;
  std::atomic<int> expired{0};
  {
    Watchdog::Guard early(&watchdog, Clock::now() + milliseconds(20), [&] { ++expired; });
    std::this_thread::sleep_for(milliseconds(200));
    EXPECT_TRUE(early.expired());
  }
  // Guards that end before their deadline never fire, even while the
  // watchdog is waiting on them (the fuzzer found a use-after-free here).
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 200; ++i) {
        Watchdog::Guard g(&watchdog, Clock::now() + milliseconds(50 + i % 7), [&] { ++expired; });
      }
    });
  }
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(expired.load(), 1);
}

TEST(MetricsTest, RendersPrometheusTextWithCumulativeBuckets) {
  Metrics metrics;
  metrics.CountRequest("Estimate", "OK");
  metrics.CountRequest("Estimate", "OK");
  metrics.CountRequest("Estimate", "UNAUTHENTICATED");
  metrics.request_seconds.Observe(0.004);
  metrics.request_seconds.Observe(0.2);
  metrics.request_seconds.Observe(500.0);
  metrics.SetLoadSource([] { return Metrics::Load{3, 60, 60, 1 << 20}; });
  metrics.AddInFlight(2);
  const std::string text = metrics.Render();
  EXPECT_TRUE(absl::StrContains(text, "weavefit_requests_total{method=\"Estimate\",code=\"OK\"} 2\n"));
  EXPECT_TRUE(absl::StrContains(
      text, "weavefit_requests_total{method=\"Estimate\",code=\"UNAUTHENTICATED\"} 1\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_queue_depth 3\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_uploads_in_progress 60\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_upload_bytes_held 60\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_estimate_memory_bytes 1048576\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_requests_in_flight 2\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_request_seconds_bucket{le=\"0.0025\"} 0\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_request_seconds_bucket{le=\"0.005\"} 1\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_request_seconds_bucket{le=\"0.25\"} 2\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_request_seconds_bucket{le=\"120\"} 2\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_request_seconds_bucket{le=\"+Inf\"} 3\n"));
  EXPECT_TRUE(absl::StrContains(text, "weavefit_request_seconds_count 3\n"));
  EXPECT_TRUE(absl::StrContains(text, "# TYPE weavefit_received_bytes histogram\n"));
}

TEST(ServerOptionsTest, ANonLoopbackAddressNeedsTlsOrInsecureRemote) {
  EXPECT_TRUE(IsLoopbackAddress("127.0.0.1:50051"));
  EXPECT_TRUE(IsLoopbackAddress("localhost:0"));
  EXPECT_TRUE(IsLoopbackAddress("[::1]:50051"));
  EXPECT_FALSE(IsLoopbackAddress("0.0.0.0:50051"));
  EXPECT_FALSE(IsLoopbackAddress("[::]:50051"));
  EXPECT_FALSE(IsLoopbackAddress("10.0.0.5:50051"));
  EXPECT_TRUE(IsLoopbackAddress("127.8.9.10:1"));
  EXPECT_FALSE(IsLoopbackAddress("127.example.org:50051")) << "a name may resolve anywhere";
  EXPECT_FALSE(IsLoopbackAddress("1270.0.0.1:50051"));
  ServerOptions options;
  options.listen = "0.0.0.0:50051";
  const absl::Status refused = options.Validate();
  EXPECT_EQ(refused.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StrContains(refused.message(), "--insecure-remote")) << refused;
  options.insecure_remote = true;
  EXPECT_TRUE(options.Validate().ok());
  options.insecure_remote = false;
  options.tls_cert = "server.pem";
  EXPECT_FALSE(options.Validate().ok()) << "a certificate without its key";
  options.tls_key = "server.key";
  EXPECT_TRUE(options.Validate().ok());
}

// Metrics are plaintext HTTP whatever the gRPC port speaks; the health port
// stays allowed anywhere, for the node's probes.
TEST(ServerOptionsTest, ANonLoopbackMetricsAddressNeedsInsecureRemote) {
  ServerOptions options;
  options.metrics_listen = "127.0.0.1:9464";
  options.health_listen = "0.0.0.0:8081";
  EXPECT_TRUE(options.Validate().ok());
  options.metrics_listen = "0.0.0.0:9464";
  const absl::Status refused = options.Validate();
  EXPECT_EQ(refused.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_TRUE(absl::StrContains(refused.message(), "--metrics-listen")) << refused;
  EXPECT_TRUE(absl::StrContains(refused.message(), "--insecure-remote")) << refused;
  options.listen = "0.0.0.0:50051";
  options.tls_cert = "server.pem";
  options.tls_key = "server.key";
  EXPECT_EQ(options.Validate().code(), absl::StatusCode::kInvalidArgument)
      << "TLS on the gRPC port does not cover metrics";
  options.insecure_remote = true;
  EXPECT_TRUE(options.Validate().ok());
}

// The service behind an in-process channel.
class InProcessService : public ::testing::Test {
 protected:
  void Start(ServiceOptions options, const std::string& tokens = "") {
    if (!tokens.empty()) {
      token_path_ = TempPath("service_tokens");
      WriteText(token_path_, tokens);
      auth_ = *Authenticator::FromFile(token_path_);
    }
    service_ = std::make_unique<WeaveFitService>(options, auth_.get(), &metrics_);
    grpc::ServerBuilder builder;
    builder.RegisterService(service_.get());
    server_ = builder.BuildAndStart();
    channel_ = server_->InProcessChannel(grpc::ChannelArguments());
    stub_ = v1::WeaveFit::NewStub(channel_);
  }
  void TearDown() override {
    if (server_) server_->Shutdown(std::chrono::system_clock::now() + milliseconds(200));
    if (!token_path_.empty()) std::remove(token_path_.c_str());
  }

  // A whole call with `chunks` after the header; returns its status.
  grpc::Status Call(const std::vector<std::string>& chunks, const std::string& token = "") {
    grpc::ClientContext context;
    context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
    if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
    v1::EstimateReply reply;
    auto writer = stub_->Estimate(&context, &reply);
    v1::EstimateRequest message;
    message.mutable_header()->mutable_acquisition()->set_phase_angle_deg(10.0);
    message.mutable_header()->mutable_acquisition()->set_cylinder_diameter_mm(46.0);
    bool open = writer->Write(message);
    for (const std::string& chunk : chunks) {
      if (!open) break;
      message.set_chunk(chunk);
      open = writer->Write(message);
    }
    writer->WritesDone();
    return writer->Finish();
  }

  static std::string ReadFixture(const std::string& name) {
    std::ifstream in(std::string(FIXTURES_DIR) + "/" + name, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  static std::vector<std::string> Chunks(const std::string& bytes) {
    std::vector<std::string> chunks;
    for (std::size_t at = 0; at < bytes.size(); at += 1 << 20) chunks.push_back(bytes.substr(at, 1 << 20));
    return chunks;
  }

  Metrics metrics_;
  std::string token_path_;
  std::unique_ptr<Authenticator> auth_;
  std::unique_ptr<WeaveFitService> service_;
  std::unique_ptr<grpc::Server> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::WeaveFit::Stub> stub_;
};

TEST_F(InProcessService, ACallWithoutAValidTokenIsUnauthenticated) {
  Start(ServiceOptions(), "lab-token\n");
  EXPECT_EQ(Call({"x"}).error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(Call({"x"}, "guess").error_code(), grpc::StatusCode::UNAUTHENTICATED);
  // Past the check, the (not an image) upload is what is refused.
  EXPECT_EQ(Call({"not an image"}, "lab-token").error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_TRUE(absl::StrContains(metrics_.Render(),
                                "{method=\"Estimate\",code=\"UNAUTHENTICATED\"} 2"));
}

TEST_F(InProcessService, TooManyChunksAreRefused) {
  ServiceOptions options;
  options.max_chunks = 2;
  Start(options);
  EXPECT_EQ(Call({"a", "b", "c"}).error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED);
  EXPECT_EQ(Call({"a", "b"}).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
}

// Opens a call that sends its header and `bytes` of image, then stalls.
struct StalledUpload {
  StalledUpload(v1::WeaveFit::Stub* stub, std::size_t bytes) {
    writer = stub->Estimate(&context, &reply);
    v1::EstimateRequest message;
    message.mutable_header()->mutable_acquisition()->set_phase_angle_deg(10.0);
    open = writer->Write(message);
    if (open && bytes > 0) {
      message.set_chunk(std::string(bytes, 'x'));
      open = writer->Write(message);
    }
  }
  grpc::ClientContext context;
  v1::EstimateReply reply;
  std::unique_ptr<grpc::ClientWriter<v1::EstimateRequest>> writer;
  bool open = false;
};

template <typename Predicate>
bool WaitFor(Predicate done) {
  const auto deadline = Clock::now() + std::chrono::seconds(5);
  while (!done() && Clock::now() < deadline) std::this_thread::sleep_for(milliseconds(5));
  return done();
}

TEST_F(InProcessService, StalledUploadsHoldNoEstimationSlot) {
  ServiceOptions options;
  options.workers = 2;
  options.max_queue = 4;
  Start(options);
  // Sixty clients send a header and a byte and then nothing: before uploads
  // and estimates were separate resources, six of them took every slot.
  std::vector<std::unique_ptr<StalledUpload>> stalled;
  for (int i = 0; i < 60; ++i) stalled.push_back(std::make_unique<StalledUpload>(stub_.get(), 1));
  ASSERT_TRUE(WaitFor([&] { return service_->upload_limits().uploads() == 60; }));
  EXPECT_EQ(service_->admission().queued(), 0);
  const std::string image = ReadFixture("gauze_sinusoid_p10.png");
  const grpc::Status status = Call(Chunks(image));
  EXPECT_TRUE(status.ok()) << status.error_message();
  for (auto& s : stalled) s->context.TryCancel();
}

TEST_F(InProcessService, BeyondTheUploadLimitACallIsRefusedAtOnceAndACancelledOneFreesItsPlace) {
  ServiceOptions options;
  options.max_uploads = 1;
  Start(options);
  auto held = std::make_unique<StalledUpload>(stub_.get(), 0);
  ASSERT_TRUE(WaitFor([&] { return service_->upload_limits().uploads() == 1; }));
  const auto start = Clock::now();
  const grpc::Status refused = Call({"x"});
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_TRUE(absl::StrContains(refused.error_message(), "--max-uploads"));
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(2)) << "refused at once, not queued";
  // It goes away mid-upload: its place is given back.
  held->context.TryCancel();
  EXPECT_EQ(held->writer->Finish().error_code(), grpc::StatusCode::CANCELLED);
  ASSERT_TRUE(WaitFor([&] { return service_->upload_limits().uploads() == 0; }));
  EXPECT_EQ(Call({"not an image"}).error_code(), grpc::StatusCode::INVALID_ARGUMENT);
}

TEST_F(InProcessService, TheBytesAllUploadsHoldAreBounded) {
  ServiceOptions options;
  options.max_upload_memory_bytes = 3 << 20;
  Start(options);
  StalledUpload first(stub_.get(), 1 << 20);
  StalledUpload second(stub_.get(), 1 << 20);
  ASSERT_TRUE(WaitFor([&] { return service_->upload_limits().held_bytes() == 2 << 20; }));
  const grpc::Status refused = Call({std::string(1 << 20, 'y'), std::string(1 << 20, 'z')});
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_TRUE(absl::StrContains(refused.error_message(), "--max-upload-memory-mb"));
  first.context.TryCancel();
  second.context.TryCancel();
  ASSERT_TRUE(WaitFor([&] { return service_->upload_limits().held_bytes() == 0; }));
}

TEST_F(InProcessService, AnIdleUploadIsCutWithDeadlineExceeded) {
  ServiceOptions options;
  options.upload_idle_s = 0.3;
  Start(options);
  StalledUpload idle(stub_.get(), 100);
  ASSERT_TRUE(idle.open);
  const auto start = Clock::now();
  const grpc::Status status = idle.writer->Finish();  // never sends WritesDone
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << status.error_message();
  EXPECT_TRUE(absl::StrContains(status.error_message(), "--upload-idle-s")) << status.error_message();
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(5));
  EXPECT_TRUE(WaitFor([&] { return service_->upload_limits().uploads() == 0; }));
}

TEST_F(InProcessService, AStalledUploadIsCutOffAtTheDaemonsDeadline) {
  ServiceOptions options;
  options.deadline_s = 0.3;
  Start(options);
  grpc::ClientContext context;  // no deadline of its own
  v1::EstimateReply reply;
  auto writer = stub_->Estimate(&context, &reply);
  v1::EstimateRequest header;
  header.mutable_header()->mutable_acquisition()->set_phase_angle_deg(10.0);
  ASSERT_TRUE(writer->Write(header));
  const auto start = Clock::now();
  const grpc::Status status = writer->Finish();  // never sends WritesDone
  EXPECT_EQ(status.error_code(), grpc::StatusCode::DEADLINE_EXCEEDED) << status.error_message();
  EXPECT_TRUE(absl::StrContains(status.error_message(), "deadline")) << status.error_message();
  EXPECT_LT(Clock::now() - start, std::chrono::seconds(5));
  // The client has its answer; the call is counted at the same time.
  EXPECT_TRUE(WaitFor([&] {
    return absl::StrContains(metrics_.Render(), "code=\"DEADLINE_EXCEEDED\"} 1");
  })) << metrics_.Render();
  EXPECT_TRUE(WaitFor([&] { return service_->upload_limits().uploads() == 0; }));
}

TEST_F(InProcessService, APhotographBeyondTheMemoryBudgetIsRefusedBeforeDecoding) {
  ServiceOptions options;
  options.memory_budget_bytes = 256 << 10;  // the 320x240 16-bit fixture needs about 0.7 MiB
  Start(options);
  const grpc::Status status = Call(Chunks(ReadFixture("gauze_sinusoid_p10.png")));
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_TRUE(absl::StrContains(status.error_message(), "--memory-budget-mb"));
}

}  // namespace
}  // namespace weavefit
