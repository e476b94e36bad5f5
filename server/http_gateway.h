// The HTTP door of the design service: an HTTP/JSON API over the same job service as gRPC
// (server/job_service.h), and the web page (client/web/). Bodies are kgd.v1 messages in their
// canonical protobuf JSON form (lowerCamelCase names, int64 as strings); errors are
//   {"error": {"code": 404, "status": "NOT_FOUND", "message": "job 7 does not exist"}}
// with the gRPC status name. Resources (Google API style):
//
//   GET  /metrics                                 the service's figures, Prometheus text format (server/service_metrics.h)
//   GET  /v1/scenes                               ListScenesResponse
//   GET  /v1/jobs?pageSize=&pageToken=&state=     ListJobsResponse (state: QUEUED, RUNNING, ...)
//   POST /v1/jobs                                 Job; body: a JobSpec (application/json), or
//                                                 multipart/form-data with a part "scene" (the scene
//                                                 file), one part per file it names (by file name),
//                                                 and an optional part "spec" (a JobSpec: optimizer,
//                                                 body, label)
//   GET  /v1/jobs/{id}                            Job
//   POST /v1/jobs/{id}:cancel                     Job
//   GET  /v1/jobs/{id}:watch?fromIteration=&view=metrics
//                                                 Server-Sent Events: "job" events (a Job) and
//                                                 "iteration" events (an IterationRecord; its id is
//                                                 the iteration, so a reconnect with Last-Event-ID
//                                                 continues after it; view=metrics: no design)
//   GET  /v1/jobs/{id}/iterations/{n}?withGarment=true   GetIterationResponse (n = -1: the last)
//   GET  /v1/jobs/{id}/iterations/{n}/positions.f32      V x 3 little-endian float32 (m)
//   GET  /v1/jobs/{id}/iterations/{n}/energy.f32         F float32: strain energy per rest area (J/m^2)
//   GET  /v1/jobs/{id}/iterations/{n}/design.u8          F bytes, 1 = reinforced
//   GET  /v1/jobs/{id}/iterations/{n}/design.ply         the iteration as binary PLY (download; core/mesh/mesh_io.h, WriteGarmentPly)
//   GET  /v1/jobs/{id}/garment/faces.u32                 F x 3 little-endian uint32
//   GET  /v1/jobs/{id}/garment/rest.f32                  V x 3 float32, the rest shape (m)
//   GET  /v1/jobs/{id}/body/vertices.f32, faces.u32      the body in the deformed pose (404: none)
//   GET  /v1/jobs/{id}/design-file                       the job's HDF5 design file, once it has ended
//   GET  /v1/jobs/{id}/evaluation                        DesignEvaluation, its arrays left out (404: none yet)
//   GET  /v1/jobs/{id}/evaluation/frames/{k}/{positions,body,energy,pressure}.f32   frame k (1..): V x 3 float32 (m),
//        the body's vertices (float32, m), F float32 (J/m^2), the skin pressure per body vertex (float32, Pa)
//   GET  /v1/jobs/{id}/evaluation/baselines/{line,x}/{positions.f32,design.u8,energy.f32}   a baseline's arrays;
//        .../design.ply: the baseline as binary PLY (download; as an iteration's)
//   GET  /v1/jobs/{id}/iterations/{n}/cut/{pattern,patches}.{svg,dxf,png}, report.json   cut files (docs/FABRICATION.md;
//        ?minFeatureMm=&seamAllowanceMm=&sheetWidthMm=&mirror=false), made by geometry alone; downloads named
//        job-{id}-iteration-{k}-{file}, k the iteration exported (the last stored for n = -1)
//   POST /v1/regions:check                               the studio page's check of a painted garment region:
//        multipart parts body (OBJ/PLY), faces, keepOut, keepIn, attachWidthM, fillHoles, mirror, symmetryPlane,
//        subdivisions, frames, motions, budget; JSON: the region after mirror/tidy/fill, valid or CheckRegion's refusal
//        (kgd region's words), area, loops, bands, subdivided counts, keep lists as garment faces, predicted
//        job seconds (server/region_check.h). Geometry only; no gRPC equivalent
//   GET  /v1/scenes/{name}/body/{rest,deformed,frame_K}.obj?height_m=&...   a built-in scene's parametric body
//        made to the measurements in the query (JobSpec.body's names, or lowerCamelCase: heightM) and posed as
//        the scene poses it, OBJ (server/scene_body.h; the first request of a body takes a job's set-up time)
//   GET  /                                               the web page (static files of web_dir)
//
// Every request whose Host header is not a name of the server (its --http address; 127.0.0.1,
// localhost and [::1] on loopback or every address; on every address, this machine's IP addresses;
// the --allowed-host names) gets 403, as does every POST, PUT, PATCH or DELETE from a page of another
// origin (its Origin, or without one its Referer): a foreign web page can neither read the service
// through a DNS-rebound name nor submit to it with a form.
//
// The handlers only translate (path and query to request, status to HTTP status, messages to JSON,
// arrays to bytes); what they serve comes from JobService and server/job_results.h.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/util/status.h"
#include "server/job_service.h"

namespace kgd::server {

struct HttpOptions {
  std::string address = "127.0.0.1:7448";  // host:port; port 0 picks a free one
  std::string web_dir;                     // the page's static files (client/web); empty: API only
  size_t max_upload_bytes = 64 << 20;      // larger request bodies get 413 RESOURCE_EXHAUSTED
  double keepalive_s = 10;                 // an SSE comment this often keeps idle watches alive
  std::string tls_cert, tls_key;           // PEM files: serve HTTPS; empty: plain HTTP
  bool insecure = false;                   // allow a non-loopback address without TLS and tokens
  // Names besides its own address (NAME: any port; NAME:PORT: that one) that requests' Host headers,
  // and the Origin of requests that change anything, may give: a Service's or an ingress's name.
  std::vector<std::string> allowed_hosts;
};

// Open :watch streams are bounded by the service (ServiceLimits::max_held_watches, --max-watchers:
// one more gets 429 RESOURCE_EXHAUSTED); the door keeps as many threads for them.
class HttpGateway {
 public:
  // What Start would refuse before binding: an address that is not HOST:PORT, a web folder without
  // index.html, half a TLS pair, a non-loopback address without both TLS and tokens (unless insecure).
  static Status CheckOptions(const HttpOptions& options, bool tokens);
  // Binds the address and starts serving `service` (which must outlive the gateway).
  static Result<std::unique_ptr<HttpGateway>> Start(JobService& service, const HttpOptions& options);
  ~HttpGateway();  // Stop()

  int port() const;
  std::string url() const;  // http://127.0.0.1:PORT/
  // Ends open watches and stops serving; idempotent.
  void Stop();

 private:
  HttpGateway() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace kgd::server
