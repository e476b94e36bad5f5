// The kgd web page: submit design jobs, follow them live in 3D and in charts, explore every stored
// iteration, download results. Talks only to the HTTP API (api.js).
import * as api from './api.js';
import { GarmentView } from './view3d.js';
import { RunCharts } from './charts.js';
import * as jobStatus from './job_status.js';
import { Compare } from './compare.js';
import { CutPanel, CUT_FILES } from './cut_files.js';
import { EnergyScale } from './colour_scale.js';
import * as viewer from './viewer_controls.js';
import { Studio } from './studio.js';

const $ = (id) => document.getElementById(id);
const state = {
  scenes: [],               // BuiltinScene
  measurements: [],         // BodyMeasurement
  jobs: new Map(),          // id -> Job
  selected: null,           // job id (string)
  job: null,                // the selected Job
  metrics: [],              // IterationMetrics of the selected job, by iteration
  watch: null,              // EventSource
  shown: -1,                // the iteration on screen
  loading: false, pending: null,
};
const view = new GarmentView($('view'));
const charts = new RunCharts();
const energyScale = new EnergyScale();
// For the browser tests: what is on screen.
window.kgd = { state, view, charts, rendered: 0 };
// The compare view takes the one-job viewer's place; the cut files' options and sheet previews are of
// the iteration shown; a point clicked on a chart shows its iteration.
const compare = new Compare({ onOpen: () => { $('viewer').hidden = true; }, onClose: () => { $('viewer').hidden = false; } });
const cutPanel = new CutPanel($('cut-panel'), { links: false, collapsed: true, onChange: () => renderDownloads() });
charts.onPick = (n) => { const s = $('scrub'); s.value = n; s.dispatchEvent(new Event('input')); };
Object.assign(window.kgd, { compare, cutPanel });

function status(text) { $('server-status').textContent = text; }

// Pa per mmHg (reports give compression in mmHg: class I 18-21, class II 23-32).
const MMHG_PA = 133.322387415;

// Peak and 95th percentile (nearest rank) over the pressed body vertices (p > 0), as kgd reports them.
function pressureFigures(p) {
  const s = [...p].filter((v) => v > 0).sort((a, b) => a - b);
  if (!s.length) return { peak: 0, p95: 0 };
  return { peak: s[s.length - 1], p95: s[Math.ceil(0.95 * s.length) - 1] };
}

// -- Submit --------------------------------------------------------------------------------------------

const budgetOf = (spec) => jobStatus.budgetOf(spec, state.scenes);

async function loadScenes() {
  const r = await api.scenes();
  state.scenes = r.scenes || [];
  if (state.job) charts.setBudget(budgetOf(state.job.spec));  // a built-in scene's budget, now known
  state.machineFactorJobs = r.machineFactorJobs || 0;
  state.maxIterations = r.maxIterations || 0;  // the server's iteration limit (0: none)
  if (state.maxIterations) $('max-iterations').max = state.maxIterations;
  state.measurements = r.bodyMeasurements || [];
  const sel = $('scene');
  sel.innerHTML = '';
  for (const s of state.scenes) {
    const o = document.createElement('option');
    o.value = s.name;
    o.textContent = s.garment ? `${s.name} (${s.garment}, ${s.garmentFaces} faces, budget ${s.budget})` : s.name;
    sel.append(o);
  }
  const fields = $('body-fields');
  fields.innerHTML = '';
  for (const m of state.measurements) {
    if (m.name === 'resolution_m') continue;
    const id = `body-${m.name}`;
    const l = document.createElement('label');
    l.htmlFor = id;
    l.textContent = m.name.replace(/_m$/, '').replaceAll('_', ' ');
    const i = document.createElement('input');
    Object.assign(i, { id, type: 'number', min: m.min, max: m.max, step: 0.005, placeholder: m.defaultValue });
    i.dataset.measurement = m.name;
    fields.append(l, i);
  }
  sceneChanged();
}

function sceneChanged() {
  const s = state.scenes.find((x) => x.name === $('scene').value);
  $('scene-description').textContent = s ? `${s.description}${s.frames ? ` ${s.frames} frames.` : ''}` : '';
  $('body-details').hidden = !s?.parametricBody;
  showMotions(s);
  showPrediction();
}

