#include "server/http_gateway.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "proto/job_spec.h"
#include "proto/connection.h"
#include "server/job_results.h"
#include "server/listen_address.h"
#include "server/region_check.h"
#include "server/scene_body.h"
// After Eigen (through the headers above): a macro of the socket headers it pulls in breaks Eigen's.
#include <httplib.h>
#include <arpa/inet.h>
#include <ifaddrs.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <optional>
#include <set>

namespace kgd::server {
namespace {

namespace pbu = google::protobuf::util;
using Clock = std::chrono::steady_clock;

int HttpStatusOf(ServiceCode code) {
  switch (code) {
    case ServiceCode::kOk: return 200;
    case ServiceCode::kCancelled: return 499;
    case ServiceCode::kInvalidArgument: return 400;
    case ServiceCode::kNotFound: return 404;
    case ServiceCode::kPermissionDenied: return 403;
    case ServiceCode::kResourceExhausted: return 429;
    case ServiceCode::kFailedPrecondition: return 400;
    case ServiceCode::kInternal: return 500;
    case ServiceCode::kUnavailable: return 503;
    case ServiceCode::kUnauthenticated: return 401;
  }
  return 500;
}

// The value of cookie `name` in the request's Cookie header; empty when absent.
std::string CookieValue(const httplib::Request& req, const std::string& name) {
  const std::string cookies = req.get_header_value("Cookie");
  for (size_t at = 0; at < cookies.size();) {
    size_t end = cookies.find(';', at);
    if (end == std::string::npos) end = cookies.size();
    std::string pair = cookies.substr(at, end - at);
    pair.erase(0, pair.find_first_not_of(' '));
    if (pair.rfind(name + "=", 0) == 0) return pair.substr(name.size() + 1);
    at = end + 1;
  }
  return "";
}

// `s` as a JSON string (quoted); bytes that are not UTF-8 become U+FFFD.
std::string JsonString(const std::string& s) { return nlohmann::json(s).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace); }

// A message as people read it: control characters (a file's bytes quoted by a parser) as \xNN, at
// most 2000 bytes.
std::string Readable(const std::string& message) {
  std::string out;
  for (const char ch : message.substr(0, 2000)) {
    const unsigned char c = static_cast<unsigned char>(ch);
    if ((c < 0x20 && c != '\n' && c != '\t') || c == 0x7f) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += hex;
    } else {
      out += ch;
    }
  }
  return out + (message.size() > 2000 ? "..." : "");
}

void SetError(httplib::Response& res, int http_status, ServiceCode code, const std::string& message) {
  res.status = http_status;
  res.set_content("{\"error\": {\"code\": " + std::to_string(http_status) + ", \"status\": \"" + ServiceCodeName(code) +
                      "\", \"message\": " + JsonString(Readable(message)) + "}}\n",
                  "application/json");
}

void SetError(httplib::Response& res, const ServiceStatus& st) { SetError(res, HttpStatusOf(st.code), st.code, st.message); }

std::string ToJson(const google::protobuf::Message& m) {
  pbu::JsonPrintOptions o;
  o.always_print_primitive_fields = true;
  std::string out;
  (void)pbu::MessageToJsonString(m, &out, o);  // only fails on invalid messages, which we never build
  return out;
}

void SetMessage(httplib::Response& res, const google::protobuf::Message& m) { res.set_content(ToJson(m) + "\n", "application/json"); }

// Parses `text` into `m`; errors name `what` and the parser's complaint.
ServiceStatus FromJson(const std::string& text, const std::string& what, google::protobuf::Message* m) {
  pbu::JsonParseOptions o;
  o.ignore_unknown_fields = false;
  const auto st = pbu::JsonStringToMessage(text, m, o);
  if (st.ok()) return ServiceStatus::Ok();
  return {ServiceCode::kInvalidArgument, what + " is not a valid " + m->GetDescriptor()->full_name() + " in JSON: " + std::string(st.message())};
}

// A non-negative (or -1) integer path or query value; errors name it.
bool ParseInt(const std::string& text, long long lo, long long* out) {
  if (text.empty() || text.size() > 18) return false;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || v < lo) return false;
  *out = v;
  return true;
}

template <typename T>
std::string LittleEndianBytes(const std::vector<T>& values) {
  static_assert(std::endian::native == std::endian::little, "binary arrays are sent in host order");
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(T));
}

// Strain energy per rest area of each face (server/job_results.h) as little-endian float32.
void SetEnergyPerArea(httplib::Response& res, const v1::Garment& g, const std::string& design,
                      const google::protobuf::RepeatedField<double>& energy_density_Pa) {
  std::vector<float> e;
  if (ServiceStatus st = EnergyPerArea(g, design, energy_density_Pa, &e); !st.ok()) return SetError(res, st);
  res.set_content(LittleEndianBytes(e), "application/octet-stream");
}

// A Host header's or an origin's host and port: the host lowercased, an IP address in its canonical
// text (IPv6 in brackets); port -1 when none is given.
struct Authority {
  std::string host;
  int port = -1;
};

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// An IP address's canonical text (IPv6 in brackets); empty when `host` is not an IP address.
std::string CanonicalIp(const std::string& host) {
  const bool bracketed = host.size() >= 2 && host.front() == '[' && host.back() == ']';
  const std::string bare = bracketed ? host.substr(1, host.size() - 2) : host;
  unsigned char bytes[16];
  char text[INET6_ADDRSTRLEN];
  if (!bracketed && inet_pton(AF_INET, bare.c_str(), bytes) == 1) return inet_ntop(AF_INET, bytes, text, sizeof text);
  if (inet_pton(AF_INET6, bare.c_str(), bytes) == 1) return "[" + std::string(inet_ntop(AF_INET6, bytes, text, sizeof text)) + "]";
  return "";
}

