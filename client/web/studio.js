// The studio (the page's second view, #studio): a body's rest and deformed poses uploaded (OBJ or PLY),
// the garment region painted on it (paint.js), attachment bands from the boundary loops or painted,
// keep-out and keep-in painted, further motions with their roles, budget and quality. After each change
// the server checks the region (POST /v1/regions:check, the rules of `kgd region`) and the status box
// gives its area, its vertices after subdivision, its boundary loops, the predicted job time, or why it
// is refused. 'Save scene' downloads the folder `kgd scene export` writes, as a zip; 'Submit' sends the
// same files as a job (POST /v1/jobs, multipart).
import { zipSync } from 'fflate';
import * as api from './api.js';
import { PaintView } from './paint.js';
import { parseMesh, samePoseProblem } from './mesh_file.js';
import { readable, checkBody } from './job_status.js';

const TEMPLATE = `
<aside class="studio-side">
  <section>
    <h2>Body</h2>
    <div class="controls" role="radiogroup" aria-label="Which body">
      <label><input type="radio" name="studio-source" value="upload" checked> Upload its poses</label>
      <label><input type="radio" name="studio-source" value="builtin"> Built-in body</label>
    </div>
    <div id="studio-upload">
      <label for="studio-rest">Rest pose (OBJ or PLY, metres)</label>
      <input id="studio-rest" type="file" accept=".obj,.ply">
      <label for="studio-deformed">Deformed pose (the motion's end, the rest pose's mesh moved)</label>
      <input id="studio-deformed" type="file" accept=".obj,.ply">
      <label for="studio-frames">Frames of the motion (optional, in order)</label>
      <input id="studio-frames" type="file" accept=".obj,.ply" multiple>
    </div>
    <div id="studio-builtin" hidden>
      <label for="studio-builtin-scene">Motion (a built-in scene's, posed as it poses the parametric body)</label>
      <select id="studio-builtin-scene"></select>
      <details><summary>Body measurements (m)</summary><div id="studio-builtin-measurements" class="grid2"></div></details>
      <label><input id="studio-builtin-frames" type="checkbox"> With the motion's frames</label>
      <button id="studio-builtin-load" type="button">Make the body</button>
      <p id="studio-builtin-note" class="hint" aria-live="polite"></p>
    </div>
    <fieldset>
      <legend>Motions and their roles</legend>
      <p class="hint">The first motion (the deformed pose above) is resisted.</p>
      <div class="grid2"><label for="studio-motion-name">Its name</label><input id="studio-motion-name" type="text" value="motion">
        <label for="studio-motion-weight">Its weight</label><input id="studio-motion-weight" type="number" min="0" step="0.1" value="1"></div>
      <div id="studio-motions"></div>
      <button id="studio-add-motion" type="button">Add a motion</button>
    </fieldset>
    <p class="error" id="studio-file-error" aria-live="polite"></p>
  </section>
  <section>
    <h2>Paint</h2>
    <div class="controls" role="radiogroup" aria-label="What the brush paints">
      <label><input type="radio" name="studio-layer" value="region" checked> Region</label>
      <label><input type="radio" name="studio-layer" value="band"> Attachment band</label>
      <label><input type="radio" name="studio-layer" value="keepOut"> Keep-out</label>
      <label><input type="radio" name="studio-layer" value="keepIn"> Keep-in</label>
    </div>
    <div class="controls">
      <label><input id="studio-erase" type="checkbox"> Erase</label>
      <label for="studio-radius">Brush radius (cm)</label>
      <input id="studio-radius" type="number" min="0.1" max="50" step="0.1" value="3">
    </div>
    <div class="controls">
      <button id="studio-mirror" type="button" title="adds the mirror image of every painted face about the symmetry plane">Mirror</button>
      <label><input id="studio-fill-holes" type="checkbox"> Fill holes</label>
      <button id="studio-clear" type="button">Clear</button>
    </div>
    <label for="studio-plane">Symmetry plane (point x, y, z and normal, m)</label>
    <input id="studio-plane" type="text" value="0,0,0,1,0,0">
    <fieldset>
      <legend>Attachment bands</legend>
      <label><input type="radio" name="studio-bands" value="loops" checked> Along the boundary loops</label>
      <label><input type="radio" name="studio-bands" value="painted"> As painted</label>
      <div class="controls"><label for="studio-band-width">Width</label>
        <input id="studio-band-width" type="range" min="0" max="10" step="0.5" value="2" aria-describedby="studio-band-width-value">
        <output id="studio-band-width-value" for="studio-band-width">2 cm</output></div>
    </fieldset>
  </section>
  <section>
    <h2>Design job</h2>
    <div class="grid2">
      <label for="studio-name">Scene name</label><input id="studio-name" type="text" value="studio" maxlength="80">
      <label for="studio-subdivisions">Subdivisions</label><input id="studio-subdivisions" type="number" min="0" max="3" step="1" value="1">
      <label for="studio-budget">Budget (area fraction)</label><input id="studio-budget" type="number" min="0.01" max="1" step="0.01" value="0.3">
      <label for="studio-quality">Accuracy</label>
      <select id="studio-quality"><option value="draft">draft (fastest)</option><option value="standard" selected>standard</option><option value="precise">precise (slowest)</option></select>
      <label for="studio-iterations">Iteration limit</label><input id="studio-iterations" type="number" min="1" step="1" placeholder="400">
      <label for="studio-symmetric">Mirror-symmetric design</label><input id="studio-symmetric" type="checkbox">
      <label for="studio-label">Label</label><input id="studio-label" type="text" maxlength="200">
    </div>
  </section>
</aside>
<section class="studio-view">
  <h2>Studio: paint the garment on the body</h2>
  <canvas id="studio-canvas" aria-label="The body in 3D: drag to paint, right-drag (or Alt + drag) to orbit, scroll to zoom" role="img"></canvas>
  <p class="hint">Drag to paint with the brush; right-drag or Alt + drag to orbit, Shift + right-drag to pan, scroll to zoom.
    <span class="swatch" style="background:#4585d9"></span> region <span class="swatch" style="background:#f28c1f"></span> attachment band
    <span class="swatch" style="background:#59595f"></span> keep-out <span class="swatch" style="background:#269e4d"></span> keep-in</p>
  <div id="studio-status" class="studio-status" role="status" aria-live="polite" data-valid="none">Upload the body's rest and deformed poses, then paint the garment region.</div>
  <div class="controls">
    <button id="studio-save" type="button" title="scene.json and the files it names, as kgd scene export writes them, in a zip">Save scene</button>
    <button id="studio-submit" type="button" title="a design job of this scene, shown in the jobs view">Submit</button>
  </div>
  <p class="error" id="studio-error" aria-live="polite"></p>
</section>`;