const roleName = (role) => (role === 'allow' ? 'allowed' : 'resisted');

// A scene of several motions: each with its role and an editable weight (the scene's own to start).
// A scene of several bodies lists its bodies as motions (each resisted), and what it weighs of them.
// Servers that do not list motions show none.
function showMotions(scene) {
  const motions = scene?.motions || [];
  const bodies = scene?.bodyObjective;
  const list = $('motion-list');
  list.innerHTML = '';
  $('motions-fields').hidden = motions.length < 2;
  if (motions.length < 2) return;
  $('motions-legend').textContent = bodies
    ? `Bodies and their weights (≥ 0); the design weighs ${bodies === 'worst' ? 'the worst body' : 'their weighted mean'}`
    : 'Motions and their weights (≥ 0)';
  for (const m of motions) {
    const id = `motion-weight-${m.name}`;
    const l = document.createElement('label');
    l.htmlFor = id;
    l.textContent = bodies ? `body ${m.name}` : `${m.name} (${roleName(m.role)})`;
    const i = document.createElement('input');
    Object.assign(i, { id, type: 'number', min: 0, step: 0.1, value: m.weight ?? 0 });
    i.dataset.motion = m.name;
    i.dataset.sceneWeight = m.weight ?? 0;
    list.append(l, i);
  }
}

// The weights typed in the form that differ from the scene's; a message naming the motion for one
// that is not a number >= 0 (the server's words).
function motionWeights() {
  const weights = {};
  if ($('motions-fields').hidden) return { weights };
  for (const i of document.querySelectorAll('#motion-list input')) {
    const text = i.value.trim();
    const w = Number(text);
    if (text === '' || !Number.isFinite(w) || w < 0)
      return { error: `motion_weights: motion '${i.dataset.motion}': weight ${text || '(none)'} must be finite and >= 0` };
    if (w !== Number(i.dataset.sceneWeight)) weights[i.dataset.motion] = w;
  }
  return { weights };
}

// The server's cost model for the chosen scene and preset (a built-in scene on the default body), on
// its workers once they have finished a job.
function showPrediction() {
  const s = state.scenes.find((x) => x.name === $('scene').value);
  const t = s?.predictedJobS?.[$('quality').value];
  const where = state.machineFactorJobs ? "on this server's workers" : 'on two cores';
  $('predicted-time').textContent = t ? `Predicted time ${where}: about ${t < 90 ? `${Math.round(t)} s` : `${Math.round(t / 60)} min`}` : '';
}

function clearErrors() {
  for (const p of document.querySelectorAll('.error[data-for]')) p.textContent = '';
  for (const e of document.querySelectorAll('.invalid')) e.classList.remove('invalid');
}

// Shows a message next to the field it names (server messages start with the field, e.g.
// "spec.optimizer.budget: 1.5 is outside (0, 1]").
function showError(message) {
  message = jobStatus.readable(message);
  const m = message.toLowerCase();
  const field = m.includes('budget') ? 'budget' : m.includes('max_iterations') || m.includes('maxiterations') ? 'maxIterations'
    : m.includes('max_pressure') || m.includes('maxpressure') ? 'maxPressure'
    : (m.includes('motion_weights') || m.includes('motionweights')) && !$('motions-fields').hidden ? 'motions'
    : m.startsWith('spec.body:') && !$('builtin-fields').hidden ? 'body'
    : m.includes('scene') || m.includes('body') || m.includes('part ') ? 'scene' : 'form';
  if (field === 'body') $('body-details').open = true;
  document.querySelector(`.error[data-for="${field}"]`).textContent = message;
  const measurement = /body measurement (\w+)/.exec(message)?.[1];
  if (field === 'body' && measurement) $(`body-${measurement}`)?.classList.add('invalid');
  const motion = /motion '([^']*)'/.exec(message)?.[1];
  const input = { budget: $('budget'), maxIterations: $('max-iterations'), maxPressure: $('max-pressure'),
    motions: [...document.querySelectorAll('#motion-list input')].find((i) => i.dataset.motion === motion) }[field];
  if (input) input.classList.add('invalid');
}

