// Charts of a run against iteration (uPlot): density ratio, reinforced area with the budget line,
// energies; and the density ratio against reinforced area over the whole run. A job of several
// motions also gets each motion's density ratio and reinforced energy, one line per motion (resisted
// solid, allowed dashed, the role in the legend).
import uPlot from 'uplot';

function width(el) { return Math.max(260, el.clientWidth || 300); }

function plot(el, series, opts = {}) {
  const data = [[], ...series.map(() => [])];
  const u = new uPlot({
    width: width(el), height: 180,
    scales: { x: { time: false }, ...(opts.scales || {}) },
    axes: [{ label: opts.xLabel || 'iteration', size: 36 }, { size: 56 }],
    series: [{ label: opts.xLabel || 'iteration' }, ...series],
    legend: { show: true, live: false },
  }, data, el);
  // The chart's canvas is named by its figure caption for screen readers.
  const caption = el.closest('figure')?.querySelector('figcaption')?.textContent || 'chart';
  u.ctx.canvas.setAttribute('role', 'img');
  u.ctx.canvas.setAttribute('aria-label', `Chart: ${caption}`);
  u.resizer = new ResizeObserver(() => u.setSize({ width: width(el), height: 180 }));
  u.resizer.observe(el);
  return u;
}

function drop(u) {
  if (!u) return;
  u.resizer.disconnect();
  u.destroy();
}

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
  constructor() {
    this.ratio = plot(document.getElementById('chart-ratio'), [{ label: 'density ratio', stroke: '#0a5fb4', width: 2 }]);
    this.area = plot(document.getElementById('chart-area'), [
      { label: 'reinforced area', stroke: '#1b7f3b', width: 2 },
      { label: 'budget', stroke: '#b00020', dash: [6, 4], width: 1 },
    ], { scales: { y: { range: [0, 1] } } });
    this.energy = plot(document.getElementById('chart-energy'), [
      { label: 'energy (J)', stroke: '#6a3d9a', width: 2 },
      { label: 'reinforced (J)', stroke: '#e4460a', width: 1.5 },
    ]);
    this.curve = plot(document.getElementById('chart-curve'), [
      { label: 'density ratio', stroke: '#0a5fb4', width: 0, points: { show: true, size: 4 } },
    ], { xLabel: 'reinforced area fraction', scales: { x: { time: false, dir: -1 } } });
    this.motionRatio = null;
    this.motionEnergy = null;
    this.motionKey = '';
    this.reset(1);
  }

  reset(budget) {
    this.budget = budget;
    this.rows = [];
    this.setMotions([]);
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
    this.motionRatio = plot(document.getElementById('chart-motion-ratio'), series.map((x) => ({ ...x })));
    this.motionEnergy = plot(document.getElementById('chart-motion-energy'), series.map((x) => ({ ...x })));
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
