// weavefitd under load from many clients at once, with a mix of good, broken,
// oversized and abandoned calls: every call gets a definite answer (OK, or
// the status its input deserves, or RESOURCE_EXHAUSTED when the queue is
// full), the daemon's memory stays bounded, and afterwards nothing is left in
// flight and it still serves. WEAVEFIT_LOAD_CLIENTS and WEAVEFIT_LOAD_CALLS
// scale it up (the ctest "long" variant runs 32 clients x 40 calls).
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "tests/test_support.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit::testing {
namespace {

int EnvInt(const char* name, int fallback) {
  const char* value = std::getenv(name);
  int parsed = 0;
  return value != nullptr && absl::SimpleAtoi(value, &parsed) && parsed > 0 ? parsed : fallback;
}

// The daemon's peak resident memory, MiB (VmHWM).
double PeakRssMb(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (absl::StartsWith(line, "VmHWM:")) {
      double kb = 0;
      (void)absl::SimpleAtod(line.substr(6, line.size() - 6 - 3), &kb);
      return kb / 1024.0;
    }
  }
  return -1.0;
}

enum class Kind { kGood, kGarbage, kOversized, kAbandoned };

grpc::StatusCode OneCall(v1::WeaveFit::Stub& stub, Kind kind, const std::string& image) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  v1::EstimateReply reply;
  auto writer = stub.Estimate(&context, &reply);
  v1::EstimateRequest message;
  message.mutable_header()->mutable_acquisition()->set_phase_angle_deg(10.0);
  message.mutable_header()->mutable_acquisition()->set_cylinder_diameter_mm(46.0);
  message.mutable_header()->set_total_bytes(kind == Kind::kOversized ? (1ULL << 40) : 0);
  bool open = writer->Write(message);
  if (kind == Kind::kAbandoned) {
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    context.TryCancel();
    return writer->Finish().error_code();
  }
  const std::string bytes = kind == Kind::kGarbage ? std::string(5000, 'x') : image;
  for (std::size_t at = 0; open && at < bytes.size(); at += 1 << 20) {
    message.set_chunk(bytes.substr(at, 1 << 20));
    open = writer->Write(message);
  }
  writer->WritesDone();
  return writer->Finish().error_code();
}

TEST(Load, EveryCallGetsADefiniteAnswerAndTheDaemonStaysBounded) {
  const int clients = EnvInt("WEAVEFIT_LOAD_CLIENTS", 8);
  const int calls = EnvInt("WEAVEFIT_LOAD_CALLS", 6);
  Daemon daemon({"--max-queue", "2",  // and --workers 2 (Daemon)
                 "--metrics-listen", "127.0.0.1:0"});
  ASSERT_TRUE(daemon.running());
  const std::string image = ReadFileOrDie(std::string(FIXTURES_DIR) + "/sin_m024_p10_quiet.png");
  const auto channel = grpc::CreateChannel(daemon.address(), grpc::InsecureChannelCredentials());
  std::mutex mutex;
  std::map<std::pair<Kind, grpc::StatusCode>, int> outcomes;
  std::vector<std::thread> threads;
  for (int c = 0; c < clients; ++c) {
    threads.emplace_back([&, c] {
      auto stub = v1::WeaveFit::NewStub(channel);
      std::mt19937 random(c + 1);
      for (int i = 0; i < calls; ++i) {
        const int pick = static_cast<int>(random() % 10);
        const Kind kind = pick < 7 ? Kind::kGood
                        : pick == 7 ? Kind::kGarbage
                        : pick == 8 ? Kind::kOversized
                                    : Kind::kAbandoned;
        const grpc::StatusCode code = OneCall(*stub, kind, image);
        std::lock_guard<std::mutex> lock(mutex);
        ++outcomes[{kind, code}];
      }
    });
  }
  for (std::thread& t : threads) t.join();

  int total = 0, ok = 0, refused = 0;
  for (const auto& [key, count] : outcomes) {
    const auto [kind, code] = key;
    total += count;
    if (code == grpc::StatusCode::RESOURCE_EXHAUSTED) {
      refused += count;  // any kind may meet a full queue
      continue;
    }
    switch (kind) {
      case Kind::kGood:
        EXPECT_EQ(code, grpc::StatusCode::OK) << count << " good calls";
        ok += code == grpc::StatusCode::OK ? count : 0;
        break;
      case Kind::kGarbage:
        EXPECT_EQ(code, grpc::StatusCode::INVALID_ARGUMENT) << count << " garbage calls";
        break;
      case Kind::kOversized:
        ADD_FAILURE() << "an oversized upload got " << code;
        break;
      case Kind::kAbandoned:
        EXPECT_EQ(code, grpc::StatusCode::CANCELLED) << count << " abandoned calls";
        break;
    }
  }
  EXPECT_EQ(total, clients * calls);
  EXPECT_GT(ok, 0);
  std::cout << clients << " clients x " << calls << " calls: " << ok << " estimated, " << refused
            << " refused with RESOURCE_EXHAUSTED; daemon peak RSS " << PeakRssMb(daemon.pid())
            << " MiB\n";
  // Bounded by (running + queued) uploads and estimates, not by the load.
  EXPECT_LT(PeakRssMb(daemon.pid()), 1024.0);
  EXPECT_TRUE(daemon.running());
  // Nothing is left in flight or queued once every client has its answer
  // (the handlers finish just after their clients hear back).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  std::string metrics;
  do {
    metrics = HttpGet(daemon.metrics_port(), "/metrics");
    if (absl::StrContains(metrics, "weavefit_requests_in_flight 0\n")) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  } while (std::chrono::steady_clock::now() < deadline);
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_requests_in_flight 0\n")) << metrics;
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_queue_depth 0\n")) << metrics;
  const CommandResult after = RunCommand({WEAVEFIT_PATH, "submit", "--server", daemon.address(),
                                          std::string(FIXTURES_DIR) + "/smooth_p10.png"});
  EXPECT_EQ(after.exit_code, 0) << after.err;
}

}  // namespace
}  // namespace weavefit::testing
