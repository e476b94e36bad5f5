// Compare and choose: two or more jobs side by side. One 3D view per job (they orbit together), their
// figures in one table, their density ratio against reinforced area on one chart (a point clicked shows
// that iteration in its job's view), and the cut files of the iteration picked.
import * as api from './api.js';
import { GarmentView } from './view3d.js';
import { CompareCurve, JOB_COLOURS } from './charts.js';
import { CutPanel } from './cut_files.js';

const $ = (id) => document.getElementById(id);
// WebGL contexts are few (Chromium keeps 16): the page's own view and up to this many.
export const MAX_COMPARED = 6;

const ended = (job) => job && !['QUEUED', 'RUNNING'].includes(job.state);
const sceneOf = (job) => job?.spec?.builtinScene || job?.spec?.sceneFiles?.scene?.name || 'scene file';
const fixed = (v, d) => (v == null ? '–' : Number(v).toFixed(d));

export class Compare {
  // onOpen(), onClose(): the page swaps the one-job viewer for the compare view and back.
  constructor({ onOpen, onClose } = {}) {
    this.onOpen = onOpen;
    this.onClose = onClose;
    this.jobs = new Map();      // id -> Job, as listed
    this.checked = new Set();   // ids ticked in the list
    this.entries = [];          // the compared jobs: { id, job, rows, view, canvas, caption, es, meshes, shown, loading, pending }
    this.picked = null;         // { id, n }: the iteration the cut files are of
    this.syncing = false;
    this.listKey = '';
    this.curve = new CompareCurve($('chart-compare'), $('compare-readout'), (id, n) => this.pick(id, n));
    this.cut = new CutPanel($('compare-cut'), { prefix: 'compare-cut', links: true });
    $('compare-button').addEventListener('click', () => this.open([...this.checked]));
    $('compare-close').addEventListener('click', () => this.close());
    $('compare-use').addEventListener('click', () => {
      if (!this.picked) return;
      this.cut.setTarget(this.picked.id, this.picked.n);
      this.cut.preview();
    });
  }

  // The jobs the server lists: those with a stored iteration can be ticked.
  setJobs(jobs) {
    this.jobs = jobs;
    const usable = [...jobs.values()].filter((j) => (j.iterations ?? 0) > 0);
    for (const id of [...this.checked]) if (!jobs.has(id)) this.checked.delete(id);
    const key = JSON.stringify(usable.map((j) => [j.id, j.spec?.label, sceneOf(j)]));
    if (key !== this.listKey) {
      this.listKey = key;
      const list = $('compare-list');
      list.innerHTML = '';
      for (const j of usable) {
        const l = document.createElement('label');
        const c = document.createElement('input');
        Object.assign(c, { type: 'checkbox', checked: this.checked.has(j.id) });
        c.dataset.id = j.id;
        c.setAttribute('aria-label', `Compare job ${j.id}`);
        c.addEventListener('change', () => {
          if (c.checked) this.checked.add(j.id); else this.checked.delete(j.id);
          this.updateButton();
        });
        l.append(c, ` Job ${j.id} · ${sceneOf(j)}${j.spec?.label ? ` — ${j.spec.label}` : ''}`);
        list.append(l);
      }
      $('compare-hint').textContent = usable.length < 2 ? 'Jobs with stored iterations can be compared once there are two.' : '';
    }
    this.updateButton();
    // Figures of compared jobs that were still running.
    let changed = false;
    for (const e of this.entries) {
      const j = jobs.get(e.id);
      if (j && (!e.job || j.state !== e.job.state || j.iterations !== e.job.iterations)) { e.job = j; changed = true; }
    }
    if (changed) this.renderTable();
  }

  updateButton() {
    const n = this.checked.size;
    const b = $('compare-button');
    b.disabled = n < 2 || n > MAX_COMPARED;
    b.textContent = n > MAX_COMPARED ? `Compare (at most ${MAX_COMPARED})` : `Compare ${n} job${n === 1 ? '' : 's'}`;
  }

