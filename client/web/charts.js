// Charts of a run against iteration (uPlot): density ratio, reinforced area with the budget line,
// energies; and the density ratio against reinforced area over the whole run. A job of several
// motions also gets each motion's density ratio and reinforced energy, one line per motion (resisted
// solid, allowed dashed, the role in the legend). Every chart shows the values under the pointer in its
// legend, marks the iteration on screen (a line across the iteration charts, a ring on the curve) and
// hands the iteration of a clicked point to onPick. CompareCurve: the density ratio against reinforced
// area of several jobs on one chart, one colour per job.
import uPlot from 'uplot';

function width(el) { return Math.max(260, el.clientWidth || 300); }

// The mark of the iteration on screen: near black, unlike every line and point.
export const MARK_COLOUR = '#222222';

// The point of any series nearest the pointer on the screen (scatter charts: the x values alone would
// pick among iterations of one area arbitrarily). Returns { idx, series } or null.
function nearestPoint(u, only = 0) {
  const left = u.cursor.left, top = u.cursor.top;
  if (left == null || left < 0) return null;
  const xs = u.data[0];
  let best = null, bestD = Infinity;
  for (let s = 1; s < u.series.length; ++s) {
    if (only && s !== only) continue;
    const ys = u.data[s];
    for (let i = 0; i < xs.length; ++i) {
      if (ys[i] == null) continue;
      const dx = u.valToPos(xs[i], 'x') - left, dy = u.valToPos(ys[i], u.series[s].scale || 'y') - top;
      const d = dx * dx + dy * dy;
      if (d < bestD) { bestD = d; best = { idx: i, series: s }; }
    }
  }
  return best;
}

// Rings (x and y) or lines across the plot (x alone) at the marks, on the canvas after each draw.
function drawMarks(u, marks) {
  const ctx = u.ctx, r = devicePixelRatio || 1, { left, top, width: w, height: h } = u.bbox;
  ctx.save();
  for (const m of marks) {
    if (m.x == null || !Number.isFinite(m.x)) continue;
    const x = u.valToPos(m.x, 'x', true);
    if (x < left - 1 || x > left + w + 1) continue;
    ctx.strokeStyle = m.stroke || MARK_COLOUR;
    ctx.lineWidth = 2.5 * r;
    ctx.beginPath();
    if (m.y == null) {
      ctx.moveTo(x, top);
      ctx.lineTo(x, top + h);
    } else {
      ctx.arc(x, u.valToPos(m.y, 'y', true), 6 * r, 0, 2 * Math.PI);
    }
    ctx.stroke();
  }
  ctx.restore();
}

// opts: xLabel, scales, scatter (the pointer picks the nearest point on the screen), xValue (the
// legend's text of the x value: (u, value, seriesIdx, idx)), marks (() => [{ x, y? }]), onPick(u, idx),
// onHover(u, idx or null).
function plot(el, series, opts = {}) {
  const data = [[], ...series.map(() => [])];
  const cursor = { drag: { x: !opts.scatter, y: false } };
  if (opts.scatter)
    cursor.dataIdx = (u, s, idx) => {
      if (s !== 0) return nearestPoint(u, s)?.idx ?? null;
      u.nearest = nearestPoint(u);
      return u.nearest ? u.nearest.idx : idx;
    };
  const scales = { x: { time: false }, ...(opts.scales || {}) };
  // Scatter charts: both axes padded, so that the outermost points' rings lie inside the plot.
  if (opts.scatter) {
    const padded = (u, min, max) => {
      const d = max > min ? max - min : Math.abs(max) || 1;
      return [min - 0.08 * d, max + 0.08 * d];
    };
    scales.x = { ...scales.x, range: padded };
    scales.y = { ...scales.y, range: padded };
  }
  const u = new uPlot({
    width: width(el), height: 180,
    scales,
    axes: [{ label: opts.xLabel || 'iteration', size: 36 }, { size: 56 }],
    series: [{ label: opts.xLabel || 'iteration', ...(opts.xValue ? { value: opts.xValue } : {}) }, ...series],
    legend: { show: true, live: true },
    cursor,
    hooks: {
      draw: [(x) => drawMarks(x, opts.marks ? opts.marks() : [])],
      setCursor: [(x) => {
        if (x.cursor.left == null || x.cursor.left < 0) x.nearest = null;
        if (opts.onHover) opts.onHover(x, opts.scatter ? (x.nearest?.idx ?? null) : x.cursor.idx);
      }],
    },
  }, data, el);
  // The chart's canvas is named by its figure caption for screen readers.
  const caption = el.closest('figure')?.querySelector('figcaption')?.textContent || 'chart';
  u.ctx.canvas.setAttribute('role', 'img');
  u.ctx.canvas.setAttribute('aria-label', `Chart: ${caption}`);
  u.resizer = new ResizeObserver(() => u.setSize({ width: width(el), height: 180 }));
  u.resizer.observe(el);
  if (opts.onPick) {
    u.over.style.cursor = 'pointer';
    u.over.title = 'Click a point to show its iteration';
    u.over.addEventListener('click', () => {
      const idx = opts.scatter ? u.nearest?.idx : u.cursor.idx;
      if (idx != null && idx >= 0) opts.onPick(u, idx);
    });
  }
  return u;
}

