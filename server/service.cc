#include "server/service.h"

#include <glog/logging.h>

#include <algorithm>



#include "absl/strings/str_cat.h"
#include "estimator/pipeline/joint.h"
#include "proto/weavefit/v1/convert.h"
#include "proto/weavefit/v1/status_util.h"

namespace weavefit {

struct WeaveFitService::Call {
  Clock::time_point start = Clock::now();
  Clock::time_point deadline = Clock::time_point::max();
  Admission::Ticket ticket;
};

absl::Status ServiceOptions::Validate() const {
  if (max_upload_bytes <= 0) {
    return absl::InvalidArgumentError("max_upload_bytes must be > 0");
  }
  if (max_chunk_bytes <= 0) {
    return absl::InvalidArgumentError("max_chunk_bytes must be > 0");
  }
  if (max_call_bytes < max_upload_bytes) {
    return absl::InvalidArgumentError("max_call_bytes must be >= max_upload_bytes");
  }
  if (max_chunks < 1) return absl::InvalidArgumentError("max_chunks must be >= 1");
  if (workers < 1) return absl::InvalidArgumentError("workers must be >= 1");
  if (max_queue < 0) return absl::InvalidArgumentError("max_queue must be >= 0");
  if (!(deadline_s > 0.0)) return absl::InvalidArgumentError("deadline_s must be > 0");
  if (max_joint_photographs < 1) {
    return absl::InvalidArgumentError("max_joint_photographs must be >= 1");
  }
  return estimate.Validate();
}

WeaveFitService::WeaveFitService(ServiceOptions options, const Authenticator* auth,
                                 Metrics* metrics)
    : options_(std::move(options)),
      auth_(auth),
      metrics_(metrics),
      admission_(options_.workers, options_.max_queue) {
  if (metrics_ != nullptr) {
    metrics_->SetQueueDepthSource([this] { return admission_.queued(); });
  }
}

absl::Status WeaveFitService::Begin(grpc::ServerContext* context, Call* call) {
  if (auth_ != nullptr && auth_->enabled()) {
    const auto& metadata = context->client_metadata();
    const auto found = metadata.find("authorization");
    const bool present = found != metadata.end();
    const absl::string_view value =
        present ? absl::string_view(found->second.data(), found->second.size())
                : absl::string_view();
    if (absl::Status s = auth_->Check(value, present); !s.ok()) return s;
  }
  // The call's deadline: the daemon's cap, or the client's when sooner.
  const auto cap = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(options_.deadline_s));
  call->deadline = call->start + cap;
  const auto client_deadline = context->deadline();
  const auto system_now = std::chrono::system_clock::now();
  if (client_deadline < system_now + cap) {
    call->deadline = call->start + std::chrono::duration_cast<Clock::duration>(
                                       client_deadline - system_now);
  }
  if (absl::Status s = admission_.Enter(&call->ticket); !s.ok()) return s;
  return absl::OkStatus();
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

absl::Status WeaveFitService::ReadUploads(grpc::ServerContext* context,
                                          grpc::ServerReader<v1::EstimateRequest>* reader,
                                          int max_photographs, Call* call,
                                          std::vector<Upload>* uploads) {
  // A read blocks until the client sends, closes or goes away; a client that
  // stalls is cut off at the call's deadline.
  Watchdog::Guard guard(&watchdog_, call->deadline, [context] { context->TryCancel(); });
  v1::EstimateRequest message;
  std::int64_t chunks = 0;
  std::int64_t call_bytes = 0;
  while (reader->Read(&message)) {
    if (message.has_header()) {
      if (!uploads->empty()) {
        if (absl::Status s = CheckUpload(uploads->back()); !s.ok()) return s;
      }
      if (static_cast<int>(uploads->size()) >= max_photographs) {
        if (max_photographs == 1) {
          return absl::InvalidArgumentError(
              "a second header arrived after the first (Estimate takes one photograph; "
              "use EstimateJoint for several)");
        }
        return absl::ResourceExhaustedError(
            absl::StrCat("more than ", max_photographs, " photographs in one joint call"));
      }
      if (message.header().total_bytes() > static_cast<std::uint64_t>(options_.max_upload_bytes)) {
        return absl::ResourceExhaustedError(absl::StrCat(
            "upload of ", message.header().total_bytes(), " bytes exceeds the limit of ",
            options_.max_upload_bytes, " bytes"));
      }
      uploads->push_back({message.header(), std::string()});
      // Room for what the header announces, but never more than a few chunks
      // on the strength of one small message.
      uploads->back().bytes.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(
          message.header().total_bytes(), 4 * options_.max_chunk_bytes)));
      continue;
    }
    if (uploads->empty()) {
      return absl::InvalidArgumentError("the first message must carry the header");
    }
    if (++chunks > options_.max_chunks) {
      return absl::ResourceExhaustedError(
          absl::StrCat("more than ", options_.max_chunks, " chunks in one call"));
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
    call_bytes += static_cast<std::int64_t>(chunk.size());
    if (call_bytes > options_.max_call_bytes) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "the photographs of one call exceed the limit of ", options_.max_call_bytes, " bytes"));
    }
    if (bytes.size() + chunk.size() > bytes.capacity()) {
      // Doubling, but never past what the header announced: an honest
      // upload ends in a buffer of exactly its size.
      const std::size_t announced = uploads->back().header.total_bytes();
      std::size_t want = std::max(2 * bytes.capacity(), bytes.size() + chunk.size());
      if (announced >= bytes.size() + chunk.size()) want = std::min<std::size_t>(want, announced);
      bytes.reserve(want);
    }
    bytes.append(chunk);
    uploads->back().received = bytes.size();
  }
  if (guard.expired()) {
    // The watchdog cancelled the call, so CANCELLED is what the client sees;
    // the log and the metrics say the same, with the reason.
    return absl::CancelledError(
        "the upload did not complete before the call's deadline (--deadline-s): cut off");
  }
  if (context->IsCancelled()) return absl::CancelledError("the client went away mid-upload");
  if (uploads->empty()) {
    return absl::InvalidArgumentError("empty request stream: a header was expected");
  }
  return CheckUpload(uploads->back());
}

