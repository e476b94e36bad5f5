// The studio's 3D body to paint on (view3d.js's renderer, camera, lights and framing): a left-button
// drag paints the faces whose centroid lies within the brush radius of the point under the pointer and
// that the surface joins to the face hit within that radius; the face hit is always painted. Right-button drag orbits (Shift + right: pan), the wheel zooms; so does
// Alt + left drag. Layers: the garment region, attachment bands, keep-out and keep-in (the last three
// painted on the region's faces only), each a 0/1 per body face, drawn in colours of their own.
import * as THREE from 'three';
import { GarmentView } from './view3d.js';

export const LAYERS = ['region', 'band', 'keepOut', 'keepIn'];
// RGB 0..1 of a face: untouched skin, then each layer (later ones drawn over earlier ones), the region's
// faces the server filled (a hole), and the attachment bands the server made from the boundary loops.
export const COLOURS = {
  skin: [0.86, 0.76, 0.66], region: [0.27, 0.52, 0.85], filled: [0.55, 0.72, 0.95], band: [0.95, 0.55, 0.12],
  keepOut: [0.35, 0.35, 0.38], keepIn: [0.15, 0.62, 0.3],
};

export class PaintView extends GarmentView {
  constructor(canvas, { onStroke } = {}) {
    super(canvas);
    this.onStroke = onStroke;  // called once a stroke (pointer down ... up) has changed a layer
    this.layer = 'region';
    this.erase = false;
    this.radiusM = 0.03;
    this.layers = {};
    this.extra = { filled: null, bands: null };  // from the server's answer (Uint8Array per face or null)
    this.raycaster = new THREE.Raycaster();
    this.controls.mouseButtons = { LEFT: null, MIDDLE: THREE.MOUSE.DOLLY, RIGHT: THREE.MOUSE.ROTATE };
    // Alt + left orbits: decided before OrbitControls sees the press (a capture listener on the parent).
    canvas.parentElement.addEventListener('pointerdown', (e) => {
      this.controls.mouseButtons.LEFT = e.altKey ? THREE.MOUSE.ROTATE : null;
    }, { capture: true });
    canvas.addEventListener('pointerdown', (e) => this.down(e));
    canvas.addEventListener('pointermove', (e) => this.move(e));
    canvas.addEventListener('pointerup', (e) => this.up(e));
    canvas.addEventListener('pointercancel', (e) => this.up(e));
    canvas.addEventListener('pointerleave', () => { this.cursor.visible = false; this.renderSoon(); });
    this.stroke = null;
    // The brush on the surface under the pointer: a ring of its radius.
    this.cursor = new THREE.Mesh(new THREE.RingGeometry(0.92, 1, 48),
      new THREE.MeshBasicMaterial({ color: 0x111111, side: THREE.DoubleSide, transparent: true, opacity: 0.7, depthTest: false }));
    this.cursor.visible = false;
    this.cursor.renderOrder = 1;
    this.scene.add(this.cursor);
  }

  // Draws at the next animation frame, once however many strokes' events come before it.
  renderSoon() {
    if (this.frame) return;
    this.frame = requestAnimationFrame(() => { this.frame = 0; this.render(); });
  }

  // Puts the brush ring at hit h (or hides it).
  showCursor(h) {
    this.cursor.visible = !!h;
    if (h) {
      const n = h.normal.clone().transformDirection(this.garment.matrixWorld);
      this.cursor.position.copy(h.point);
      this.cursor.lookAt(h.point.clone().add(n));
      this.cursor.scale.setScalar(this.radiusM);
    }
    this.renderSoon();
  }

