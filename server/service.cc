#include "server/service.h"

#include <glog/logging.h>

#include <algorithm>
#include <mutex>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "estimator/pipeline/joint.h"
#include "proto/weavefit/v1/convert.h"
#include "proto/weavefit/v1/status_util.h"

namespace weavefit {
namespace {

// The status of one photograph of a joint call, naming it.
template <typename Upload>
absl::Status NamePhotograph(std::size_t index, const Upload& upload, const absl::Status& status) {
  return absl::Status(status.code(),
                      absl::StrCat("photograph ", index + 1, " (\"",
                                   absl::CEscape(upload.header.filename()), "\"): ",
                                   status.message()));
}

}  // namespace

// What a call carries from its first message to its answer. Shared by the
// reactor (gRPC's threads), the watchdog and the worker that estimates it:
// `mutex` orders the upload's state with `finished`, and whoever sets
// `finished` first answers the call (Complete).
struct WeaveFitService::Call {
  const char* method = "";
  grpc::CallbackServerContext* context = nullptr;
  grpc::ServerReadReactor<v1::EstimateRequest>* reactor = nullptr;
  int max_photographs = 1;
  Run run;
  Clock::time_point start = Clock::now();
  Clock::time_point deadline = Clock::time_point::max();
  Clock::time_point client_deadline = Clock::time_point::max();

  std::mutex mutex;
  bool finished = false;  // answered; nothing may touch `reactor` after
  std::vector<Upload> uploads;
  std::int64_t chunks = 0;
  std::int64_t call_bytes = 0;
  UploadLimits::Pass pass;

  // Set by the reactor when the upload is complete (the watchdog reads it
  // to word its message).
  std::atomic<bool> uploaded{false};
  // From the end of the upload: set by the reactor before the job is
  // scheduled, then used by the worker alone.
  std::int64_t working_bytes = 0;
  Admission::Ticket ticket;

  bool Finished() {
    std::lock_guard<std::mutex> lock(mutex);
    return finished;
  }
};

// The reactor of one call: reads its messages, keeps its idle and call
// deadlines with the watchdog, and hands the complete upload over.
class WeaveFitService::Reactor final : public grpc::ServerReadReactor<v1::EstimateRequest> {
 public:
  Reactor(WeaveFitService* service, std::shared_ptr<Call> call)
      : service_(service), call_(std::move(call)) {
    call_->reactor = this;
  }

  void Start() {
    absl::Status s = service_->Begin(call_->context, call_.get());
    if (s.ok()) s = service_->upload_limits_.Enter(&call_->pass);
    if (!s.ok()) {
      service_->Complete(call_.get(), s);
      return;
    }
    WeaveFitService* service = service_;
    std::shared_ptr<Call> call = call_;
    guard_ = std::make_unique<Watchdog::Guard>(&service_->watchdog_, IdleDeadline(),
                                               [service, call] { service->Expire(call.get()); });
    ReadNext();
  }

  void OnReadDone(bool ok) override {
    if (!ok) {  // the client closed its side, went away, or the call was answered
      HandOver();
      return;
    }
    absl::Status s;
    {
      std::lock_guard<std::mutex> lock(call_->mutex);
      if (call_->finished) return;
      s = service_->Accept(message_, call_.get());
    }
    if (!s.ok()) {
      service_->Complete(call_.get(), s);
      return;
    }
    guard_->MoveTo(IdleDeadline());
    ReadNext();
  }

  void OnCancel() override { service_->Complete(call_.get(), service_->CancellationReason(*call_)); }

  void OnDone() override { delete this; }

 private:
  // The upload's next message must come within the idle limit (and the call's deadline).
  Clock::time_point IdleDeadline() const {
    const auto idle = std::chrono::duration_cast<Clock::duration>(
        std::chrono::duration<double>(service_->options_.upload_idle_s));
    return std::min(call_->deadline, Clock::now() + idle);
  }

  void ReadNext() {
    // Under the lock, so that no read starts once the call is answered.
    std::lock_guard<std::mutex> lock(call_->mutex);
    if (!call_->finished) StartRead(&message_);
  }