// Material and solver settings of a saved scene: those of the built-in body-region scenes (knee_brace).
const SCENE_DEFAULTS = {
  materials: { lame: 'solid3d', cloth: { youngs_modulus_Pa: 5e5, poisson_ratio: 0.33, thickness_m: 0.00027 },
    reinforced: { youngs_modulus_Pa: 5.7e6, poisson_ratio: 0.33, thickness_m: 0.00035 } },
  effects: { relaxation: 'exact', clamps: false, membrane: true, contact: 'unilateral', attachments: true, fold_barrier: true, friction: 0.0, bending: false, uniform_pressure_Pa: 0.0 },
  contact: { stiffness_N_per_m: 5000.0 },
  attachmentStiffness: 3000.0,
  solver: { method: 'newton', grad_tol: 1e-4, max_iterations: 0, reuse_factorization: false, lbfgs_history: 20, project_contact_crossings: true, local_steps: true },
};

const $ = (id) => document.getElementById(id);
const extension = (name) => (name.toLowerCase().endsWith('.ply') ? 'ply' : 'obj');
const cm = (m) => `${(100 * m).toFixed(1)} cm`;
const duration = (s) => (s < 1 ? 'under a second' : s < 90 ? `about ${Math.round(s)} s` : s < 5400 ? `about ${Math.round(s / 60)} min` : `about ${(s / 3600).toFixed(1)} h`);

