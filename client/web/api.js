// The HTTP/JSON API of kgd serve (server/http_gateway.h): kgd.v1 messages in protobuf JSON form.

export class ApiError extends Error {
  constructor(status, code, message) {
    super(message);
    this.status = status;  // gRPC status name, e.g. "INVALID_ARGUMENT"
    this.code = code;      // HTTP status
  }
}

// A server started with --auth-tokens wants a bearer token: asked for once, kept in this browser
// (localStorage), sent as the Authorization header, and as the cookie kgd_token for what cannot send
// headers (EventSource, download links: GET only).
let token = localStorage.getItem('kgd_token') || '';
export function setToken(value) {
  token = value;
  localStorage.setItem('kgd_token', value);
  document.cookie = `kgd_token=${encodeURIComponent(value)}; path=/; SameSite=Strict`;
}
if (token) setToken(token);

// One question at a time: requests refused together wait for the same answer.
let asking = null;
async function request(path, init = {}) {
  const send = () => fetch(path, { ...init, headers: { ...(init.headers || {}), ...(token ? { Authorization: `Bearer ${token}` } : {}) } });
  const sent = token;
  let res = await send();
  if (res.status === 401) {
    if (token === sent) {
      asking ??= new Promise((resolve) => setTimeout(() => resolve(window.prompt('This kgd server needs your access token:', '')), 0)).then((value) => {
        if (value) setToken(value.trim());
        asking = null;
      });
      await asking;
    }
    if (token !== sent) res = await send();
  }
  return res;
}

async function check(res) {
  if (res.ok) return res;
  let body = null;
  try { body = await res.json(); } catch { /* not JSON */ }
  const e = body && body.error;
  throw new ApiError(e ? e.status : 'UNKNOWN', res.status, e ? e.message : `HTTP ${res.status}`);
}

export async function getJson(path) { return (await check(await request(path))).json(); }
export async function getText(path) { return (await check(await request(path))).text(); }

export async function postJson(path, body) {
  const res = await request(path, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body ?? {}) });
  return (await check(res)).json();
}

export async function postForm(path, form) { return (await check(await request(path, { method: 'POST', body: form }))).json(); }

// Little-endian typed arrays from the binary endpoints.
export async function getFloat32(path) { return new Float32Array(await (await check(await request(path))).arrayBuffer()); }
export async function getUint32(path) { return new Uint32Array(await (await check(await request(path))).arrayBuffer()); }
export async function getUint8(path) { return new Uint8Array(await (await check(await request(path))).arrayBuffer()); }

export const scenes = () => getJson('/v1/scenes');
export const jobs = (pageSize = 50) => getJson(`/v1/jobs?pageSize=${pageSize}`);
export const job = (id) => getJson(`/v1/jobs/${id}`);
export const createJob = (spec) => postJson('/v1/jobs', spec);
export const cancelJob = (id) => postJson(`/v1/jobs/${id}:cancel`);

export const garmentFaces = (id) => getUint32(`/v1/jobs/${id}/garment/faces.u32`);
export const bodyVertices = (id) => getFloat32(`/v1/jobs/${id}/body/vertices.f32`);
export const bodyFaces = (id) => getUint32(`/v1/jobs/${id}/body/faces.u32`);
export const positions = (id, n) => getFloat32(`/v1/jobs/${id}/iterations/${n}/positions.f32`);
export const energy = (id, n) => getFloat32(`/v1/jobs/${id}/iterations/${n}/energy.f32`);
export const design = (id, n) => getUint8(`/v1/jobs/${id}/iterations/${n}/design.u8`);

export const evaluation = (id) => getJson(`/v1/jobs/${id}/evaluation`);
export const framePositions = (id, k) => getFloat32(`/v1/jobs/${id}/evaluation/frames/${k}/positions.f32`);
export const frameBody = (id, k) => getFloat32(`/v1/jobs/${id}/evaluation/frames/${k}/body.f32`);
export const frameEnergy = (id, k) => getFloat32(`/v1/jobs/${id}/evaluation/frames/${k}/energy.f32`);
export const framePressure = (id, k) => getFloat32(`/v1/jobs/${id}/evaluation/frames/${k}/pressure.f32`);  // Pa per body vertex
export const baselinePositions = (id, name) => getFloat32(`/v1/jobs/${id}/evaluation/baselines/${name}/positions.f32`);
export const baselineDesign = (id, name) => getUint8(`/v1/jobs/${id}/evaluation/baselines/${name}/design.u8`);
export const baselineEnergy = (id, name) => getFloat32(`/v1/jobs/${id}/evaluation/baselines/${name}/energy.f32`);

// Follows a job by Server-Sent Events: onJob(job), onIteration(record without design). EventSource
// reconnects by itself and sends Last-Event-ID, so the server continues after the last iteration seen.
export function watch(id, { onJob, onIteration, onError }) {
  const es = new EventSource(`/v1/jobs/${id}:watch?view=metrics`);
  es.addEventListener('job', (e) => onJob(JSON.parse(e.data)));
  es.addEventListener('iteration', (e) => onIteration(JSON.parse(e.data)));
  es.onerror = () => onError && onError(es.readyState);
  return es;
}