  void HandOver() {
    if (call_->Finished()) return;
    // A read also ends when gRPC cancels the call (the client went away,
    // or the shutdown's grace ended): that upload is cut, not complete.
    if (call_->context->IsCancelled()) {
      service_->Complete(call_.get(), service_->CancellationReason(*call_));
      return;
    }
    call_->uploaded = true;
    call_->pass.EndUpload();
    const absl::Status s = service_->Admit(call_.get());
    if (!s.ok()) {
      service_->Complete(call_.get(), s);
      return;
    }
    guard_->MoveTo(call_->deadline);  // no idle limit while queued and estimating
    WeaveFitService* service = service_;
    std::shared_ptr<Call> call = call_;
    // The reactor may be gone as soon as the job answers: nothing after this.
    service_->pool_.Schedule([service, call] { service->RunEstimate(call); });
  }

  WeaveFitService* service_;
  std::shared_ptr<Call> call_;
  v1::EstimateRequest message_;
  std::unique_ptr<Watchdog::Guard> guard_;
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
  if (max_uploads < 1) return absl::InvalidArgumentError("max_uploads must be >= 1");
  if (max_upload_memory_bytes < max_chunk_bytes) {
    return absl::InvalidArgumentError("max_upload_memory_bytes must be >= max_chunk_bytes");
  }
  if (!(upload_idle_s > 0.0)) return absl::InvalidArgumentError("upload_idle_s must be > 0");
  if (workers < 1) return absl::InvalidArgumentError("workers must be >= 1");
  if (max_queue < 0) return absl::InvalidArgumentError("max_queue must be >= 0");
  if (memory_budget_bytes < 0) {
    return absl::InvalidArgumentError("memory_budget_bytes must be >= 0 (0 = none)");
  }
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
      upload_limits_(options_.max_uploads, options_.max_upload_memory_bytes),
      admission_(options_.workers, options_.max_queue, options_.memory_budget_bytes),
      pool_(options_.workers) {
  // The library refuses on its own what could never fit the budget.
  if (options_.memory_budget_bytes > 0) {
    options_.estimate.max_working_bytes = options_.memory_budget_bytes;
  }
  if (metrics_ != nullptr) {
    metrics_->SetLoadSource([this] {
      return Metrics::Load{admission_.queued(), upload_limits_.uploads(),
                           upload_limits_.held_bytes(), admission_.memory_in_use()};
    });
  }
}

WeaveFitService::~WeaveFitService() {
  if (metrics_ != nullptr) metrics_->SetLoadSource(nullptr);
}

void WeaveFitService::BeginShutdown(Clock::time_point grace_end) {
  grace_end_.store(grace_end.time_since_epoch().count());
}

grpc::ServerReadReactor<v1::EstimateRequest>* WeaveFitService::StartCall(
    grpc::CallbackServerContext* context, const char* method, int max_photographs, Run run) {
  if (metrics_ != nullptr) metrics_->AddInFlight(1);
  auto call = std::make_shared<Call>();
  call->method = method;
  call->context = context;
  call->max_photographs = max_photographs;
  call->run = std::move(run);
  auto* reactor = new Reactor(this, call);
  reactor->Start();
  return reactor;
}

grpc::ServerReadReactor<v1::EstimateRequest>* WeaveFitService::Estimate(
    grpc::CallbackServerContext* context, v1::EstimateReply* reply) {
  return StartCall(context, "Estimate", 1,
                   [this, reply](Call* call, std::function<void()>* commit) {
                     auto result = std::make_shared<v1::EstimateReply>();
                     absl::Status s = EstimateOne(call, result.get());
                     *commit = [reply, result] { *reply = std::move(*result); };
                     return s;
                   });
}

grpc::ServerReadReactor<v1::EstimateRequest>* WeaveFitService::EstimateJoint(
    grpc::CallbackServerContext* context, v1::JointEstimateReply* reply) {
  return StartCall(context, "EstimateJoint", options_.max_joint_photographs,
                   [this, reply](Call* call, std::function<void()>* commit) {
                     auto result = std::make_shared<v1::JointEstimateReply>();
                     absl::Status s = EstimateSeveral(call, result.get());
                     *commit = [reply, result] { *reply = std::move(*result); };
                     return s;
                   });
}

absl::Status WeaveFitService::Begin(grpc::CallbackServerContext* context, Call* call) {
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
    call->client_deadline = call->start + std::chrono::duration_cast<Clock::duration>(
                                              client_deadline - system_now);
    call->deadline = call->client_deadline;
  }
  return absl::OkStatus();
}

absl::Status WeaveFitService::CheckUpload(const Upload& upload) const {
  const std::uint64_t announced = upload.header.total_bytes();
  if (announced > 0 && upload.bytes.size() != announced) {
    return absl::InvalidArgumentError(absl::StrCat(
        "header of \"", absl::CEscape(upload.header.filename()), "\" announced ", announced,
        " bytes but ", upload.bytes.size(), " arrived"));
  }
  return absl::OkStatus();
}

absl::Status WeaveFitService::Accept(const v1::EstimateRequest& message, Call* call) {
  std::vector<Upload>& uploads = call->uploads;
  if (message.has_header()) {
    if (!uploads.empty()) {
      if (absl::Status s = CheckUpload(uploads.back()); !s.ok()) return s;
    }
    if (static_cast<int>(uploads.size()) >= call->max_photographs) {
      if (call->max_photographs == 1) {
        return absl::InvalidArgumentError(
            "a second header arrived after the first (Estimate takes one photograph; "
            "use EstimateJoint for several)");
      }
      return absl::ResourceExhaustedError(
          absl::StrCat("more than ", call->max_photographs, " photographs in one joint call"));
    }
    if (message.header().total_bytes() > static_cast<std::uint64_t>(options_.max_upload_bytes)) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "upload of ", message.header().total_bytes(), " bytes exceeds the limit of ",
          options_.max_upload_bytes, " bytes"));
    }
    // Nonsense acquisition values or options are refused before the image
    // is read (the same checks run again where the estimate starts).
    if (absl::Status s = AcquisitionFromProto(message.header().acquisition()).status(); !s.ok()) {
      return s;
    }
    if (absl::Status s = OptionsFromProto(message.header().options(), options_.estimate).status();
        !s.ok()) {
      return s;
    }
    uploads.push_back({message.header(), std::string()});
    return absl::OkStatus();
  }
  if (uploads.empty()) {
    return absl::InvalidArgumentError("the first message must carry the header");
  }
  if (++call->chunks > options_.max_chunks) {
    return absl::ResourceExhaustedError(
        absl::StrCat("more than ", options_.max_chunks, " chunks in one call"));
  }
  const std::string& chunk = message.chunk();
  if (static_cast<std::int64_t>(chunk.size()) > options_.max_chunk_bytes) {
    return absl::InvalidArgumentError(
        absl::StrCat("chunk of ", chunk.size(), " bytes exceeds ", options_.max_chunk_bytes));
  }
  std::string& bytes = uploads.back().bytes;
  if (static_cast<std::int64_t>(bytes.size() + chunk.size()) > options_.max_upload_bytes) {
    return absl::ResourceExhaustedError(
        absl::StrCat("upload exceeds the limit of ", options_.max_upload_bytes, " bytes"));
  }
  call->call_bytes += static_cast<std::int64_t>(chunk.size());
  if (call->call_bytes > options_.max_call_bytes) {
    return absl::ResourceExhaustedError(absl::StrCat(
        "the photographs of one call exceed the limit of ", options_.max_call_bytes, " bytes"));
  }
  // Counted before it is kept: all uploads in progress together stay
  // within --max-upload-memory-mb.
  if (absl::Status s = call->pass.Hold(static_cast<std::int64_t>(chunk.size())); !s.ok()) return s;
  if (bytes.size() + chunk.size() > bytes.capacity()) {
    // Doubling, but never past what the header announced: an honest upload
    // ends in a buffer of exactly its size.
    const std::size_t announced = uploads.back().header.total_bytes();
    std::size_t want = std::max(2 * bytes.capacity(), bytes.size() + chunk.size());
    if (announced >= bytes.size() + chunk.size()) want = std::min<std::size_t>(want, announced);
    bytes.reserve(want);
  }
  bytes.append(chunk);
  uploads.back().received = bytes.size();
  return absl::OkStatus();
}

