// The garment on the body in 3D: three.js, orbit controls, the garment coloured per face by its
// design or by its energy per area, the body semi-transparent or coloured by skin pressure. The camera
// frames the garment shown, whatever its pose: from the view chosen (front, back, the garment's side, or
// the default: the broadest of a few from the front and side), or from where the user orbited to, at the
// user's zoom.
import * as THREE from 'three';
import { OrbitControls } from 'three/addons/controls/OrbitControls.js';

// The body's axes in kgd's scenes (core/body/parametric_body.h): +y up, +z the body's front, +x its left.
const UP = new THREE.Vector3(0, 1, 0), FRONT = new THREE.Vector3(0, 0, 1), LEFT = new THREE.Vector3(1, 0, 0);
// Where the camera looks from, as a direction from the garment; `side` is +1 for a garment on the body's
// left, -1 on its right; x the garment's vertices. The default (reset) is the one of a few views from
// the front and the garment's side, a little from above, that sees the garment broadest: a sleeve from
// its side, not down its cut end (a flexed arm's forearm points to the front).
const VIEWS = {
  reset: (side, x) => {
    const candidates = [[0.6, 1], [1, 0.6], [1, 0.15]].map(([s, f]) => FRONT.clone().multiplyScalar(f).addScaledVector(LEFT, s * side).addScaledVector(UP, 0.35));
    let best = candidates[0], most = -1;
    for (const d of candidates) { const a = projectedArea(x, d); if (a > most + 1e-12) { most = a; best = d; } }
    return best;
  },
  front: () => FRONT.clone(),
  back: () => FRONT.clone().negate(),
  side: (side) => LEFT.clone().multiplyScalar(side),
};
// The area (m²) of the rectangle around the vertices x seen along direction d (orthographic, up +y).
export function projectedArea(x, d) {
  const f = d.clone().normalize(), r = new THREE.Vector3().crossVectors(f, UP);
  if (r.lengthSq() < 1e-8) r.copy(LEFT);
  r.normalize();
  const u = new THREE.Vector3().crossVectors(r, f).normalize(), p = new THREE.Vector3();
  let r0 = Infinity, r1 = -Infinity, u0 = Infinity, u1 = -Infinity;
  for (let i = 0; i < x.length; i += 3) {
    p.fromArray(x, i);
    const a = p.dot(r), b = p.dot(u);
    r0 = Math.min(r0, a); r1 = Math.max(r1, a); u0 = Math.min(u0, b); u1 = Math.max(u1, b);
  }
  return (r1 - r0) * (u1 - u0);
}

// The share of the canvas the garment may fill, the rest a margin on each side.
const FILL = 0.9;

// Turbo-like colour map for energy (0..1 -> rgb), the same stops as the CSS colour bar.
const STOPS = [[0x30, 0x12, 0x3b], [0x46, 0x86, 0xfb], [0x1a, 0xe4, 0xb6], [0xa2, 0xfc, 0x3c], [0xfa, 0xba, 0x39], [0xe4, 0x46, 0x0a], [0x7a, 0x04, 0x03]];
function colormap(t, out, o) {
  const x = Math.min(Math.max(t, 0), 1) * (STOPS.length - 1);
  const i = Math.min(Math.floor(x), STOPS.length - 2), f = x - i;
  for (let k = 0; k < 3; ++k) out[o + k] = (STOPS[i][k] * (1 - f) + STOPS[i + 1][k] * f) / 255;
}

export class GarmentView {
  constructor(canvas) {
    // preserveDrawingBuffer: the browser tests read the canvas back.
    this.renderer = new THREE.WebGLRenderer({ canvas, antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(Math.min(window.devicePixelRatio || 1, 2));
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color(0xfbfbfa);
    this.camera = new THREE.PerspectiveCamera(35, 1, 0.01, 100);
    this.controls = new OrbitControls(this.camera, canvas);
    this.controls.addEventListener('change', () => this.render());
    this.view = 'reset';  // the view the next fit takes (null: the direction the camera has)
    this.fitDistance = 0;  // the camera's distance at the last fit (the user's zoom is relative to it)
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x667788, 2.2));
    const sun = new THREE.DirectionalLight(0xffffff, 1.2);
    sun.position.set(1, 2, 1.5);
    this.scene.add(sun);
    this.garment = null;
    this.body = null;
    this.faces = null;
    new ResizeObserver(() => this.resize()).observe(canvas);
    this.resize();
  }

