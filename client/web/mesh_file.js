// A body mesh read in the browser for the studio's 3D view: OBJ (v and f lines) or PLY (ascii or binary
// little-endian), each polygon fanned into triangles as core/mesh/mesh_io.cpp does (corners 0, k, k + 1),
// so that face indices agree with the server's. Refusals are sentences naming the file and the line.
import { checkMeshBytes } from './job_status.js';

// { vertices: Float32Array (V x 3), faces: Uint32Array (F x 3) } or { error: '...' }.
export function parseMesh(name, bytes) {
  const problem = checkMeshBytes(name, bytes);
  if (problem) return { error: problem };
  const r = name.toLowerCase().endsWith('.ply') ? parsePly(name, bytes) : parseObj(name, new TextDecoder().decode(bytes));
  if (r.error) return r;
  if (!r.faces.length) return { error: `${name} has no faces: a body is a surface of triangles or polygons` };
  return extentProblem(name, r.vertices) || r;
}

// The server's limit on a mesh's bounding-box diagonal (core/mesh/trimesh.h kMaxMeshExtent_m): a
// larger mesh was written in centimetres or millimetres.
export const MAX_MESH_EXTENT_M = 20;

// { error } in the server's words (core/mesh/trimesh.cpp ValidateMesh) for a mesh more than
// MAX_MESH_EXTENT_M across, else null.
function extentProblem(name, v) {
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let i = 0; i < v.length; ++i) { lo[i % 3] = Math.min(lo[i % 3], v[i]); hi[i % 3] = Math.max(hi[i % 3], v[i]); }
  const across = Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
  if (!(across > MAX_MESH_EXTENT_M)) return null;
  const mm = across > 2000;
  const grouped = Math.round(across).toString().replace(/\B(?=(\d{3})+$)/g, ',');
  return { error: `${name}: the mesh is ${grouped} m across: ${mm ? 'millimetres' : 'centimetres'}? kgd reads metres (SI); scale the mesh by ${mm ? '0.001' : '0.01'}` };
}

function parseObj(name, text) {
  const v = [], f = [];
  const lines = text.split('\n');
  for (let k = 0; k < lines.length; ++k) {
    const w = lines[k].trim().split(/\s+/);
    if (w[0] === 'v') {
      const p = [Number(w[1]), Number(w[2]), Number(w[3])];
      if (w.length < 4 || !p.every(Number.isFinite)) return { error: `${name}, line ${k + 1}: a vertex needs three finite numbers ("${lines[k].trim().slice(0, 60)}")` };
      v.push(...p);
    } else if (w[0] === 'f') {
      const c = [];
      for (const word of w.slice(1)) {
        const i = Number(word.split('/')[0]);
        if (!Number.isInteger(i) || i === 0) return { error: `${name}, line ${k + 1}: "${word}" is not a vertex number` };
        c.push(i > 0 ? i - 1 : v.length / 3 + i);  // 1-based; negative counts back from the last vertex read
      }
      if (c.length < 3) return { error: `${name}, line ${k + 1}: a face needs at least 3 corners, this one has ${c.length}` };
      for (let j = 1; j + 1 < c.length; ++j) f.push(c[0], c[j], c[j + 1]);
    }
  }
  return checked(name, v, f);
}

const PLY_TYPES = { char: ['getInt8', 1], int8: ['getInt8', 1], uchar: ['getUint8', 1], uint8: ['getUint8', 1], short: ['getInt16', 2], int16: ['getInt16', 2],
  ushort: ['getUint16', 2], uint16: ['getUint16', 2], int: ['getInt32', 4], int32: ['getInt32', 4], uint: ['getUint32', 4], uint32: ['getUint32', 4],
  float: ['getFloat32', 4], float32: ['getFloat32', 4], double: ['getFloat64', 8], float64: ['getFloat64', 8] };