absl::Status WeaveFitService::Admit(Call* call) {
  {
    std::lock_guard<std::mutex> lock(call->mutex);
    if (call->uploads.empty()) {
      return absl::InvalidArgumentError("empty request stream: a header was expected");
    }
    if (absl::Status s = CheckUpload(call->uploads.back()); !s.ok()) return s;
  }
  // Photographs of a joint call are estimated one after another: the call
  // needs the memory of its largest. Read from each file's header, so a
  // decompression bomb is refused or queued before a pixel is decoded.
  std::int64_t working = 0;
  for (std::size_t i = 0; i < call->uploads.size(); ++i) {
    absl::StatusOr<std::int64_t> bytes = EstimateWorkingBytes(call->uploads[i].bytes);
    if (!bytes.ok()) {
      if (call->uploads.size() == 1) return bytes.status();
      return NamePhotograph(i, call->uploads[i], bytes.status());
    }
    working = std::max(working, *bytes);
  }
  if (options_.memory_budget_bytes > 0 && working > options_.memory_budget_bytes) {
    return absl::ResourceExhaustedError(absl::StrFormat(
        "estimating this photograph takes about %.0f MiB of memory, more than the daemon's "
        "budget of %.0f MiB (--memory-budget-mb); send a smaller image or a region of interest",
        working / 1048576.0, options_.memory_budget_bytes / 1048576.0));
  }
  call->working_bytes = working;
  return admission_.Enter(&call->ticket);
}