export class Studio {
  // root: the element the view fills; onSubmitted(job): a job was created.
  constructor(root, { onSubmitted } = {}) {
    this.root = root;
    this.onSubmitted = onSubmitted;
    root.innerHTML = TEMPLATE;
    this.view = null;  // the PaintView, made when the studio is first shown (one WebGL context less until then)
    this.files = { rest: null, deformed: null, frames: [] };  // { name, bytes, mesh }
    this.refused = { rest: null, deformed: null };  // why the file chosen for a pose was refused
    this.motions = [];  // further motions: { row, file: { name, bytes, mesh } | null, frames: [...] }
    this.answer = null;  // the newest check's answer (POST /v1/regions:check)
    this.serial = 0;
    this.timer = null;
    this.checking = null;  // the promise of the newest check
    this.failure = null;  // why the server refused the newest check's request
    this.wire();
    // For the browser tests: the studio and its camera.
    const studio = this;
    window.kgdStudio = { studio, get paint() { return studio.paint; }, screenPoint: (x, y, z) => studio.paint.screenPoint(x, y, z) };
  }

  // The 3D view, made on first use with the brush and layer the form says.
  get paint() {
    if (!this.view) {
      this.view = new PaintView($('studio-canvas'), { onStroke: () => this.changed() });
      this.view.layer = this.root.querySelector('input[name=studio-layer]:checked').value;
      this.view.erase = $('studio-erase').checked;
      this.view.radiusM = (Number($('studio-radius').value) || 3) / 100;
    }
    return this.view;
  }

  wire() {
    for (const r of this.root.querySelectorAll('input[name=studio-source]'))
      r.addEventListener('change', () => {
        const builtin = this.root.querySelector('input[name=studio-source]:checked').value === 'builtin';
        $('studio-upload').hidden = builtin;
        $('studio-builtin').hidden = !builtin;
        if (builtin) this.loadScenes();
        this.showAnswer();
      });
    $('studio-builtin-load').addEventListener('click', () => this.loadBuiltin());
    $('studio-rest').addEventListener('change', () => this.loadRest());
    $('studio-deformed').addEventListener('change', () => this.loadPose('deformed'));
    $('studio-frames').addEventListener('change', () => this.loadFrames());
    $('studio-add-motion').addEventListener('click', () => this.addMotion());
    for (const r of this.root.querySelectorAll('input[name=studio-layer]'))
      r.addEventListener('change', () => { this.paint.layer = this.root.querySelector('input[name=studio-layer]:checked').value; });
    $('studio-erase').addEventListener('change', () => { this.paint.erase = $('studio-erase').checked; });
    $('studio-radius').addEventListener('input', () => { const r = Number($('studio-radius').value); if (r > 0) this.paint.radiusM = r / 100; });
    $('studio-mirror').addEventListener('click', () => this.mirror());
    $('studio-clear').addEventListener('click', () => { for (const l of ['region', 'band', 'keepOut', 'keepIn']) this.paint.setLayerFaces(l, []); this.changed(); });
    const width = () => { $('studio-band-width-value').textContent = `${$('studio-band-width').value} cm`; };
    $('studio-band-width').addEventListener('input', () => { width(); this.changed(); });
    width();
    for (const id of ['studio-fill-holes', 'studio-subdivisions', 'studio-plane']) $(id).addEventListener('change', () => this.changed());
    for (const r of this.root.querySelectorAll('input[name=studio-bands]'))
      r.addEventListener('change', () => { $('studio-band-width').disabled = this.bandMode() === 'painted'; this.changed(); });
    $('studio-quality').addEventListener('change', () => this.showAnswer());
    $('studio-budget').addEventListener('change', () => this.changed());
    $('studio-save').addEventListener('click', () => this.save());
    $('studio-submit').addEventListener('click', () => this.submit());
  }

  // The view is on screen: its 3D view sized.
  show() { this.paint.resize(); }

  fileError(text) { $('studio-file-error').textContent = text ? readable(text) : ''; }
  error(text) { $('studio-error').textContent = text ? readable(text) : ''; }

  // -- Files ------------------------------------------------------------------------------------------

  async readMesh(file) {
    const bytes = new Uint8Array(await file.arrayBuffer());
    const mesh = parseMesh(file.name, bytes);
    return mesh.error ? { error: mesh.error } : { name: file.name, bytes, mesh };
  }

  async loadRest() {
    this.fileError('');
    const file = $('studio-rest').files[0];
    if (!file) return;
    const r = await this.readMesh(file);
    this.setRest(r);
    // Poses chosen before the rest pose are checked against it now.
    if (r.mesh && this.files.deformed) await this.loadPose('deformed');
  }

