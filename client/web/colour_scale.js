// The energy colour scale of a job: one top (J/m²) for everything of the job the page shows — every
// iteration, every frame of the motion and the Line and X baselines — so that one colour is one energy
// per area wherever it appears. The top is the 99th percentile of the energies per area of the job's
// faces pooled over the evaluated design in the deformed pose, every motion frame and the baselines
// (the job's evaluation); while the job runs (no evaluation yet), over its newest iteration. A top typed
// by the user replaces it.
import * as api from './api.js';

export const PERCENTILE = 0.99;

// The q-quantile (nearest rank below) of every value of `arrays` together; 0 for none.
export function pooledPercentile(arrays, q) {
  const n = arrays.reduce((s, a) => s + a.length, 0);
  if (!n) return 0;
  const all = new Float32Array(n);
  let o = 0;
  for (const a of arrays) { all.set(a, o); o += a.length; }
  all.sort();
  return all[Math.floor(q * (n - 1))];
}

export class EnergyScale {
  constructor() { this.reset(null); }

  // A new job: nothing known.
  reset(id) {
    this.id = id;
    this.evaluated = null;   // Promise of the evaluation's top
    this.newest = { n: -1, top: 0 };  // the newest iteration's top while the job runs
  }

  // { top, source, what } for the job `id` showing `t` (app.js target()) with the energies `values`,
  // `newest` its newest stored iteration, `evaluation` its DesignEvaluation or null, `fixed` the typed
  // top (J/m², NaN or <= 0: none). `source` is 'fixed', 'job' or 'run'; `what` says what was pooled.
  async top(id, t, values, newest, evaluation, fixed) {
    if (id !== this.id) this.reset(id);
    if (fixed > 0) return { top: fixed, source: 'fixed', what: 'typed' };
    if (evaluation) {
      const frames = evaluation.frames?.length || 0, baselines = (evaluation.baselines || []).map((b) => b.name);
      this.evaluated ??= Promise.all([api.energy(id, evaluation.iteration),
        ...Array.from({ length: frames }, (_, k) => api.frameEnergy(id, k + 1)), ...baselines.map((b) => api.baselineEnergy(id, b))])
        .then((arrays) => pooledPercentile(arrays, PERCENTILE));
      try {
        const what = [`the final design`, frames && `its ${frames} motion frames`, baselines.length && `the ${baselines.map((b) => (b === 'x' ? 'X' : 'Line')).join(' and ')}`].filter(Boolean);
        return { top: await this.evaluated, source: 'job', what: what.join(', ') };
      } catch {
        this.evaluated = null;  // asked again next time; this time the run's scale
      }
    }
    if (t.kind === 'iteration' && t.n === newest) this.newest = { n: newest, top: pooledPercentile([values], PERCENTILE) };
    else if (this.newest.n !== newest && newest >= 0) {
      try { this.newest = { n: newest, top: pooledPercentile([await api.energy(id, newest)], PERCENTILE) }; } catch { /* keep the last */ }
    }
    if (this.newest.n < 0) return { top: pooledPercentile([values], PERCENTILE), source: 'run', what: 'the design shown' };
    return { top: this.newest.top, source: 'run', what: `iteration ${this.newest.n}, the newest` };
  }
}