// HOST[:PORT] ([IPv6][:PORT]); nullopt when it is not one.
std::optional<Authority> ParseAuthority(const std::string& text) {
  Authority a;
  std::string rest;
  if (!text.empty() && text.front() == '[') {
    const size_t close = text.find(']');
    if (close == std::string::npos) return std::nullopt;
    a.host = text.substr(0, close + 1);
    rest = text.substr(close + 1);
  } else {
    const size_t colon = text.find(':');
    a.host = text.substr(0, colon);
    if (colon != std::string::npos) rest = text.substr(colon);
  }
  if (a.host.empty() || a.host.find_first_of(" /@?#\\") != std::string::npos) return std::nullopt;
  if (!rest.empty()) {
    long long port = 0;
    if (rest.front() != ':' || !ParseInt(rest.substr(1), 0, &port) || port > 65535) return std::nullopt;
    a.port = static_cast<int>(port);
  }
  const std::string ip = CanonicalIp(a.host);
  a.host = ip.empty() ? Lower(a.host) : ip;
  return a;
}

// The SCHEME://HOST[:PORT] of an Origin header or a Referer URL: its authority with the scheme's port
// when it names none; nullopt when it is no such URL ("null", a file: page).
std::optional<Authority> OriginAuthority(const std::string& url) {
  const size_t sep = url.find("://");
  if (sep == std::string::npos) return std::nullopt;
  const std::string scheme = Lower(url.substr(0, sep));
  std::string authority = url.substr(sep + 3, url.find_first_of("/?#", sep + 3) - (sep + 3));
  if (const size_t at = authority.rfind('@'); at != std::string::npos) authority = authority.substr(at + 1);
  std::optional<Authority> a = ParseAuthority(authority);
  if (a && a->port < 0) a->port = scheme == "https" ? 443 : scheme == "http" ? 80 : -1;
  return a;
}

// The addresses of this machine's network interfaces, canonical (IPv6 in brackets).
std::set<std::string> InterfaceAddresses() {
  std::set<std::string> out;
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) != 0) return out;
  for (ifaddrs* i = list; i; i = i->ifa_next) {
    if (!i->ifa_addr) continue;
    char text[INET6_ADDRSTRLEN];
    if (i->ifa_addr->sa_family == AF_INET)
      out.insert(inet_ntop(AF_INET, &reinterpret_cast<sockaddr_in*>(i->ifa_addr)->sin_addr, text, sizeof text));
    else if (i->ifa_addr->sa_family == AF_INET6)
      out.insert("[" + std::string(inet_ntop(AF_INET6, &reinterpret_cast<sockaddr_in6*>(i->ifa_addr)->sin6_addr, text, sizeof text)) + "]");
  }
  freeifaddrs(list);
  return out;
}

}  // namespace

struct HttpGateway::Impl {
  JobService* service = nullptr;
  HttpOptions options;
  std::unique_ptr<httplib::Server> server;  // an SSLServer with TLS
  std::thread listener;
  std::atomic<bool> stopping{false};
  int port = 0;
  std::string host;
  int listening_socket = -1;  // the socket the library made last (set in its socket-options callback)
  SceneBodies scene_bodies;   // the built-in scenes' posed bodies, for GET /v1/scenes/{name}/body/...
  std::vector<Authority> allowed_hosts;  // --allowed-host (port -1: any)
  std::set<std::string> own_hosts;       // the --http host; loopback names on loopback or every address
  bool every_address = false;            // --http 0.0.0.0 or [::]: this machine's addresses are its names too

  // The names the server answers to: `own_hosts` (on every address, also this machine's interface
  // addresses) at the port it listens on, or with `any_port` at any (a browser sends a Host only to
  // the server it connected to, so for a Host header the name is what counts: a DNS rebinding page
  // sends its own), and the --allowed-host names at their port, if they name one.
  bool Names(const Authority& a, bool any_port) const {
    const int port = a.port >= 0 ? a.port : (options.tls_cert.empty() ? 80 : 443);
    for (const Authority& allowed : allowed_hosts)
      if (allowed.host == a.host && (allowed.port < 0 || allowed.port == port)) return true;
    if (!any_port && port != this->port) return false;
    if (own_hosts.count(a.host)) return true;
    return every_address && !CanonicalIp(a.host).empty() && InterfaceAddresses().count(a.host);
  }

  // A DNS rebinding page (a foreign name resolved to this machine) is refused on every request by its
  // Host header; a page of another origin is refused on every request that changes anything by its
  // Origin (or, without one, its Referer). Requests with neither come from programs, not pages, and
  // requests without a Host from HTTP/1.0 programs: no browser sends one without it.
  bool Refused(const httplib::Request& req, httplib::Response& res) const {
    std::optional<Authority> host;
    if (req.has_header("Host")) {
      const std::string text = req.get_header_value("Host");
      host = ParseAuthority(text);
      if (!host || !Names(*host, true)) {
        SetError(res, 403, ServiceCode::kPermissionDenied,
                 "host '" + text + "' is not a name of this server (--allowed-host NAME[:PORT] adds one)");
        return true;
      }
    }
    if (req.method == "GET" || req.method == "HEAD" || req.method == "OPTIONS") return false;
    const bool has_origin = req.has_header("Origin");
    if (!has_origin && !req.has_header("Referer")) return false;
    const std::string page = req.get_header_value(has_origin ? "Origin" : "Referer");
    const std::optional<Authority> origin = OriginAuthority(page);
    const int default_port = options.tls_cert.empty() ? 80 : 443;
    const bool same_origin = origin && host && origin->host == host->host && origin->port == (host->port >= 0 ? host->port : default_port);
    if (origin && (same_origin || Names(*origin, false))) return false;
    const size_t sep = page.find("://");
    const std::string from = sep == std::string::npos ? page : page.substr(0, page.find_first_of("/?#", sep + 3));
    SetError(res, 403, ServiceCode::kPermissionDenied,
             "a page from " + (from.empty() ? std::string("an unnamed origin") : from) + (has_origin ? "" : " (its Referer)") + " may not " +
                 req.method + " " + req.path + " on this server: only the server's own page may (the server's own names only: another site is never let in)");
    return true;
  }