function parsePly(name, bytes) {
  const end = findHeaderEnd(bytes);
  if (end < 0) return { error: `${name}: the PLY header has no end_header line` };
  const header = new TextDecoder().decode(bytes.subarray(0, end)).split('\n').map((l) => l.trim());
  let binary = false;
  const elements = [];
  for (const line of header) {
    const w = line.split(/\s+/);
    if (w[0] === 'format') {
      if (w[1] === 'binary_little_endian') binary = true;
      else if (w[1] !== 'ascii') return { error: `${name}: PLY format "${w[1]}" is not read (ascii or binary_little_endian)` };
    } else if (w[0] === 'element') elements.push({ name: w[1], count: Number(w[2]), props: [] });
    else if (w[0] === 'property') {
      const e = elements[elements.length - 1];
      if (!e) return { error: `${name}: a PLY property before any element` };
      const p = w[1] === 'list' ? { list: true, countType: w[2], type: w[3], name: w[4] } : { type: w[1], name: w[2] };
      if (!PLY_TYPES[p.type] || (p.list && !PLY_TYPES[p.countType])) return { error: `${name}: unknown PLY property type in "${line}"` };
      e.props.push(p);
    }
  }
  const v = [], f = [];
  // Values one by one: words of the ascii lines, or little-endian numbers.
  let next;
  if (binary) {
    const view = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
    let at = end;
    next = (type) => {
      const [get, size] = PLY_TYPES[type];
      if (at + size > bytes.length) return NaN;
      const x = view[get](at, true);
      at += size;
      return x;
    };
  } else {
    const words = new TextDecoder().decode(bytes.subarray(end)).split(/\s+/).filter(Boolean);
    let at = 0;
    next = () => (at < words.length ? Number(words[at++]) : NaN);
  }
  for (const e of elements) {
    for (let i = 0; i < e.count; ++i) {
      const vertex = [NaN, NaN, NaN];
      for (const p of e.props) {
        if (!p.list) {
          const x = next(p.type);
          if (Number.isNaN(x)) return { error: `${name}: ${e.name} ${i} ends early (property ${p.name})` };
          const axis = ['x', 'y', 'z'].indexOf(p.name);
          if (e.name === 'vertex' && axis >= 0) vertex[axis] = x;
          continue;
        }
        const n = next(p.countType);
        if (!(n >= 0 && Number.isInteger(n))) return { error: `${name}: ${e.name} ${i} has a bad list length` };
        const c = [];
        for (let j = 0; j < n; ++j) c.push(next(p.type));
        if (e.name !== 'face' || (p.name !== 'vertex_indices' && p.name !== 'vertex_index')) continue;
        if (n < 3) return { error: `${name}: face ${i} has ${n} corners, need at least 3` };
        for (let j = 1; j + 1 < n; ++j) f.push(c[0], c[j], c[j + 1]);
      }
      if (e.name === 'vertex') {
        if (!vertex.every(Number.isFinite)) return { error: `${name}: vertex ${i} lacks a finite x, y or z` };
        v.push(...vertex);
      }
    }
  }
  return checked(name, v, f);
}

// The byte after the header's "end_header" line, or -1.
function findHeaderEnd(bytes) {
  const head = new TextDecoder('latin1').decode(bytes.subarray(0, Math.min(bytes.length, 65536)));
  const m = /end_header\r?\n/.exec(head);
  return m ? m.index + m[0].length : -1;
}

function checked(name, v, f) {
  const nv = v.length / 3;
  for (let i = 0; i < f.length; ++i)
    if (!(f[i] >= 0 && f[i] < nv)) return { error: `${name}: face ${Math.floor(i / 3)} refers to vertex ${f[i] + 1} (1-based) but the file has ${nv} vertices` };
  return { vertices: new Float32Array(v), faces: new Uint32Array(f) };
}

// A pose of the rest mesh (deformed pose, frame): the rest pose's vertices and faces, or a sentence why not.
export function samePoseProblem(rest, restName, pose, poseName) {
  if (pose.vertices.length !== rest.vertices.length || pose.faces.length !== rest.faces.length)
    return `${poseName} has ${pose.vertices.length / 3} vertices and ${pose.faces.length / 3} faces, the rest pose ${restName} ${rest.vertices.length / 3} and ${rest.faces.length / 3}: a pose must be the rest pose's mesh moved`;
  for (let i = 0; i < rest.faces.length; ++i)
    if (rest.faces[i] !== pose.faces[i]) return `${poseName}: face ${Math.floor(i / 3)} joins other vertices than in the rest pose ${restName}: a pose must be the rest pose's mesh moved`;
  return null;
}
