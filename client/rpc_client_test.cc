// Unit tests of client/rpc_client: the gRPC target a --server value becomes
// (names resolved by a fake, so no DNS), the bearer token's sources, and
// waiting for a server to come up (an in-process one on loopback).
#include "client/rpc_client.h"

#include <arpa/inet.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <iostream>
#include <map>
#include <thread>
#include <vector>

#include "tests/temp_dir.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit {
namespace {

// A resolver that knows a few names and counts its calls.
struct FakeDns {
  std::map<std::string, std::vector<std::string>> names = {
      {"alpha", {"10.0.0.1"}},
      {"beta", {"10.0.0.2", "fd00::2"}},
      {"gamma6", {"fd00::3"}},
      {"localhost", {"::1", "127.0.0.1"}},
  };
  int calls = 0;
  HostResolver resolver() {
    return [this](const std::string& host) -> absl::StatusOr<std::vector<std::string>> {
      ++calls;
      auto it = names.find(host);
      if (it == names.end()) return absl::UnavailableError("cannot resolve '" + host + "'");
      return it->second;
    };
  }
};

TEST(ChannelTargetTest, OneAddressOrASchemeIsPassedOn) {
  FakeDns dns;
  for (const char* server :
       {"127.0.0.1:50051", "localhost:50051", "dns:///weavefitd.lab.svc.cluster.local:50051",
        "ipv4:10.0.0.1:1,10.0.0.2:2", "unix:/run/weavefitd.sock", "[::1]:50051"}) {
    absl::StatusOr<ChannelTarget> target = ChannelTargetFor(server, dns.resolver());
    ASSERT_TRUE(target.ok()) << server << ": " << target.status();
    EXPECT_EQ(target->target, server);
    EXPECT_EQ(target->authority, "");
  }
  EXPECT_EQ(ChannelTargetFor("  10.0.0.1:1  ", dns.resolver())->target, "10.0.0.1:1");
  EXPECT_EQ(dns.calls, 0);  // gRPC resolves these itself
}

TEST(ChannelTargetTest, ALoopbackListBecomesOneIpv4Target) {
  FakeDns dns;
  absl::StatusOr<ChannelTarget> target =
      ChannelTargetFor("127.0.0.1:5001,127.0.0.1:5002, 127.0.0.1:5003", dns.resolver());
  ASSERT_TRUE(target.ok()) << target.status();
  EXPECT_EQ(target->target, "ipv4:127.0.0.1:5001,127.0.0.1:5002,127.0.0.1:5003");
  EXPECT_EQ(target->authority, "127.0.0.1:5001");
  EXPECT_EQ(dns.calls, 0);
}

TEST(ChannelTargetTest, NamesAreResolvedAndOneFamilyChosen) {
  FakeDns dns;
  // Every entry has IPv4: IPv4.
  absl::StatusOr<ChannelTarget> v4 = ChannelTargetFor("alpha:50051,beta:50052", dns.resolver());
  ASSERT_TRUE(v4.ok()) << v4.status();
  EXPECT_EQ(v4->target, "ipv4:10.0.0.1:50051,10.0.0.2:50052");
  EXPECT_EQ(v4->authority, "alpha:50051");
  // One entry has only IPv6 and every entry has IPv6: IPv6.
  absl::StatusOr<ChannelTarget> v6 =
      ChannelTargetFor("beta:1,gamma6:2,[fd00::9]:3", dns.resolver());
  ASSERT_TRUE(v6.ok()) << v6.status();
  EXPECT_EQ(v6->target, "ipv6:[fd00::2]:1,[fd00::3]:2,[fd00::9]:3");
  EXPECT_EQ(v6->authority, "beta:1");
  // localhost has both: IPv4 with the IPv4 entries.
  EXPECT_EQ(ChannelTargetFor("localhost:1,127.0.0.1:2", dns.resolver())->target,
            "ipv4:127.0.0.1:1,127.0.0.1:2");
  // A trailing comma is no entry.
  EXPECT_EQ(ChannelTargetFor("alpha:1,", dns.resolver())->target, "alpha:1");
}

TEST(ChannelTargetTest, MistakesAreNamed) {
  FakeDns dns;
  struct Case {
    std::string server;
    absl::StatusCode code;
    std::string expect;
  };
  const std::vector<Case> cases = {
      {"", absl::StatusCode::kInvalidArgument, "empty"},
      {"alpha,beta:1", absl::StatusCode::kInvalidArgument, "'alpha' is not host:port"},
      {"alpha:0,beta:1", absl::StatusCode::kInvalidArgument, "'alpha:0'"},
      {"alpha:99999,beta:1", absl::StatusCode::kInvalidArgument, "'alpha:99999'"},
      {"alpha:x,beta:1", absl::StatusCode::kInvalidArgument, "'alpha:x'"},
      {"fd00::1:5,beta:1", absl::StatusCode::kInvalidArgument, "in brackets"},
      {"[fd00::1,beta:1", absl::StatusCode::kInvalidArgument, "']'"},
      {"alpha:1,nowhere:2", absl::StatusCode::kUnavailable, "nowhere"},
      {"alpha:1,gamma6:2", absl::StatusCode::kInvalidArgument, "one address family"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.server);
    absl::StatusOr<ChannelTarget> target = ChannelTargetFor(c.server, dns.resolver());
    ASSERT_FALSE(target.ok()) << target->target;
    EXPECT_EQ(target.status().code(), c.code);
    EXPECT_NE(target.status().message().find(c.expect), absl::string_view::npos)
        << target.status().message();
  }
}

TEST(ChannelTargetTest, TheSystemResolverKnowsLocalhost) {
  absl::StatusOr<std::vector<std::string>> addresses = ResolveHost("localhost");
  ASSERT_TRUE(addresses.ok()) << addresses.status();
  EXPECT_FALSE(addresses->empty());
}

TEST(ConnectionTest, TokenFromTheFileElseTheEnvironment) {
  const std::string path = testing::MakeTempDir() + "/rpc_client_test_token";
  std::ofstream(path) << "  s3cret \nsecond line\n";
  Connection c;
  ASSERT_TRUE(c.LoadToken(path).ok());
  EXPECT_EQ(c.token, "s3cret");
  setenv("WEAVEFIT_TOKEN", "from-env", 1);
  Connection e;
  ASSERT_TRUE(e.LoadToken("").ok());
  EXPECT_EQ(e.token, "from-env");
  unsetenv("WEAVEFIT_TOKEN");
  std::ofstream(path) << "\n";
  EXPECT_EQ(Connection().LoadToken(path).code(), absl::StatusCode::kInvalidArgument);
}

TEST(ClientTest, ConnectRefusesABadServerList) {
  Connection c;
  c.server = "alpha,beta";
  EXPECT_EQ(Client::Connect(c).status().code(), absl::StatusCode::kInvalidArgument);
  c.server = "127.0.0.1:1,127.0.0.1:2";
  EXPECT_TRUE(Client::Connect(c).ok());  // no connection is made until a call
}

// A loopback port nothing listens on (yet).
int FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t length = sizeof(address);
  bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address));
  getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length);
  close(fd);
  return ntohs(address.sin_port);
}

