#include "proto/connection.h"

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace kgd {

Connection ConnectionFromEnvironment() {
  Connection c;
  if (const char* v = std::getenv("KGD_SERVER"); v && *v) c.server = v;
  if (const char* v = std::getenv("KGD_TOKEN"); v && *v) c.token = v;
  if (const char* v = std::getenv("KGD_TLS_CA"); v && *v) c.tls_ca = v;
  return c;
}

Result<std::string> ReadPemFile(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::Error(path + ": cannot read the " + what);
  std::ostringstream text;
  text << in.rdbuf();
  if (text.str().find("-----BEGIN ") == std::string::npos) return Status::Error(path + ": the " + what + " is not in PEM format");
  return text.str();
}

Result<std::shared_ptr<grpc::Channel>> OpenChannel(const Connection& connection, const grpc::ChannelArguments& args) {
  if (connection.tls_ca.empty()) return grpc::CreateCustomChannel(connection.server, grpc::InsecureChannelCredentials(), args);
  Result<std::string> ca = ReadPemFile(connection.tls_ca, "certificate authority (--tls-ca)");
  if (!ca.ok()) return ca.status();
  grpc::SslCredentialsOptions ssl;
  ssl.pem_root_certs = *ca;
  return grpc::CreateCustomChannel(connection.server, grpc::SslCredentials(ssl), args);
}

void Authorize(const Connection& connection, grpc::ClientContext* context) {
  if (!connection.token.empty()) context->AddMetadata("authorization", "Bearer " + connection.token);
}

}  // namespace kgd
