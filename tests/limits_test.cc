// weavefitd's resource limits of issue 30 through the real binary: a
// decompression bomb against the memory budget, stalled uploads beside a
// normal client, and what the log says of hostile file names and of calls
// cut by a shutdown.
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <zlib.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "tests/test_support.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit::testing {
namespace {

using Clock = std::chrono::steady_clock;
const std::string kFixture = std::string(FIXTURES_DIR) + "/gauze_sinusoid_p10.png";

void AppendChunk(const std::string& type, const std::string& data, std::string* png) {
  auto be32 = [png](std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) png->push_back(static_cast<char>((v >> s) & 0xFF));
  };
  be32(static_cast<std::uint32_t>(data.size()));
  const std::string body = type + data;
  *png += body;
  be32(static_cast<std::uint32_t>(
      crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
}

// A valid PNG of width x height 16-bit RGBA, all zero: about 0.5 MB for
// 7999x7999, 512 MB of samples once inflated.
std::string PngBomb(int width, int height) {
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string ihdr;
  for (int v : {width, height}) {
    for (int s = 24; s >= 0; s -= 8) ihdr.push_back(static_cast<char>((v >> s) & 0xFF));
  }
  ihdr += std::string("\x10\x06\x00\x00\x00", 5);  // 16 bits, RGBA, deflate, no filter, no interlace
  AppendChunk("IHDR", ihdr, &png);
  z_stream z{};
  deflateInit(&z, 9);
  const std::string row(1 + static_cast<std::size_t>(width) * 8, '\0');  // filter byte + samples
  std::string idat;
  std::vector<unsigned char> out(1 << 16);
  for (int y = 0; y < height; ++y) {
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(row.data()));
    z.avail_in = static_cast<uInt>(row.size());
    const int flush = y + 1 == height ? Z_FINISH : Z_NO_FLUSH;
    do {
      z.next_out = out.data();
      z.avail_out = static_cast<uInt>(out.size());
      deflate(&z, flush);
      idat.append(reinterpret_cast<char*>(out.data()), out.size() - z.avail_out);
    } while (z.avail_out == 0);
  }
  deflateEnd(&z);
  AppendChunk("IDAT", idat, &png);
  AppendChunk("IEND", "", &png);
  return png;
}

// The daemon's peak resident set (VmHWM), MiB.
double PeakResidentMiB(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (absl::StartsWith(line, "VmHWM:")) return std::stod(line.substr(6)) / 1024.0;
  }
  return -1.0;
}

std::unique_ptr<v1::WeaveFit::Stub> StubFor(const Daemon& daemon) {
  return v1::WeaveFit::NewStub(
      grpc::CreateChannel(daemon.address(), grpc::InsecureChannelCredentials()));
}

grpc::Status Upload(v1::WeaveFit::Stub* stub, const std::string& bytes,
                    const std::string& filename = "photo.png") {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  v1::EstimateReply reply;
  auto writer = stub->Estimate(&context, &reply);
  v1::EstimateRequest message;
  message.mutable_header()->mutable_acquisition()->set_phase_angle_deg(10.0);
  message.mutable_header()->mutable_acquisition()->set_cylinder_diameter_mm(46.0);
  message.mutable_header()->set_filename(filename);
  message.mutable_header()->set_total_bytes(bytes.size());
  bool open = writer->Write(message);
  for (std::size_t at = 0; open && at < bytes.size(); at += 1 << 20) {
    message.set_chunk(bytes.substr(at, 1 << 20));
    open = writer->Write(message);
  }
  writer->WritesDone();
  return writer->Finish();
}

TEST(Limits, ADecompressionBombBeyondTheMemoryBudgetIsRefusedBeforeDecoding) {
  Daemon daemon({"--memory-budget-mb", "600"});
  auto stub = StubFor(daemon);
  const std::string bomb = PngBomb(7999, 7999);
  ASSERT_LT(bomb.size(), 2u << 20);
  const grpc::Status status = Upload(stub.get(), bomb);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << status.error_message();
  EXPECT_TRUE(absl::StrContains(status.error_message(), "--memory-budget-mb"));
  // Decoding it would have taken over 1 GB; the daemon never went near that.
  EXPECT_LT(PeakResidentMiB(daemon.pid()), 400.0);
  EXPECT_TRUE(Upload(stub.get(), ReadFileOrDie(kFixture)).ok()) << "still serving";
}

// Sends a header and a byte, then nothing.
struct Stalled {
  explicit Stalled(v1::WeaveFit::Stub* stub) {
    writer = stub->Estimate(&context, &reply);
    v1::EstimateRequest message;
    message.mutable_header()->mutable_acquisition()->set_phase_angle_deg(10.0);
    writer->Write(message);
    message.set_chunk("x");
    writer->Write(message);
  }
  grpc::ClientContext context;
  v1::EstimateReply reply;
  std::unique_ptr<grpc::ClientWriter<v1::EstimateRequest>> writer;
};

TEST(Limits, SixtyStalledUploadsLeaveANormalClientItsAnswer) {
  Daemon daemon;  // the stalled uploads stay well within the 10 s idle limit
  auto normal = StubFor(daemon);
  const std::string image = ReadFileOrDie(kFixture);
  ASSERT_TRUE(Upload(normal.get(), image).ok());  // warm: the FLANN bank is built
  auto t0 = Clock::now();
  ASSERT_TRUE(Upload(normal.get(), image).ok());
  const double alone_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  // The stalled clients use channels of their own, as separate machines would.
  std::vector<std::unique_ptr<v1::WeaveFit::Stub>> stubs;
  std::vector<std::unique_ptr<Stalled>> stalled;
  for (int i = 0; i < 60; ++i) {
    stubs.push_back(StubFor(daemon));
    stalled.push_back(std::make_unique<Stalled>(stubs.back().get()));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  t0 = Clock::now();
  const grpc::Status status = Upload(normal.get(), image);
  const double beside_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  EXPECT_TRUE(status.ok()) << status.error_message();
  // A figure for the record, not a pass/fail timing.
  std::printf("normal call alone %.1f ms, beside 60 stalled uploads %.1f ms\n", alone_ms,
              beside_ms);
  for (auto& s : stalled) s->context.TryCancel();
}

TEST(Limits, AClientsFileNameCannotForgeALogLine) {
  Daemon daemon;
  auto stub = StubFor(daemon);
  const std::string forged =
      "a.png\nI1204 12:00:00.000000 1 service.cc:1] Estimate peer=ipv4:10.0.0.1:1 outcome=OK";
  EXPECT_EQ(Upload(stub.get(), "not an image", forged).error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  const std::string log = daemon.Log();
  EXPECT_TRUE(absl::StrContains(log, "file=\"a.png\\nI1204")) << log;
  EXPECT_FALSE(absl::StrContains(log, "\nI1204 12:00:00.000000 1 service.cc:1]")) << log;
}

TEST(Limits, ACallCutAtTheEndOfTheShutdownGraceIsLoggedSo) {
  Daemon daemon({"--shutdown-grace-s", "0.5"});
  auto stub = StubFor(daemon);
  Stalled stalled(stub.get());
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  daemon.Signal(SIGTERM);
  const grpc::Status status = stalled.writer->Finish();
  EXPECT_FALSE(status.ok());
  const auto deadline = Clock::now() + std::chrono::seconds(10);
  while (daemon.running() && Clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const std::string log = daemon.Log();
  EXPECT_TRUE(absl::StrContains(log, "grace period (--shutdown-grace-s) ended")) << log;
  EXPECT_FALSE(absl::StrContains(log, "the client went away")) << log;
}

}  // namespace
}  // namespace weavefit::testing