function drop(u) {
  if (!u) return;
  u.resizer.disconnect();
  u.destroy();
}

const percent = (v) => (v == null ? '–' : `${(100 * v).toFixed(1)} %`);

// One colour per motion, in the scene's order.
const MOTION_COLOURS = ['#0a5fb4', '#e4460a', '#1b7f3b', '#6a3d9a', '#b8860b', '#00838f'];

// A motion's line: its name and role in the legend; allowed motions dashed.
export function motionSeries(m, k) {
  const allowed = m.role === 'allow';
  const weight = m.weight ?? 0;
  return {
    label: `${m.name} (${allowed ? 'allowed' : 'resisted'}, weight ${+weight.toPrecision(3)})`,
    stroke: MOTION_COLOURS[k % MOTION_COLOURS.length], width: 2, ...(allowed ? { dash: [6, 4] } : {}),
  };
}

export class RunCharts {
  // onPick(iteration): a point of a chart was clicked.
  constructor() {
    this.onPick = null;
    this.shown = -1;
    this.rows = [];
    const byIteration = {
      marks: () => (this.shown >= 0 ? [{ x: this.shown }] : []),
      onPick: (u, idx) => this.pick(u.data[0][idx]),
    };
    this.ratio = plot(document.getElementById('chart-ratio'), [{ label: 'density ratio', stroke: '#0a5fb4', width: 2 }], byIteration);
    this.area = plot(document.getElementById('chart-area'), [
      { label: 'reinforced area', stroke: '#1b7f3b', width: 2 },
      { label: 'budget', stroke: '#b00020', dash: [6, 4], width: 1 },
    ], { ...byIteration, scales: { y: { range: [0, 1] } } });
    this.energy = plot(document.getElementById('chart-energy'), [
      { label: 'energy (J)', stroke: '#6a3d9a', width: 2 },
      { label: 'reinforced (J)', stroke: '#e4460a', width: 1.5 },
    ], byIteration);
    // The curve's points in order of area, and the iteration of each.
    this.curveIterations = [];
    this.curve = plot(document.getElementById('chart-curve'), [
      { label: 'density ratio', stroke: '#0a5fb4', width: 0, points: { show: true, size: 4 } },
    ], {
      xLabel: 'reinforced area fraction', scales: { x: { time: false, dir: -1 } }, scatter: true,
      xValue: (u, v, s, idx) => (idx == null ? '–' : `${percent(v)} (iteration ${this.curveIterations[idx]})`),
      marks: () => {
        const m = this.rows[this.shown];
        return m ? [{ x: m.areaFraction ?? 0, y: m.densityRatio ?? 0 }] : [];
      },
      onPick: (u, idx) => this.pick(this.curveIterations[idx]),
    });
    this.byIteration = byIteration;
    this.motionRatio = null;
    this.motionEnergy = null;
    this.motionKey = '';
    this.reset(1);
  }

  pick(iteration) {
    if (iteration != null && this.onPick) this.onPick(iteration);
  }

  // Marks the iteration on screen (-1: none).
  setShown(n) {
    if (n === this.shown) return;
    this.shown = n;
    for (const u of this.all()) u.redraw(false);
  }

  all() { return [this.ratio, this.area, this.energy, this.curve, this.motionRatio, this.motionEnergy].filter(Boolean); }

  reset(budget) {
    this.budget = budget;
    this.rows = [];
    this.shown = -1;
    this.setMotions([]);
    this.redraw();
  }

  // The budget line at this area fraction (the job's, once its spec is known).
  setBudget(budget) {
    if (budget === this.budget) return;
    this.budget = budget;
    this.redraw();
  }

  // The per-motion charts for these motions (MotionMetrics: name, role, weight), shown for two or more.
  setMotions(motions) {
    const key = JSON.stringify(motions.map((m) => [m.name, m.role, m.weight ?? 0]));
    if (key === this.motionKey) return;
    this.motionKey = key;
    drop(this.motionRatio);
    drop(this.motionEnergy);
    this.motionRatio = this.motionEnergy = null;
    const several = motions.length > 1;
    for (const id of ['figure-motion-ratio', 'figure-motion-energy']) document.getElementById(id).hidden = !several;
    if (!several) return;
    const series = motions.map(motionSeries);
    for (const id of ['chart-motion-ratio', 'chart-motion-energy']) document.getElementById(id).innerHTML = '';
    this.motionRatio = plot(document.getElementById('chart-motion-ratio'), series.map((x) => ({ ...x })), this.byIteration);
    this.motionEnergy = plot(document.getElementById('chart-motion-energy'), series.map((x) => ({ ...x })), this.byIteration);
  }