  // The rest pose read ({ name, bytes, mesh } or { error }): the body shown, nothing painted.
  setRest(r) {
    this.files.rest = null;
    this.answer = null;
    this.refused.rest = r.error || null;
    if (r.error) { this.fileError(r.error); this.paint.clearBody(); this.showAnswer(); return; }
    this.files.rest = r;
    this.paint.setBody(r.mesh.vertices, r.mesh.faces);
    this.changed();
  }

  // -- The built-in body: a built-in scene's parametric body, posed as the scene poses it --------------

  async loadScenes() {
    if (this.scenes) return;
    try {
      const r = await api.scenes();
      this.scenes = (r.scenes || []).filter((x) => x.parametricBody);
      const sel = $('studio-builtin-scene');
      sel.innerHTML = '';
      for (const x of this.scenes) sel.append(Object.assign(document.createElement('option'), { value: x.name, textContent: `${x.name}${x.frames ? ` (${x.frames} frames)` : ''}` }));
      const box = $('studio-builtin-measurements');
      box.innerHTML = '';
      for (const m of r.bodyMeasurements || []) {
        if (m.name === 'resolution_m') continue;
        const id = `studio-body-${m.name}`;
        box.append(Object.assign(document.createElement('label'), { htmlFor: id, textContent: m.name.replace(/_m$/, '').replaceAll('_', ' ') }));
        const i = Object.assign(document.createElement('input'), { id, type: 'number', min: m.min, max: m.max, step: 0.005, placeholder: m.defaultValue });
        i.dataset.measurement = m.name;
        box.append(i);
      }
      this.measurements = r.bodyMeasurements || [];
    } catch (e) {
      this.scenes = null;
      $('studio-builtin-note').textContent = `cannot list the built-in scenes: ${e.message}`;
    }
  }

  async loadBuiltin() {
    this.fileError('');
    const name = $('studio-builtin-scene').value, note = $('studio-builtin-note');
    if (!name) return;
    const inputs = [...this.root.querySelectorAll('#studio-builtin-measurements input')];
    const bad = checkBody(inputs, this.measurements || []);
    if (bad) return this.fileError(bad.message);
    const query = inputs.filter((i) => i.value.trim() !== '').map((i) => `${i.dataset.measurement}=${encodeURIComponent(i.value.trim())}`).join('&');
    const scene = this.scenes.find((x) => x.name === name);
    const poses = ['rest', 'deformed', ...($('studio-builtin-frames').checked ? Array.from({ length: scene?.frames || 0 }, (_, k) => `frame_${k + 1}`) : [])];
    $('studio-builtin-load').disabled = true;
    note.textContent = `making ${name}'s body (the first time for a scene and measurements takes as long as a job's set-up)…`;
    try {
      const read = [];
      for (const pose of poses) {
        const bytes = await api.getUint8(`/v1/scenes/${name}/body/${pose}.obj${query ? `?${query}` : ''}`);
        const fileName = `${name}_${pose}.obj`;
        const mesh = parseMesh(fileName, bytes);
        if (mesh.error) throw new Error(mesh.error);
        read.push({ name: fileName, bytes, mesh });
      }
      this.setRest(read[0]);
      this.files.deformed = read[1];
      this.refused.deformed = null;
      this.files.frames = read.slice(2);
      $('studio-motion-name').value = name;
      note.textContent = `${name}'s body: ${read[0].mesh.faces.length / 3} faces${read.length > 2 ? `, ${read.length - 2} frames` : ''}.`;
    } catch (e) {
      note.textContent = '';
      this.fileError(`${name}'s body: ${e.message}`);
    } finally {
      $('studio-builtin-load').disabled = false;
    }
  }

  // The rest pose's mesh moved, or a message naming both files.
  async readPose(file) {
    const r = await this.readMesh(file);
    if (r.error) return r;
    const rest = this.files.rest;
    if (rest) {
      const problem = samePoseProblem(rest.mesh, rest.name, r.mesh, file.name);
      if (problem) return { error: problem };
    }
    return r;
  }

