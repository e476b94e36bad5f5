#include "server/service_flags.h"

namespace kgd::server {

void AddServiceFlags(CLI::App* app, ServiceFlags* f) {
  HostOptions& h = f->host;
  app->add_option("--data", h.service.data_dir, "Data folder: kgd.sqlite and jobs/job-N.h5 (created if missing)")->required();
  app->add_option("--listen", h.grpc.address, "host:port to listen on (port 0: any free port)")->capture_default_str();
  app->add_option("--lease-s", h.service.lease_duration_s, "Seconds without a heartbeat after which a worker's job is queued again")
      ->check(CLI::PositiveNumber)->capture_default_str();
  app->add_option("--max-attempts", h.service.max_attempts, "Leases a job gets before it fails")->check(CLI::PositiveNumber)->capture_default_str();
  // gRPC takes the limit as an int of bytes: below 2 GiB.
  app->add_option("--max-message-mb", f->max_message_mb, "Largest request accepted (MiB)")->check(CLI::Range(0.001, 2047.0))->capture_default_str();
  app->add_option("--drain-s", h.drain_timeout_s, "On SIGTERM, seconds to wait for workers to checkpoint")->capture_default_str();
  app->add_flag("--quiet", h.service.quiet, "No log lines");
  app->add_option("--internal-listen", h.grpc.internal_address,
                  "Also a plaintext gRPC port on loopback (host:port), for health probes and local workers of a TLS server");
  app->add_option("--http", h.http.address,
                  h.http.address.empty() ? "host:port of the web page and the HTTP/JSON API (default: none; port 0: any free port)"
                                         : "host:port of the web page and the HTTP/JSON API (port 0: any free port)")
      ->capture_default_str();
  app->add_option("--allowed-host", h.http.allowed_hosts,
                  "A name (NAME: any port; NAME:PORT) the HTTP door also answers to, besides its address (and 127.0.0.1, localhost, "
                  "[::1] on loopback; this machine's IP addresses on 0.0.0.0): a Service's or an ingress's; repeatable")
      ->expected(1)->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  app->add_option("--web", h.http.web_dir, "Folder of the web page's files")->capture_default_str();
  app->add_option("--max-upload-mb", f->max_upload_mb, "Largest HTTP request body accepted (MiB)")->check(CLI::PositiveNumber)->capture_default_str();
  ServiceLimits& l = h.service.limits;
  app->add_option("--max-watchers", l.max_held_watches, "Open HTTP watch streams (Server-Sent Events) served at once")
      ->check(CLI::PositiveNumber)->capture_default_str();
  app->add_option("--auth-tokens", f->auth_tokens, "Token file (lines: TOKEN USER ROLE; role user, admin or worker): every request needs a token")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-cert", h.grpc.tls_cert, "PEM certificate (chain): serve gRPC and HTTP over TLS")->check(CLI::ExistingFile);
  app->add_option("--tls-key", h.grpc.tls_key, "PEM private key of --tls-cert")->check(CLI::ExistingFile);
  app->add_flag("--insecure", h.grpc.insecure, "Allow a non-loopback address without TLS and tokens");
  const auto limit = CLI::NonNegativeNumber;
  app->add_option("--max-iterations", l.max_iterations, "Largest optimizer.maxIterations a job may ask for (0: no limit)")->check(limit)->capture_default_str();
  app->add_option("--max-mesh-vertices", l.max_mesh_vertices, "Vertices of an uploaded mesh file (0: no limit)")->check(limit)->capture_default_str();
  app->add_option("--max-mesh-faces", l.max_mesh_faces, "Faces of an uploaded mesh file (0: no limit)")->check(limit)->capture_default_str();
  app->add_option("--max-frames", l.max_frames, "Motion frames of an uploaded scene (0: no limit)")->check(limit)->capture_default_str();
  app->add_option("--max-queued-per-user", l.max_queued_per_user, "Jobs a user may have waiting in the queue (0: no limit)")->check(limit)->capture_default_str();
  app->add_option("--max-watchers-per-job", l.max_watchers_per_job, "Open watches of one job (0: no limit)")->check(limit)->capture_default_str();
  app->add_option("--max-design-file-mb", f->max_design_file_mb, "A job's design file; a job that outgrows it fails (MiB, 0: no limit)")
      ->check(limit)->capture_default_str();
  app->add_option("--max-jobs-per-minute", l.max_jobs_per_minute, "Job creations per user per minute (0: no limit)")->check(limit)->capture_default_str();
}

Result<HostOptions> HostOptionsOf(const ServiceFlags& f) {
  HostOptions h = f.host;
  if (!f.auth_tokens.empty()) {
    Result<TokenTable> tokens = TokenTable::Load(f.auth_tokens);
    if (!tokens.ok()) return tokens.status();
    h.service.tokens = std::move(tokens).value();
  }
  h.grpc.quiet = h.service.quiet;
  h.grpc.max_message_bytes = static_cast<int>(f.max_message_mb * (1 << 20));
  h.http.tls_cert = h.grpc.tls_cert;
  h.http.tls_key = h.grpc.tls_key;
  h.http.insecure = h.grpc.insecure;
  h.http.max_upload_bytes = static_cast<size_t>(f.max_upload_mb * (1 << 20));
  h.service.limits.max_design_file_bytes = static_cast<int64_t>(f.max_design_file_mb * (1 << 20));
  return h;
}

}  // namespace kgd::server
