// The command-line flags that secure a design server, shared by kgd-server and `kgd serve`:
//   --auth-tokens FILE   bearer tokens (server/auth.h): every request needs one; jobs have owners
//   --tls-cert, --tls-key  PEM files: gRPC and HTTP over TLS
//   --insecure           serve a non-loopback address without TLS and tokens (refused otherwise)
#pragma once

#include <CLI/CLI.hpp>
#include <string>

#include "server/design_server.h"
#include "server/http_gateway.h"

namespace kgd::server {

struct SecurityFlags {
  std::string auth_tokens, tls_cert, tls_key;
  bool insecure = false;
};

inline void AddSecurityFlags(CLI::App* app, SecurityFlags* f) {
  app->add_option("--auth-tokens", f->auth_tokens, "Token file (lines: TOKEN USER ROLE; role user, admin or worker): every request needs a token")
      ->check(CLI::ExistingFile);
  app->add_option("--tls-cert", f->tls_cert, "PEM certificate (chain): serve gRPC and HTTP over TLS")->check(CLI::ExistingFile);
  app->add_option("--tls-key", f->tls_key, "PEM private key of --tls-cert")->check(CLI::ExistingFile);
  app->add_flag("--insecure", f->insecure, "Allow a non-loopback address without TLS and tokens");
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
  return Status::Ok();
}

}  // namespace kgd::server