  // The request's caller: the Authorization header's bearer token, or for GET (the browser's
  // EventSource and download links cannot send headers) the cookie kgd_token.
  Result<Caller> Authenticate(const httplib::Request& req) const {
    const std::string authorization = req.get_header_value("Authorization");
    if (!authorization.empty() || req.method != "GET") return service->Authenticate(authorization);
    return service->AuthenticateToken(CookieValue(req, "kgd_token"));
  }
  // After the pre-routing check, which refused requests that do not authenticate; a request that
  // still does not is a worker, which reads nothing.
  Caller CallerOf(const httplib::Request& req) const {
    Result<Caller> c = Authenticate(req);
    return c.ok() ? *c : Caller{"", Role::kWorker};
  }

  // Path parameters: job id and iteration (-1: the last).
  bool JobId(const httplib::Request& req, httplib::Response& res, int64_t* id) {
    long long v = 0;
    if (!ParseInt(req.matches[1], 1, &v)) {
      SetError(res, 400, ServiceCode::kInvalidArgument, "job id '" + std::string(req.matches[1]) + "' is not a positive integer");
      return false;
    }
    *id = v;
    return true;
  }
  bool IterationNumber(const httplib::Request& req, httplib::Response& res, int* n) {
    long long v = 0;
    if (!ParseInt(req.matches[2], -1, &v) || v > 1 << 30) {
      SetError(res, 400, ServiceCode::kInvalidArgument, "iteration '" + std::string(req.matches[2]) + "' is not an integer >= -1");
      return false;
    }
    *n = static_cast<int>(v);
    return true;
  }

  // False (the response set to the error) when `st` is one.
  static bool Answered(httplib::Response& res, const ServiceStatus& st) {
    if (st.ok()) return true;
    SetError(res, st);
    return false;
  }

  bool Iteration(const httplib::Request& req, httplib::Response& res, v1::GetIterationResponse* out, bool with_garment) {
    int64_t id = 0;
    int n = 0;
    if (!JobId(req, res, &id) || !IterationNumber(req, res, &n)) return false;
    v1::GetIterationRequest r;
    r.set_id(id);
    r.set_iteration(n);
    r.set_with_garment(with_garment);
    return Answered(res, service->GetIteration(CallerOf(req), r, out));
  }

  bool Garment(const httplib::Request& req, httplib::Response& res, v1::Garment* out) {
    int64_t id = 0;
    return JobId(req, res, &id) && Answered(res, service->GetGarment(CallerOf(req), id, out));
  }

  bool Evaluation(const httplib::Request& req, httplib::Response& res, v1::DesignEvaluation* out) {
    int64_t id = 0;
    return JobId(req, res, &id) && Answered(res, service->GetEvaluation(CallerOf(req), id, out));
  }

  // The iteration an evaluation is of, with the garment (for the thicknesses).
  bool EvaluatedIteration(const httplib::Request& req, httplib::Response& res, const v1::DesignEvaluation& e, v1::GetIterationResponse* out) {
    v1::GetIterationRequest r;
    r.set_id(std::atoll(std::string(req.matches[1]).c_str()));
    r.set_iteration(e.iteration());
    r.set_with_garment(true);
    return Answered(res, service->GetIteration(CallerOf(req), r, out));
  }

  // One function per resource; each registers its routes (the table in http_gateway.h).
  void ServiceRoutes();     // /metrics, /healthz, /readyz, /v1/scenes
  void JobRoutes();         // /v1/jobs, /v1/jobs/{id}, :cancel, :watch
  void IterationRoutes();   // /v1/jobs/{id}/iterations/{n}[/positions.f32|energy.f32|design.u8|design.ply]
  void CutFileRoutes();     // /v1/jobs/{id}/iterations/{n}/cut/...
  void GarmentRoutes();     // /v1/jobs/{id}/garment/..., /v1/jobs/{id}/body/...
  void EvaluationRoutes();  // /v1/jobs/{id}/evaluation[/frames/...|/baselines/...]
  void DesignFileRoutes();  // /v1/jobs/{id}/design-file
  void RegionRoutes();      // /v1/regions:check, /v1/scenes/{name}/body/{pose}.obj
  void Watch(const httplib::Request& req, httplib::Response& res);
  void CreateJob(const httplib::Request& req, httplib::Response& res);
};

using Request = httplib::Request;
using Response = httplib::Response;

void HttpGateway::Impl::ServiceRoutes() {
  httplib::Server& http = *server;
  http.Get("/metrics", [this](const Request&, Response& res) {
    res.set_content(service->MetricsText(), "text/plain; version=0.0.4; charset=utf-8");
  });
  // Probes, without a token: liveness (the process answers) and readiness (it can take work:
  // JobService::Ready; 503 with the reason while it cannot store, or drains).
  http.Get("/healthz", [](const Request&, Response& res) { res.set_content("ok\n", "text/plain; charset=utf-8"); });
  http.Get("/readyz", [this](const Request&, Response& res) {
    const ServiceStatus st = service->Ready();
    res.status = st.ok() ? 200 : 503;
    res.set_content(st.ok() ? std::string("ready\n") : "not ready: " + st.message + "\n", "text/plain; charset=utf-8");
  });
  http.Get("/v1/scenes", [this](const Request&, Response& res) {
    v1::ListScenesResponse out;
    if (Answered(res, service->ListScenes(&out))) SetMessage(res, out);
  });
}

