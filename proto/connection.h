// How clients and workers reach the design server: its address, the bearer token that says who they
// are (server/auth.h) and, for TLS, the certificate authority that signed the server's certificate.
//
// The token goes as the call metadata `authorization: Bearer TOKEN` on every call (Authorize), over
// plaintext or TLS alike: gRPC's call credentials travel only over TLS, and the server on loopback
// takes tokens without TLS.
#pragma once

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>

#include "core/util/status.h"

namespace kgd {

struct Connection {
  std::string server = "127.0.0.1:7447";  // host:port
  std::string token;                      // empty: none (a server without --auth-tokens)
  std::string tls_ca;                     // PEM file of the CA to trust; empty: plaintext
};

// The connection from the environment's defaults: KGD_SERVER, KGD_TOKEN, KGD_TLS_CA (unset: the
// defaults above).
Connection ConnectionFromEnvironment();

// A channel to the server (TLS when tls_ca is set). Errors: an unreadable CA file.
Result<std::shared_ptr<grpc::Channel>> OpenChannel(const Connection& connection, const grpc::ChannelArguments& args);

// Adds the token (if any) to a call's metadata.
void Authorize(const Connection& connection, grpc::ClientContext* context);

// Standard gRPC health checking of the whole server (grpc.health.v1.Health/Check, empty service name):
// OK when it answers SERVING within timeout_s; the error says what came instead.
Status CheckHealth(const Connection& connection, double timeout_s);

// The contents of a file (certificates, keys); an error names the file.
Result<std::string> ReadPemFile(const std::string& path, const std::string& what);

}  // namespace kgd