async function submit(ev) {
  ev.preventDefault();
  clearErrors();
  const spec = { optimizer: { quality: $('quality').value }, label: $('label').value };
  const budget = $('budget').value, iters = $('max-iterations').value;
  if (budget !== '') {
    const b = Number(budget);
    if (!(b > 0 && b <= 1)) return showError(`budget: ${budget} is outside (0, 1]`);
    spec.optimizer.budget = b;
  }
  if ($('symmetric').checked) spec.optimizer.symmetric = true;
  if ($('resist-only').checked) spec.optimizer.resistOnly = true;
  const pressure = $('max-pressure').value;
  if (pressure !== '') {
    const kPa = Number(pressure);
    if (!(kPa >= 0 && Number.isFinite(kPa))) return showError(`max_pressure: ${pressure} kPa must be a number >= 0`);
    spec.optimizer.maxPressurePa = 1e3 * kPa;
  }
  if (iters !== '') {
    const problem = jobStatus.checkIterations(iters, state.maxIterations);
    if (problem) return showError(problem);
    spec.optimizer.maxIterations = Number(iters);
  }
  try {
    let job;
    if (document.querySelector('input[name=source]:checked').value === 'builtin') {
      const { weights, error } = motionWeights();
      if (error) return showError(error);
      if (Object.keys(weights).length) spec.optimizer.motionWeights = weights;
      spec.builtinScene = $('scene').value;
      const body = jobStatus.checkBody(document.querySelectorAll('#body-fields input'), state.measurements);
      if (body) return showError(body.message);
      spec.body = [...document.querySelectorAll('#body-fields input')].filter((i) => i.value !== '').map((i) => `${i.dataset.measurement}=${i.value}`);
      job = await api.createJob(spec);
    } else {
      const file = $('scene-file').files[0];
      if (!file) return showError('scene: choose a scene file (JSON)');
      const problem = await jobStatus.checkSceneUpload(file, $('mesh-files').files);
      if (problem) return showError(problem);
      const form = new FormData();
      form.append('scene', file, file.name);
      for (const f of $('mesh-files').files) form.append(f.name, f, f.name);
      form.append('spec', new Blob([JSON.stringify(spec)], { type: 'application/json' }), 'spec.json');
      job = await api.postForm('/v1/jobs', form);
    }
    status(`job ${job.id} queued`);
    showSubmitted(job);
  } catch (e) {
    showError(e.message);
  }
}

// -- Jobs list -----------------------------------------------------------------------------------------

// Its progress, or its phase after the last iteration (job_status.js).
function progressOf(job) { return jobStatus.progressOf(job, budgetOf(job.spec)); }

function renderJobs() {
  const body = document.querySelector('#jobs tbody');
  body.innerHTML = '';
  for (const job of state.jobs.values()) {
    const tr = document.createElement('tr');
    tr.dataset.id = job.id;
    tr.tabIndex = 0;
    if (job.id === state.selected) tr.classList.add('selected');
    const p = progressOf(job);
    const scene = job.spec?.builtinScene || job.spec?.sceneFiles?.scene?.name || 'scene file';
    tr.innerHTML = `<td>${job.id}</td><td></td><td class="state-${job.state}">${job.state}</td><td><progress max="1" aria-label="progress of job ${job.id}"></progress> <span></span></td><td></td>`;
    tr.children[1].textContent = scene + (job.spec?.label ? ` — ${job.spec.label}` : '');
    tr.querySelector('progress').value = p.fraction;
    tr.querySelector('span').textContent = p.text;
    if (job.state === 'FAILED') tr.title = job.failure;
    if (job.state === 'QUEUED' || job.state === 'RUNNING') {
      const b = document.createElement('button');
      b.textContent = 'Cancel';
      b.setAttribute('aria-label', `Cancel job ${job.id}`);
      b.onclick = async (e) => {
        e.stopPropagation();
        try { await api.cancelJob(job.id); status(`job ${job.id}: cancel requested`); } catch (err) { status(err.message); }
        refreshJobs();
      };
      tr.children[4].append(b);
    }
    tr.onclick = () => select(job.id);
    tr.onkeydown = (e) => { if (e.key === 'Enter') select(job.id); };
    body.append(tr);
  }
}