  // vertices: Float32Array (V x 3), faces: Uint32Array (F x 3), both of the rest pose.
  setBody(vertices, faces) {
    this.setMeshes(faces, null);
    const nf = faces.length / 3;
    for (const l of LAYERS) this.layers[l] = new Uint8Array(nf);
    this.extra = { filled: null, bands: null };
    this.centroids = new Float32Array(3 * nf);
    for (let t = 0; t < nf; ++t)
      for (let d = 0; d < 3; ++d)
        this.centroids[3 * t + d] = (vertices[3 * faces[3 * t] + d] + vertices[3 * faces[3 * t + 1] + d] + vertices[3 * faces[3 * t + 2] + d]) / 3;
    // Faces sharing an edge: CSR lists.
    const edges = new Map(), pairs = [];
    for (let t = 0; t < nf; ++t)
      for (let k = 0; k < 3; ++k) {
        const a = faces[3 * t + k], b = faces[3 * t + ((k + 1) % 3)];
        const key = a < b ? `${a},${b}` : `${b},${a}`;
        const other = edges.get(key);
        if (other === undefined) edges.set(key, [t]);
        else { for (const o of other) pairs.push(o, t); other.push(t); }
      }
    const count = new Uint32Array(nf + 1);
    for (const t of pairs) count[t + 1]++;
    for (let t = 0; t < nf; ++t) count[t + 1] += count[t];
    const next = count.slice(0, nf), list = new Uint32Array(pairs.length);
    for (let i = 0; i < pairs.length; i += 2) { list[next[pairs[i]]++] = pairs[i + 1]; list[next[pairs[i + 1]]++] = pairs[i]; }
    this.adjStart = count;
    this.adj = list;
    this.update(vertices, 'design', new Uint8Array(nf), 0);
    this.setView('front');
    this.recolour();
  }

  // No body: nothing to paint.
  clearBody() {
    this.clear();
    this.centroids = null;
    this.layers = {};
    this.extra = { filled: null, bands: null };
    this.cursor.visible = false;
  }

  get faceCount() { return this.centroids ? this.centroids.length / 3 : 0; }

  // The body face under the page point (clientX, clientY) and the point hit, or null.
  hit(clientX, clientY) {
    if (!this.garment) return null;
    const r = this.renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(((clientX - r.left) / r.width) * 2 - 1, -((clientY - r.top) / r.height) * 2 + 1);
    this.raycaster.setFromCamera(ndc, this.camera);
    const h = this.raycaster.intersectObject(this.garment, false)[0];
    return h ? { face: h.faceIndex, point: h.point, normal: h.face.normal } : null;
  }

  // The faces whose centroid lies within radius (m) of point p, reached from face f across faces whose
  // centroids do (a search over neighbouring faces that stops beyond the radius: a limb or fold within
  // the radius but not joined to f by the surface inside it stays unpainted); f itself always.
  facesNear(f, p, radius) {
    const c = this.centroids, seen = new Set([f]), out = [f];
    const inside = (t) => Math.hypot(c[3 * t] - p.x, c[3 * t + 1] - p.y, c[3 * t + 2] - p.z) <= radius;
    for (let i = 0; i < out.length; ++i)
      for (let k = this.adjStart[out[i]]; k < this.adjStart[out[i] + 1]; ++k) {
        const u = this.adj[k];
        if (!seen.has(u)) { seen.add(u); if (inside(u)) out.push(u); }
      }
    return out;
  }

  // Paints (or erases) the brush at a page point; true when a face changed.
  paintAt(clientX, clientY) {
    const h = this.hit(clientX, clientY);
    this.showCursor(h);
    if (!h) return false;
    const value = this.erase ? 0 : 1, layer = this.layers[this.layer], region = this.layers.region;
    let changed = false;
    for (const t of this.facesNear(h.face, h.point, this.radiusM)) {
      // Bands, keep-out and keep-in lie in the region: painted on its faces only.
      if (this.layer !== 'region' && !region[t]) continue;
      if (layer[t] !== value) { layer[t] = value; changed = true; }
      // Erasing the region erases what lies in it.
      if (this.erase && this.layer === 'region') for (const l of LAYERS) if (this.layers[l][t]) { this.layers[l][t] = 0; changed = true; }
    }
    if (changed) this.recolour();
    return changed;
  }