absl::StatusOr<v1::EstimateReply> WeaveFitService::EstimateUpload(Upload* upload_ptr,
                                                                  grpc::ServerContext* context,
                                                                  Call* call) {
  Upload& upload = *upload_ptr;
  absl::StatusOr<Acquisition> acquisition = AcquisitionFromProto(upload.header.acquisition());
  if (!acquisition.ok()) return acquisition.status();
  absl::StatusOr<EstimateOptions> parsed =
      OptionsFromProto(upload.header.options(), options_.estimate);
  if (!parsed.ok()) return parsed.status();
  EstimateOptions options = *std::move(parsed);
  const Clock::time_point deadline = call->deadline;
  options.interrupt = [context, deadline]() -> absl::Status {
    if (Clock::now() >= deadline) {
      return absl::DeadlineExceededError("the call's deadline passed during the estimate");
    }
    if (context->IsCancelled()) return absl::CancelledError("the client went away mid-estimate");
    return absl::OkStatus();
  };
  if (metrics_ != nullptr) metrics_->received_bytes.Observe(upload.bytes.size());
  absl::StatusOr<weavefit::Estimate> estimate =
      EstimateFromBytes(std::move(upload.bytes), *acquisition, options);
  if (!estimate.ok()) return estimate.status();
  if (metrics_ != nullptr) {
    double decode_ms = 0.0, rest_ms = 0.0;
    for (const StageTime& t : estimate->timings) {
      (t.stage == "decode" ? decode_ms : rest_ms) += t.milliseconds;
    }
    metrics_->decode_seconds.Observe(decode_ms / 1000.0);
    metrics_->fit_seconds.Observe(rest_ms / 1000.0);
  }
  return ReplyFromEstimate(*estimate, upload.header.sample_name());
}