void WeaveFitService::RunEstimate(const std::shared_ptr<Call>& call) {
  if (call->Finished()) return;  // cancelled or past its deadline while queued
  const Clock::time_point waiting = Clock::now();
  absl::Status status = call->ticket.AwaitSlot(call->deadline, [&call] { return call->Finished(); },
                                               call->working_bytes);
  std::function<void()> commit;
  if (status.ok()) {
    if (metrics_ != nullptr) {
      metrics_->queue_seconds.Observe(std::chrono::duration<double>(Clock::now() - waiting).count());
    }
    status = call->run(call.get(), &commit);
  }
  call->ticket = Admission::Ticket();  // slot and memory free before the reply is sent
  Complete(call.get(), status, commit);
}

absl::StatusOr<v1::EstimateReply> WeaveFitService::EstimateUpload(Upload* upload_ptr, Call* call) {
  Upload& upload = *upload_ptr;
  absl::StatusOr<Acquisition> acquisition = AcquisitionFromProto(upload.header.acquisition());
  if (!acquisition.ok()) return acquisition.status();
  absl::StatusOr<EstimateOptions> parsed =
      OptionsFromProto(upload.header.options(), options_.estimate);
  if (!parsed.ok()) return parsed.status();
  EstimateOptions options = *std::move(parsed);
  const Clock::time_point deadline = call->deadline;
  options.interrupt = [call, deadline]() -> absl::Status {
    if (Clock::now() >= deadline) {
      return absl::DeadlineExceededError("the call's deadline passed during the estimate");
    }
    // Answered meanwhile (the client went away, or the watchdog cut it).
    if (call->Finished()) return absl::CancelledError("the call was answered meanwhile");
    return absl::OkStatus();
  };
  if (metrics_ != nullptr) metrics_->received_bytes.Observe(upload.bytes.size());
  const auto held = static_cast<std::int64_t>(upload.bytes.size());
  absl::StatusOr<weavefit::Estimate> estimate =
      EstimateFromBytes(std::move(upload.bytes), *acquisition, options);
  call->pass.Release(held);  // decoded (or refused): the upload's bytes are gone
  if (!estimate.ok()) return estimate.status();
  if (metrics_ != nullptr) {
    double decode_ms = 0.0, rest_ms = 0.0;
    for (const StageTime& t : estimate->timings) {
      (t.stage == "decode" ? decode_ms : rest_ms) += t.milliseconds;
    }
    metrics_->decode_seconds.Observe(decode_ms / 1000.0);
    metrics_->fit_seconds.Observe(rest_ms / 1000.0);
  }
  v1::EstimateReply reply = ReplyFromEstimate(*estimate, upload.header.sample_name());
  reply.set_filename(upload.header.filename());
  return reply;
}