  resize() {
    const c = this.renderer.domElement;
    const w = c.clientWidth || 640, h = c.clientHeight || 420;
    this.renderer.setSize(w, h, false);
    this.camera.aspect = w / h;
    this.camera.updateProjectionMatrix();
    if (this.garment && this.x) this.fit();
    this.render();
  }

  render() { this.renderer.render(this.scene, this.camera); }

  clear() {
    for (const m of [this.garment, this.body]) if (m) { this.scene.remove(m); m.geometry.dispose(); }
    this.garment = this.body = this.faces = this.x = null;
    this.view = 'reset';
    this.fitDistance = 0;
    this.render();
  }

  // faces: Uint32Array (F x 3); body: { vertices: Float32Array, faces: Uint32Array } or null.
  setMeshes(faces, body) {
    this.clear();
    this.faces = faces;
    const nf = faces.length / 3;
    const g = new THREE.BufferGeometry();
    // One vertex per face corner, so each face has its own colour.
    g.setAttribute('position', new THREE.BufferAttribute(new Float32Array(nf * 9), 3));
    g.setAttribute('color', new THREE.BufferAttribute(new Float32Array(nf * 9).fill(0.8), 3));
    this.garment = new THREE.Mesh(g, new THREE.MeshStandardMaterial({ vertexColors: true, side: THREE.DoubleSide, roughness: 0.8, flatShading: true }));
    this.scene.add(this.garment);
    if (body) {
      const b = new THREE.BufferGeometry();
      this.bodyRest = body.vertices.slice();
      b.setAttribute('position', new THREE.BufferAttribute(body.vertices, 3));
      b.setIndex(new THREE.BufferAttribute(body.faces, 1));
      b.computeVertexNormals();
      this.body = new THREE.Mesh(b, new THREE.MeshStandardMaterial({ color: 0xd9b38c, transparent: true, opacity: 0.3, depthWrite: false, roughness: 0.9 }));
      this.scene.add(this.body);
    }
  }

  // The body's vertices in another pose (same faces); null: the pose it was set with.
  setBodyPose(vertices) {
    if (!this.body) return;
    const p = this.body.geometry.attributes.position;
    p.array.set(vertices || this.bodyRest);
    p.needsUpdate = true;
    this.body.geometry.computeVertexNormals();
  }

  showBody(on) { if (this.body) { this.body.visible = on; this.render(); } }

  // The body coloured per vertex by skin pressure (Float32Array, Pa, with max), opaque; null: plain and
  // semi-transparent.
  setBodyPressure(pressure, max) {
    if (!this.body) return;
    const g = this.body.geometry, m = this.body.material;
    if (!pressure) {
      Object.assign(m, { vertexColors: false, opacity: 0.3, transparent: true, depthWrite: false });
      m.color.set(0xd9b38c);
    } else {
      const n = pressure.length;
      if (!g.attributes.color || g.attributes.color.count !== n) g.setAttribute('color', new THREE.BufferAttribute(new Float32Array(3 * n), 3));
      const c = g.attributes.color.array;
      for (let v = 0; v < n; ++v) {
        if (pressure[v] > 0) colormap(max > 0 ? pressure[v] / max : 0, c, 3 * v);
        else { c[3 * v] = 0.85; c[3 * v + 1] = 0.7; c[3 * v + 2] = 0.55; }  // untouched skin
      }
      g.attributes.color.needsUpdate = true;
      Object.assign(m, { vertexColors: true, opacity: 1, transparent: false, depthWrite: true });
      m.color.set(0xffffff);
    }
    m.needsUpdate = true;
    this.render();
  }

