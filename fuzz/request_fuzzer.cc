// libFuzzer target: weavefitd's request handler fed with mutated protobuf
// messages through an in-process gRPC channel (the same service object the
// daemon runs, with small limits so one input stays quick).
//
// Why this target once missed a crash (issue 30): a region of interest with
// x_px = 2147483547, width_px = 200 overflowed a 32-bit bounds check in
// DetectCylinder and killed weavefitd with SIGSEGV. To get there an input
// needs, at once, (1) a header whose roi, three messages deep
// (EstimateRequest.header.acquisition.roi), holds two fields summing past
// 2^31 - 1 (five-byte varints), and (2) chunks that still decode to an image
// with a cylinder in it. No seed carried an roi, and inserting one into a
// serialised header means inserting a tag and a length-delimited message and
// fixing up, in the same mutation, the lengths of acquisition, header and
// this harness's own record: byte-level mutation practically never does
// that, and a record that fails to parse is sent as a chunk, so the call
// lost its header instead. Meanwhile any mutation of the image's chunks
// breaks the PNG's CRCs, so the calls that did carry a header stopped at
// decoding. So the request fields that steer the estimator's geometry are
// now taken straight from fixed bytes of the input (below) and applied to
// every header parsed, and the seeds carry a small image that decodes.
//
// Input layout:
//   byte 0        which call and how (bit 0: Estimate or EstimateJoint; bit 1:
//                 the authorization header carries the right token or a
//                 fuzzed one, from the input's last 16 bytes; bit 2 set: no
//                 authorization header at all; bit 3: apply the roi below;
//                 bit 4: the phase angle and diameter; bit 5: the mode)
//   bytes 1-16    roi x_px, y_px, width_px, height_px (int32, little-endian)
//   bytes 17-32   phase_angle_deg, cylinder_diameter_mm (double, little-endian)
//   bytes 33-36   options.mode (int32, little-endian; any value, unknown ones too)
//   then          records of [2-byte little-endian length][bytes], each parsed
//                 as a weavefit.v1.EstimateRequest (records that do not parse
//                 are sent as a chunk, so raw image bytes reach the decoder too).
// The service must answer every call with a status and never crash or report
// a sanitizer error.
#include <glog/logging.h>
#include <grpcpp/grpcpp.h>

#include <cstddef>
#include <cstdint>
#include <unistd.h>

#include <cstdio>
#include <cstring>
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

// The fixed fields after byte 0, applied to every header of the call.
struct Overrides {
  static constexpr size_t kSize = 36;
  bool roi = false;
  bool geometry = false;
  bool mode = false;
  int32_t roi_px[4] = {0, 0, 0, 0};
  double phase_angle_deg = 0.0;
  double cylinder_diameter_mm = 0.0;
  int32_t mode_value = 0;

  // From data[1..36]; the caller has checked that size > kSize.
  static Overrides Read(const uint8_t* data) {
    Overrides o;
    o.roi = data[0] & 8;
    o.geometry = data[0] & 16;
    o.mode = data[0] & 32;
    std::memcpy(o.roi_px, data + 1, sizeof(o.roi_px));  // little-endian host
    std::memcpy(&o.phase_angle_deg, data + 17, sizeof(double));
    std::memcpy(&o.cylinder_diameter_mm, data + 25, sizeof(double));
    std::memcpy(&o.mode_value, data + 33, sizeof(int32_t));
    return o;
  }

  void ApplyTo(weavefit::v1::EstimateRequest* message) const {
    if (!message->has_header()) return;
    weavefit::v1::Acquisition* acquisition = message->mutable_header()->mutable_acquisition();
    if (roi) {
      weavefit::v1::RegionOfInterest* r = acquisition->mutable_roi();
      r->set_x_px(roi_px[0]);
      r->set_y_px(roi_px[1]);
      r->set_width_px(roi_px[2]);
      r->set_height_px(roi_px[3]);
    }
    if (geometry) {
      acquisition->set_phase_angle_deg(phase_angle_deg);
      acquisition->set_cylinder_diameter_mm(cylinder_diameter_mm);
    }
    if (mode) {
      message->mutable_header()->mutable_options()->set_mode(
          static_cast<weavefit::v1::Mode>(mode_value));
    }
  }
};

template <typename Reply, typename Open>
void RunCall(const uint8_t* data, size_t size, bool authorised, const std::string& token,
             const Overrides& overrides, Open open) {
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(20));
  if (authorised) context.AddMetadata("authorization", "Bearer " + token);
  Reply reply;
  auto writer = open(&context, &reply);
  size_t at = 1 + Overrides::kSize;
  bool writing = true;
  while (writing && at + 2 <= size) {
    const size_t length = std::min<size_t>(data[at] | (data[at + 1] << 8), size - at - 2);
    at += 2;
    weavefit::v1::EstimateRequest message;
    if (!message.ParseFromArray(data + at, static_cast<int>(length))) {
      message.Clear();
      message.set_chunk(reinterpret_cast<const char*>(data + at), length);
    }
    overrides.ApplyTo(&message);
    at += length;
    writing = writer->Write(message);
  }
  writer->WritesDone();
  (void)writer->Finish();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static Harness* harness = new Harness();
  if (size <= Overrides::kSize) return 0;
  const Overrides overrides = Overrides::Read(data);
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
        data, size, authorised, token, overrides,
        [&stub](grpc::ClientContext* c, weavefit::v1::JointEstimateReply* r) {
          return stub.EstimateJoint(c, r);
        });
  } else {
    RunCall<weavefit::v1::EstimateReply>(
        data, size, authorised, token, overrides,
        [&stub](grpc::ClientContext* c, weavefit::v1::EstimateReply* r) {
          return stub.Estimate(c, r);
        });
  }
  return 0;
}
