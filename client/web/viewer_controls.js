// What the viewer's controls say follows what the 3D view shows (app.js target(): an iteration of the
// run, the final design in a frame of the motion, or a baseline): the frame slider and the iteration
// scrubber, the download of the shown design, the colour bar's scale; and the camera's views, the
// image download, and on narrow screens the viewer brought into sight when a job is chosen.

const $ = (id) => document.getElementById(id);
export const baselineTitle = (name) => (name === 'x' ? 'X' : 'Line');

// The frame slider: a frame of the final design's motion, the deformed pose for the run's iterations
// (each is solved in it), and none for a baseline (solved in the deformed pose alone). Not while a newer
// request waits (`pending`): the slider may have moved since `t` was asked for.
export function showFrameControls(t, evaluation, pending) {
  if (!evaluation || pending) return;
  const slider = $('frame'), out = $('frame-value');
  const frames = evaluation.frames?.length || 0;
  if (t.kind === 'baseline') {
    slider.disabled = true;
    out.textContent = `${baselineTitle(t.name)} baseline: one frame, the deformed pose`;
    return;
  }
  slider.disabled = frames === 0;
  const k = t.kind === 'frame' ? t.k : frames;
  slider.value = Math.max(1, k);
  out.textContent = frames ? `${k} / ${frames}${k === frames ? ' (deformed pose)' : ''}` : 'no motion';
}

// The scrubber's text: the iteration shown of the run's 0..last, or the baseline in its place.
export function scrubText(t, shown, last, evaluation) {
  if (t.kind === 'baseline') return `${baselineTitle(t.name)} baseline (of iteration ${evaluation.iteration}'s area)`;
  return `${shown} / ${last}`;
}

// The PLY of the design shown: { href, download, text }.
export function shownDesignLink(id, t, shown) {
  if (t?.kind === 'baseline')
    return { href: `/v1/jobs/${id}/evaluation/baselines/${t.name}/design.ply`, download: `job-${id}-baseline-${t.name}.ply`,
      text: `Download the ${baselineTitle(t.name)} baseline (PLY, deformed pose)` };
  if (t?.kind === 'frame')
    return { href: `/v1/jobs/${id}/iterations/${shown}/design.ply`, download: `job-${id}-iteration-${shown}.ply`,
      text: `Download the final design, iteration ${shown} (PLY, deformed pose)` };
  return { href: `/v1/jobs/${id}/iterations/${shown}/design.ply`, download: `job-${id}-iteration-${shown}.ply`, text: `Download iteration ${shown} (PLY)` };
}

// The colour bar's scale note and the typed top's placeholder, for the energy's scale (colour_scale.js).
export function showEnergyScale(scale) {
  const note = $('colorbar-scale');
  if (!scale) { note.textContent = ''; note.title = ''; return; }
  note.textContent = { fixed: 'fixed', job: 'job scale', run: 'run so far' }[scale.source];
  note.title = scale.source === 'fixed' ? 'the top typed under the view' : `top: the 99th percentile over ${scale.what}`;
  if (scale.source !== 'fixed') $('energy-top').placeholder = `${scale.top.toPrecision(3)} (job's)`;
}

// A name for the image of what is shown, e.g. job-3-frame-2-of-8-energy.png.
function imageName(id, t, shown, evaluation, mode) {
  const what = t?.kind === 'baseline' ? `baseline-${t.name}` : t?.kind === 'frame' ? `frame-${t.k}-of-${evaluation.frames.length}` : `iteration-${shown}`;
  return `job-${id}-${what}-${mode}.png`;
}

// The view as a PNG: the canvas, with the colour bar and its labels when it is shown, and a caption
// (what is shown). Downloads it under a name saying what it shows.
export async function downloadImage(view, { id, t, shown, evaluation, mode, caption }) {
  const src = view.renderer.domElement;
  view.render();
  const c = document.createElement('canvas');
  c.width = src.width;
  c.height = src.height;
  const g = c.getContext('2d');
  g.drawImage(src, 0, 0);
  const px = c.width / (src.clientWidth || c.width);
  g.font = `${Math.round(12 * px)}px system-ui, sans-serif`;
  g.textBaseline = 'top';
  const bar = $('colorbar');
  if (!bar.hidden) {
    const w = 14 * px, h = 160 * px, x = c.width - 40 * px, y = 30 * px;
    const grad = g.createLinearGradient(0, y + h, 0, y);
    ['#30123b', '#4686fb', '#1ae4b6', '#a2fc3c', '#faba39', '#e4460a', '#7a0403'].forEach((s, i, a) => grad.addColorStop(i / (a.length - 1), s));
    g.fillStyle = grad;
    g.fillRect(x, y, w, h);
    g.fillStyle = '#1d1d1f';
    g.textAlign = 'center';
    g.fillText($('colorbar-max').textContent, x + w / 2, y - 16 * px);
    g.fillText($('colorbar-min').textContent, x + w / 2, y + h + 3 * px);
    g.fillText($('colorbar-unit').textContent, x + w / 2, y + h + 18 * px);
    g.fillText($('colorbar-scale').textContent, x + w / 2, y + h + 33 * px);
  }
  if (caption) {
    g.textAlign = 'left';
    g.fillStyle = '#1d1d1f';
    g.fillText(caption, 8 * px, c.height - 20 * px, c.width - 16 * px);
  }
  const blob = await new Promise((resolve) => c.toBlob(resolve, 'image/png'));
  const a = document.createElement('a');
  a.href = URL.createObjectURL(blob);
  a.download = imageName(id, t, shown, evaluation, mode);
  document.body.append(a);
  a.click();
  a.remove();
  setTimeout(() => URL.revokeObjectURL(a.href), 10000);
}

// On a narrow screen (one column: style.css's breakpoint) the viewer is below the jobs list: bring it
// into sight.
export function revealViewer() {
  if (window.matchMedia('(max-width: 900px)').matches) $('viewer').scrollIntoView({ block: 'start' });
}