// One list request at a time: a list of jobs made from scene files carries their meshes (megabytes
// each), and polls that overlap on a busy server would queue the job's stream and meshes behind them.
let listing = null;
function refreshJobs() {
  if (!listing) listing = listJobs().finally(() => { listing = null; });
  return listing;
}

async function listJobs() {
  try {
    const r = await api.jobs(50);
    const listed = new Map((r.jobs || []).map((j) => [j.id, j]));
    // A job submitted while this list was on its way stays (newest first).
    const newest = Math.max(0, ...[...listed.keys()].map(Number));
    const newer = [...state.jobs.values()].filter((j) => Number(j.id) > newest);
    state.jobs = new Map([...newer.map((j) => [j.id, j]), ...listed]);
    renderJobs();
    compare.setJobs(state.jobs);
    status(`connected · ${state.jobs.size} job${state.jobs.size === 1 ? '' : 's'}`);
  } catch (e) {
    status(`server unreachable (${e.message})`);
  }
}

// A job just created: in the list and on screen at once (the next list refresh adds the others).
function showSubmitted(job) {
  state.jobs = new Map([[job.id, job], ...state.jobs]);
  renderJobs();
  select(job.id);
  refreshJobs();
}

// -- One job: live view and explorer -------------------------------------------------------------------

// A failed job's reason where its iterations' figures go (a job with none would show nothing), and above
// the 3D view with how a job ended or what it is doing after its last iteration.
function showFailure(job) {
  $('metrics').textContent = job?.state === 'FAILED' ? `failed: ${jobStatus.readable(job.failure || 'no reason given')}` : '';
  jobStatus.showJobNote($('job-note'), job);
}

// A job of several motions: each motion's figures at its last stored iteration (the final design's
// once the job has ended).
function showMotionSummary(job) {
  const motions = job?.last?.motions || [];
  const box = $('motions-summary');
  box.hidden = motions.length < 2;
  if (box.hidden) return;
  const ended = !['QUEUED', 'RUNNING'].includes(job.state);
  $('motions-summary-title').textContent = `${ended ? 'Final motions' : 'Motions'} (iteration ${job.last.iteration ?? 0}):`;
  const ul = box.querySelector('ul');
  ul.innerHTML = '';
  for (const m of motions) {
    const li = document.createElement('li');
    li.textContent = `${m.name} (${roleName(m.role)}, weight ${+(m.weight ?? 0).toPrecision(3)}): density ratio ${(m.densityRatio ?? 0).toFixed(3)}, reinforced energy ${(m.reinforcedEnergyJ ?? 0).toPrecision(3)} J`;
    ul.append(li);
  }
}

async function select(id) {
  id = String(id);
  compare.close();
  if (state.watch) state.watch.close();
  Object.assign(state, { selected: id, job: state.jobs.get(id) || null, metrics: [], shown: -1, pending: null, evaluation: null, useFrame: false });
  $('explorer').hidden = true;
  document.querySelector('input[name=compare][value=optimized]').checked = true;
  renderJobs();
  $('viewer-title').textContent = `Job ${id}`;
  charts.reset(budgetOf(state.job?.spec));
  view.clear();
  state.meshes = null;
  $('scrub').max = 0;
  $('scrub').value = 0;
  showFailure(state.job);
  showMotionSummary(state.job);
  renderDownloads();
  viewer.revealViewer();
  // The server ends the stream of an ended job once it has sent every iteration; EventSource would
  // reconnect to it every two seconds for as long as the page stays open.
  const es = api.watch(id, {
    onError: () => {
      const job = state.job;
      if (job && !['QUEUED', 'RUNNING'].includes(job.state) && state.metrics.filter(Boolean).length >= (job.iterations || 0)) es.close();
    },
    onJob: (job) => {
      state.job = job;
      state.jobs.set(job.id, job);
      charts.setBudget(budgetOf(job.spec));
      renderJobs();
      showFailure(job);
      showMotionSummary(job);
      renderDownloads();
      if (job.state === 'SUCCEEDED' && !state.evaluation) loadEvaluation(id);
    },
    onIteration: (rec) => {
      const m = rec.metrics;
      const n = m.iteration ?? 0;
      state.metrics[n] = m;
      charts.add(m);
      if (n === state.metrics.length - 1 && state.job) showMotionSummary({ ...state.job, last: m });
      const last = state.metrics.length - 1;
      $('scrub').max = last;
      if ($('follow').checked && !state.useFrame && target().kind === 'iteration') { $('scrub').value = last; show(); }
    },
  });
  state.watch = es;
}

