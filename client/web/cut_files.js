// Cut files of one stored iteration (docs/FABRICATION.md) with the options of `kgd export`: minimum
// feature, seam allowance, sheet width and mirroring, checked here against the ranges the server
// checks; the files' links; and a preview of the two cut sheets drawn from their SVGs. The SVGs' cut
// lines are hairlines (0.01 mm, what cutters want), invisible at a browser's scale: the preview draws
// every line at a screen width (non-scaling strokes), cut lines thicker.
import * as api from './api.js';

export const CUT_FILES = ['pattern.svg', 'patches.svg', 'pattern.dxf', 'patches.dxf', 'pattern.png', 'patches.png', 'report.json'];

// Each option: its query parameter, its words, `kgd export`'s default and range (the server's words).
export const CUT_OPTIONS = [
  { key: 'min-feature', param: 'minFeatureMm', words: 'minimum feature', label: 'Minimum feature (mm)', def: 3, max: 100, zero: true,
    title: 'Reinforcement thinner than this is removed (and islands and holes under its square x 4); [0, 100] mm' },
  { key: 'seam-allowance', param: 'seamAllowanceMm', words: 'seam allowance', label: 'Seam allowance (mm)', def: 10, max: 100, zero: true,
    title: 'Added around every pattern piece; [0, 100] mm' },
  { key: 'sheet-width', param: 'sheetWidthMm', words: 'sheet width', label: 'Sheet width (mm)', def: 305, max: 10000, zero: false,
    title: 'Width of the vinyl roll the patches are nested on; (0, 10000] mm' },
];

// The SVG text of a cut sheet as an element to show: sized to its container, every stroke a screen
// width (cut and notch lines 1.5 px, the others 1 px) whatever the scale.
export function previewSvg(text, label) {
  const doc = new DOMParser().parseFromString(text, 'image/svg+xml');
  const svg = doc.documentElement;
  if (svg.nodeName !== 'svg' || doc.querySelector('parsererror')) throw new Error(`${label}: not an SVG`);
  svg.removeAttribute('width');
  svg.removeAttribute('height');
  svg.setAttribute('role', 'img');
  svg.setAttribute('aria-label', label);
  svg.classList.add('sheet-preview');
  for (const g of svg.querySelectorAll('[stroke-width]')) {
    const cut = ['1', '4'].includes(g.getAttribute('data-layer'));
    g.setAttribute('stroke-width', cut ? '1.5' : '1');
  }
  for (const e of svg.querySelectorAll('polyline, polygon, path, line, rect, circle, ellipse')) e.setAttribute('vector-effect', 'non-scaling-stroke');
  return document.importNode(svg, true);
}

export class CutPanel {
  // root: an element to fill; prefix: of the inputs' ids; links: list the files' links here;
  // collapsed: in a <details>, closed; onChange(): the options changed.
  constructor(root, { prefix = 'cut', links = true, collapsed = false, onChange = null } = {}) {
    this.root = root;
    this.links = links;
    this.onChange = onChange;
    this.id = null;
    this.n = -1;
    this.request = 0;
    root.classList.add('cut-panel');
    root.innerHTML = '';
    const fs = document.createElement(collapsed ? 'details' : 'fieldset');
    const legend = document.createElement(collapsed ? 'summary' : 'legend');
    fs.className = 'cut-box';
    legend.textContent = collapsed ? 'Cut-file options and sheet preview (kgd export)' : 'Cut files (kgd export)';
    this.title = document.createElement('p');
    this.title.className = 'hint';
    const grid = document.createElement('div');
    grid.className = 'grid2 cut-options';
    this.inputs = {};
    for (const o of CUT_OPTIONS) {
      const l = document.createElement('label');
      l.htmlFor = `${prefix}-${o.key}`;
      l.textContent = o.label;
      const i = document.createElement('input');
      Object.assign(i, { id: `${prefix}-${o.key}`, type: 'number', min: 0, max: o.max, step: o.key === 'sheet-width' ? 1 : 0.5, placeholder: o.def, title: o.title });
      i.addEventListener('input', () => this.changed());
      this.inputs[o.param] = i;
      grid.append(l, i);
    }
    const ml = document.createElement('label');
    ml.htmlFor = `${prefix}-mirror`;
    ml.textContent = 'Mirror the patches';
    this.mirror = document.createElement('input');
    Object.assign(this.mirror, { id: `${prefix}-mirror`, type: 'checkbox', checked: true, title: 'Mirrored is right for heat-transfer vinyl cut from the back' });
    this.mirror.addEventListener('change', () => this.changed());
    grid.append(ml, this.mirror);
    this.error = document.createElement('p');
    this.error.className = 'error';
    this.error.setAttribute('aria-live', 'polite');
    this.fileLinks = document.createElement('p');
    this.fileLinks.className = 'controls cut-links';
    this.button = document.createElement('button');
    this.button.type = 'button';
    this.button.textContent = 'Preview the cut sheets';
    this.button.addEventListener('click', () => this.preview());
    this.summary = document.createElement('p');
    this.summary.className = 'hint cut-summary';
    this.summary.setAttribute('aria-live', 'polite');
    this.sheets = document.createElement('div');
    this.sheets.className = 'cut-sheets';
    fs.append(legend, this.title, grid, this.error, this.fileLinks, this.button, this.summary, this.sheets);
    root.append(fs);
    this.setTarget(null, -1);
  }

