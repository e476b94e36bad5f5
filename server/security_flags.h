// The command-line flags that secure a design server, shared by kgd-server and `kgd serve`:
//   --auth-tokens FILE   bearer tokens (server/auth.h): every request needs one; jobs have owners
//   --tls-cert, --tls-key  PEM files: gRPC and HTTP over TLS
//   --insecure           serve a non-loopback address without TLS and tokens (refused otherwise)
//   --max-...            the limits of server/job_service.h (ServiceLimits)
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "server/design_server.h"
#include "server/http_gateway.h"

namespace kgd::server {

struct SecurityFlags {
  std::string auth_tokens, tls_cert, tls_key;
  bool insecure = false;
  ServiceLimits limits;
  double max_design_file_mb = static_cast<double>(ServiceLimits().max_design_file_bytes >> 20);
};

inline void AddSecurityFlags(CLI::App* app, SecurityFlags* f) {
  app->add_option("--auth-tokens", f->auth_tokens, "Token file (lines: TOKEN USER ROLE; role user, admin or worker): every request needs a token")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-cert", f->tls_cert, "PEM certificate (chain): serve gRPC and HTTP over TLS")->check(CLI::ExistingFile);
  app->add_option("--tls-key", f->tls_key, "PEM private key of --tls-cert")->check(CLI::ExistingFile);
  app->add_flag("--insecure", f->insecure, "Allow a non-loopback address without TLS and tokens");
  ServiceLimits& l = f->limits;
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

// Loads the token file and sets both doors' TLS files.
inline Status ApplySecurityFlags(const SecurityFlags& f, ServerOptions* server, HttpOptions* http) {
  if (!f.auth_tokens.empty()) {
    Result<TokenTable> tokens = TokenTable::Load(f.auth_tokens);
    if (!tokens.ok()) return tokens.status();
    server->tokens = std::move(tokens).value();
  }
  server->tls_cert = http->tls_cert = f.tls_cert;
  server->tls_key = http->tls_key = f.tls_key;
  server->insecure = http->insecure = f.insecure;
  server->limits = f.limits;
  server->limits.max_design_file_bytes = static_cast<int64_t>(f.max_design_file_mb * (1 << 20));
  return Status::Ok();
}

}  // namespace kgd::server