async function ensureMeshes(id) {
  if (state.meshes) return true;
  const faces = await api.garmentFaces(id);
  let body = null;
  try { body = { vertices: await api.bodyVertices(id), faces: await api.bodyFaces(id) }; } catch { /* a flat scene */ }
  if (state.selected !== id) return false;
  state.meshes = { faces, body };
  view.setMeshes(faces, body);
  view.showBody($('show-body').checked);
  return true;
}

// What is on screen: an iteration of the run, the final design in one frame of the motion, or a
// baseline beside it.
function target() {
  const e = state.evaluation;
  const compare = document.querySelector('input[name=compare]:checked').value;
  if (e && compare !== 'optimized') return { kind: 'baseline', name: compare };
  const k = Number($('frame').value);
  if (e && state.useFrame && e.frames?.length) return { kind: 'frame', k };
  // Skin pressure is computed for the final design over the motion: the frame chosen there.
  if (e && e.frames?.length && $('color-mode').value === 'pressure') return { kind: 'frame', k };
  return { kind: 'iteration', n: Number($('scrub').value) };
}

async function fetchTarget(id, t, mode) {
  const e = state.evaluation;
  if (t.kind === 'iteration')
    return { x: await api.positions(id, t.n), values: await (mode === 'energy' ? api.energy(id, t.n) : api.design(id, t.n)), body: null };
  if (t.kind === 'frame') {
    const [x, values, body, pressure] = await Promise.all([api.framePositions(id, t.k), mode === 'energy' ? api.frameEnergy(id, t.k) : api.design(id, e.iteration),
      state.meshes.body ? api.frameBody(id, t.k) : Promise.resolve(null),
      mode === 'pressure' && state.meshes.body ? api.framePressure(id, t.k).catch(() => null) : Promise.resolve(null)]);
    return { x, values, body, pressure };
  }
  return { x: await api.baselinePositions(id, t.name), values: await (mode === 'energy' ? api.baselineEnergy(id, t.name) : api.baselineDesign(id, t.name)), body: null };
}

function describe(t) {
  const e = state.evaluation;
  if (t.kind === 'frame') {
    const f = e.frames[t.k - 1];
    const p = state.pressureFigures;
    const skin = p ? `; skin pressure peak ${(p.peak / 1e3).toPrecision(3)} kPa (${(p.peak / MMHG_PA).toPrecision(3)} mmHg), p95 ${(p.p95 / 1e3).toPrecision(3)} kPa (${(p.p95 / MMHG_PA).toPrecision(3)} mmHg)` : '';
    return `final design (iteration ${e.iteration}) in motion frame ${t.k} of ${e.frames.length}: energy ${(f.energyJ ?? 0).toPrecision(4)} J (${f.solveStatus})${skin}`;
  }
  if (t.kind === 'baseline') {
    const b = e.baselines.find((x) => x.name === t.name);
    return `${t.name === 'x' ? 'X' : 'Line'} baseline of the same area: reinforced area ${(100 * (b.areaFraction ?? 0)).toFixed(1)} %, reinforced density ${(b.reinforcedDensityJPerM2 ?? 0).toPrecision(4)} J/m², density ratio ${(b.densityRatio ?? 0).toFixed(3)}`;
  }
  const m = state.metrics[t.n];
  return m ? `iteration ${t.n}: reinforced area ${(100 * (m.areaFraction ?? 0)).toFixed(1)} %, energy ${(m.energyJ ?? 0).toPrecision(4)} J, reinforced density ${(m.reinforcedDensityJPerM2 ?? 0).toPrecision(4)} J/m², density ratio ${(m.densityRatio ?? 0).toFixed(3)}` : '';
}

