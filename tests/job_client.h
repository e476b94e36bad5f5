// The design service as the service tests call it over gRPC: one channel to a server's address
// (reconnecting within `reconnect_backoff_ms`, messages up to 256 MiB) and the job calls they make.
#pragma once

#include <grpcpp/grpcpp.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "kgd/v1/kgd.grpc.pb.h"

namespace kgd::test_support {

class JobClient {
 public:
  explicit JobClient(const std::string& address, int reconnect_backoff_ms = 500) {
    grpc::ChannelArguments args;
    args.SetInt(GRPC_ARG_MAX_RECONNECT_BACKOFF_MS, reconnect_backoff_ms);
    args.SetMaxReceiveMessageSize(256 << 20);
    args.SetMaxSendMessageSize(256 << 20);
    channel_ = grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), args);
    stub_ = v1::DesignService::NewStub(channel_);
  }

  v1::DesignService::Stub& stub() { return *stub_; }

  // CreateJob, within 10 s.
  grpc::Status Create(const v1::JobSpec& spec, v1::Job* job) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    v1::CreateJobRequest req;
    *req.mutable_spec() = spec;
    return stub_->CreateJob(&ctx, req, job);
  }
  // GetJob, within 5 s; a job in state JOB_STATE_UNSPECIFIED when the call fails.
  v1::Job Get(int64_t id) {
    grpc::ClientContext ctx;
    ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(5));
    v1::GetJobRequest req;
    req.set_id(id);
    v1::Job job;
    if (!stub_->GetJob(&ctx, req, &job).ok()) job.set_state(v1::JOB_STATE_UNSPECIFIED);
    return job;
  }
  // The job has ended: succeeded, failed or cancelled.
  bool Finished(int64_t id) {
    const v1::JobState s = Get(id).state();
    return s == v1::SUCCEEDED || s == v1::FAILED || s == v1::CANCELLED;
  }

 private:
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::DesignService::Stub> stub_;
};

}  // namespace kgd::test_support