  down(e) {
    if (e.button !== 0 || e.altKey || !this.garment) return;
    this.stroke = { changed: false };
    this.renderer.domElement.setPointerCapture?.(e.pointerId);
    this.stroke.changed = this.paintAt(e.clientX, e.clientY);
  }

  move(e) {
    if (!this.stroke) {
      if (this.garment && !e.buttons) this.showCursor(this.hit(e.clientX, e.clientY));
      return;
    }
    this.stroke.changed = this.paintAt(e.clientX, e.clientY) || this.stroke.changed;
  }

  up() {
    if (!this.stroke) return;
    const changed = this.stroke.changed;
    this.stroke = null;
    if (changed && this.onStroke) this.onStroke();
  }

  // A layer's faces (ascending) and setting them.
  layerFaces(layer) {
    const out = [], a = this.layers[layer];
    if (a) for (let t = 0; t < a.length; ++t) if (a[t]) out.push(t);
    return out;
  }

  setLayerFaces(layer, list) {
    const a = this.layers[layer];
    if (!a) return;
    a.fill(0);
    for (const t of list) if (t >= 0 && t < a.length) a[t] = 1;
    this.recolour();
  }

  // What the server answered: the faces it filled and the attachment bands it made (lists or null).
  setAnswer({ filled = null, bands = null } = {}) {
    const mark = (list) => {
      if (!list) return null;
      const a = new Uint8Array(this.faceCount);
      for (const t of list) if (t >= 0 && t < a.length) a[t] = 1;
      return a;
    };
    this.extra = { filled: mark(filled), bands: mark(bands) };
    this.recolour();
  }

  recolour() {
    if (!this.garment) return;
    const col = this.garment.geometry.attributes.color, c = col.array, L = this.layers, x = this.extra;
    for (let t = 0; t < this.faceCount; ++t) {
      let rgb = COLOURS.skin;
      if (L.region[t]) rgb = COLOURS.region;
      else if (x.filled?.[t]) rgb = COLOURS.filled;
      if (L.band[t] || x.bands?.[t]) rgb = COLOURS.band;
      if (L.keepOut[t]) rgb = COLOURS.keepOut;
      if (L.keepIn[t]) rgb = COLOURS.keepIn;
      for (let k = 0; k < 3; ++k) c.set(rgb, 9 * t + 3 * k);
    }
    col.needsUpdate = true;
    this.renderSoon();
  }

  // Page coordinates of a point (m) as the camera shows it (for the browser tests' strokes).
  screenPoint(x, y, z) {
    const p = new THREE.Vector3(x, y, z).project(this.camera);
    const r = this.renderer.domElement.getBoundingClientRect();
    return { x: r.left + ((p.x + 1) / 2) * r.width, y: r.top + ((1 - p.y) / 2) * r.height, inside: Math.abs(p.x) < 1 && Math.abs(p.y) < 1 && p.z < 1 };
  }

  // Looks at the body from direction d ([x, y, z] from the body towards the camera), the body framed.
  lookFrom(d) {
    if (!this.x) return;
    this.view = null;
    this.fitDistance = 0;
    this.camera.position.copy(this.controls.target).add(new THREE.Vector3(...d).normalize());
    this.fit();
    this.render();
  }

  // Looks at face t along its normal from `distance` m (for painting a face the views do not show).
  lookAtFace(t, distance = 0.6) {
    const c = new THREE.Vector3().fromArray(this.centroids, 3 * t);
    const p = this.garment.geometry.attributes.position.array;
    const a = new THREE.Vector3().fromArray(p, 9 * t), b = new THREE.Vector3().fromArray(p, 9 * t + 3), d = new THREE.Vector3().fromArray(p, 9 * t + 6);
    const n = b.sub(a).cross(d.sub(a)).normalize();
    this.controls.target.copy(c);
    this.camera.position.copy(c).addScaledVector(n, distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 100;
    this.camera.updateProjectionMatrix();
    this.controls.update();
    this.render();
  }
}
