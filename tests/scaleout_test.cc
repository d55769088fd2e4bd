// Scale-out (issue 8): three weavefitd daemons on loopback ports behind one
// `weavefit submit --server a,b,c`, gRPC's round_robin spreading the calls;
// then one daemon killed mid-batch, and the batch still completing through
// the others (the client's retries on UNAVAILABLE, round_robin dropping the
// dead backend). Through the real binaries (STYLE.md "Tests").
#include <arpa/inet.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "grpc/health/v1/health.grpc.pb.h"
#include "tests/test_support.h"

namespace weavefit::testing {
namespace {

const std::string kFixtures = FIXTURES_DIR;
constexpr std::size_t kBatch = 30;

bool Serving(const std::string& address) {
  auto stub = grpc::health::v1::Health::NewStub(
      grpc::CreateChannel(address, grpc::InsecureChannelCredentials()));
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
  grpc::health::v1::HealthCheckRequest request;
  request.set_service("weavefit.v1.WeaveFit");  // readiness, not only liveness
  grpc::health::v1::HealthCheckResponse response;
  return stub->Check(&context, request, &response).ok() &&
         response.status() == grpc::health::v1::HealthCheckResponse::SERVING;
}

// Calls a daemon finished ("Estimate peer=... outcome=..." per call).
int Served(const Daemon& daemon) {
  const std::string log = daemon.Log();
  int n = 0;
  for (std::size_t at = log.find("Estimate peer="); at != std::string::npos;
       at = log.find("Estimate peer=", at + 1)) {
    ++n;
  }
  return n;
}

// weavefit_requests_in_flight from a daemon's Prometheus endpoint (-1 when
// it does not answer).
int InFlight(int metrics_port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(metrics_port));
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string response;
  if (connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)) == 0) {
    const std::string request = "GET /metrics HTTP/1.0\r\nHost: localhost\r\n\r\n";
    if (write(fd, request.data(), request.size()) == static_cast<ssize_t>(request.size())) {
      char buffer[4096];
      ssize_t n;
      while ((n = read(fd, buffer, sizeof(buffer))) > 0) response.append(buffer, n);
    }
  }
  close(fd);
  const std::string key = "\nweavefit_requests_in_flight ";
  const std::size_t at = response.find(key);
  return at == std::string::npos ? -1 : std::atoi(response.c_str() + at + key.size());
}

// The CSV on stdout: per image, its cells by column name (the columns
// before `warnings`, the only one that may be quoted).
std::map<std::string, std::map<std::string, std::string>> ParseCsv(const std::string& csv) {
  std::map<std::string, std::map<std::string, std::string>> rows;
  const std::vector<std::string> lines = absl::StrSplit(csv, '\n', absl::SkipEmpty());
  if (lines.empty()) return rows;
  const std::vector<std::string> header = absl::StrSplit(lines[0], ',');
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> cells = absl::StrSplit(lines[i], ',');
    std::map<std::string, std::string> row;
    for (std::size_t c = 0; c + 1 < header.size() && c < cells.size(); ++c) {
      row[header[c]] = cells[c];
    }
    rows[row["image"]] = row;
  }
  return rows;
}