  // Opens the compare view on these job ids (two or more).
  open(ids) {
    this.close(false);
    ids = ids.map(String).slice(0, MAX_COMPARED);
    if (ids.length < 2) return;
    $('compare').hidden = false;
    if (this.onOpen) this.onOpen();
    const views = $('compare-views');
    views.innerHTML = '';
    views.style.setProperty('--columns', Math.min(ids.length, 3));
    this.entries = ids.map((id, k) => {
      const fig = document.createElement('figure');
      fig.className = 'compare-view';
      fig.dataset.id = id;
      const canvas = document.createElement('canvas');
      canvas.setAttribute('role', 'img');
      canvas.setAttribute('aria-label', `Job ${id} in 3D; drag to orbit all views together, scroll to zoom`);
      const caption = document.createElement('figcaption');
      caption.style.borderColor = JOB_COLOURS[k % JOB_COLOURS.length];
      fig.append(caption, canvas);
      views.append(fig);
      const e = { id, job: this.jobs.get(id) || null, rows: [], canvas, caption, shown: -1, loading: false, pending: null, meshes: null, es: null, drawn: null };
      e.view = new GarmentView(canvas);
      e.view.controls.addEventListener('change', () => this.sync(e));
      return e;
    });
    this.picked = null;
    this.cut.setTarget(null, -1);
    $('compare-picked').textContent = 'Click a point of the chart to pick an iteration.';
    $('compare-use').disabled = true;
    $('compare-readout').textContent = 'Point at the chart to read a point; click it to show that iteration';
    this.renderTable();
    this.renderCurve();
    for (const e of this.entries) this.follow(e);
  }

  // Leaves the compare view: its streams closed, its views' WebGL contexts released.
  close(notify = true) {
    for (const e of this.entries) {
      if (e.es) e.es.close();
      e.view.clear();
      e.view.renderer.dispose();
      e.view.renderer.forceContextLoss();
    }
    this.entries = [];
    this.curve.destroy();
    this.cut.setTarget(null, -1);
    $('compare-views').innerHTML = '';
    if (!$('compare').hidden) {
      $('compare').hidden = true;
      if (notify && this.onClose) this.onClose();
    }
  }

  // Every stored iteration's figures of a job (the watch stream sends them all, then follows a running
  // job); its last shown once known.
  follow(e) {
    const es = api.watch(e.id, {
      onJob: (job) => {
        e.job = job;
        this.renderTable();
        if (e.shown < 0 && job.iterations > 0) this.show(e, job.iterations - 1);
      },
      onIteration: (rec) => {
        const m = rec.metrics;
        e.rows[m.iteration ?? 0] = m;
        this.scheduleCurve();
      },
      onError: () => {
        if (ended(e.job) && e.rows.filter(Boolean).length >= (e.job.iterations || 0)) es.close();
      },
    });
    e.es = es;
  }

  scheduleCurve() {
    if (this.curvePending) return;
    this.curvePending = true;
    requestAnimationFrame(() => { this.curvePending = false; this.renderCurve(); });
  }

  // A view's caption: its job, the iteration drawn and its figures (once they have arrived).
  caption(e) {
    if (e.drawn == null) return;
    const m = e.rows[e.drawn];
    e.caption.textContent = `Job ${e.id} · iteration ${e.drawn}${m ? `: reinforced area ${(100 * (m.areaFraction ?? 0)).toFixed(1)} %, density ratio ${fixed(m.densityRatio ?? 0, 3)}` : ''}`;
  }

  renderCurve() {
    if (!this.entries.length) return;
    for (const e of this.entries) this.caption(e);
    this.curve.set(this.entries.map((e) => ({ id: e.id, label: `job ${e.id} (${sceneOf(e.job)})`, rows: e.rows, picked: e.shown })));
  }

