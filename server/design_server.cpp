#include "server/design_server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>

#include <chrono>
#include <cstdio>

#include "kgd/v1/kgd.grpc.pb.h"

namespace kgd::server {
using grpc::ServerContext;

namespace {

grpc::Status ToGrpc(const ServiceStatus& st) {
  return st.ok() ? grpc::Status::OK : grpc::Status(static_cast<grpc::StatusCode>(st.code), st.message);
}

// DesignService and WorkerService: each call is the job service's, with the context's cancellation.
class GrpcServices final : public v1::DesignService::Service, public v1::WorkerService::Service {
 public:
  explicit GrpcServices(JobService* service) : service_(*service) {}

  grpc::Status ListScenes(ServerContext*, const v1::ListScenesRequest*, v1::ListScenesResponse* out) override {
    return ToGrpc(service_.ListScenes(out));
  }
  grpc::Status CreateJob(ServerContext*, const v1::CreateJobRequest* req, v1::Job* out) override {
    return ToGrpc(service_.CreateJob(*req, out));
  }
  grpc::Status GetJob(ServerContext*, const v1::GetJobRequest* req, v1::Job* out) override { return ToGrpc(service_.GetJob(req->id(), out)); }
  grpc::Status ListJobs(ServerContext*, const v1::ListJobsRequest* req, v1::ListJobsResponse* out) override {
    return ToGrpc(service_.ListJobs(*req, out));
  }
  grpc::Status CancelJob(ServerContext*, const v1::CancelJobRequest* req, v1::Job* out) override {
    return ToGrpc(service_.CancelJob(req->id(), out));
  }
  grpc::Status GetIteration(ServerContext*, const v1::GetIterationRequest* req, v1::GetIterationResponse* out) override {
    return ToGrpc(service_.GetIteration(*req, out));
  }
  grpc::Status GetEvaluation(ServerContext*, const v1::GetEvaluationRequest* req, v1::DesignEvaluation* out) override {
    return ToGrpc(service_.GetEvaluation(req->id(), out));
  }
  grpc::Status ExportDesign(ServerContext*, const v1::ExportDesignRequest* req, v1::ExportDesignResponse* out) override {
    return ToGrpc(service_.ExportDesign(*req, out));
  }
  grpc::Status WatchJob(ServerContext* ctx, const v1::WatchJobRequest* req, grpc::ServerWriter<v1::WatchJobEvent>* writer) override {
    return ToGrpc(service_.WatchJob(
        *req, [writer](const v1::WatchJobEvent& ev) { return writer->Write(ev); }, [ctx] { return ctx->IsCancelled(); }));
  }

  grpc::Status LeaseJob(ServerContext* ctx, const v1::LeaseJobRequest* req, v1::LeaseJobResponse* out) override {
    return ToGrpc(service_.LeaseJob(*req, out, [ctx] { return ctx->IsCancelled(); }));
  }
  grpc::Status RunJob(ServerContext* ctx, grpc::ServerReaderWriter<v1::ServerMessage, v1::WorkerMessage>* stream) override {
    return ToGrpc(service_.RunJob([stream](v1::WorkerMessage* m) { return stream->Read(m); },
                                  [stream](const v1::ServerMessage& m) { return stream->Write(m); }, [ctx] { return ctx->IsCancelled(); }));
  }

 private:
  JobService& service_;
};

}  // namespace

struct DesignServer::Impl {
  ServerOptions options;
  std::unique_ptr<JobService> service;
  std::unique_ptr<GrpcServices> services;
  std::unique_ptr<grpc::Server> server;
  int port = 0;
  bool shut = false;
};

Result<std::unique_ptr<DesignServer>> DesignServer::Start(const ServerOptions& options) {
  auto s = std::unique_ptr<DesignServer>(new DesignServer);
  s->impl_ = std::make_unique<Impl>();
  Impl& m = *s->impl_;
  m.options = options;
  Result<std::unique_ptr<JobService>> service =
      JobService::Open({.data_dir = options.data_dir, .lease_duration_s = options.lease_duration_s, .max_attempts = options.max_attempts, .quiet = options.quiet});
  if (!service.ok()) return service.status();
  m.service = std::move(service).value();
  m.services = std::make_unique<GrpcServices>(m.service.get());

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  builder.AddListeningPort(options.address, grpc::InsecureServerCredentials(), &m.port);
  builder.SetMaxReceiveMessageSize(options.max_message_bytes);
  builder.SetMaxSendMessageSize(options.max_message_bytes);
  builder.RegisterService(static_cast<v1::DesignService::Service*>(m.services.get()));
  builder.RegisterService(static_cast<v1::WorkerService::Service*>(m.services.get()));
  m.server = builder.BuildAndStart();
  if (!m.server || m.port == 0) return Status::Error(options.address + ": cannot listen (address in use?)");
  if (!options.quiet) std::fprintf(stderr, "kgd-server: serving on %s (data in %s)\n", s->address().c_str(), options.data_dir.c_str());
  return s;
}

DesignServer::~DesignServer() { Shutdown(); }

int DesignServer::port() const { return impl_->port; }
std::string DesignServer::address() const {
  const std::string& a = impl_->options.address;
  const std::string host = a.substr(0, a.rfind(':'));
  return (host == "0.0.0.0" || host == "[::]" ? "127.0.0.1" : host) + ":" + std::to_string(impl_->port);
}
const std::string& DesignServer::data_dir() const { return impl_->options.data_dir; }
JobService& DesignServer::service() { return *impl_->service; }

void DesignServer::Drain() { impl_->service->Drain(impl_->options.drain_timeout_s); }

void DesignServer::Shutdown() {
  Impl& m = *impl_;
  if (!m.service || m.shut) return;
  m.shut = true;
  m.service->Stop();
  if (m.server) m.server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
  m.service->Close();
}

void DesignServer::Wait() {
  if (impl_->server) impl_->server->Wait();
}

}  // namespace kgd::server