class ScaleOut : public ::testing::Test {
 protected:
  void SetUp() override {
    // The second, the one killed below, serves metrics (its calls in flight).
    daemons_.push_back(std::make_unique<Daemon>());
    daemons_.push_back(std::make_unique<Daemon>(
        std::vector<std::string>{"--metrics-listen", "127.0.0.1:0"}));
    daemons_.push_back(std::make_unique<Daemon>());
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    for (const auto& d : daemons_) {
      while (!Serving(d->address()) && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
      ASSERT_TRUE(Serving(d->address())) << d->address() << "\n" << d->Log();
    }
    const std::vector<std::string> all = FixtureImages(kFixtures);
    ASSERT_GE(all.size(), kBatch);
    images_.assign(all.begin(), all.begin() + kBatch);
  }

  std::string Servers() const {
    std::vector<std::string> addresses;
    for (const auto& d : daemons_) addresses.push_back(d->address());
    return absl::StrJoin(addresses, ",");
  }

  // weavefit submit over the batch to all three daemons, CSV on stdout.
  CommandResult SubmitBatch() const {
    std::vector<std::string> args = {WEAVEFIT_PATH, "submit", "--server", Servers(),
                                     "--jobs", "4", "--format", "csv",
                                     // A loaded 2-core machine: room for slow calls.
                                     "--timeout-s", "120", "--retries", "5"};
    args.insert(args.end(), images_.begin(), images_.end());
    return RunCommand(args);
  }

  // Every image of the batch has one OK row, its umax arctan of its slope.
  void ExpectAllOk(const CommandResult& run) const {
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto rows = ParseCsv(run.out);
    EXPECT_EQ(rows.size(), images_.size()) << run.out;
    for (const std::string& image : images_) {
      SCOPED_TRACE(image);
      auto it = rows.find(image);
      ASSERT_NE(it, rows.end()) << run.out;
      const auto& row = it->second;
      EXPECT_EQ(row.at("status"), "OK");
      if (!row.at("max_slope").empty()) {
        EXPECT_NEAR(std::stod(row.at("max_inclination_deg")),
                    std::atan(std::stod(row.at("max_slope"))) * 180.0 / M_PI, 1e-7);
      } else {
        EXPECT_EQ(row.at("max_inclination_deg"), "");
      }
    }
  }

  std::vector<std::unique_ptr<Daemon>> daemons_;
  std::vector<std::string> images_;
};

TEST_F(ScaleOut, EveryDaemonServesPartOfTheBatch) {
  const CommandResult run = SubmitBatch();
  ExpectAllOk(run);
  int total = 0;
  for (const auto& d : daemons_) {
    const int served = Served(*d);
    std::cout << d->address() << " served " << served << " of " << kBatch << "\n";
    // round_robin: a share each, not all on one (a third each when all are
    // ready from the start; a daemon slow to connect gets fewer).
    EXPECT_GE(served, 2) << d->address();
    total += served;
  }
  EXPECT_GE(total, static_cast<int>(kBatch));
}

TEST_F(ScaleOut, TheBatchCompletesWhenADaemonIsKilledMidway) {
  std::atomic<bool> finished{false};
  CommandResult run;
  std::thread batch([&] {
    run = SubmitBatch();
    finished = true;
  });
  // Kill the second daemon while it holds a call of this batch, once it
  // has finished one (so it surely was in the rotation).
  Daemon& victim = *daemons_[1];
  ASSERT_GT(victim.metrics_port(), 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (!finished && std::chrono::steady_clock::now() < deadline &&
         !(Served(victim) >= 1 && InFlight(victim.metrics_port()) >= 1)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  const bool killed_mid_batch = !finished;
  victim.Signal(SIGKILL);
  const int victim_served = Served(victim);
  batch.join();
  std::size_t retries = 0;
  for (std::size_t at = run.err.find("; retry "); at != std::string::npos;
       at = run.err.find("; retry ", at + 1)) {
    ++retries;
  }
  // Retries happen when the kill caught a call in flight (almost always:
  // the kill follows the metrics within a millisecond or two); round_robin
  // keeps later calls off the dead daemon either way.
  std::cout << "killed " << victim.address() << " after it served " << victim_served
            << (killed_mid_batch ? " (mid-batch)" : " (after the batch!)") << "; " << retries
            << " retries\nclient stderr:\n"
            << run.err;
  EXPECT_TRUE(killed_mid_batch) << "the batch ended before the daemon was killed";
  ExpectAllOk(run);
  EXPECT_FALSE(victim.running());
  // The other two finished the rest.
  const int survivors = Served(*daemons_[0]) + Served(*daemons_[2]);
  EXPECT_GE(survivors + victim_served, static_cast<int>(kBatch));
  EXPECT_GT(survivors, 0);
}

}  // namespace
}  // namespace weavefit::testing
