// What the page says about a job and its form before the server does: the form's values checked
// against the server's own rules (its listing's body measurement ranges and iteration limit; a scene
// file's garment and meshes), a job's progress and phase, how it ended, why it failed. Messages are
// for people: a file's bytes are never shown raw (readable()).

// A message as the page shows it: control characters and bytes that are not text as \xNN, at most
// `max` characters.
export function readable(message, max = 600) {
  const text = String(message ?? '').replace(/[\u0000-\u0008\u000b-\u001f\u007f\ufffd]/g, (c) => (c === '\ufffd' ? '\\x??' : `\\x${c.charCodeAt(0).toString(16).padStart(2, '0').toUpperCase()}`));
  return text.length > max ? `${text.slice(0, max)}…` : text;
}

// The body measurements typed in the form (inputs with data-measurement), each within the range the
// server lists (GET /v1/scenes bodyMeasurements): the first that is not, in the server's words.
export function checkBody(inputs, measurements) {
  for (const i of inputs) {
    if (i.value.trim() === '') continue;
    const m = measurements.find((x) => x.name === i.dataset.measurement);
    const v = Number(i.value);
    if (!m) continue;
    if (!Number.isFinite(v) || v < m.min || v > m.max)
      return { input: i, message: `spec.body: body measurement ${m.name} = ${i.value.trim()} is outside [${m.min}, ${m.max}]` };
  }
  return null;
}

// An iteration limit typed in the form against the server's (GET /v1/scenes maxIterations; 0: none).
export function checkIterations(text, serverMax) {
  const n = Number(text);
  if (!Number.isInteger(n) || n < 1) return `maxIterations: ${text} is not a whole number >= 1`;
  if (serverMax > 0 && n > serverMax) return `spec.optimizer.max_iterations: ${n} is above this server's limit of ${serverMax} iterations`;
  return null;
}

// A line's bytes are text: UTF-8 without control characters (tabs and form feeds aside).
function isText(bytes) {
  try {
    const text = new TextDecoder('utf-8', { fatal: true }).decode(bytes);
    return !/[\u0000-\u0008\u000a\u000e-\u001f\u007f]/.test(text.replace(/\r$/, ''));
  } catch {
    return false;
  }
}