  renderTable() {
    const body = document.querySelector('#compare-table tbody');
    body.innerHTML = '';
    this.entries.forEach((e, k) => {
      const j = e.job, m = j?.last;
      const tr = document.createElement('tr');
      tr.dataset.id = e.id;
      const motions = (m?.motions?.length ?? 0) > 1
        ? m.motions.map((x) => `${x.name} (${x.role === 'allow' ? 'allowed' : 'resisted'}) ${fixed(x.densityRatio, 3)}`).join('; ') : '–';
      const shown = e.rows[e.shown];
      const cells = [
        `Job ${e.id}`, `${sceneOf(j)}${j?.spec?.label ? ` — ${j.spec.label}` : ''}`, `${j?.state ?? ''}`, `${j?.iterations ?? 0}`,
        m ? `${(100 * (m.areaFraction ?? 0)).toFixed(1)} %` : '–', m ? fixed(m.densityRatio ?? 0, 3) : '–',
        m ? (m.reinforcedEnergyJ ?? 0).toPrecision(4) : '–', motions,
        shown ? `${e.shown}: ${(100 * (shown.areaFraction ?? 0)).toFixed(1)} %, ratio ${fixed(shown.densityRatio ?? 0, 3)}` : e.shown >= 0 ? `${e.shown}` : '–',
      ];
      for (const [i, text] of cells.entries()) {
        const td = document.createElement(i === 0 ? 'th' : 'td');
        if (i === 0) { td.scope = 'row'; td.style.borderLeft = `4px solid ${JOB_COLOURS[k % JOB_COLOURS.length]}`; }
        td.textContent = text;
        tr.append(td);
      }
      body.append(tr);
    });
  }

  // A point of the chart: that job's view shows the iteration, which becomes the one picked.
  pick(id, n) {
    const e = this.entries.find((x) => x.id === String(id));
    if (!e) return;
    this.picked = { id: e.id, n };
    $('compare-picked').textContent = `Picked: job ${e.id}, iteration ${n}.`;
    $('compare-use').disabled = false;
    this.show(e, n);
  }

  // Shows iteration n of a compared job in its view; while a fetch is in flight, only the newest waits.
  async show(e, n) {
    e.shown = n;
    this.renderTable();
    this.renderCurve();
    if (e.loading) { e.pending = n; return; }
    e.loading = true;
    try {
      if (!e.meshes) {
        const faces = await api.garmentFaces(e.id);
        let body = null;
        try { body = { vertices: await api.bodyVertices(e.id), faces: await api.bodyFaces(e.id) }; } catch { /* a flat scene */ }
        if (!this.entries.includes(e)) return;
        e.meshes = { faces, body };
        e.view.setMeshes(faces, body);
      }
      const [x, design] = await Promise.all([api.positions(e.id, n), api.design(e.id, n)]);
      if (!this.entries.includes(e)) return;
      e.view.update(x, 'design', design, 0);
      // One camera for all: the first view drawn frames its garment, the others take its camera.
      const other = this.entries.find((o) => o !== e && o.drawn != null);
      if (other) this.copyCamera(other.view, e.view); else this.sync(e);
      e.drawn = n;
      this.caption(e);
    } catch (err) {
      e.caption.textContent = `Job ${e.id}: ${err.message}`;
    } finally {
      e.loading = false;
      if (e.pending != null) { const p = e.pending; e.pending = null; if (p !== e.drawn) this.show(e, p); }
    }
  }

  copyCamera(from, to) {
    to.camera.up.copy(from.camera.up);
    to.camera.position.copy(from.camera.position);
    to.camera.quaternion.copy(from.camera.quaternion);
    to.camera.near = from.camera.near;
    to.camera.far = from.camera.far;
    to.camera.updateProjectionMatrix();
    to.controls.target.copy(from.controls.target);
    to.render();
  }

  // One view orbited or zoomed: the others take its camera.
  sync(src) {
    if (this.syncing) return;
    this.syncing = true;
    try {
      for (const e of this.entries) if (e !== src) this.copyCamera(src.view, e.view);
    } finally {
      this.syncing = false;
    }
  }
}
