// The command-line flags of the design service, one set for kgd-server and `kgd serve` (server/
// service_host.h):
//   --data, --listen, --internal-listen, --lease-s, --max-attempts, --max-message-mb, --drain-s, --quiet
//   --http HOST:PORT, --web DIR, --max-upload-mb   the HTTP door and the web page
//   --allowed-host NAME[:PORT]   a name the HTTP door answers to besides its address (repeatable)
//   --auth-tokens FILE   bearer tokens (server/auth.h): every request needs one; jobs have owners
//   --tls-cert, --tls-key  PEM files: gRPC and HTTP over TLS
//   --insecure           serve a non-loopback address without TLS and tokens (refused otherwise)
//   --max-...            the limits of server/job_service.h (ServiceLimits), --max-watchers included
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "server/service_host.h"

namespace kgd::server {

struct ServiceFlags {
  HostOptions host;  // the defaults; set host.http.address before AddServiceFlags for a default HTTP door
  std::string auth_tokens;
  double max_message_mb = (64 << 20) / double(1 << 20);
  double max_upload_mb = 64;
  double max_design_file_mb = static_cast<double>(ServiceLimits().max_design_file_bytes >> 20);
};

// Registers every flag above on `app`, writing into `flags`.
void AddServiceFlags(CLI::App* app, ServiceFlags* flags);

// The host's options from the parsed flags: loads the token file, sets both doors' TLS files.
Result<HostOptions> HostOptionsOf(const ServiceFlags& flags);

}  // namespace kgd::server