  // x: Float32Array (V x 3); values per face: design bits (Uint8Array) or energies (Float32Array, with max).
  update(x, mode, values, max) {
    if (!this.garment) return;
    const f = this.faces, nf = f.length / 3;
    const pos = this.garment.geometry.attributes.position, col = this.garment.geometry.attributes.color;
    const p = pos.array, c = col.array;
    for (let t = 0; t < nf; ++t)
      for (let k = 0; k < 3; ++k) {
        const v = f[3 * t + k], o = 9 * t + 3 * k;
        p[o] = x[3 * v]; p[o + 1] = x[3 * v + 1]; p[o + 2] = x[3 * v + 2];
      }
    for (let t = 0; t < nf; ++t) {
      const o = 9 * t;
      if (mode === 'energy') colormap(max > 0 ? values[t] / max : 0, c, o);
      else { const r = values[t] ? [0.12, 0.16, 0.3] : [0.86, 0.87, 0.9]; c[o] = r[0]; c[o + 1] = r[1]; c[o + 2] = r[2]; }
      for (let k = 1; k < 3; ++k) { c[o + 3 * k] = c[o]; c[o + 3 * k + 1] = c[o + 1]; c[o + 3 * k + 2] = c[o + 2]; }
    }
    pos.needsUpdate = true;
    col.needsUpdate = true;
    this.garment.geometry.computeVertexNormals();
    this.garment.geometry.computeBoundingSphere();
    this.x = x;
    this.fit();
    this.render();
  }

  // Looks from `name` (reset, front, back or side) at the garment shown, at no zoom.
  setView(name) {
    if (!VIEWS[name]) return;
    this.view = name;
    this.fitDistance = 0;
    if (this.garment && this.x) this.fit();
    this.render();
  }

  // +1 when the garment is on the body's left (+x of the body's centre), -1 on its right.
  garmentSide() {
    const x = this.x;
    let sum = 0;
    for (let i = 0; i < x.length; i += 3) sum += x[i];
    let centre = 0;
    if (this.body) {
      this.body.geometry.computeBoundingBox();
      centre = this.body.geometry.boundingBox.getCenter(new THREE.Vector3()).x;
    }
    return sum / (x.length / 3) >= centre ? 1 : -1;
  }

  // Moves the camera so that every vertex of the garment shown is inside the view with a margin: the
  // direction from the view chosen last (or where the user orbited to), the distance the nearest that
  // holds the garment times the user's zoom since the last fit.
  fit() {
    const x = this.x, n = x.length / 3;
    if (!n) return;
    const lo = new THREE.Vector3(Infinity, Infinity, Infinity), hi = new THREE.Vector3(-Infinity, -Infinity, -Infinity), p = new THREE.Vector3();
    for (let i = 0; i < n; ++i) { p.fromArray(x, 3 * i); lo.min(p); hi.max(p); }
    if (![lo.x, lo.y, lo.z, hi.x, hi.y, hi.z].every(Number.isFinite)) return;
    const centre = lo.clone().add(hi).multiplyScalar(0.5);
    const cam = this.camera, target = this.controls.target;
    // Forward: from the camera to what it looks at.
    const forward = this.view ? VIEWS[this.view](this.garmentSide(), x).normalize().negate() : target.clone().sub(cam.position).normalize();
    if (!(forward.lengthSq() > 0.5)) forward.copy(FRONT).negate();
    const zoom = this.fitDistance > 0 ? cam.position.distanceTo(target) / this.fitDistance : 1;
    const right = new THREE.Vector3().crossVectors(forward, UP);
    if (right.lengthSq() < 1e-8) right.copy(LEFT);
    right.normalize();
    const up = new THREE.Vector3().crossVectors(right, forward).normalize();
    const tanV = Math.tan((cam.fov * Math.PI) / 360) * FILL, tanH = tanV * cam.aspect;
    // A vertex at q from the centre is inside when |q.right| <= (d + q.forward) tanH, and so for up.
    // Every vertex stays well in front of the camera (near = d / 100).
    let d = 0, nearest = 0;
    for (let i = 0; i < n; ++i) {
      p.fromArray(x, 3 * i).sub(centre);
      const z = p.dot(forward);
      nearest = Math.min(nearest, z);
      d = Math.max(d, Math.abs(p.dot(right)) / tanH - z, Math.abs(p.dot(up)) / tanV - z);
    }
    d = Math.max(d, -1.1 * nearest, 1e-3);
    target.copy(centre);
    cam.up.copy(UP);
    cam.position.copy(centre).addScaledVector(forward, -d * zoom);
    cam.near = d / 100;
    cam.far = d * 100;
    cam.updateProjectionMatrix();
    this.controls.update();
    this.fitDistance = d;
    this.view = null;
  }

  // The canvas as a PNG data URL (drawn again first, so it is what the camera sees now).
  imagePng() {
    this.render();
    return this.renderer.domElement.toDataURL('image/png');
  }
}