// A line of a file (its bytes, without the newline) quoted as the server quotes it: text as it is,
// other bytes as \xNN, at most 40 bytes.
function quoted(bytes) {
  if (bytes.length && bytes[bytes.length - 1] === 13) bytes = bytes.subarray(0, bytes.length - 1);
  const cut = bytes.subarray(0, 40);
  let out = '';
  if (isText(cut)) out = new TextDecoder('utf-8').decode(cut).replace(/["\\]/g, (c) => `\\${c}`);
  else for (const c of cut) out += c >= 0x20 && c < 0x7f ? (c === 34 || c === 92 ? '\\' : '') + String.fromCharCode(c) : `\\x${c.toString(16).padStart(2, '0').toUpperCase()}`;
  return `"${out}${bytes.length > 40 ? '...' : ''}"`;
}

// The lines of a file's first 4 KB as bytes (a last line cut at 4 KB left out).
function headLines(bytes) {
  const head = bytes.subarray(0, 4096);
  const lines = [];
  let start = 0;
  for (let i = 0; i < head.length; ++i)
    if (head[i] === 10) { lines.push(head.subarray(start, i)); start = i + 1; }
  if (start < head.length && head.length === bytes.length) lines.push(head.subarray(start));
  return lines;
}

// The first line of a file that is not text, with its number; null when there is none in its first 4 KB.
function firstNonText(bytes) {
  const lines = headLines(bytes);
  for (let k = 0; k < lines.length; ++k) if (!isText(lines[k])) return { line: k + 1, bytes: lines[k] };
  return null;
}

// OBJ statements kgd reads or skips (the server's check, core/mesh/mesh_io.h CheckMeshBytes).
const OBJ_STATEMENTS = new Set(['v', 'vt', 'vn', 'vp', 'f', 'l', 'p', 'o', 'g', 's', 'usemtl', 'mtllib']);

// Whether a file's bytes can be the mesh its name says (.obj, .ply), as the server checks it: the
// message names the file and quotes the line, escaped.
export function checkMeshBytes(name, bytes) {
  const lower = name.toLowerCase();
  if (!lower.endsWith('.obj') && !lower.endsWith('.ply')) return `${name}: unknown mesh format (expected .obj or .ply)`;
  const refused = (k, line, what) => `${name} is not an OBJ or PLY mesh (line ${k}: ${quoted(line)} ${what})`;
  const lines = headLines(bytes);
  if (lower.endsWith('.ply')) {
    const first = lines[0] || bytes.subarray(0, Math.min(bytes.length, 4096));
    const text = new TextDecoder('utf-8').decode(first).replace(/\r$/, '');
    return text === 'ply' ? null : refused(1, first, isText(first) ? 'is not "ply", a PLY file\'s first line' : 'is not text');
  }
  let statement = false;
  for (let k = 0; k < lines.length; ++k) {
    let line = lines[k];
    if (k === 0 && line[0] === 0xef && line[1] === 0xbb && line[2] === 0xbf) line = line.subarray(3);  // a byte-order mark
    if (!isText(line)) return refused(k + 1, line, 'is not text');
    if (statement) continue;
    const words = new TextDecoder('utf-8').decode(line).trim().split(/\s+/);
    if (words[0] === '' || words[0].startsWith('#')) continue;
    if (!OBJ_STATEMENTS.has(words[0])) return refused(k + 1, line, 'is not an OBJ statement (v, f, vn, vt, o, g, s, usemtl, mtllib, # ...)');
    statement = true;
  }
  return null;
}

// The files a scene names that are meshes (the keys the server checks), as written in it.
function meshesNamed(scene) {
  const out = [];
  const add = (p) => typeof p === 'string' && out.push(p);
  add(scene.garment?.rest);
  add(scene.garment?.initial);
  for (const k of ['mesh', 'rest', 'deformed']) add(scene.body?.[k]);
  for (const f of scene.body?.frames || []) add(f);
  for (const group of [scene.motions, scene.bodies])
    for (const m of group || []) {
      add(m.rest);
      add(m.deformed);
      for (const f of m.frames || []) add(f);
    }
  return out;
}

// A scene file and the files sent with it, as the server would check them: text, JSON, a garment, and
// each mesh it names sent and a mesh. The first problem in words, or null.
export async function checkSceneUpload(sceneFile, files) {
  const bytes = new Uint8Array(await sceneFile.arrayBuffer());
  const bad = firstNonText(bytes);
  if (bad) return `scene: ${sceneFile.name} is not a JSON scene file (line ${bad.line}: ${quoted(bad.bytes)} is not text)`;
  let scene;
  try {
    scene = JSON.parse(new TextDecoder('utf-8').decode(bytes));
  } catch (e) {
    return `scene: ${sceneFile.name} is not valid JSON (${readable(e.message, 120)})`;
  }
  if (!scene || typeof scene !== 'object' || Array.isArray(scene) || !scene.garment)
    return `scene: ${sceneFile.name}: garment: missing (give garment.rest, or garment.region with body.rest and body.deformed)`;
  if (typeof scene.garment === 'object' && !('rest' in scene.garment) && !('region' in scene.garment))
    return `scene: ${sceneFile.name}: garment.rest: missing (or give garment.region to cut the garment from the body)`;
  const byName = new Map([...files].map((f) => [f.name, f]));
  for (const name of meshesNamed(scene)) {
    const base = name.split('/').pop();
    const f = byName.get(name) || byName.get(base);
    if (!f) return `scene: ${sceneFile.name} names ${name}: choose it among the files it names`;
    const problem = checkMeshBytes(base, new Uint8Array(await f.arrayBuffer()));
    if (problem) return `scene: ${problem}`;
  }
  return null;
}

// The reinforced area fraction a job aims at: its spec's budget, else its scene file's, else its built-in
// scene's (scenes: GET /v1/scenes), else kgd's default 0.15 (OptimizerSettings.budget).
export const DEFAULT_BUDGET = 0.15;
export function budgetOf(spec, scenes = []) {
  if (spec?.optimizer?.budget) return spec.optimizer.budget;
  if (spec?.sceneFiles?.scene?.budget) return spec.sceneFiles.scene.budget;
  const s = scenes.find((x) => x.name === spec?.builtinScene);
  return s?.budget || DEFAULT_BUDGET;
}

// Iterations a job probably still runs after its last stored one: down to the budget at ER per
// iteration, then the convergence window, no more than its iteration limit allows.
function iterationsLeft(job, budget) {
  const m = job.last;
  const o = job.spec?.optimizer || {};
  const area = m.areaFraction ?? 1;
  const er = o.evolutionaryRatio || 0.015, window = o.convergeWindow || 5, limit = o.maxIterations || 400;
  const left = (area > budget + 1e-9 ? Math.ceil(Math.log(budget / area) / Math.log(1 - er)) : 0) + window;
  return Math.max(0, Math.min(left, limit - (m.iteration ?? job.iterations - 1)));
}

// A job's row in the list: what it is doing and how far it is ({ text, fraction }). After its last
// iteration a job evaluates its final design (no countdown of iterations); an ended job says so.
export function progressOf(job, budget) {
  const m = job.last;
  // Paused: the server cannot store the job's work now (its disk is full); it continues by itself.
  const paused = job.state === 'RUNNING' && job.paused ? `paused: ${readable(job.paused)}` : '';
  if (!m || !job.iterations) return { text: job.state === 'QUEUED' ? 'waiting' : paused, fraction: 0 };
  const ratio = `ratio ${(m.densityRatio ?? 0).toFixed(2)}`;
  const it = `iteration ${job.iterations - 1}`;
  if (paused) return { text: `${it}, ${ratio} · ${paused}`, fraction: job.iterations / (job.iterations + iterationsLeft(job, budget)) };
  if (job.state === 'RUNNING' && job.phase === 'EVALUATING') return { text: `${it}, ${ratio} · evaluating the final design (frames, Line, X)`, fraction: 1 };
  const done = job.state !== 'RUNNING' && job.state !== 'QUEUED';
  if (done) return { text: `${it}, ${ratio}`, fraction: 1 };
  const left = iterationsLeft(job, budget);
  const fraction = job.iterations / (job.iterations + left);
  // Stopped part-way and queued again: it resumes on a worker of the kernel level its iterations ran at.
  if (job.state === 'QUEUED') {
    const level = job.kernels && job.kernels !== 'unknown' ? ` on an ${job.kernels} worker` : '';
    return { text: `${it}, ${ratio} · waits to resume${level}`, fraction };
  }
  return { text: `${it}, ${ratio} · ~${Math.round(left * (m.totalS ?? 0))} s left`, fraction };
}

// The sentence the viewer shows over the 3D view for a job ({ text, kind } or null): why it failed,
// how its design loop ended, or that it is evaluating its final design.
export function jobNote(job) {
  if (!job) return null;
  if (job.state === 'FAILED') return { kind: 'failed', text: `Job ${job.id} failed: ${readable(job.failure || 'no reason given')}` };
  if (job.state === 'RUNNING' && job.paused)
    return { kind: 'paused', text: `Job ${job.id} paused: ${readable(job.paused)}; it continues by itself when the server can store again` };
  if (job.state === 'RUNNING' && job.phase === 'EVALUATING')
    return { kind: 'evaluating', text: `Evaluating the final design (frames, Line, X)${job.ended ? `; the design loop ${readable(job.ended)}` : ''}` };
  if (job.state === 'CANCELLED') return { kind: 'ended', text: `Job ${job.id} was cancelled after ${job.iterations || 0} iterations` };
  if (job.state === 'SUCCEEDED') return { kind: 'ended', text: `Job ${job.id} ${job.ended ? readable(job.ended) : 'succeeded'}` };
  return null;
}

// Shows jobNote(job) in `el` (hidden when there is none).
export function showJobNote(el, job) {
  const note = jobNote(job);
  el.hidden = !note;
  el.textContent = note ? note.text : '';
  el.dataset.kind = note ? note.kind : '';
}
