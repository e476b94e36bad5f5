#include "server/design_server.h"

#include <grpcpp/ext/proto_server_reflection_plugin.h>
#include <grpcpp/grpcpp.h>
#include <grpcpp/health_check_service_interface.h>

#include <chrono>
#include <optional>
#include <cstdio>

#include "kgd/v1/kgd.grpc.pb.h"
#include "proto/connection.h"
#include "server/listen_address.h"

namespace kgd::server {
using grpc::ServerContext;

namespace {

grpc::Status ToGrpc(const ServiceStatus& st) {
  return st.ok() ? grpc::Status::OK : grpc::Status(static_cast<grpc::StatusCode>(st.code), st.message);
}

// The call's caller from its `authorization` metadata (server/auth.h); nullopt and `status` set when
// it does not authenticate.
std::optional<Caller> CallerOf(const JobService& service, ServerContext* ctx, grpc::Status* status) {
  const auto& metadata = ctx->client_metadata();
  const auto it = metadata.find("authorization");
  Result<Caller> caller = service.Authenticate(it == metadata.end() ? std::string() : std::string(it->second.data(), it->second.size()));
  if (!caller.ok()) {
    *status = grpc::Status(grpc::StatusCode::UNAUTHENTICATED, caller.message());
    return std::nullopt;
  }
  return *caller;
}

// DesignService and WorkerService: each call is the job service's, with the context's cancellation.
class GrpcServices final : public v1::DesignService::Service, public v1::WorkerService::Service {
 public:
  explicit GrpcServices(JobService* service) : service_(*service) {}

  grpc::Status ListScenes(ServerContext* ctx, const v1::ListScenesRequest*, v1::ListScenesResponse* out) override {
    grpc::Status st;
    if (!CallerOf(service_, ctx, &st)) return st;
    return ToGrpc(service_.ListScenes(out));
  }
  grpc::Status CreateJob(ServerContext* ctx, const v1::CreateJobRequest* req, v1::Job* out) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    return caller ? ToGrpc(service_.CreateJob(*caller, *req, out)) : st;
  }
  grpc::Status GetJob(ServerContext* ctx, const v1::GetJobRequest* req, v1::Job* out) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    return caller ? ToGrpc(service_.GetJob(*caller, req->id(), out)) : st;
  }
  grpc::Status ListJobs(ServerContext* ctx, const v1::ListJobsRequest* req, v1::ListJobsResponse* out) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    return caller ? ToGrpc(service_.ListJobs(*caller, *req, out)) : st;
  }
  grpc::Status CancelJob(ServerContext* ctx, const v1::CancelJobRequest* req, v1::Job* out) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    return caller ? ToGrpc(service_.CancelJob(*caller, req->id(), out)) : st;
  }
  grpc::Status GetIteration(ServerContext* ctx, const v1::GetIterationRequest* req, v1::GetIterationResponse* out) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    return caller ? ToGrpc(service_.GetIteration(*caller, *req, out)) : st;
  }
  grpc::Status GetEvaluation(ServerContext* ctx, const v1::GetEvaluationRequest* req, v1::DesignEvaluation* out) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    return caller ? ToGrpc(service_.GetEvaluation(*caller, req->id(), out)) : st;
  }
  grpc::Status ExportDesign(ServerContext* ctx, const v1::ExportDesignRequest* req, grpc::ServerWriter<v1::ExportDesignEvent>* writer) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    if (!caller) return st;
    v1::ExportDesignEvent files;
    st = ToGrpc(service_.ExportDesign(*caller, *req, files.mutable_files(), [writer](const v1::ExportProgress& p) {
      v1::ExportDesignEvent e;
      *e.mutable_progress() = p;
      writer->Write(e);  // a client gone away only misses the progress; the export ends anyway
    }));
    if (!st.ok()) return st;
    writer->Write(files);
    return grpc::Status::OK;
  }
  grpc::Status WatchJob(ServerContext* ctx, const v1::WatchJobRequest* req, grpc::ServerWriter<v1::WatchJobEvent>* writer) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    if (!caller) return st;
    return ToGrpc(service_.WatchJob(
        *caller, *req, [writer](const v1::WatchJobEvent& ev) { return writer->Write(ev); }, [ctx] { return ctx->IsCancelled(); }));
  }

  grpc::Status LeaseJob(ServerContext* ctx, const v1::LeaseJobRequest* req, v1::LeaseJobResponse* out) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    if (!caller) return st;
    return ToGrpc(service_.LeaseJob(*caller, *req, out, [ctx] { return ctx->IsCancelled(); }));
  }
  grpc::Status RunJob(ServerContext* ctx, grpc::ServerReaderWriter<v1::ServerMessage, v1::WorkerMessage>* stream) override {
    grpc::Status st;
    const auto caller = CallerOf(service_, ctx, &st);
    if (!caller) return st;
    return ToGrpc(service_.RunJob(*caller, [stream](v1::WorkerMessage* m) { return stream->Read(m); },
                                  [stream](const v1::ServerMessage& m) { return stream->Write(m); }, [ctx] { return ctx->IsCancelled(); }));
  }

 private:
  JobService& service_;
};

}  // namespace