void HttpGateway::Impl::JobRoutes() {
  httplib::Server& http = *server;
  http.Get("/v1/jobs", [this](const Request& req, Response& res) {
    v1::ListJobsRequest r;
    if (req.has_param("pageSize")) {
      long long n = 0;
      if (!ParseInt(req.get_param_value("pageSize"), 0, &n) || n > 1000)
        return SetError(res, 400, ServiceCode::kInvalidArgument, "pageSize '" + req.get_param_value("pageSize") + "' is not in 0..1000");
      r.set_page_size(static_cast<int>(n));
    }
    r.set_page_token(req.get_param_value("pageToken"));
    if (req.has_param("state")) {
      v1::JobState state;
      if (!v1::JobState_Parse(req.get_param_value("state"), &state) || state == v1::JOB_STATE_UNSPECIFIED)
        return SetError(res, 400, ServiceCode::kInvalidArgument,
                        "state '" + req.get_param_value("state") + "' is not one of QUEUED, RUNNING, SUCCEEDED, FAILED, CANCELLED");
      r.set_state_filter(state);
    }
    v1::ListJobsResponse out;
    if (Answered(res, service->ListJobs(CallerOf(req), r, &out))) SetMessage(res, out);
  });
  http.Post("/v1/jobs", [this](const Request& req, Response& res) { CreateJob(req, res); });
  http.Get(R"(/v1/jobs/([^/:]+))", [this](const Request& req, Response& res) {
    int64_t id = 0;
    v1::Job job;
    if (JobId(req, res, &id) && Answered(res, service->GetJob(CallerOf(req), id, &job))) SetMessage(res, job);
  });
  http.Post(R"(/v1/jobs/([^/:]+):cancel)", [this](const Request& req, Response& res) {
    int64_t id = 0;
    v1::Job job;
    if (JobId(req, res, &id) && Answered(res, service->CancelJob(CallerOf(req), id, &job))) SetMessage(res, job);
  });
  http.Get(R"(/v1/jobs/([^/:]+):watch)", [this](const Request& req, Response& res) { Watch(req, res); });
}

void HttpGateway::Impl::IterationRoutes() {
  httplib::Server& http = *server;
  http.Get(R"(/v1/jobs/([^/:]+)/iterations/([^/]+))", [this](const Request& req, Response& res) {
    v1::GetIterationResponse out;
    if (Iteration(req, res, &out, req.get_param_value("withGarment") == "true")) SetMessage(res, out);
  });
  http.Get(R"(/v1/jobs/([^/:]+)/iterations/([^/]+)/positions\.f32)", [this](const Request& req, Response& res) {
    v1::GetIterationResponse out;
    if (Iteration(req, res, &out, false))
      res.set_content(LittleEndianBytes(std::vector<float>(out.record().positions().begin(), out.record().positions().end())), "application/octet-stream");
  });
  http.Get(R"(/v1/jobs/([^/:]+)/iterations/([^/]+)/energy\.f32)", [this](const Request& req, Response& res) {
    v1::GetIterationResponse out;
    if (Iteration(req, res, &out, true)) SetEnergyPerArea(res, out.garment(), out.record().design(), out.record().energy_density_pa());
  });
  http.Get(R"(/v1/jobs/([^/:]+)/iterations/([^/]+)/design\.u8)", [this](const Request& req, Response& res) {
    v1::GetIterationResponse out;
    if (Iteration(req, res, &out, false)) res.set_content(out.record().design(), "application/octet-stream");
  });
  http.Get(R"(/v1/jobs/([^/:]+)/iterations/([^/]+)/design\.ply)", [this](const Request& req, Response& res) {
    v1::GetIterationResponse out;
    if (!Iteration(req, res, &out, true)) return;
    const std::string name = "job-" + std::string(req.matches[1]) + "-iteration-" + std::to_string(out.record().metrics().iteration()) + ".ply";
    std::string ply;
    if (!Answered(res, IterationPly(out, name, &ply))) return;
    res.set_header("Content-Disposition", "attachment; filename=\"" + name + "\"");
    res.set_content(ply, "application/octet-stream");
  });
}

// Cut files (docs/FABRICATION.md) of an iteration, made on request by geometry alone.
void HttpGateway::Impl::CutFileRoutes() {
  httplib::Server& http = *server;
  http.Get(R"(/v1/jobs/([^/:]+)/iterations/([^/]+)/cut/(pattern\.svg|pattern\.dxf|pattern\.png|patches\.svg|patches\.dxf|patches\.png|report\.json))",
              [this](const Request& req, Response& res) {
                int64_t id = 0;
                int n = 0;
                if (!JobId(req, res, &id) || !IterationNumber(req, res, &n)) return;
                v1::ExportDesignRequest r;
                r.set_id(id);
                r.set_iteration(n);
                r.set_no_mirror(req.get_param_value("mirror") == "false");
                for (const auto& [param, set] : std::initializer_list<std::pair<const char*, void (v1::ExportDesignRequest::*)(double)>>{
                         {"minFeatureMm", &v1::ExportDesignRequest::set_min_feature_mm},
                         {"seamAllowanceMm", &v1::ExportDesignRequest::set_seam_allowance_mm},
                         {"sheetWidthMm", &v1::ExportDesignRequest::set_sheet_width_mm}})
                  if (req.has_param(param)) {
                    char* end = nullptr;
                    const std::string v = req.get_param_value(param);
                    const double d = std::strtod(v.c_str(), &end);
                    if (v.empty() || end != v.c_str() + v.size() || !std::isfinite(d) || d < 0)
                      return SetError(res, 400, ServiceCode::kInvalidArgument, std::string(param) + " '" + v + "' is not a finite number >= 0");
                    (r.*set)(d);
                  }
                v1::ExportDesignResponse out;
                if (!Answered(res, service->ExportDesign(CallerOf(req), r, &out))) return;
                const std::string name = req.matches[3];
                const auto it = out.files().find(name);
                if (it == out.files().end()) return SetError(res, 500, ServiceCode::kInternal, "the export made no " + name);
                const std::string type = name.ends_with(".svg")    ? "image/svg+xml"
                                         : name.ends_with(".png")  ? "image/png"
                                         : name.ends_with(".json") ? "application/json"
                                                                   : "application/dxf";
                // The file's name says which iteration it is of (the last stored, for -1: the report says which).
                int k = n;
                if (const auto report = out.files().find("report.json"); report != out.files().end()) {
                  const nlohmann::json j = nlohmann::json::parse(report->second, nullptr, /*allow_exceptions=*/false);
                  if (j.is_object() && j.contains("iteration") && j["iteration"].is_number_integer()) k = j["iteration"].get<int>();
                }
                res.set_header("Content-Disposition",
                               "attachment; filename=\"job-" + std::to_string(id) + "-iteration-" + std::to_string(k) + "-" + name + "\"");
                res.set_content(it->second, type.c_str());
              });
}

