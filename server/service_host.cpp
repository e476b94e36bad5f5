#include "server/service_host.h"

#include "server/listen_address.h"

namespace kgd::server {

Result<std::unique_ptr<ServiceHost>> ServiceHost::Start(HostOptions o) {
  auto h = std::unique_ptr<ServiceHost>(new ServiceHost);
  if (o.in_process_workers) {
    if (o.service.tokens.enabled()) {
      h->worker_token_ = NewToken();
      KGD_RETURN_IF_ERROR(o.service.tokens.Add(h->worker_token_, "kgd-serve-workers", Role::kWorker));
    }
    if (!o.grpc.tls_cert.empty() && o.grpc.internal_address.empty()) o.grpc.internal_address = "127.0.0.1:0";
  }
  const bool tokens = o.service.tokens.enabled();
  KGD_RETURN_IF_ERROR(DesignServer::CheckOptions(o.grpc, tokens));
  if (!o.http.address.empty()) KGD_RETURN_IF_ERROR(HttpGateway::CheckOptions(o.http, tokens));
  // A taken address is refused before the data folder is opened (the doors refuse it too, should it
  // be taken in between).
  KGD_RETURN_IF_ERROR(CheckAddressFree("--listen", o.grpc.address));
  if (!o.grpc.internal_address.empty()) KGD_RETURN_IF_ERROR(CheckAddressFree("--internal-listen", o.grpc.internal_address));
  if (!o.http.address.empty()) KGD_RETURN_IF_ERROR(CheckAddressFree("--http", o.http.address));
  h->options_ = o;
  Result<std::unique_ptr<JobService>> service = JobService::Open(o.service);
  if (!service.ok()) return service.status();
  h->service_ = std::move(service).value();
  Result<std::unique_ptr<DesignServer>> grpc = DesignServer::Start(*h->service_, o.grpc);
  if (!grpc.ok()) return grpc.status();
  h->grpc_ = std::move(grpc).value();
  if (!o.http.address.empty()) {
    Result<std::unique_ptr<HttpGateway>> http = HttpGateway::Start(*h->service_, o.http);
    if (!http.ok()) return http.status();
    h->http_ = std::move(http).value();
  }
  return h;
}

ServiceHost::~ServiceHost() { Shutdown(); }

JobService& ServiceHost::service() { return *service_; }
std::string ServiceHost::grpc_address() const { return grpc_->address(); }
std::string ServiceHost::http_url() const { return http_ ? http_->url() : ""; }

Connection ServiceHost::worker_connection() const {
  Connection c;
  c.server = grpc_->internal_address();
  c.token = worker_token_;
  return c;
}

void ServiceHost::Shutdown(const std::function<void()>& after_drain) {
  if (shut_ || !service_) return;
  shut_ = true;
  if (http_) http_->Stop();
  service_->Drain(options_.drain_timeout_s);
  if (after_drain) after_drain();
  service_->Stop();
  if (grpc_) grpc_->Shutdown();
  service_->Close();
}

}  // namespace kgd::server