struct DesignServer::Impl {
  GrpcOptions options;
  JobService* service = nullptr;
  std::unique_ptr<GrpcServices> services;
  std::unique_ptr<grpc::Server> server;
  int port = 0, internal_port = 0;
  bool shut = false;
};

Status DesignServer::CheckOptions(const GrpcOptions& options, bool tokens) {
  const bool tls = !options.tls_cert.empty() || !options.tls_key.empty();
  if (tls && (options.tls_cert.empty() || options.tls_key.empty())) return Status::Error("TLS needs both --tls-cert and --tls-key");
  KGD_RETURN_IF_ERROR(CheckExposure("--listen", options.address, tls, tokens, options.insecure));
  if (!options.internal_address.empty() && !IsLoopbackAddress(options.internal_address))
    return Status::Error("the internal port " + options.internal_address + " must be on loopback");
  return Status::Ok();
}

Result<std::unique_ptr<DesignServer>> DesignServer::Start(JobService& service, const GrpcOptions& options) {
  KGD_RETURN_IF_ERROR(CheckOptions(options, service.options().tokens.enabled()));
  auto s = std::unique_ptr<DesignServer>(new DesignServer);
  s->impl_ = std::make_unique<Impl>();
  Impl& m = *s->impl_;
  m.options = options;
  m.service = &service;
  std::shared_ptr<grpc::ServerCredentials> credentials = grpc::InsecureServerCredentials();
  if (!options.tls_cert.empty()) {
    Result<std::string> cert = ReadPemFile(options.tls_cert, "certificate (--tls-cert)");
    if (!cert.ok()) return cert.status();
    Result<std::string> key = ReadPemFile(options.tls_key, "private key (--tls-key)");
    if (!key.ok()) return key.status();
    grpc::SslServerCredentialsOptions ssl;
    ssl.pem_key_cert_pairs.push_back({*key, *cert});
    credentials = grpc::SslServerCredentials(ssl);
  }
  m.services = std::make_unique<GrpcServices>(&service);

  grpc::EnableDefaultHealthCheckService(true);
  grpc::reflection::InitProtoReflectionServerBuilderPlugin();
  grpc::ServerBuilder builder;
  // No SO_REUSEPORT: a port another server listens on is refused rather than shared with it.
  builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
  builder.AddListeningPort(options.address, credentials, &m.port);
  if (!options.internal_address.empty()) builder.AddListeningPort(options.internal_address, grpc::InsecureServerCredentials(), &m.internal_port);
  builder.SetMaxReceiveMessageSize(options.max_message_bytes);
  builder.SetMaxSendMessageSize(options.max_message_bytes);
  builder.RegisterService(static_cast<v1::DesignService::Service*>(m.services.get()));
  builder.RegisterService(static_cast<v1::WorkerService::Service*>(m.services.get()));
  m.server = builder.BuildAndStart();
  if (!m.server || m.port == 0 || (!options.internal_address.empty() && m.internal_port == 0)) {
    // Which port failed: with a server built, the internal one; without, either (nothing of ours listens).
    if (!m.server) KGD_RETURN_IF_ERROR(CheckAddressFree("--listen", options.address));
    if (!options.internal_address.empty()) KGD_RETURN_IF_ERROR(CheckAddressFree("--internal-listen", options.internal_address));
    return Status::Error(options.address + (options.internal_address.empty() ? "" : " or " + options.internal_address) +
                         ": cannot listen (not an address of this machine?)");
  }
  if (!options.quiet) std::fprintf(stderr, "kgd-server: serving on %s (data in %s)\n", s->address().c_str(), service.options().data_dir.c_str());
  return s;
}

DesignServer::~DesignServer() { Shutdown(); }

int DesignServer::port() const { return impl_->port; }
std::string DesignServer::address() const {
  const std::string& a = impl_->options.address;
  const std::string host = a.substr(0, a.rfind(':'));
  return (host == "0.0.0.0" || host == "[::]" ? "127.0.0.1" : host) + ":" + std::to_string(impl_->port);
}
std::string DesignServer::internal_address() const {
  if (impl_->internal_port == 0) return address();
  const std::string& a = impl_->options.internal_address;
  return a.substr(0, a.rfind(':')) + ":" + std::to_string(impl_->internal_port);
}
void DesignServer::Shutdown() {
  Impl& m = *impl_;
  if (m.shut) return;
  m.shut = true;
  if (m.server) m.server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
}

void DesignServer::Wait() {
  if (impl_->server) impl_->server->Wait();
}

}  // namespace kgd::server
