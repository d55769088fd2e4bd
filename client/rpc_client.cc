#include "client/rpc_client.h"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>

#include "proto/weavefit/v1/status_util.h"
#include "weavefit/v1/weavefit.grpc.pb.h"

namespace weavefit {

absl::StatusOr<v1::EstimateReply> SubmitEstimate(const std::string& server,
                                                 v1::RequestHeader header,
                                                 const std::string& bytes,
                                                 double timeout_s) {
  auto channel = grpc::CreateChannel(server, grpc::InsecureChannelCredentials());
  auto stub = v1::WeaveFit::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::milliseconds(static_cast<long long>(timeout_s * 1000)));
  context.set_wait_for_ready(false);
  v1::EstimateReply reply;
  std::unique_ptr<grpc::ClientWriter<v1::EstimateRequest>> writer =
      stub->Estimate(&context, &reply);
  header.set_total_bytes(bytes.size());
  v1::EstimateRequest message;
  *message.mutable_header() = std::move(header);
  bool open = writer->Write(message);
  for (std::size_t at = 0; open && at < bytes.size(); at += kChunkBytes) {
    message.set_chunk(bytes.substr(at, std::min(kChunkBytes, bytes.size() - at)));
    open = writer->Write(message);
  }
  // A closed stream means the server already answered (an early error):
  // Finish() then returns that status.
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  if (!status.ok()) return FromGrpcStatus(status);
  return reply;
}

absl::StatusOr<v1::JointEstimateReply> SubmitJoint(const std::string& server,
                                                   std::vector<v1::RequestHeader> headers,
                                                   const std::vector<std::string>& bytes,
                                                   double timeout_s) {
  if (headers.size() != bytes.size()) {
    return absl::InvalidArgumentError("one header per photograph is needed");
  }
  auto channel = grpc::CreateChannel(server, grpc::InsecureChannelCredentials());
  auto stub = v1::WeaveFit::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() +
                       std::chrono::milliseconds(static_cast<long long>(timeout_s * 1000)));
  v1::JointEstimateReply reply;
  std::unique_ptr<grpc::ClientWriter<v1::EstimateRequest>> writer =
      stub->EstimateJoint(&context, &reply);
  bool open = true;
  for (std::size_t i = 0; open && i < headers.size(); ++i) {
    headers[i].set_total_bytes(bytes[i].size());
    v1::EstimateRequest message;
    *message.mutable_header() = std::move(headers[i]);
    open = writer->Write(message);
    for (std::size_t at = 0; open && at < bytes[i].size(); at += kChunkBytes) {
      message.set_chunk(bytes[i].substr(at, std::min(kChunkBytes, bytes[i].size() - at)));
      open = writer->Write(message);
    }
  }
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  if (!status.ok()) return FromGrpcStatus(status);
  return reply;
}

}  // namespace weavefit