  async loadPose(which) {
    this.fileError('');
    const file = $('studio-deformed').files[0];
    this.files[which] = null;
    this.refused[which] = null;
    if (!file) return;
    const r = await this.readPose(file);
    this.refused[which] = r.error || null;
    if (r.error) this.fileError(r.error);
    else this.files[which] = r;
    this.showAnswer();
  }

  async loadFrames() {
    this.fileError('');
    this.files.frames = [];
    for (const f of $('studio-frames').files) {
      const r = await this.readPose(f);
      if (r.error) { this.fileError(r.error); this.files.frames = []; return; }
      this.files.frames.push(r);
    }
    this.changed();
  }

  addMotion() {
    const k = this.motions.length + 2;
    const row = document.createElement('div');
    row.className = 'studio-motion grid2';
    row.innerHTML = `<label>Motion ${k}: deformed pose</label><input type="file" accept=".obj,.ply" data-field="file">
      <label>Its frames (optional)</label><input type="file" accept=".obj,.ply" multiple data-field="frames">
      <label>Name</label><input type="text" data-field="name" value="motion_${k}">
      <label>Role</label><select data-field="role"><option value="resist">resist</option><option value="allow">allow</option></select>
      <label>Weight (≥ 0)</label><input type="number" min="0" step="0.1" value="1" data-field="weight">
      <button type="button" data-field="remove">Remove</button>`;
    const m = { row, file: null, frames: [] };
    row.querySelector('[data-field=frames]').addEventListener('change', async (e) => {
      this.fileError('');
      m.frames = [];
      for (const f of e.target.files) {
        const r = await this.readPose(f);
        if (r.error) { this.fileError(r.error); m.frames = []; return; }
        m.frames.push(r);
      }
      this.changed();
    });
    row.querySelector('[data-field=file]').addEventListener('change', async (e) => {
      this.fileError('');
      m.file = null;
      const f = e.target.files[0];
      if (!f) return;
      const r = await this.readPose(f);
      if (r.error) this.fileError(r.error);
      else m.file = r;
    });
    row.querySelector('[data-field=remove]').addEventListener('click', () => { row.remove(); this.motions = this.motions.filter((x) => x !== m); this.changed(); });
    $('studio-motions').append(row);
    this.motions.push(m);
    this.changed();
  }

  // -- The server's check -----------------------------------------------------------------------------

  bandMode() { return this.root.querySelector('input[name=studio-bands]:checked').value; }

  // The symmetry plane typed: [x, y, z, nx, ny, nz] or null.
  plane() {
    const p = $('studio-plane').value.split(',').map((s) => Number(s.trim()));
    return p.length === 6 && p.every(Number.isFinite) && Math.hypot(p[3], p[4], p[5]) > 0 ? p : null;
  }

  changed() {
    clearTimeout(this.timer);
    this.timer = setTimeout(() => this.check(), 250);
  }

  // POST /v1/regions:check of what is painted (mirror: with the mirror image added): the answer, or null
  // when there is nothing to check or the server refused the request (the status box says why). A check
  // overtaken by a newer one gives the newer one's answer.
  check(options) {
    clearTimeout(this.timer);
    this.timer = null;
    const p = this.runCheck(options || {});
    this.checking = p;
    p.finally(() => { if (this.checking === p) this.checking = null; });
    return p;
  }

  async runCheck({ mirror = false }) {
    const serial = ++this.serial;
    const rest = this.files.rest, faces = this.paint.layerFaces('region');
    if (!rest || !faces.length) {
      Object.assign(this, { answer: null, failure: null });
      this.paint.setAnswer();
      this.showAnswer();
      return null;
    }
    const plane = this.plane();
    const form = new FormData();
    form.append('body', new Blob([rest.bytes]), rest.name);
    form.append('faces', faces.join(' '));
    for (const layer of ['keepOut', 'keepIn']) {
      const list = this.paint.layerFaces(layer);
      if (list.length) form.append(layer, list.join(' '));
    }
    const width = Number($('studio-band-width').value) / 100;
    if (this.bandMode() === 'loops' && width > 0) form.append('attachWidthM', String(width));
    if ($('studio-fill-holes').checked) form.append('fillHoles', 'true');
    if (mirror) form.append('mirror', 'true');
    if (plane) form.append('symmetryPlane', plane.join(','));
    form.append('subdivisions', String(Math.max(0, Math.round(Number($('studio-subdivisions').value) || 0))));
    // For the predicted time: every motion's frames, and the motions a design weighs.
    const further = this.motions.filter((m) => m.row.isConnected);
    form.append('frames', String(further.reduce((n, m) => n + m.frames.length, this.files.frames.length)));
    form.append('motions', String(1 + further.length));
    const budget = Number($('studio-budget').value);
    if (budget > 0 && budget <= 1) form.append('budget', String(budget));
    const { answer, failure } = await api.postForm('/v1/regions:check', form).then((a) => ({ answer: a }), (e) => ({ failure: e.message }));
    if (serial !== this.serial) return this.checking || this.answer;
    Object.assign(this, { answer: answer || null, failure: failure || null });
    const bands = answer && this.bandMode() === 'loops' ? (answer.bands || []).flatMap((b) => b.faces || []) : null;
    this.paint.setAnswer(answer ? { filled: answer.filledFaces, bands } : {});
    this.showAnswer();
    return this.answer;
  }

