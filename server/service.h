// The WeaveFit gRPC service: read the upload, convert, call the pipeline,
// convert back. No estimation logic lives here.
#ifndef WEAVEFIT_SERVER_SERVICE_H_
#define WEAVEFIT_SERVER_SERVICE_H_

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "estimator/pipeline/estimate.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit {

struct ServiceOptions {
  std::int64_t max_upload_bytes = 64LL << 20;  // encoded image, whole stream
  std::int64_t max_chunk_bytes = 1LL << 20;    // one chunk message
  int workers = 2;                             // estimates run at once
  int max_joint_photographs = 16;              // per EstimateJoint call
  EstimateOptions estimate;                    // decode limits, stages

  absl::Status Validate() const;
};

// A counting semaphore bounding the estimates that run at once.
class WorkerSlots {
 public:
  explicit WorkerSlots(int slots) : free_(slots) {}
  void Acquire();
  void Release();

 private:
  std::mutex mutex_;
  std::condition_variable available_;
  int free_;
};

class WeaveFitService final : public v1::WeaveFit::Service {
 public:
  explicit WeaveFitService(ServiceOptions options);

  grpc::Status Estimate(grpc::ServerContext* context,
                        grpc::ServerReader<v1::EstimateRequest>* reader,
                        v1::EstimateReply* reply) override;

  grpc::Status EstimateJoint(grpc::ServerContext* context,
                             grpc::ServerReader<v1::EstimateRequest>* reader,
                             v1::JointEstimateReply* reply) override;

 private:
  // Reads header and chunks; fills the image bytes. Errors as statuses.
  absl::Status ReadUpload(grpc::ServerContext* context,
                          grpc::ServerReader<v1::EstimateRequest>* reader,
                          v1::RequestHeader* header, std::string* bytes);

  // One photograph of a joint upload: its header and image bytes.
  struct Upload {
    v1::RequestHeader header;
    std::string bytes;
  };
  // Reads a joint upload: each header starts a photograph, its chunks follow.
  absl::Status ReadJointUpload(grpc::ServerContext* context,
                               grpc::ServerReader<v1::EstimateRequest>* reader,
                               std::vector<Upload>* uploads);
  // Checks a finished upload's size against its header.
  absl::Status CheckUpload(const Upload& upload) const;
  // Decodes and estimates one upload on a worker slot.
  absl::StatusOr<v1::EstimateReply> EstimateUpload(const Upload& upload);

  ServiceOptions options_;
  WorkerSlots slots_;
};

}  // namespace weavefit

#endif  // WEAVEFIT_SERVER_SERVICE_H_
