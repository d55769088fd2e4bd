#include "server/service.h"

#include <glog/logging.h>

#include <chrono>

#include "absl/strings/str_cat.h"
#include "estimator/pipeline/joint.h"
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
  if (max_joint_photographs < 1) {
    return absl::InvalidArgumentError("max_joint_photographs must be >= 1");
  }
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

absl::Status WeaveFitService::CheckUpload(const Upload& upload) const {
  const std::uint64_t announced = upload.header.total_bytes();
  if (announced > 0 && upload.bytes.size() != announced) {
    return absl::InvalidArgumentError(absl::StrCat(
        "header of \"", upload.header.filename(), "\" announced ", announced, " bytes but ",
        upload.bytes.size(), " arrived"));
  }
  return absl::OkStatus();
}

absl::Status WeaveFitService::ReadJointUpload(grpc::ServerContext* context,
                                              grpc::ServerReader<v1::EstimateRequest>* reader,
                                              std::vector<Upload>* uploads) {
  v1::EstimateRequest message;
  while (reader->Read(&message)) {
    if (context->IsCancelled()) return absl::CancelledError("client cancelled");
    if (message.has_header()) {
      if (!uploads->empty()) {
        if (absl::Status s = CheckUpload(uploads->back()); !s.ok()) return s;
      }
      if (static_cast<int>(uploads->size()) >= options_.max_joint_photographs) {
        return absl::ResourceExhaustedError(absl::StrCat(
            "more than ", options_.max_joint_photographs, " photographs in one joint call"));
      }
      if (message.header().total_bytes() > static_cast<std::uint64_t>(options_.max_upload_bytes)) {
        return absl::ResourceExhaustedError(absl::StrCat(
            "upload of ", message.header().total_bytes(), " bytes exceeds the limit of ",
            options_.max_upload_bytes, " bytes"));
      }
      uploads->push_back({message.header(), std::string()});
      continue;
    }
    if (uploads->empty()) {
      return absl::InvalidArgumentError("the first message must carry a header");
    }
    const std::string& chunk = message.chunk();
    if (static_cast<std::int64_t>(chunk.size()) > options_.max_chunk_bytes) {
      return absl::InvalidArgumentError(absl::StrCat(
          "chunk of ", chunk.size(), " bytes exceeds ", options_.max_chunk_bytes));
    }
    std::string& bytes = uploads->back().bytes;
    if (static_cast<std::int64_t>(bytes.size() + chunk.size()) > options_.max_upload_bytes) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "upload exceeds the limit of ", options_.max_upload_bytes, " bytes"));
    }
    bytes.append(chunk);
  }
  if (uploads->empty()) {
    return absl::InvalidArgumentError("empty request stream: a header was expected");
  }
  return CheckUpload(uploads->back());
}

absl::StatusOr<v1::EstimateReply> WeaveFitService::EstimateUpload(const Upload& upload) {
  absl::StatusOr<Acquisition> acquisition = AcquisitionFromProto(upload.header.acquisition());
  if (!acquisition.ok()) return acquisition.status();
  const EstimateOptions options = OptionsFromProto(upload.header.options(), options_.estimate);
  slots_.Acquire();
  absl::StatusOr<weavefit::Estimate> estimate = EstimateFromBytes(upload.bytes, *acquisition, options);
  slots_.Release();
  if (!estimate.ok()) return estimate.status();
  return ReplyFromEstimate(*estimate, upload.header.sample_name());
}

grpc::Status WeaveFitService::EstimateJoint(grpc::ServerContext* context,
                                            grpc::ServerReader<v1::EstimateRequest>* reader,
                                            v1::JointEstimateReply* reply) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<Upload> uploads;
  absl::Status status = ReadJointUpload(context, reader, &uploads);
  std::vector<PhotographEstimate> photographs;
  std::vector<std::string> names;
  for (std::size_t i = 0; status.ok() && i < uploads.size(); ++i) {
    absl::StatusOr<v1::EstimateReply> one = EstimateUpload(uploads[i]);
    if (!one.ok()) {
      status = absl::Status(one.status().code(),
                            absl::StrCat("photograph ", i + 1, " (\"", uploads[i].header.filename(),
                                         "\"): ", one.status().message()));
      break;
    }
    photographs.push_back(PhotographFromReply(*one));
    names.push_back(one->sample_name());
    *reply->add_photographs() = *std::move(one);
  }
  if (status.ok()) {
    absl::StatusOr<JointEstimate> joint = CombineEstimates(photographs);
    status = joint.status();
    if (joint.ok()) *reply->mutable_joint() = JointToProto(*joint, names);
  }
  if (!status.ok()) reply->Clear();
  const double ms = std::chrono::duration<double, std::milli>(
                        std::chrono::steady_clock::now() - start).count();
  LOG(INFO) << "EstimateJoint peer=" << context->peer() << " photographs=" << uploads.size()
            << " outcome="
            << (status.ok() ? std::string("OK")
                            : absl::StatusCodeToString(status.code()) + ": " +
                                  std::string(status.message()))
            << " ms=" << ms;
  return ToGrpcStatus(status);
}

}  // namespace weavefit
