// Who is calling the design service, and the bearer tokens that say so.
//
// A token file (`--auth-tokens FILE`) has one token per line, three fields separated by blanks:
//   TOKEN USER ROLE        e.g.  3f9c0d1e...  alice  user
// ROLE is `user` (sees, watches, fetches, exports and cancels the jobs it created), `admin` (all jobs)
// or `worker` (leases and reports jobs; cannot list or read them). Blank lines and lines starting with
// # are skipped. Tokens are opaque strings of at least 16 characters without blanks; each appears once.
//
// Both doors take the token the same way: gRPC as the metadata `authorization: Bearer TOKEN`, HTTP as
// the header `Authorization: Bearer TOKEN` (or, for the browser's GET requests, the cookie kgd_token).
// Without a token file the service has one anonymous caller that may do everything.
#pragma once

#include <map>
#include <string>

#include "core/util/status.h"

namespace kgd::server {

enum class Role { kUser, kAdmin, kWorker };

struct Caller {
  std::string user;          // the token's user; empty for the anonymous caller
  Role role = Role::kAdmin;  // the anonymous caller may do everything
};

class TokenTable {
 public:
  // No tokens: every request is the anonymous caller.
  TokenTable() = default;
  // Reads a token file; errors name the file, the line and what is wrong with it.
  static Result<TokenTable> Load(const std::string& path);

  bool enabled() const { return !tokens_.empty(); }
  // Adds a token (Load's rules); an error when it is malformed or already present.
  Status Add(const std::string& token, const std::string& user, Role role);
  // The caller of a request from its authorization value ("Bearer TOKEN"; empty: none given). With no
  // tokens, the anonymous caller. Errors are for UNAUTHENTICATED and never echo the token.
  Result<Caller> Authenticate(const std::string& authorization) const;
  // The caller with a bare token (as a cookie carries it).
  Result<Caller> AuthenticateToken(const std::string& token) const;

 private:
  std::map<std::string, Caller> tokens_;
};

// A fresh random token (32 hex digits from the system's random source).
std::string NewToken();

// True for 127.0.0.0/8, ::1 and localhost (the host part of host:port).
bool IsLoopbackAddress(const std::string& address);

// Refuses to expose a door beyond loopback without TLS and tokens, unless `insecure`. `door` names it
// in the message ("--listen", "--http").
Status CheckExposure(const std::string& door, const std::string& address, bool tls, bool tokens, bool insecure);

}  // namespace kgd::server