  // m: IterationMetrics (protobuf JSON).
  add(m) {
    this.rows[m.iteration ?? 0] = m;
    if ((m.motions?.length ?? 0) > 1) this.setMotions(m.motions);
    this.redraw();
  }

  redraw() {
    const rows = this.rows.filter(Boolean);
    const it = rows.map((m) => m.iteration ?? 0);
    this.ratio.setData([it, rows.map((m) => m.densityRatio ?? 0)]);
    this.area.setData([it, rows.map((m) => m.areaFraction ?? 0), rows.map(() => this.budget)]);
    this.energy.setData([it, rows.map((m) => m.energyJ ?? 0), rows.map((m) => m.reinforcedEnergyJ ?? 0)]);
    const byArea = [...rows].sort((a, b) => (a.areaFraction ?? 0) - (b.areaFraction ?? 0));
    this.curveIterations = byArea.map((m) => m.iteration ?? 0);
    this.curve.setData([byArea.map((m) => m.areaFraction ?? 0), byArea.map((m) => m.densityRatio ?? 0)]);
    if (this.motionRatio) {
      // Iterations stored before per-motion records have none: a gap (null) in each line.
      const n = JSON.parse(this.motionKey).length;
      const per = (field) => Array.from({ length: n }, (_, k) => rows.map((m) => m.motions?.[k]?.[field] ?? null));
      this.motionRatio.setData([it, ...per('densityRatio')]);
      this.motionEnergy.setData([it, ...per('reinforcedEnergyJ')]);
    }
  }
}

// One colour per compared job.
export const JOB_COLOURS = ['#0a5fb4', '#e4460a', '#1b7f3b', '#6a3d9a', '#b8860b', '#00838f'];

// The density ratio against reinforced area of several jobs: a series of points per job (its stored
// iterations), the pointer's nearest point described in `readout`, each job's picked iteration ringed,
// onPick(jobId, iteration) for a clicked point.
export class CompareCurve {
  constructor(el, readout, onPick) {
    this.el = el;
    this.readout = readout;
    this.onPick = onPick;
    this.u = null;
    this.key = '';
    this.points = [];  // per column: { id, iteration, m }
    this.jobs = [];
  }

  // jobs: [{ id, label, rows: IterationMetrics by iteration, picked: iteration or -1 }], in order.
  set(jobs) {
    this.jobs = jobs;
    const key = JSON.stringify(jobs.map((j) => [j.id, j.label]));
    if (key !== this.key) {
      this.key = key;
      drop(this.u);
      this.el.innerHTML = '';
      this.u = plot(this.el, jobs.map((j, k) => ({
        label: j.label, stroke: JOB_COLOURS[k % JOB_COLOURS.length], width: 0,
        points: { show: true, size: 6, fill: JOB_COLOURS[k % JOB_COLOURS.length] },
      })), {
        xLabel: 'reinforced area fraction', scales: { x: { time: false, dir: -1 } }, scatter: true,
        xValue: (u, v, s, idx) => {
          const p = idx == null ? null : this.points[idx];
          return p ? `${percent(v)} (job ${p.id}, iteration ${p.iteration})` : '–';
        },
        marks: () => this.jobs.map((j) => j.rows[j.picked]).filter(Boolean).map((m) => ({ x: m.areaFraction ?? 0, y: m.densityRatio ?? 0 })),
        onHover: (u, idx) => this.describe(idx),
        onPick: (u, idx) => { const p = this.points[idx]; if (p) this.onPick(p.id, p.iteration); },
      });
    }
    const points = [];
    jobs.forEach((j, k) => { for (const m of j.rows) if (m) points.push({ id: j.id, k, iteration: m.iteration ?? 0, m }); });
    points.sort((a, b) => (a.m.areaFraction ?? 0) - (b.m.areaFraction ?? 0));
    this.points = points;
    this.u.setData([points.map((p) => p.m.areaFraction ?? 0), ...jobs.map((j, k) => points.map((p) => (p.k === k ? p.m.densityRatio ?? 0 : null)))]);
  }

  // Redraws the rings of the picked iterations.
  marksChanged() { if (this.u) this.u.redraw(false); }

  describe(idx) {
    const p = idx == null ? null : this.points[idx];
    this.readout.textContent = p
      ? `job ${p.id}, iteration ${p.iteration}: reinforced area ${percent(p.m.areaFraction ?? 0)}, density ratio ${(p.m.densityRatio ?? 0).toFixed(3)} (click to show it)`
      : 'Point at the chart to read a point; click it to show that iteration';
  }

  destroy() {
    drop(this.u);
    this.u = null;
    this.key = '';
  }
}
