// The WeaveFit gRPC service: check the caller, read the upload within the
// upload limits, admit the complete upload for estimation, convert, call the
// pipeline, convert back. No estimation logic lives here; limits are
// enforced before the work they protect.
#ifndef WEAVEFIT_SERVER_SERVICE_H_
#define WEAVEFIT_SERVER_SERVICE_H_

#include <atomic>
#include <chrono>
#include <functional>
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
#include "server/worker_pool.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit {

struct ServiceOptions {
  std::int64_t max_upload_bytes = 64LL << 20;  // encoded image, one photograph
  std::int64_t max_call_bytes = 256LL << 20;   // all photographs of one call together
  std::int64_t max_chunk_bytes = 1LL << 20;    // one chunk message
  std::int64_t max_chunks = 16384;             // chunk messages per call
  int max_uploads = 128;                       // uploads in progress at once
  std::int64_t max_upload_memory_bytes = 1LL << 30;  // bytes all uploads in progress hold
  double upload_idle_s = 10.0;  // an upload that sends nothing this long is cut, s
  int workers = 2;              // estimates that run at once
  int max_queue = 4;            // complete uploads waiting for a worker beyond those
  // Working memory of the estimates running at once (EstimateWorkingBytes),
  // bytes; a photograph that needs more on its own is refused. 0 = none.
  std::int64_t memory_budget_bytes = 4LL << 30;
  double deadline_s = 300.0;    // longest call, s (the client's may be shorter)
  int max_joint_photographs = 16;  // per EstimateJoint call
  EstimateOptions estimate;        // decode limits, stages

  absl::Status Validate() const;
};

// The WeaveFit service on gRPC's callback API: gRPC's threads only read
// uploads (a stalled client costs an upload pass, no thread and no
// estimation slot); a complete upload is admitted (Admission) and
// estimated on the service's own WorkerPool.
class WeaveFitService final : public v1::WeaveFit::CallbackService {
 public:
  using Clock = std::chrono::steady_clock;
  // `auth` (may be null = open) and `metrics` (may be null) outlive the service.
  WeaveFitService(ServiceOptions options, const Authenticator* auth, Metrics* metrics);
  ~WeaveFitService() override;

  grpc::ServerReadReactor<v1::EstimateRequest>* Estimate(
      grpc::CallbackServerContext* context, v1::EstimateReply* reply) override;
  grpc::ServerReadReactor<v1::EstimateRequest>* EstimateJoint(
      grpc::CallbackServerContext* context, v1::JointEstimateReply* reply) override;

  // The daemon is shutting down and will cancel the calls still in flight
  // at `grace_end`: those are logged as cut by the shutdown, not as clients
  // that went away.
  void BeginShutdown(Clock::time_point grace_end);

  const Admission& admission() const { return admission_; }
  const UploadLimits& upload_limits() const { return upload_limits_; }

 private:
  // One photograph of an upload: its header and image bytes.
  struct Upload {
    v1::RequestHeader header;
    std::string bytes;  // released once decoded (EstimateUpload)
    std::size_t received = 0;
  };
  struct Call;
  class Reactor;
  // Fills the call's reply from its uploads (on a worker, holding a slot);
  // `commit` then copies the result into gRPC's reply if the call is still
  // unanswered.
  using Run = std::function<absl::Status(Call* call, std::function<void()>* commit)>;

  grpc::ServerReadReactor<v1::EstimateRequest>* StartCall(grpc::CallbackServerContext* context,
                                                          const char* method,
                                                          int max_photographs, Run run);
  // Token check and the call's deadline; the first failure.
  absl::Status Begin(grpc::CallbackServerContext* context, Call* call);
  // One message of the stream: a header starts a photograph, a chunk
  // extends it. Called under the call's lock.
  absl::Status Accept(const v1::EstimateRequest& message, Call* call);
  // The stream is closed: the last upload is checked, its working memory
  // measured, and the call admitted for estimation.
  absl::Status Admit(Call* call);
  // Checks a finished upload's size against its header.
  absl::Status CheckUpload(const Upload& upload) const;
  // On a worker: waits for a slot and memory, runs the estimate, answers.
  void RunEstimate(const std::shared_ptr<Call>& call);
  // Decodes and estimates one upload; its bytes are released once decoded.
  absl::StatusOr<v1::EstimateReply> EstimateUpload(Upload* upload, Call* call);
  absl::Status EstimateOne(Call* call, v1::EstimateReply* reply);
  absl::Status EstimateSeveral(Call* call, v1::JointEstimateReply* reply);
  // Answers the call once, whoever comes first (the estimate, the
  // watchdog, a cancellation): logs, counts and finishes the RPC. False
  // when it was answered already.
  bool Complete(Call* call, const absl::Status& status,
                const std::function<void()>& commit = nullptr);
  // The watchdog's deadline passed: the idle limit or the call's deadline.
  void Expire(Call* call);
  // Why gRPC cancelled a call: the client, its deadline, or the shutdown.
  absl::Status CancellationReason(const Call& call) const;

  ServiceOptions options_;
  const Authenticator* auth_;
  Metrics* metrics_;
  UploadLimits upload_limits_;
  Admission admission_;
  std::atomic<Clock::rep> grace_end_{Clock::time_point::max().time_since_epoch().count()};
  Watchdog watchdog_;
  WorkerPool pool_;  // last: joined first, before what its jobs use
};

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_SERVICE_H_
