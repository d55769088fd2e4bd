// weavefitd under load from many clients at once, with a mix of good, broken,
// oversized and abandoned calls: every call gets a definite answer (OK, or
// the status its input deserves, or RESOURCE_EXHAUSTED when the queue is
// full), the daemon's memory stays bounded, and afterwards nothing is left in
// flight and it still serves. A warm-up run at the same load comes first;
// memory, open files and threads are compared after it. WEAVEFIT_LOAD_CLIENTS
// (16) and WEAVEFIT_LOAD_CALLS (3) scale it (the ctest "long" variant runs 32
// clients x 40 calls).
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <dirent.h>

#include <algorithm>
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
#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "tests/test_support.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit::testing {
namespace {

// The sanitize preset builds the daemon and this test with AddressSanitizer.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kUnderAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kUnderAddressSanitizer = true;
#else
constexpr bool kUnderAddressSanitizer = false;
#endif
#else
constexpr bool kUnderAddressSanitizer = false;
#endif

int EnvInt(const char* name, int fallback) {
  const char* value = std::getenv(name);
  int parsed = 0;
  return value != nullptr && absl::SimpleAtoi(value, &parsed) && parsed > 0 ? parsed : fallback;
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
  const grpc::StatusCode code = writer->Finish().error_code();
  if (code == grpc::StatusCode::OK) ExpectFiniteReply(reply);
  return code;
}

// A line of /proc/PID/status ("VmRSS:", "VmHWM:", "Threads:") as a number
// (kB for the memory lines).
double ProcStatus(pid_t pid, const std::string& key) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (absl::StartsWith(line, key)) {
      std::string value = line.substr(key.size());
      absl::StripAsciiWhitespace(&value);
      value = value.substr(0, value.find(' '));
      double parsed = -1;
      (void)absl::SimpleAtod(value, &parsed);
      return parsed;
    }
  }
  return -1;
}

int OpenFiles(pid_t pid) {
  int n = 0;
  if (DIR* dir = opendir(("/proc/" + std::to_string(pid) + "/fd").c_str())) {
    while (readdir(dir) != nullptr) ++n;
    closedir(dir);
  }
  return n - 2;  // . and ..
}

struct Outcomes {
  std::map<std::pair<Kind, grpc::StatusCode>, int> counts;
  std::vector<double> good_ms;  // latency of the valid calls that succeeded
};

Outcomes RunLoad(const std::shared_ptr<grpc::Channel>& channel, int clients, int calls,
                 const std::string& image) {
  Outcomes outcomes;
  std::mutex mutex;
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
        const auto start = std::chrono::steady_clock::now();
        const grpc::StatusCode code = OneCall(*stub, kind, image);
        const double ms = std::chrono::duration<double, std::milli>(
                              std::chrono::steady_clock::now() - start).count();
        std::lock_guard<std::mutex> lock(mutex);
        ++outcomes.counts[{kind, code}];
        if (kind == Kind::kGood && code == grpc::StatusCode::OK) outcomes.good_ms.push_back(ms);
      }
    });
  }
  for (std::thread& t : threads) t.join();
  return outcomes;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * (v.size() - 1) + 0.5)];
}

// Waits until the daemon reports nothing in flight or queued.
std::string QuietMetrics(const Daemon& daemon) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  std::string metrics;
  do {
    metrics = HttpGet(daemon.metrics_port(), "/metrics");
    if (absl::StrContains(metrics, "weavefit_requests_in_flight 0\n")) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  } while (std::chrono::steady_clock::now() < deadline);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // connections settle
  return metrics;
}

TEST(Load, EveryCallGetsADefiniteAnswerAndTheDaemonStaysBounded) {
  const int clients = EnvInt("WEAVEFIT_LOAD_CLIENTS", 16);
  const int calls = EnvInt("WEAVEFIT_LOAD_CALLS", 3);
  Daemon daemon({"--max-queue", "2",  // and --workers 2 (Daemon)
                 "--metrics-listen", "127.0.0.1:0"});
  ASSERT_TRUE(daemon.running());
  const std::string image = ReadFileOrDie(std::string(FIXTURES_DIR) + "/sin_m024_p10_quiet.png");
  const auto channel = grpc::CreateChannel(daemon.address(), grpc::InsecureChannelCredentials());

  // A warm-up run at the same load: glibc keeps freed arenas and gRPC grows
  // its thread pool on demand, so growth is judged after it.
  (void)RunLoad(channel, clients, calls, image);
  (void)QuietMetrics(daemon);
  const pid_t pid = daemon.pid();
  const double rss_warm_kb = ProcStatus(pid, "VmRSS:");
  const int files_warm = OpenFiles(pid);
  const double threads_warm = ProcStatus(pid, "Threads:");

  const auto start = std::chrono::steady_clock::now();
  const Outcomes outcomes = RunLoad(channel, clients, calls, image);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const std::string metrics = QuietMetrics(daemon);

  int total = 0, ok = 0;
  std::map<std::string, int> by_status;
  for (const auto& [key, count] : outcomes.counts) {
    const auto [kind, code] = key;
    total += count;
    by_status[absl::StatusCodeToString(static_cast<absl::StatusCode>(code))] += count;
    if (code == grpc::StatusCode::RESOURCE_EXHAUSTED) continue;  // any kind, a full queue
    switch (kind) {
      case Kind::kGood:
        EXPECT_EQ(code, grpc::StatusCode::OK) << count << " valid calls";
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
  const double rss_after_kb = ProcStatus(pid, "VmRSS:");
  const int files_after = OpenFiles(pid);
  const double threads_after = ProcStatus(pid, "Threads:");
  std::string statuses;
  for (const auto& [name, count] : by_status) absl::StrAppend(&statuses, " ", name, "=", count);
  std::cout << clients << " clients x " << calls << " calls in " << wall_s << " s:" << statuses
            << "; valid calls estimated " << ok << ", latency p50 "
            << Quantile(outcomes.good_ms, 0.5) << " ms, p99 " << Quantile(outcomes.good_ms, 0.99)
            << " ms; daemon RSS after warm-up " << rss_warm_kb / 1024 << " MiB, after the run "
            << rss_after_kb / 1024 << " MiB, peak " << ProcStatus(pid, "VmHWM:") / 1024
            << " MiB; open files " << files_warm << " -> " << files_after << ", threads "
            << threads_warm << " -> " << threads_after << "\n";
  if (!kUnderAddressSanitizer) {  // its quarantine holds freed memory on purpose
    EXPECT_LT(rss_after_kb, 1.10 * rss_warm_kb) << "memory grew by more than 10% after warm-up";
  }
  EXPECT_LE(files_after, files_warm) << "file descriptors leaked";
  EXPECT_LE(threads_after, threads_warm + 2) << "threads leaked";
  EXPECT_LT(ProcStatus(pid, "VmHWM:") / 1024, 1024.0) << "bounded by the admission limit";
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_requests_in_flight 0\n")) << metrics;
  EXPECT_TRUE(absl::StrContains(metrics, "weavefit_queue_depth 0\n")) << metrics;
  EXPECT_TRUE(daemon.running());
  const CommandResult after = RunCommand({WEAVEFIT_PATH, "submit", "--server", daemon.address(),
                                          std::string(FIXTURES_DIR) + "/smooth_p10.png"});
  EXPECT_EQ(after.exit_code, 0) << after.err;
}

}  // namespace
}  // namespace weavefit::testing
