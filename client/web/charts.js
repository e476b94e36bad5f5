// Charts of a run against iteration (uPlot): density ratio, reinforced area with the budget line,
// energies; and the density ratio against reinforced area over the whole run.
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
  new ResizeObserver(() => u.setSize({ width: width(el), height: 180 })).observe(el);
  return u;
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
    this.reset(1);
  }

  reset(budget) {
    this.budget = budget;
    this.rows = [];
    this.redraw();
  }

  // m: IterationMetrics (protobuf JSON).
  add(m) {
    this.rows[m.iteration ?? 0] = m;
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
  }
}