  // The answer to what is painted now (a check waiting or in flight finished first).
  async current() {
    if (this.timer) return this.check();
    if (this.checking) return this.checking;
    return this.answer;
  }

  async mirror() {
    this.error('');
    if (!this.paint.layerFaces('region').length) return this.error('Mirror: paint the region first');
    if (!this.plane()) return this.error('Mirror: the symmetry plane is not six numbers x, y, z, nx, ny, nz with a normal');
    const a = await this.check({ mirror: true });
    if (!a) return;
    // The mirror images join what is painted (the region's as the server tidied them; keep-out and
    // keep-in as it echoed them, mirrored); nothing painted is lost.
    const union = (layer, list) => this.paint.setLayerFaces(layer, [...this.paint.layerFaces(layer), ...(list || [])]);
    // Painted attachment bands: mirrored by the server as a keep list of the same region.
    const bands = this.paint.layerFaces('band');
    const mirroredBands = bands.length ? await this.mirrorList(bands) : [];
    union('region', a.faces);
    union('keepOut', a.keepOut);
    union('keepIn', a.keepIn);
    union('band', mirroredBands);
    await this.check();
  }

  // The body faces `list` (in the painted region) and their mirror images, as the server pairs them.
  async mirrorList(list) {
    const form = new FormData();
    form.append('body', new Blob([this.files.rest.bytes]), this.files.rest.name);
    form.append('faces', this.paint.layerFaces('region').join(' '));
    form.append('keepIn', list.join(' '));
    form.append('mirror', 'true');
    form.append('symmetryPlane', this.plane().join(','));
    try {
      return (await api.postForm('/v1/regions:check', form)).keepIn || [];
    } catch (e) {
      this.error(`Mirror of the painted bands: ${e.message}`);
      return [];
    }
  }

  showAnswer() {
    const box = $('studio-status');
    const a = this.answer;
    box.innerHTML = '';
    const line = (text, cls) => { const p = document.createElement('p'); p.textContent = text; if (cls) p.className = cls; box.append(p); return p; };
    if (!this.files.rest) {
      const builtin = this.root.querySelector('input[name=studio-source]:checked').value === 'builtin';
      box.dataset.valid = this.refused.rest && !builtin ? 'false' : 'none';
      if (this.refused.rest && !builtin) line(readable(this.refused.rest), 'refusal');
      line(builtin ? 'Choose a motion (and the body\'s measurements), press \'Make the body\', then paint the garment region.'
        : 'Upload the body\'s rest and deformed poses, then paint the garment region.');
      return;
    }
    if (this.refused.deformed) line(readable(this.refused.deformed), 'refusal');
    if (!a) {
      box.dataset.valid = this.failure ? 'false' : 'none';
      line(this.failure ? readable(this.failure) : 'Paint the garment region on the body (drag on it).', this.failure ? 'refusal' : '');
      return;
    }
    box.dataset.valid = a.valid ? 'true' : 'false';
    const n = (a.faces || []).length, s = Number($('studio-subdivisions').value) || 0;
    const area = a.valid ? `, ${((a.areaM2 ?? 0) * 1e4).toFixed(0)} cm²` : '';
    line(`Region: ${n} body faces${area}${a.mirrored ? ', mirrored' : ''}${a.filledFaces?.length ? `, ${a.filledFaces.length} faces filled` : ''}.`);
    if (!a.valid) { line(a.refusal || 'refused', 'refusal'); return; }
    line(`After ${s} subdivision${s === 1 ? '' : 's'}: ${a.subdividedVertices ?? '?'} vertices, ${a.subdividedFaces ?? '?'} faces.`);
    const loops = a.loops || [];
    line(`${loops.length} boundary loop${loops.length === 1 ? '' : 's'}${loops.length ? `: ${loops.map((l) => cm(l.lengthM ?? 0)).join(', ')}` : ''}.`);
    if ($('studio-fill-holes').checked && !a.filledFaces?.length && loops.length > 2)
      line('Fill holes filled nothing: each loop encloses more than the hole-area limit (an opening, not a hole); paint over an opening to close it.');
    if (this.bandMode() === 'loops') {
      const bands = a.bands || [];
      const faces = new Set(bands.flatMap((b) => b.faces || []));
      line(bands.length ? `Attachment bands: ${bands.length}, ${faces.size} faces, ${(bands.reduce((x, b) => x + (b.areaM2 ?? 0), 0) * 1e4).toFixed(0)} cm².` : 'No attachment bands (width 0).');
    } else line(`Attachment bands as painted: ${this.paint.layerFaces('band').length} faces.`);
    const q = $('studio-quality').value, t = a.predictedJobS?.[q];
    if (t) line(`Predicted job time (${q}): ${duration(t)}.`);
  }