void WeaveFitService::Finish(const char* method, grpc::ServerContext* context, const Call& call,
                             const std::vector<Upload>& uploads, const absl::Status& status) {
  const double seconds = std::chrono::duration<double>(Clock::now() - call.start).count();
  std::size_t bytes = 0;
  for (const Upload& u : uploads) bytes += u.received;
  const std::string outcome =
      status.ok() ? std::string("OK")
                  : absl::StrCat(absl::StatusCodeToString(status.code()), ": ", status.message());
  // Never the payload: a refused caller's upload was not even read.
  LOG(INFO) << method << " peer=" << context->peer() << " photographs=" << uploads.size()
            << (uploads.size() == 1 ? absl::StrCat(" file=\"", uploads[0].header.filename(), "\"")
                                    : std::string())
            << " bytes=" << bytes << " outcome=" << outcome << " ms=" << seconds * 1000.0;
  if (metrics_ != nullptr) {
    metrics_->CountRequest(method, absl::StatusCodeToString(status.code()));
    metrics_->request_seconds.Observe(seconds);
  }
}

grpc::Status WeaveFitService::Estimate(grpc::ServerContext* context,
                                       grpc::ServerReader<v1::EstimateRequest>* reader,
                                       v1::EstimateReply* reply) {
  if (metrics_ != nullptr) metrics_->AddInFlight(1);
  Call call;
  std::vector<Upload> uploads;
  absl::Status status = Begin(context, &call);
  if (status.ok()) status = ReadUploads(context, reader, 1, &call, &uploads);
  if (status.ok()) {
    const Clock::time_point read = Clock::now();
    status = call.ticket.AwaitSlot(call.deadline, [context] { return context->IsCancelled(); });
    if (metrics_ != nullptr && status.ok()) {
      metrics_->queue_seconds.Observe(std::chrono::duration<double>(Clock::now() - read).count());
    }
  }
  if (status.ok()) {
    absl::StatusOr<v1::EstimateReply> one = EstimateUpload(&uploads[0], context, &call);
    status = one.status();
    if (one.ok()) *reply = *std::move(one);
  }
  call.ticket = Admission::Ticket();  // the slot is free before the reply is sent
  Finish("Estimate", context, call, uploads, status);
  if (metrics_ != nullptr) metrics_->AddInFlight(-1);
  return ToGrpcStatus(status);
}

grpc::Status WeaveFitService::EstimateJoint(grpc::ServerContext* context,
                                            grpc::ServerReader<v1::EstimateRequest>* reader,
                                            v1::JointEstimateReply* reply) {
  if (metrics_ != nullptr) metrics_->AddInFlight(1);
  Call call;
  std::vector<Upload> uploads;
  absl::Status status = Begin(context, &call);
  if (status.ok()) {
    status = ReadUploads(context, reader, options_.max_joint_photographs, &call, &uploads);
  }
  if (status.ok()) {
    const Clock::time_point read = Clock::now();
    status = call.ticket.AwaitSlot(call.deadline, [context] { return context->IsCancelled(); });
    if (metrics_ != nullptr && status.ok()) {
      metrics_->queue_seconds.Observe(std::chrono::duration<double>(Clock::now() - read).count());
    }
  }
  std::vector<PhotographEstimate> photographs;
  std::vector<std::string> names;
  for (std::size_t i = 0; status.ok() && i < uploads.size(); ++i) {
    absl::StatusOr<v1::EstimateReply> one = EstimateUpload(&uploads[i], context, &call);
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
  call.ticket = Admission::Ticket();
  if (status.ok()) {
    absl::StatusOr<JointEstimate> joint = CombineEstimates(photographs);
    status = joint.status();
    if (joint.ok()) *reply->mutable_joint() = JointToProto(*joint, names);
  }
  if (!status.ok()) reply->Clear();
  Finish("EstimateJoint", context, call, uploads, status);
  if (metrics_ != nullptr) metrics_->AddInFlight(-1);
  return ToGrpcStatus(status);
}

}  // namespace weavefit