// Shows what the controls select; while a fetch is in flight, only the newest request waits.
async function show() {
  if (state.loading) { state.pending = true; return; }
  state.loading = true;
  const id = state.selected;
  try {
    if (await ensureMeshes(id)) {
      const mode = $('color-mode').value;
      const t = target();
      const { x, values, body, pressure } = await fetchTarget(id, t, mode);
      // Energy: the job's one scale (colour_scale.js), or the top typed.
      const scale = mode === 'energy' ? await energyScale.top(id, t, values, state.metrics.length - 1, state.evaluation, Number($('energy-top').value)) : null;
      if (state.selected === id) {
        state.energyScale = scale;
        const max = scale?.top || 0;
        view.setBodyPose(body);
        state.pressureFigures = pressure ? pressureFigures(pressure) : null;
        // Skin pressure: the body coloured up to the peak, the garment by its design.
        view.setBodyPressure(pressure || null, state.pressureFigures?.peak || 0);
        if (pressure) view.showBody(true);
        else view.showBody($('show-body').checked);
        view.update(x, mode === 'pressure' ? 'design' : mode, values, max);
        $('colorbar').hidden = mode !== 'energy' && !pressure;
        $('colorbar-max').textContent = pressure ? `${(state.pressureFigures.peak / 1e3).toPrecision(3)}` : `≥ ${max.toPrecision(3)}`;
        $('colorbar-min').textContent = '0';
        $('colorbar-unit').textContent = pressure ? 'kPa' : 'J/m²';
        viewer.showEnergyScale(pressure ? null : state.energyScale);
        if (mode === 'pressure' && !pressure) status(state.evaluation ? 'this job has no skin pressure (no body or no contact)' : 'skin pressure: shown once the job has finished and its design was evaluated over the motion');
        state.shown = t.kind === 'iteration' ? t.n : state.evaluation.iteration;
        state.target = t;
        charts.setShown(state.shown);
        window.kgd.rendered++;
        $('scrub-value').textContent = viewer.scrubText(t, state.shown, state.metrics.length - 1, state.evaluation);
        viewer.showFrameControls(t, state.evaluation, state.pending);
        $('metrics').textContent = describe(t);
        renderDownloads();
      }
    }
  } catch (e) {
    status(e.message);
  } finally {
    state.loading = false;
    if (state.pending) { state.pending = null; show(); }
  }
}

// The evaluation comes after the last iteration: the final design over the motion and the baselines.
async function loadEvaluation(id) {
  try {
    const e = await api.evaluation(id);
    if (state.selected !== id) return;
    state.evaluation = e;
    const k = e.frames?.length || 0;
    $('explorer').hidden = false;
    $('frame').max = Math.max(1, k);
    $('frame').value = Math.max(1, k);
    $('frame').disabled = k === 0;
    $('frame-value').textContent = k ? `${k} / ${k} (deformed pose)` : 'no motion';
    for (const r of document.querySelectorAll('input[name=compare]'))
      r.disabled = r.value !== 'optimized' && !(e.baselines || []).some((b) => b.name === r.value);
    const last = state.metrics[e.iteration];
    const parts = (e.baselines || []).map((b) => `${b.name === 'x' ? 'X' : 'Line'} ${(b.densityRatio ?? 0).toFixed(2)}`);
    $('baseline-figures').textContent = parts.length ? `density ratios: optimized ${(last?.densityRatio ?? 0).toFixed(2)}, ${parts.join(', ')}` : (e.note || '');
    if (state.shown >= 0) show();  // the job's energy scale and the controls, now with the evaluation
  } catch { /* none (yet) */ }
}