void HttpGateway::Impl::GarmentRoutes() {
  httplib::Server& http = *server;
  http.Get(R"(/v1/jobs/([^/:]+)/garment/faces\.u32)", [this](const Request& req, Response& res) {
    v1::Garment g;
    if (Garment(req, res, &g)) res.set_content(LittleEndianBytes(std::vector<uint32_t>(g.faces().begin(), g.faces().end())), "application/octet-stream");
  });
  http.Get(R"(/v1/jobs/([^/:]+)/garment/rest\.f32)", [this](const Request& req, Response& res) {
    v1::Garment g;
    if (Garment(req, res, &g))
      res.set_content(LittleEndianBytes(std::vector<float>(g.rest_vertices().begin(), g.rest_vertices().end())), "application/octet-stream");
  });
  http.Get(R"(/v1/jobs/([^/:]+)/body/(vertices\.f32|faces\.u32))", [this](const Request& req, Response& res) {
    v1::Garment g;
    if (!Garment(req, res, &g)) return;
    if (g.body_faces_size() == 0)
      return SetError(res, 404, ServiceCode::kNotFound, "job " + std::string(req.matches[1]) + " has no body (a flat scene, or a design file of an older kgd)");
    if (req.matches[2] == "vertices.f32")
      res.set_content(LittleEndianBytes(std::vector<float>(g.body_vertices().begin(), g.body_vertices().end())), "application/octet-stream");
    else
      res.set_content(LittleEndianBytes(std::vector<uint32_t>(g.body_faces().begin(), g.body_faces().end())), "application/octet-stream");
  });
}

// The finished design over the motion and beside the baselines: figures as JSON, arrays as binary.
void HttpGateway::Impl::EvaluationRoutes() {
  httplib::Server& http = *server;
  http.Get(R"(/v1/jobs/([^/:]+)/evaluation)", [this](const Request& req, Response& res) {
    v1::DesignEvaluation e;
    if (!Evaluation(req, res, &e)) return;
    for (v1::MotionFrame& f : *e.mutable_frames()) f.clear_positions(), f.clear_body_vertices(), f.clear_energy_density_pa(), f.clear_skin_pressure_pa();
    for (v1::BaselineRecord& b : *e.mutable_baselines()) b.clear_positions(), b.clear_energy_density_pa(), b.clear_design();
    SetMessage(res, e);
  });
  http.Get(R"(/v1/jobs/([^/:]+)/evaluation/frames/([^/]+)/(positions\.f32|body\.f32|energy\.f32|pressure\.f32))", [this](const Request& req, Response& res) {
    v1::DesignEvaluation e;
    if (!Evaluation(req, res, &e)) return;
    long long k = 0;
    if (!ParseInt(req.matches[2], 1, &k) || k > e.frames_size())
      return SetError(res, 404, ServiceCode::kNotFound, "frame '" + std::string(req.matches[2]) + "' is not one of 1.." + std::to_string(e.frames_size()));
    const v1::MotionFrame& f = e.frames(static_cast<int>(k - 1));
    if (req.matches[3] == "positions.f32")
      return res.set_content(LittleEndianBytes(std::vector<float>(f.positions().begin(), f.positions().end())), "application/octet-stream");
    if (req.matches[3] == "body.f32") {
      if (f.body_vertices_size() == 0) return SetError(res, 404, ServiceCode::kNotFound, "the evaluation has no body");
      return res.set_content(LittleEndianBytes(std::vector<float>(f.body_vertices().begin(), f.body_vertices().end())), "application/octet-stream");
    }
    if (req.matches[3] == "pressure.f32") {  // Pa per body vertex
      if (f.skin_pressure_pa_size() == 0) return SetError(res, 404, ServiceCode::kNotFound, "the evaluation has no skin pressure (no body or no contact)");
      return res.set_content(LittleEndianBytes(std::vector<float>(f.skin_pressure_pa().begin(), f.skin_pressure_pa().end())), "application/octet-stream");
    }
    v1::GetIterationResponse it;
    if (EvaluatedIteration(req, res, e, &it)) SetEnergyPerArea(res, it.garment(), it.record().design(), f.energy_density_pa());
  });
  http.Get(R"(/v1/jobs/([^/:]+)/evaluation/baselines/([^/]+)/(positions\.f32|design\.u8|energy\.f32|design\.ply))", [this](const Request& req, Response& res) {
    v1::DesignEvaluation e;
    if (!Evaluation(req, res, &e)) return;
    const v1::BaselineRecord* b = nullptr;
    for (const v1::BaselineRecord& r : e.baselines())
      if (r.name() == req.matches[2]) b = &r;
    if (!b) return SetError(res, 404, ServiceCode::kNotFound, "the evaluation has no baseline '" + std::string(req.matches[2]) + "'");
    if (req.matches[3] == "positions.f32")
      return res.set_content(LittleEndianBytes(std::vector<float>(b->positions().begin(), b->positions().end())), "application/octet-stream");
    if (req.matches[3] == "design.u8") return res.set_content(b->design(), "application/octet-stream");
    v1::GetIterationResponse it;
    if (!EvaluatedIteration(req, res, e, &it)) return;
    if (req.matches[3] == "energy.f32") return SetEnergyPerArea(res, it.garment(), b->design(), b->energy_density_pa());
    // The baseline as the garment PLY of an iteration: its design, positions and energies in the garment's.
    v1::IterationRecord& r = *it.mutable_record();
    r.set_design(b->design());
    *r.mutable_positions() = b->positions();
    *r.mutable_energy_density_pa() = b->energy_density_pa();
    const std::string name = "job-" + std::string(req.matches[1]) + "-baseline-" + b->name() + ".ply";
    std::string ply;
    if (!Answered(res, IterationPly(it, name, &ply))) return;
    res.set_header("Content-Disposition", "attachment; filename=\"" + name + "\"");
    res.set_content(ply, "application/octet-stream");
  });
}

void HttpGateway::Impl::DesignFileRoutes() {
  httplib::Server& http = *server;
  http.Get(R"(/v1/jobs/([^/:]+)/design-file)", [this](const Request& req, Response& res) {
    int64_t id = 0;
    std::string bytes;
    if (!JobId(req, res, &id) || !Answered(res, service->GetDesignFile(CallerOf(req), id, &bytes))) return;
    res.set_header("Content-Disposition", "attachment; filename=\"job-" + std::to_string(id) + ".h5\"");
    res.set_content(bytes, "application/x-hdf5");
  });
}

