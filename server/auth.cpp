#include "server/auth.h"

#include <fstream>
#include <random>
#include <sstream>

namespace kgd::server {

Status TokenTable::Add(const std::string& token, const std::string& user, Role role) {
  if (token.size() < 16) return Status::Error("a token must have at least 16 characters");
  if (user.empty()) return Status::Error("a token needs a user");
  if (!tokens_.emplace(token, Caller{user, role}).second) return Status::Error("a token appears twice");
  return Status::Ok();
}

Result<TokenTable> TokenTable::Load(const std::string& path) {
  std::ifstream in(path);
  if (!in) return Status::Error(path + ": cannot read the token file");
  TokenTable table;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    std::istringstream fields(line);
    std::string token, user, role, extra;
    if (!(fields >> token) || token[0] == '#') continue;
    const std::string where = path + ":" + std::to_string(n) + ": ";
    if (!(fields >> user >> role) || (fields >> extra)) return Status::Error(where + "expected three fields: TOKEN USER ROLE");
    Role r;
    if (role == "user")
      r = Role::kUser;
    else if (role == "admin")
      r = Role::kAdmin;
    else if (role == "worker")
      r = Role::kWorker;
    else
      return Status::Error(where + "role '" + role + "' is not one of user, admin, worker");
    if (Status st = table.Add(token, user, r); !st.ok()) return Status::Error(where + st.message());
  }
  if (!table.enabled()) return Status::Error(path + ": no tokens (a service with a token file needs at least one)");
  return table;
}

Result<Caller> TokenTable::AuthenticateToken(const std::string& token) const {
  if (!enabled()) return Caller{};
  if (token.empty()) return Status::Error("this server needs a token (kgd and kgd-worker: --token or $KGD_TOKEN; HTTP: authorization: Bearer TOKEN)");
  auto it = tokens_.find(token);
  if (it == tokens_.end()) return Status::Error("the token is not known to this server");
  return it->second;
}

Result<Caller> TokenTable::Authenticate(const std::string& authorization) const {
  if (!enabled()) return Caller{};
  if (authorization.empty()) return AuthenticateToken("");
  constexpr std::string_view kBearer = "Bearer ";
  if (authorization.compare(0, kBearer.size(), kBearer) != 0) return Status::Error("authorization must be 'Bearer TOKEN'");
  return AuthenticateToken(authorization.substr(kBearer.size()));
}

bool IsLoopbackAddress(const std::string& address) {
  const size_t colon = address.rfind(':');
  std::string host = colon == std::string::npos ? address : address.substr(0, colon);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') host = host.substr(1, host.size() - 2);
  return host == "localhost" || host == "::1" || host.rfind("127.", 0) == 0;
}

Status CheckExposure(const std::string& door, const std::string& address, bool tls, bool tokens, bool insecure) {
  if (insecure || IsLoopbackAddress(address) || (tls && tokens)) return Status::Ok();
  std::string missing = !tls && !tokens ? "TLS (--tls-cert, --tls-key) and tokens (--auth-tokens)" : !tls ? "TLS (--tls-cert, --tls-key)" : "tokens (--auth-tokens)";
  return Status::Error(door + " " + address + " is reachable from other machines: it needs " + missing + ", or --insecure to serve it open");
}

std::string NewToken() {
  std::random_device rd;
  std::ostringstream out;
  for (int i = 0; i < 4; ++i) {
    char buf[9];
    std::snprintf(buf, sizeof(buf), "%08x", rd());
    out << buf;
  }
  return out.str();
}

}  // namespace kgd::server
