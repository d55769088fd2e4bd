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

}  // namespace weavefit