// The studio page's check of a painted garment region (server/region_check.h): parts in, JSON out.
void HttpGateway::Impl::RegionRoutes() {
  httplib::Server& http = *server;
  http.Post("/v1/regions:check", [this](const Request& req, Response& res) {
    if (!req.is_multipart_form_data())
      return SetError(res, 415, ServiceCode::kInvalidArgument,
                      "POST /v1/regions:check takes multipart/form-data (parts body, faces, ...), not '" + req.get_header_value("Content-Type") + "'");
    auto part = [&req](const char* name) { return req.has_file(name) ? req.get_file_value(name).content : std::string(); };
    RegionCheckRequest r;
    if (req.has_file("body")) r.body_name = req.get_file_value("body").filename;
    r.body_bytes = part("body");
    r.faces = part("faces");
    r.keep_out = part("keepOut");
    r.keep_in = part("keepIn");
    r.attach_width_m = part("attachWidthM");
    r.fill_holes = part("fillHoles");
    r.mirror = part("mirror");
    r.symmetry_plane = part("symmetryPlane");
    r.subdivisions = part("subdivisions");
    r.frames = part("frames");
    r.motions = part("motions");
    r.budget = part("budget");
    r.max_mesh_vertices = service->options().limits.max_mesh_vertices;
    r.max_mesh_faces = service->options().limits.max_mesh_faces;
    v1::ListScenesResponse scenes;  // for the machine factor
    if (!Answered(res, service->ListScenes(&scenes))) return;
    Result<RegionCheckAnswer> a = CheckPaintedRegion(r, scenes.machine_factor());
    if (!a.ok()) return SetError(res, 400, ServiceCode::kInvalidArgument, a.message());
    nlohmann::json j;
    j["faces"] = a->faces;
    j["filledFaces"] = a->filled_faces;
    j["mirrored"] = a->mirrored;
    j["valid"] = a->valid;
    if (!a->valid) j["refusal"] = a->refusal;
    j["keepOut"] = a->keep_out;
    j["keepIn"] = a->keep_in;
    j["predictedJobS"] = a->predicted_job_s;
    if (a->valid) {
      j["areaM2"] = a->region.area_m2;
      j["vertices"] = a->region.vertices;
      j["subdividedVertices"] = a->subdivided_vertices;
      j["subdividedFaces"] = a->subdivided_faces;
      j["loops"] = nlohmann::json::array();
      for (const RegionLoop& l : a->region.loops)
        j["loops"].push_back({{"lengthM", l.length_m}, {"centreM", {l.centre_m.x(), l.centre_m.y(), l.centre_m.z()}}, {"vertices", l.vertices.size()}});
      if (!r.attach_width_m.empty()) {
        j["bands"] = nlohmann::json::array();
        for (const AttachmentBand& b : a->bands) j["bands"].push_back({{"loop", b.loop}, {"faces", b.faces}, {"areaM2", b.area_m2}});
      }
      j["keepOutGarmentFaces"] = a->keep_out_garment_faces;
      j["keepInGarmentFaces"] = a->keep_in_garment_faces;
    }
    res.set_content(j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n", "application/json");
  });
  // A built-in scene's parametric body, posed as the scene poses it; the query's parameters are its
  // measurements, named as in JobSpec.body (height_m) or in lowerCamelCase (heightM).
  http.Get(R"(/v1/scenes/([^/]+)/body/([^/]+)\.obj)", [this](const Request& req, Response& res) {
    std::vector<std::string> measurements;
    for (const auto& [param, value] : req.params) {
      std::string name;
      for (const char c : param) name += std::isupper(static_cast<unsigned char>(c)) ? std::string("_") + char(std::tolower(c)) : std::string(1, c);
      measurements.push_back(name + "=" + value);
    }
    std::string obj;
    if (!Answered(res, scene_bodies.Obj(req.matches[1], measurements, req.matches[2], &obj))) return;
    res.set_header("Content-Disposition", "attachment; filename=\"" + std::string(req.matches[1]) + "-" + std::string(req.matches[2]) + ".obj\"");
    res.set_content(obj, "model/obj");
  });
}

void HttpGateway::Impl::CreateJob(const Request& req, Response& res) {
  const std::string type = req.get_header_value("Content-Type");
  v1::CreateJobRequest r;
  if (type.rfind("application/json", 0) == 0) {
    if (!Answered(res, FromJson(req.body, "the request body", r.mutable_spec()))) return;
  } else if (req.is_multipart_form_data()) {
    if (req.has_file("spec") && !Answered(res, FromJson(req.get_file_value("spec").content, "part 'spec'", r.mutable_spec()))) return;
    if (!req.has_file("scene"))
      return SetError(res, 400, ServiceCode::kInvalidArgument, "multipart upload: the part 'scene' (the scene file) is missing");
    const httplib::MultipartFormData scene_part = req.get_file_value("scene");
    const std::string source = "part 'scene'" + (scene_part.filename.empty() ? "" : " (" + scene_part.filename + ")");
    // A file that is not text (a photo chosen as the scene: JSON has no control characters) is named, not quoted.
    const std::string head = scene_part.content.substr(0, 4096);
    if (std::any_of(head.begin(), head.end(), [](char c) { return (static_cast<unsigned char>(c) < 0x20 && c != '\n' && c != '\r' && c != '\t') || c == 0x7f; }))
      return SetError(res, 400, ServiceCode::kInvalidArgument, source + " is not a JSON scene file: it is not text");
    Result<v1::Scene> scene = ParseSceneJson(scene_part.content, source);
    if (!scene.ok()) return SetError(res, 400, ServiceCode::kInvalidArgument, scene.message());
    v1::SceneFiles* files = r.mutable_spec()->mutable_scene_files();
    *files->mutable_scene() = *scene;
    for (const auto& [name, part] : req.files) {
      if (name == "scene" || name == "spec") continue;
      const std::string file = part.filename.empty() ? name : part.filename;
      (*files->mutable_files())[file] = part.content;
    }
  } else {
    return SetError(res, 415, ServiceCode::kInvalidArgument,
                    "POST /v1/jobs takes application/json (a JobSpec) or multipart/form-data (scene and files), not '" + type + "'");
  }
  v1::Job job;
  if (Answered(res, service->CreateJob(CallerOf(req), r, &job))) SetMessage(res, job);
}

void HttpGateway::Impl::Watch(const Request& req, Response& res) {
  int64_t id = 0;
  if (!JobId(req, res, &id)) return;
  v1::WatchJobRequest r;
  r.set_id(id);
  long long from = 0;
  const std::string last_event = req.get_header_value("Last-Event-ID");
  if (!last_event.empty()) {
    if (!ParseInt(last_event, 0, &from)) return SetError(res, 400, ServiceCode::kInvalidArgument, "Last-Event-ID '" + last_event + "' is not an iteration");
    ++from;
  } else if (req.has_param("fromIteration")) {
    if (!ParseInt(req.get_param_value("fromIteration"), 0, &from))
      return SetError(res, 400, ServiceCode::kInvalidArgument, "fromIteration '" + req.get_param_value("fromIteration") + "' is not an integer >= 0");
  }
  r.set_from_iteration(static_cast<int>(std::min<long long>(from, 1 << 30)));
  const bool metrics_only = req.get_param_value("view") == "metrics";
  // An unknown job, one watched by as many as the limit, or no thread left for one more watch is an
  // error response, not an empty stream. The place is held while the response lives.
  WatchPlace place;
  if (!Answered(res, service->CanWatch(CallerOf(req), id)) || !Answered(res, service->TakeWatchPlace(&place))) return;

  res.set_header("Cache-Control", "no-cache");
  res.set_header("X-Accel-Buffering", "no");
  res.set_chunked_content_provider("text/event-stream", [this, r, metrics_only, caller = CallerOf(req), place](size_t, httplib::DataSink& sink) {
    Clock::time_point last_write = Clock::now();
    bool gone = false;
    auto send = [&](const std::string& text) {
      last_write = Clock::now();
      if (!sink.write(text.data(), text.size())) gone = true;
      return !gone;
    };
    send("retry: 2000\n\n");
    const ServiceStatus st = service->WatchJob(
        caller, r,
        [&](const v1::WatchJobEvent& ev) {
          if (ev.has_job()) return send("event: job\ndata: " + ToJson(ev.job()) + "\n\n");
          v1::IterationRecord rec = ev.iteration();
          if (metrics_only) rec.clear_design();
          return send("id: " + std::to_string(rec.metrics().iteration()) + "\nevent: iteration\ndata: " + ToJson(rec) + "\n\n");
        },
        [&] {
          if (stopping || gone) return true;
          // A comment now and then finds a client that has gone while the job is idle.
          if (Clock::now() - last_write > std::chrono::duration<double>(options.keepalive_s)) send(": keepalive\n\n");
          return gone;
        });
    // A refusal after the check above (the limit reached meanwhile) ends the stream with its reason.
    if (!st.ok() && st.code != ServiceCode::kCancelled)
      send("event: error\ndata: {\"status\": \"" + std::string(ServiceCodeName(st.code)) + "\", \"message\": " + JsonString(st.message) + "}\n\n");
    sink.done();
    return true;
  });
}

Status HttpGateway::CheckOptions(const HttpOptions& options, bool tokens) {
  const size_t colon = options.address.rfind(':');
  long long port = 0;
  if (colon == std::string::npos || !ParseInt(options.address.substr(colon + 1), 0, &port) || port > 65535)
    return Status::Error("--http " + options.address + ": expected HOST:PORT");
  if (!options.web_dir.empty() && !std::filesystem::is_regular_file(std::filesystem::path(options.web_dir) / "index.html"))
    return Status::Error("web page folder " + options.web_dir + " has no index.html");
  const std::string host = options.address.substr(0, colon);
  if (!host.empty() && host != "::" && !ParseAuthority(host)) return Status::Error("--http " + options.address + ": expected HOST:PORT");
  for (const std::string& name : options.allowed_hosts)
    if (name.empty() || !ParseAuthority(name)) return Status::Error("--allowed-host '" + name + "': expected NAME or NAME:PORT");
  const bool tls = !options.tls_cert.empty() || !options.tls_key.empty();
  if (tls && (options.tls_cert.empty() || options.tls_key.empty())) return Status::Error("HTTPS needs both --tls-cert and --tls-key");
  return CheckExposure("--http", options.address, tls, tokens, options.insecure);
}

Result<std::unique_ptr<HttpGateway>> HttpGateway::Start(JobService& service, const HttpOptions& options) {
  KGD_RETURN_IF_ERROR(CheckOptions(options, service.options().tokens.enabled()));
  const size_t colon = options.address.rfind(':');
  const int port = std::atoi(options.address.c_str() + colon + 1);
  auto g = std::unique_ptr<HttpGateway>(new HttpGateway);
  g->impl_ = std::make_unique<Impl>();
  Impl& m = *g->impl_;
  m.service = &service;
  m.options = options;
  m.host = options.address.substr(0, colon);
  for (const std::string& name : options.allowed_hosts) m.allowed_hosts.push_back(*ParseAuthority(name));  // CheckOptions parsed each
  m.every_address = m.host.empty() || m.host == "0.0.0.0" || m.host == "[::]" || m.host == "::";
  if (!m.every_address) m.own_hosts.insert(ParseAuthority(m.host)->host);
  if (m.every_address || IsLoopbackAddress(options.address))
    for (const char* name : {"127.0.0.1", "localhost", "[::1]"}) m.own_hosts.insert(name);
  if (!options.tls_cert.empty()) {
    for (const auto& [path, what] : {std::pair{options.tls_cert, "certificate (--tls-cert)"}, std::pair{options.tls_key, "private key (--tls-key)"}})
      if (Result<std::string> pem = ReadPemFile(path, what); !pem.ok()) return pem.status();
    auto ssl = std::make_unique<httplib::SSLServer>(options.tls_cert.c_str(), options.tls_key.c_str());
    if (!ssl->is_valid()) return Status::Error(options.tls_cert + ", " + options.tls_key + ": not a certificate and its private key");
    m.server = std::move(ssl);
  } else {
    m.server = std::make_unique<httplib::Server>();
  }
  httplib::Server& http = *m.server;
  // Each watch holds a thread for its whole life (as many as the service gives places to); the other
  // requests keep threads of their own.
  const int held = service.options().limits.max_held_watches;
  http.new_task_queue = [n = static_cast<size_t>(std::max(held, 0) + 16)] { return new httplib::ThreadPool(n); };
  // Debian's cpp-httplib compresses with Brotli at its slowest quality whenever a client accepts it
  // (1.3 s for three.js); gzip costs 2 % of that, so the gateway hides "br" from the library.
  // Every request's Host, and every change's Origin, is checked here first (Impl::Refused); then every
  // API request and /metrics is authenticated (the page's static files are public).
  http.set_pre_routing_handler([&m](const Request& req, Response& res) {
    auto& headers = const_cast<Request&>(req).headers;  // the library's own, non-const Request
    auto it = headers.find("Accept-Encoding");
    if (it != headers.end() && it->second.find("br") != std::string::npos) it->second = it->second.find("gzip") != std::string::npos ? "gzip" : "";
    if (m.Refused(req, res)) return httplib::Server::HandlerResponse::Handled;
    if (req.path.rfind("/v1/", 0) != 0 && req.path != "/metrics") return httplib::Server::HandlerResponse::Unhandled;
    Result<Caller> caller = m.Authenticate(req);
    if (!caller.ok()) {
      res.set_header("WWW-Authenticate", "Bearer");
      SetError(res, 401, ServiceCode::kUnauthenticated, caller.message());
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.path == "/metrics" && caller->role != Role::kAdmin) {
      SetError(res, 403, ServiceCode::kPermissionDenied, "/metrics needs an admin's token");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });
  // The page's libraries change only with client/web/package-lock.json.
  http.set_file_request_handler([](const Request& req, Response& res) {
    res.set_header("Cache-Control", req.path.rfind("/vendor/", 0) == 0 ? "public, max-age=86400" : "no-cache");
  });
  http.set_payload_max_length(options.max_upload_bytes);
  http.set_keep_alive_max_count(100);
  for (const auto& [ext, type] : std::initializer_list<std::pair<const char*, const char*>>{
           {"js", "text/javascript"}, {"mjs", "text/javascript"}, {"css", "text/css"}, {"html", "text/html"},
           {"json", "application/json"}, {"svg", "image/svg+xml"}, {"map", "application/json"}})
    http.set_file_extension_and_mimetype_mapping(ext, type);
  if (!options.web_dir.empty()) {
    http.set_mount_point("/", options.web_dir);
    // The page's libraries, installed by npm from client/web/package-lock.json.
    http.set_mount_point("/vendor", (std::filesystem::path(options.web_dir) / "node_modules").string());
  }
  http.set_error_handler(httplib::Server::HandlerWithResponse([](const Request& req, Response& res) {
    if (!res.body.empty()) return httplib::Server::HandlerResponse::Unhandled;
    if (res.status == 413)
      SetError(res, 413, ServiceCode::kResourceExhausted, "the request body is larger than the server accepts (--max-upload-mb)");
    else if (res.status == 404)
      SetError(res, 404, ServiceCode::kNotFound, "no such resource: " + req.method + " " + req.path);
    else if (res.status == 405 || res.status == 400)
      SetError(res, res.status, ServiceCode::kInvalidArgument, "bad request: " + req.method + " " + req.path);
    else
      SetError(res, res.status, ServiceCode::kInternal, "HTTP " + std::to_string(res.status) + " on " + req.method + " " + req.path);
    return httplib::Server::HandlerResponse::Handled;
  }));
  http.set_exception_handler([](const Request&, Response& res, std::exception_ptr ep) {
    std::string what = "unknown error";
    try {
      std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    SetError(res, 500, ServiceCode::kInternal, what);
  });
  m.ServiceRoutes();
  m.JobRoutes();
  m.IterationRoutes();
  m.CutFileRoutes();
  m.GarmentRoutes();
  m.EvaluationRoutes();
  m.DesignFileRoutes();
  m.RegionRoutes();
  // SO_REUSEADDR (a port in TIME_WAIT is taken again) but not the library's SO_REUSEPORT, with which a
  // second server would share the port; the socket is kept to widen its listen queue below.
  http.set_socket_options([&m](int sock) {
    const int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
    m.listening_socket = sock;
  });
  if (port == 0) {
    m.port = http.bind_to_any_port(m.host);
    if (m.port <= 0) return Status::Error("--http " + options.address + ": cannot bind a port on " + m.host);
  } else {
    if (!http.bind_to_port(m.host, port)) {
      KGD_RETURN_IF_ERROR(CheckAddressFree("--http", options.address));
      return Status::Error("--http " + options.address + ": cannot bind (not an address of this machine?)");
    }
    m.port = port;
  }
  // Debian's cpp-httplib listens with a backlog of 5 (compiled in): a burst of connections, such as a
  // hundred watchers opening at once, overflows it and the kernel drops SYNs, which clients retry
  // seconds later or give up on. Listening again on the bound socket widens the queue (Linux keeps
  // the socket and takes the new backlog).
  if (m.listening_socket >= 0) ::listen(m.listening_socket, SOMAXCONN);
  m.listener = std::thread([&m] { m.server->listen_after_bind(); });
  return g;
}

HttpGateway::~HttpGateway() { Stop(); }

int HttpGateway::port() const { return impl_->port; }

std::string HttpGateway::url() const {
  const std::string host = impl_->host == "0.0.0.0" || impl_->host.empty() ? "127.0.0.1" : impl_->host;
  const bool tls = !impl_->options.tls_cert.empty();
  return (tls ? "https://" : "http://") + host + ":" + std::to_string(impl_->port) + "/";
}

void HttpGateway::Stop() {
  if (!impl_ || impl_->stopping.exchange(true)) return;
  if (impl_->server) impl_->server->stop();
  if (impl_->listener.joinable()) impl_->listener.join();
}

}  // namespace kgd::server
