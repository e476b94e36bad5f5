#include "proto/connection.h"

#include <grpcpp/generic/generic_stub.h>

#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <mutex>
#include <vector>
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

Status CheckHealth(const Connection& connection, double timeout_s) {
  Result<std::shared_ptr<grpc::Channel>> channel = OpenChannel(connection, grpc::ChannelArguments());
  if (!channel.ok()) return channel.status();
  grpc::GenericStub generic(*channel);
  grpc::ClientContext ctx;
  ctx.set_deadline(std::chrono::system_clock::now() + std::chrono::milliseconds(static_cast<int64_t>(timeout_s * 1000)));
  grpc::Slice empty("");
  grpc::ByteBuffer request(&empty, 1), response;
  std::mutex mu;
  std::condition_variable cv;
  bool done = false;
  grpc::Status status;
  // HealthCheckRequest{} is empty on the wire; the generic stub spares the health proto's generated code.
  generic.UnaryCall(&ctx, "/grpc.health.v1.Health/Check", grpc::StubOptions(), &request, &response, [&](grpc::Status s) {
    std::lock_guard lock(mu);
    status = s;
    done = true;
    cv.notify_all();
  });
  std::unique_lock lock(mu);
  cv.wait(lock, [&] { return done; });
  if (!status.ok()) return Status::Error(connection.server + ": health check failed: " + status.error_message());
  std::vector<grpc::Slice> slices;
  response.Dump(&slices);
  std::string bytes;
  for (const grpc::Slice& s : slices) bytes.append(reinterpret_cast<const char*>(s.begin()), s.size());
  // HealthCheckResponse{status: SERVING (1)}.
  if (bytes != std::string("\x08\x01", 2)) return Status::Error(connection.server + ": not serving");
  return Status::Ok();
}

void Authorize(const Connection& connection, grpc::ClientContext* context) {
  if (!connection.token.empty()) context->AddMetadata("authorization", "Bearer " + connection.token);
}

}  // namespace kgd