function renderDownloads() {
  const d = $('downloads');
  d.innerHTML = '';
  const id = state.selected;
  cutPanel.setTarget(state.target?.kind === 'baseline' ? null : id, state.shown);
  if (!id || state.shown < 0) return;
  const ply = document.createElement('a');
  const link = viewer.shownDesignLink(id, state.target, state.shown);
  Object.assign(ply, { href: link.href, download: link.download, textContent: link.text });
  d.append(ply);
  // Cut files for fabrication (made on request: a second or two).
  const cut = document.createElement('span');
  cut.textContent = 'Cut files: ';
  const cutQuery = cutPanel.query();  // null: an option out of range (the panel below says which)
  for (const name of cutQuery === null ? [] : CUT_FILES) {
    const a = document.createElement('a');
    a.href = `/v1/jobs/${id}/iterations/${state.shown}/cut/${name}${cutQuery}`;
    a.download = `job-${id}-iteration-${state.shown}-${name}`;
    a.textContent = name;
    a.setAttribute('aria-label', `Download the cut file ${name} of iteration ${state.shown}`);
    cut.append(a, ' ');
  }
  d.append(cut);
  cut.hidden = state.target?.kind === 'baseline';  // cut files are made of the run's iterations
  const ended = state.job && !['QUEUED', 'RUNNING'].includes(state.job.state);
  if (ended) {
    const h5 = document.createElement('a');
    h5.href = `/v1/jobs/${id}/design-file`;
    h5.download = `job-${id}.h5`;
    h5.textContent = 'Download the design file (HDF5, every iteration)';
    d.append(h5);
  }
}

// -- Wiring --------------------------------------------------------------------------------------------

$('submit-form').addEventListener('submit', submit);
$('scene').addEventListener('change', sceneChanged);
$('quality').addEventListener('change', showPrediction);
for (const r of document.querySelectorAll('input[name=source]'))
  r.addEventListener('change', () => {
    const builtin = document.querySelector('input[name=source]:checked').value === 'builtin';
    $('builtin-fields').hidden = !builtin;
    $('upload-fields').hidden = builtin;
  });
$('scrub').addEventListener('input', () => {
  $('follow').checked = Number($('scrub').value) === state.metrics.length - 1;
  state.useFrame = false;
  document.querySelector('input[name=compare][value=optimized]').checked = true;
  show();
});
$('frame').addEventListener('input', () => {
  const e = state.evaluation, k = Number($('frame').value);
  state.useFrame = true;
  $('scrub').value = e.iteration;
  $('frame-value').textContent = `${k} / ${e.frames.length}${k === e.frames.length ? ' (deformed pose)' : ''}`;
  document.querySelector('input[name=compare][value=optimized]').checked = true;
  show();
});
for (const r of document.querySelectorAll('input[name=compare]')) r.addEventListener('change', () => show());
$('color-mode').addEventListener('change', () => {
  $('energy-scale').hidden = $('color-mode').value !== 'energy';
  if (state.shown >= 0) show();
});
$('energy-top').addEventListener('change', () => state.shown >= 0 && show());
for (const b of document.querySelectorAll('#camera-controls button[data-view]')) b.addEventListener('click', () => view.setView(b.dataset.view));
$('download-image').addEventListener('click', () => state.shown >= 0 && viewer.downloadImage(view, {
  id: state.selected, t: state.target, shown: state.shown, evaluation: state.evaluation, mode: $('color-mode').value, caption: $('metrics').textContent }));
$('show-body').addEventListener('change', () => view.showBody($('show-body').checked));

loadScenes().catch((e) => status(`cannot load scenes: ${e.message}`));
refreshJobs();
setInterval(refreshJobs, 2000);
// The studio (#studio) in the jobs view's place; a job it submits is shown in the jobs view.
const studio = new Studio($('studio'), { onSubmitted: (job) => { location.hash = '#jobs'; showSubmitted(job); } });
window.kgd.studio = studio;
function showView() {
  const inStudio = location.hash === '#studio';
  $('jobs-view').hidden = inStudio;
  $('studio').hidden = !inStudio;
  for (const a of document.querySelectorAll('#view-tabs a')) a.toggleAttribute('aria-current', a.hash === (inStudio ? '#studio' : '#jobs'));
  if (inStudio) studio.show();
}
window.addEventListener('hashchange', showView);
showView();
