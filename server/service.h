// The WeaveFit gRPC service: check the caller, admit the call, read the
// upload, convert, call the pipeline, convert back. No estimation logic lives
// here; limits are enforced before the work they protect.
#ifndef WEAVEFIT_SERVER_SERVICE_H_
#define WEAVEFIT_SERVER_SERVICE_H_

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "estimator/pipeline/estimate.h"
#include "server/admission.h"
#include "server/auth.h"
#include "server/metrics.h"
#include "server/watchdog.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit {

struct ServiceOptions {
  std::int64_t max_upload_bytes = 64LL << 20;  // encoded image, one photograph
  std::int64_t max_call_bytes = 256LL << 20;   // all photographs of one call together
  std::int64_t max_chunk_bytes = 1LL << 20;    // one chunk message
  std::int64_t max_chunks = 16384;             // chunk messages per call
  int workers = 2;                             // estimates that run at once
  int max_queue = 4;                           // admitted calls waiting beyond those
  double deadline_s = 300.0;                   // longest call, s (the client's may be shorter)
  int max_joint_photographs = 16;              // per EstimateJoint call
  EstimateOptions estimate;                    // decode limits, stages

  absl::Status Validate() const;
};

class WeaveFitService final : public v1::WeaveFit::Service {
 public:
  // `auth` (may be null = open) and `metrics` (may be null) outlive the service.
  WeaveFitService(ServiceOptions options, const Authenticator* auth, Metrics* metrics);

  grpc::Status Estimate(grpc::ServerContext* context,
                        grpc::ServerReader<v1::EstimateRequest>* reader,
                        v1::EstimateReply* reply) override;

  grpc::Status EstimateJoint(grpc::ServerContext* context,
                             grpc::ServerReader<v1::EstimateRequest>* reader,
                             v1::JointEstimateReply* reply) override;

  const Admission& admission() const { return admission_; }

 private:
  using Clock = std::chrono::steady_clock;
  // One photograph of an upload: its header and image bytes.
  struct Upload {
    v1::RequestHeader header;
    std::string bytes;   // released once decoded (EstimateUpload)
    std::size_t received = 0;
  };
  // What a call carries from its start to its end.
  struct Call;

  // Token check, admission and the call's deadline; the first failure.
  absl::Status Begin(grpc::ServerContext* context, Call* call);
  // Reads every message: each header starts a photograph, its chunks follow
  // (Estimate allows one photograph, EstimateJoint up to the limit).
  absl::Status ReadUploads(grpc::ServerContext* context,
                           grpc::ServerReader<v1::EstimateRequest>* reader, int max_photographs,
                           Call* call, std::vector<Upload>* uploads);
  // Checks a finished upload's size against its header.
  absl::Status CheckUpload(const Upload& upload) const;
  // Decodes and estimates one upload (the call holds a worker slot); its
  // bytes are released once decoded, so that they and the decoded image are
  // not both held through the fit.
  absl::StatusOr<v1::EstimateReply> EstimateUpload(Upload* upload, grpc::ServerContext* context,
                                                   Call* call);
  // Logging and metrics of a finished call.
  void Finish(const char* method, grpc::ServerContext* context, const Call& call,
              const std::vector<Upload>& uploads, const absl::Status& status);

  ServiceOptions options_;
  const Authenticator* auth_;
  Metrics* metrics_;
  Admission admission_;
  Watchdog watchdog_;
};

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_SERVICE_H_