absl::Status WeaveFitService::EstimateOne(Call* call, v1::EstimateReply* reply) {
  absl::StatusOr<v1::EstimateReply> one = EstimateUpload(&call->uploads[0], call);
  if (!one.ok()) return one.status();
  *reply = *std::move(one);
  return absl::OkStatus();
}

absl::Status WeaveFitService::EstimateSeveral(Call* call, v1::JointEstimateReply* reply) {
  std::vector<PhotographEstimate> photographs;
  std::vector<std::string> names;
  for (std::size_t i = 0; i < call->uploads.size(); ++i) {
    absl::StatusOr<v1::EstimateReply> one = EstimateUpload(&call->uploads[i], call);
    if (!one.ok()) return NamePhotograph(i, call->uploads[i], one.status());
    photographs.push_back(PhotographFromReply(*one));
    names.push_back(one->sample_name());
    *reply->add_photographs() = *std::move(one);
  }
  absl::StatusOr<JointEstimate> joint = CombineEstimates(photographs);
  if (!joint.ok()) return joint.status();
  *reply->mutable_joint() = JointToProto(*joint, names);
  return absl::OkStatus();
}

void WeaveFitService::Expire(Call* call) {
  // The watchdog moves the deadline to the idle limit while uploading, and
  // back to the call's deadline once the upload is complete.
  if (Clock::now() < call->deadline) {
    Complete(call, absl::DeadlineExceededError(absl::StrFormat(
                       "the upload sent nothing for %g s (--upload-idle-s): cut off",
                       options_.upload_idle_s)));
    return;
  }
  Complete(call, absl::DeadlineExceededError(
                     !call->uploaded ? "the upload did not complete before the call's deadline "
                                 "(--deadline-s or the client's): cut off"
                               : "the call's deadline passed while queued or estimating"));
}

absl::Status WeaveFitService::CancellationReason(const Call& call) const {
  const Clock::time_point now = Clock::now();
  const Clock::time_point grace_end{Clock::duration(grace_end_.load())};
  if (now >= grace_end) {
    return absl::CancelledError(
        "cut off by the daemon's shutdown: the grace period (--shutdown-grace-s) ended");
  }
  if (now >= call.client_deadline) {
    return absl::DeadlineExceededError("the client's deadline passed");
  }
  return absl::CancelledError("the client went away");
}

bool WeaveFitService::Complete(Call* call, const absl::Status& status,
                               const std::function<void()>& commit) {
  {
    std::lock_guard<std::mutex> lock(call->mutex);
    if (call->finished) return false;
    call->finished = true;
  }
  if (status.ok() && commit) commit();
  const double seconds = std::chrono::duration<double>(Clock::now() - call->start).count();
  std::size_t bytes = 0;
  for (const Upload& u : call->uploads) bytes += u.received;
  const std::string outcome =
      status.ok() ? std::string("OK")
                  : absl::StrCat(absl::StatusCodeToString(status.code()), ": ", status.message());
  // Never the payload; what the client named is escaped, so that a file
  // name cannot forge a log line.
  LOG(INFO) << call->method << " peer=" << call->context->peer()
            << " photographs=" << call->uploads.size()
            << (call->uploads.size() == 1
                    ? absl::StrCat(" file=\"", absl::CEscape(call->uploads[0].header.filename()),
                                   "\"")
                    : std::string())
            << " bytes=" << bytes << " outcome=" << outcome << " ms=" << seconds * 1000.0;
  if (metrics_ != nullptr) {
    metrics_->CountRequest(call->method, absl::StatusCodeToString(status.code()));
    metrics_->request_seconds.Observe(seconds);
    metrics_->AddInFlight(-1);
  }
  call->reactor->Finish(ToGrpcStatus(status));
  return true;
}

}  // namespace weavefit
