#include "server/service.h"

#include <glog/logging.h>

#include <chrono>

#include "absl/strings/str_cat.h"
#include "proto/weavefit/v1/convert.h"
#include "proto/weavefit/v1/status_util.h"

namespace weavefit {

absl::Status ServiceOptions::Validate() const {
  if (max_upload_bytes <= 0) {
    return absl::InvalidArgumentError("max_upload_bytes must be > 0");
  }
  if (max_chunk_bytes <= 0) {
    return absl::InvalidArgumentError("max_chunk_bytes must be > 0");
  }
  if (workers < 1) return absl::InvalidArgumentError("workers must be >= 1");
  return estimate.Validate();
}

void WorkerSlots::Acquire() {
  std::unique_lock<std::mutex> lock(mutex_);
  available_.wait(lock, [this] { return free_ > 0; });
  --free_;
}

void WorkerSlots::Release() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++free_;
  }
  available_.notify_one();
}

WeaveFitService::WeaveFitService(ServiceOptions options)
    : options_(std::move(options)), slots_(options_.workers) {}

absl::Status WeaveFitService::ReadUpload(
    grpc::ServerContext* context,
    grpc::ServerReader<v1::EstimateRequest>* reader,
    v1::RequestHeader* header, std::string* bytes) {
  v1::EstimateRequest message;
  if (!reader->Read(&message)) {
    return absl::InvalidArgumentError("empty request stream: a header was expected");
  }
  if (!message.has_header()) {
    return absl::InvalidArgumentError("the first message must carry the header");
  }
  *header = message.header();
  if (header->total_bytes() > static_cast<std::uint64_t>(options_.max_upload_bytes)) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "upload of ", header->total_bytes(), " bytes exceeds the limit of ",
        options_.max_upload_bytes, " bytes"));
  }
  if (header->total_bytes() > 0) bytes->reserve(header->total_bytes());
  while (reader->Read(&message)) {
    if (context->IsCancelled()) return absl::CancelledError("client cancelled");
    if (message.has_header()) {
      return absl::InvalidArgumentError("a second header arrived after the first");
    }
    const std::string& chunk = message.chunk();
    if (static_cast<std::int64_t>(chunk.size()) > options_.max_chunk_bytes) {
      return absl::InvalidArgumentError(absl::StrCat(
          "chunk of ", chunk.size(), " bytes exceeds ", options_.max_chunk_bytes));
    }
    if (static_cast<std::int64_t>(bytes->size() + chunk.size()) > options_.max_upload_bytes) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "upload exceeds the limit of ", options_.max_upload_bytes, " bytes"));
    }
    bytes->append(chunk);
  }
  if (header->total_bytes() > 0 && bytes->size() != header->total_bytes()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "header announced ", header->total_bytes(), " bytes but ", bytes->size(),
        " arrived"));
  }
  return absl::OkStatus();
}

grpc::Status WeaveFitService::Estimate(
    grpc::ServerContext* context,
    grpc::ServerReader<v1::EstimateRequest>* reader, v1::EstimateReply* reply) {
  const auto start = std::chrono::steady_clock::now();
  v1::RequestHeader header;
  std::string bytes;
  absl::Status status = ReadUpload(context, reader, &header, &bytes);
  absl::StatusOr<Acquisition> acquisition = status.ok()
      ? AcquisitionFromProto(header.acquisition())
      : absl::StatusOr<Acquisition>(status);
  if (status.ok()) status = acquisition.status();
  if (status.ok()) {
    const EstimateOptions options =
        OptionsFromProto(header.options(), options_.estimate);
    slots_.Acquire();
    absl::StatusOr<weavefit::Estimate> estimate =
        EstimateFromBytes(bytes, *acquisition, options);
    slots_.Release();
    status = estimate.status();
    if (estimate.ok()) *reply = ReplyFromEstimate(*estimate, header.sample_name());
  }
  const double ms = std::chrono::duration<double, std::milli>(
                        std::chrono::steady_clock::now() - start).count();
  LOG(INFO) << "Estimate peer=" << context->peer() << " file=\""
            << header.filename() << "\" bytes=" << bytes.size() << " outcome="
            << (status.ok() ? std::string("OK")
                            : absl::StatusCodeToString(status.code()) + ": " +
                                  std::string(status.message()))
            << " ms=" << ms;
  return ToGrpcStatus(status);
}

}  // namespace weavefit