// CPU time of this process so far, user and system, s.
double CpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// Four waiters on one channel while its server is away, as the workers of a
// batch are when the daemon restarts (issue 30): each sees the server once
// it listens, and none burns CPU meanwhile.
TEST(ClientTest, WaitersBlockUntilTheServerListens) {
  const std::string address = "127.0.0.1:" + std::to_string(FreePort());
  Connection c;
  c.server = address;
  absl::StatusOr<Client> client = Client::Connect(c);
  ASSERT_TRUE(client.ok()) << client.status();
  EXPECT_FALSE(client->Connected());
  EXPECT_FALSE(client->WaitForConnected(0.0));
  EXPECT_FALSE(client->WaitForConnected(0.3));

  const double cpu_before_s = CpuSeconds();
  std::atomic<int> connected{0};
  std::vector<std::thread> waiters;
  for (int w = 0; w < 4; ++w) {
    waiters.emplace_back([&] { connected += client->WaitForConnected(30.0) ? 1 : 0; });
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  // The service unimplemented: connecting needs none, but gRPC wants one.
  v1::WeaveFit::Service service;
  grpc::ServerBuilder builder;
  builder.AddListeningPort(address, grpc::InsecureServerCredentials());
  builder.RegisterService(&service);
  std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
  const auto listening = std::chrono::steady_clock::now();
  for (std::thread& w : waiters) w.join();
  ASSERT_NE(server, nullptr);
  const double found_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - listening).count();
  const double cpu_s = CpuSeconds() - cpu_before_s;
  std::cout << "connected " << found_s << " s after the server listened; " << cpu_s
            << " s of CPU for 4 waiters over " << 1.5 + found_s << " s\n";
  EXPECT_EQ(connected.load(), 4);
  EXPECT_TRUE(client->Connected());
  EXPECT_LT(cpu_s, 1.0);  // polling threads would use their cores' whole time
  server->Shutdown();
}

}  // namespace
}  // namespace weavefit