  // -- Scene files ------------------------------------------------------------------------------------

  // { json: the scene, files: Map(path -> Uint8Array) } of what is painted and uploaded, or { error }.
  async sceneFiles() {
    const { rest, deformed, frames } = this.files;
    if (!rest) return { error: this.refused.rest ? `Choose another rest pose: ${this.refused.rest}` : 'Choose the body\'s rest pose (OBJ or PLY) first' };
    if (!deformed) return { error: this.refused.deformed ? `Choose another deformed pose: ${this.refused.deformed}` : 'Choose the body\'s deformed pose (the rest pose\'s mesh moved) first' };
    const a = await this.current();
    if (!a) return { error: this.failure ? readable(this.failure) : 'Paint the garment region on the body first' };
    if (!a.valid) return { error: `The region is refused: ${a.refusal}` };
    const budget = Number($('studio-budget').value);
    if (!(budget > 0 && budget <= 1)) return { error: `budget: ${$('studio-budget').value} is outside (0, 1]` };
    const name = $('studio-name').value.trim() || 'studio';
    const enc = new TextEncoder(), list = (xs) => enc.encode(xs.map((x) => `${x}\n`).join(''));
    const files = new Map();
    const restPath = `body_rest.${extension(rest.name)}`, deformedPath = `body_deformed.${extension(deformed.name)}`;
    files.set(restPath, rest.bytes);
    files.set(deformedPath, deformed.bytes);
    const body = { rest: restPath, deformed: deformedPath };
    if (frames.length) {
      body.frames = frames.map((f, k) => `frames/frame_${String(k + 1).padStart(2, '0')}.${extension(f.name)}`);
      frames.forEach((f, k) => files.set(body.frames[k], f.bytes));
    }
    const subdivisions = Math.max(0, Math.round(Number($('studio-subdivisions').value) || 0));
    const garment = { region: 'garment_region.txt', subdivisions, design: 'all_cloth' };
    files.set('garment_region.txt', list(a.faces));
    for (const [key, field, file] of [['keep_out', 'keepOutGarmentFaces', 'keep_out.txt'], ['keep_in', 'keepInGarmentFaces', 'keep_in.txt']])
      if (a[field]?.length) { garment[key] = file; files.set(file, list(a[field])); }
    const plane = this.plane();
    if ($('studio-symmetric').checked && plane) garment.symmetry = { point_m: plane.slice(0, 3), normal: plane.slice(3) };
    // Attachment bands: the server's along the loops, or those painted (inside the region).
    const inRegion = new Set(a.faces);
    const attached = this.bandMode() === 'loops' ? [...new Set((a.bands || []).flatMap((b) => b.faces || []))].sort((x, y) => x - y)
      : this.paint.layerFaces('band').filter((t) => inRegion.has(t));
    const scene = { name, description: `Made in the studio on ${rest.name}: ${a.faces.length} body faces.`, budget, body, garment };
    // Motions: the first is the body's own (resisted); each further one a deformed pose of its own.
    const further = this.motions.filter((m) => m.row.isConnected);
    if (further.length) {
      const weight = (input, what) => { const w = Number(input.value); if (!(w >= 0 && Number.isFinite(w))) throw new Error(`${what}: weight ${input.value} must be a number >= 0`); return w; };
      try {
        const first = $('studio-motion-name').value.trim() || 'motion';
        scene.motions = [{ name: first, role: 'resist', weight: weight($('studio-motion-weight'), `motion '${first}'`) }];
        further.forEach((m, k) => {
          const field = (f) => m.row.querySelector(`[data-field=${f}]`);
          const mname = field('name').value.trim() || `motion_${k + 2}`;
          if (!m.file) throw new Error(`motion '${mname}': choose its deformed pose`);
          const path = `motions/${k + 1}/deformed.${extension(m.file.name)}`;
          files.set(path, m.file.bytes);
          const motion = { name: mname, role: field('role').value, weight: weight(field('weight'), `motion '${mname}'`), deformed: path };
          if (m.frames.length) {
            motion.frames = m.frames.map((f, j) => `motions/${k + 1}/frame_${String(j + 1).padStart(2, '0')}.${extension(f.name)}`);
            m.frames.forEach((f, j) => files.set(motion.frames[j], f.bytes));
          }
          scene.motions.push(motion);
        });
      } catch (e) {
        return { error: e.message };
      }
      const names = scene.motions.map((m) => m.name);
      const twice = names.find((x, i) => names.indexOf(x) !== i);
      if (twice) return { error: `motions: the name '${twice}' is used twice` };
    }
    scene.materials = SCENE_DEFAULTS.materials;
    scene.effects = { ...SCENE_DEFAULTS.effects, attachments: attached.length > 0 };
    scene.contact = SCENE_DEFAULTS.contact;
    if (attached.length) {
      scene.attachments = { body_faces: 'attachment_body_faces.txt', stiffness_N_per_m: SCENE_DEFAULTS.attachmentStiffness };
      files.set('attachment_body_faces.txt', list(attached));
    }
    scene.solver = SCENE_DEFAULTS.solver;
    const json = `${JSON.stringify(scene, null, 2)}\n`;
    return { name, json, files };
  }