  // The query of the options typed ('' for none), or null (and the message shown) for one out of range.
  query() {
    const params = [];
    this.error.textContent = '';
    for (const i of Object.values(this.inputs)) i.classList.remove('invalid');
    for (const o of CUT_OPTIONS) {
      const i = this.inputs[o.param], text = i.value.trim();
      if (text === '') continue;
      const v = Number(text);
      if (!Number.isFinite(v) || v < 0 || (v === 0 && !o.zero) || v > o.max) {
        i.classList.add('invalid');
        this.error.textContent = `${o.param}: the ${o.words} ${text} mm is not a number in ${o.zero ? '[' : '('}0, ${o.max}] mm`;
        return null;
      }
      params.push(`${o.param}=${encodeURIComponent(v)}`);
    }
    if (!this.mirror.checked) params.push('mirror=false');
    return params.length ? `?${params.join('&')}` : '';
  }

  // The iteration whose files are offered (id null or n < 0: none); a preview of another is cleared.
  setTarget(id, n) {
    id = id == null ? null : String(id);
    const same = id === this.id && n === this.n;
    this.id = id;
    this.n = n;
    this.root.hidden = id == null || n < 0;
    this.title.textContent = id == null || n < 0 ? '' : `Job ${id}, iteration ${n}`;
    if (!same) this.clearPreview();
    this.renderLinks();
  }

  changed() {
    this.clearPreview();
    this.renderLinks();
    if (this.onChange) this.onChange();
  }

  clearPreview() {
    this.request++;
    this.sheets.innerHTML = '';
    this.summary.textContent = '';
    this.shownPreview = null;
  }

  url(name, q) { return `/v1/jobs/${this.id}/iterations/${this.n}/cut/${name}${q}`; }

  renderLinks() {
    this.fileLinks.innerHTML = '';
    const q = this.query();
    this.button.disabled = q === null || this.id == null;
    if (!this.links || this.id == null || this.n < 0 || q === null) return;
    this.fileLinks.append(`Cut files of iteration ${this.n}: `);
    for (const name of CUT_FILES) {
      const a = document.createElement('a');
      a.href = this.url(name, q);
      a.download = `job-${this.id}-iteration-${this.n}-${name}`;
      a.textContent = name;
      a.setAttribute('aria-label', `Download the cut file ${name} of job ${this.id}, iteration ${this.n}`);
      this.fileLinks.append(a, ' ');
    }
  }

  // Fetches the report and both sheets (one export on the server: its cache serves the rest) and
  // shows them.
  async preview() {
    const q = this.query();
    if (q === null || this.id == null) return;
    const id = this.id, n = this.n, request = ++this.request;
    this.summary.textContent = `Making the cut files of iteration ${n}…`;
    this.sheets.innerHTML = '';
    try {
      const report = await api.getJson(this.url('report.json', q));
      const [pattern, patches] = await Promise.all([api.getText(this.url('pattern.svg', q)), api.getText(this.url('patches.svg', q))]);
      if (request !== this.request) return;
      const pieces = report.pieces?.length ?? 0, count = report.patches?.length ?? 0;
      this.summary.textContent = `Iteration ${report.iteration}: ${pieces} pattern piece${pieces === 1 ? '' : 's'}, ${count} patch${count === 1 ? '' : 'es'}; `
        + `reinforced area ${(100 * (report.area_fraction ?? 0)).toFixed(1)} %, ${(100 * (report.cleaned?.area_fraction ?? 0)).toFixed(1)} % once cleaned; `
        + `${(100 * (report.sheet_usage ?? 0)).toFixed(0)} % of the vinyl sheet used. Cut lines red, placement guides blue, seams grey.`;
      for (const [name, text] of [['pattern.svg', pattern], ['patches.svg', patches]]) {
        const fig = document.createElement('figure');
        const cap = document.createElement('figcaption');
        cap.textContent = name === 'pattern.svg' ? 'Pattern (fabric pieces, seam allowance)' : 'Patches (vinyl sheet)';
        fig.append(cap, previewSvg(text, `Cut sheet ${name} of job ${id}, iteration ${n}`));
        fig.dataset.file = name;
        this.sheets.append(fig);
      }
      this.shownPreview = { id, n, query: q, iteration: report.iteration };
    } catch (e) {
      // The server refused the export (e.g. a patch wider than the sheet): no links to files it will not make.
      if (request !== this.request) return;
      this.summary.textContent = `No cut files: ${e.message}`;
      this.fileLinks.innerHTML = '';
    }
  }
}
