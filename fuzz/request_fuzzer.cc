// libFuzzer target: weavefitd's request handler fed with mutated protobuf
// messages through an in-process gRPC channel (the same service object the
// daemon runs, with small limits so one input stays quick).
//
// Input layout: byte 0 picks the call (bit 0: Estimate or EstimateJoint),
// whether the authorization header carries the right token or a fuzzed one
// (bit 1; the fuzzed one from the input's last 16 bytes) and whether it is
// sent at all (bit 2 set: none); then records of [2-byte little-endian length][bytes], each
// parsed as a weavefit.v1.EstimateRequest (records that do not parse are sent
// as a chunk, so raw image bytes reach the decoder too). The service must
// answer every call with a status and never crash or report a sanitizer error.
#include <glog/logging.h>
#include <grpcpp/grpcpp.h>

#include <cstddef>
#include <cstdint>
#include <unistd.h>

#include <cstdio>
#include <memory>
#include <string>

#include "server/auth.h"
#include "server/metrics.h"
#include "server/service.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace {

struct Harness {
  Harness() {
    FLAGS_minloglevel = google::GLOG_WARNING;  // one log line per call would swamp the run
    weavefit::ServiceOptions options;
    options.max_upload_bytes = 2 << 20;
    options.max_chunks = 64;
    options.workers = 1;
    options.max_queue = 1;
    options.deadline_s = 10.0;
    options.max_joint_photographs = 4;
    options.estimate.max_pixels = 1 << 20;
    // A file of this process's own: several fuzzer processes may run at once.
    char tokens_template[] = "/tmp/weavefit_fuzz_tokens_XXXXXX";
    const int fd = mkstemp(tokens_template);
    if (fd >= 0) {
      const char kToken[] = "fuzz-token\n";
      (void)!write(fd, kToken, sizeof(kToken) - 1);
      close(fd);
    }
    const std::string tokens = tokens_template;
    // Calls without the header are refused before reading; with it, the
    // handler reads everything. Both paths are exercised.
    auth = *weavefit::Authenticator::FromFile(tokens);
    std::remove(tokens.c_str());
    service = std::make_unique<weavefit::WeaveFitService>(options, auth.get(), &metrics);
    grpc::ServerBuilder builder;
    builder.RegisterService(service.get());
    server = builder.BuildAndStart();
    stub = weavefit::v1::WeaveFit::NewStub(server->InProcessChannel(grpc::ChannelArguments()));
  }
  weavefit::Metrics metrics;
  std::unique_ptr<weavefit::Authenticator> auth;
  std::unique_ptr<weavefit::WeaveFitService> service;
  std::unique_ptr<grpc::Server> server;
  std::unique_ptr<weavefit::v1::WeaveFit::Stub> stub;
};

template <typename Reply, typename Open>
void RunCall(const uint8_t* data, size_t size, bool authorised, const std::string& token,
             Open open) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
  if (authorised) context.AddMetadata("authorization", "Bearer " + token);
  Reply reply;
  auto writer = open(&context, &reply);
  size_t at = 1;
  bool writing = true;
  while (writing && at + 2 <= size) {
    const size_t length = std::min<size_t>(data[at] | (data[at + 1] << 8), size - at - 2);
    at += 2;
    weavefit::v1::EstimateRequest message;
    if (!message.ParseFromArray(data + at, static_cast<int>(length))) {
      message.Clear();
      message.set_chunk(reinterpret_cast<const char*>(data + at), length);
    }
    at += length;
    writing = writer->Write(message);
  }
  writer->WritesDone();
  (void)writer->Finish();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Harness* harness = new Harness();
  if (size < 1) return 0;
  const bool joint = data[0] & 1;
  // Most inputs carry the right token so that the handler reads them; a few
  // carry a fuzzed one.
  const bool fuzzed_token = data[0] & 2;
  const bool authorised = (data[0] & 4) == 0;  // bit 2: no authorization header at all
  // A fuzzed token is mapped onto printable ASCII: gRPC's client refuses
  // (asserts on) other header bytes before they could reach a daemon.
  std::string token = "fuzz-token";
  if (fuzzed_token) {
    token.clear();
    for (size_t i = size - std::min<size_t>(size, 16); i < size; ++i) {
      token.push_back(static_cast<char>(0x21 + data[i] % 94));
    }
  }
  auto& stub = *harness->stub;
  if (joint) {
    RunCall<weavefit::v1::JointEstimateReply>(
        data, size, authorised, token,
        [&stub](grpc::ClientContext* c, weavefit::v1::JointEstimateReply* r) {
          return stub.EstimateJoint(c, r);
        });
  } else {
    RunCall<weavefit::v1::EstimateReply>(
        data, size, authorised, token,
        [&stub](grpc::ClientContext* c, weavefit::v1::EstimateReply* r) {
          return stub.Estimate(c, r);
        });
  }
  return 0;
}