  async save() {
    this.error('');
    const s = await this.sceneFiles();
    if (s.error) return this.error(s.error);
    const entries = { 'scene.json': new TextEncoder().encode(s.json) };
    for (const [path, bytes] of s.files) entries[path] = bytes;
    const zip = zipSync(entries, { level: 6 });
    const url = URL.createObjectURL(new Blob([zip], { type: 'application/zip' }));
    const a = Object.assign(document.createElement('a'), { href: url, download: `${s.name.replace(/[^\w.-]+/g, '_')}.zip` });
    document.body.append(a);
    a.click();
    a.remove();
    setTimeout(() => URL.revokeObjectURL(url), 10000);
  }

  async submit() {
    this.error('');
    const s = await this.sceneFiles();
    if (s.error) return this.error(s.error);
    const spec = { optimizer: { quality: $('studio-quality').value }, label: $('studio-label').value };
    const iters = $('studio-iterations').value.trim();
    if (iters !== '') {
      const n = Number(iters);
      if (!Number.isInteger(n) || n < 1) return this.error(`Iteration limit: ${iters} is not a whole number >= 1`);
      spec.optimizer.maxIterations = n;
    }
    if ($('studio-symmetric').checked) spec.optimizer.symmetric = true;
    const form = new FormData();
    form.append('scene', new Blob([s.json], { type: 'application/json' }), 'scene.json');
    for (const [path, bytes] of s.files) form.append(path, new Blob([bytes]), path);
    form.append('spec', new Blob([JSON.stringify(spec)], { type: 'application/json' }), 'spec.json');
    $('studio-submit').disabled = true;
    try {
      const job = await api.postForm('/v1/jobs', form);
      if (this.onSubmitted) this.onSubmitted(job);
    } catch (e) {
      this.error(e.message);
    } finally {
      $('studio-submit').disabled = false;
    }
  }
}
