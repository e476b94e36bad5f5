// The 3D viewer in headless Chromium against a real `kgd serve` (harness.mjs), on one short knee_flexion
// job: one energy colour scale for the whole job (the colour bar's top the same at every motion frame
// and for Line, X and the optimized design; the 99th percentile over the final design, its frames and
// the baselines, as the API's energies give it; each face drawn in the scale's colour of its energy;
// a typed top replaces it), the garment framed at every frame (its projected bounds inside the canvas
// and filling it), the front, back and side views, the view downloaded as PNG, the frame slider,
// scrubber and download following a baseline shown (its PLY is the baseline's design and positions),
// the jobs list's iteration the scrubber's, and at 420 px the viewer scrolled into sight when a job is
// chosen. Screenshots go to --artifacts.
//   node tests/web/viewer_test.mjs --kgd build/client/kgd --artifacts build/test-artifacts/web/viewer
import fs from 'node:fs';
import path from 'node:path';
import { runBrowserTest, submitJob, waitForEnd, apiJson, apiFloats, apiBytes, openPage, settled } from './harness.mjs';

// The page's energy colour map (view3d.js and the CSS colour bar share these stops).
const STOPS = [[0x30, 0x12, 0x3b], [0x46, 0x86, 0xfb], [0x1a, 0xe4, 0xb6], [0xa2, 0xfc, 0x3c], [0xfa, 0xba, 0x39], [0xe4, 0x46, 0x0a], [0x7a, 0x04, 0x03]];
function colour(t) {
  const x = Math.min(Math.max(t, 0), 1) * (STOPS.length - 1);
  const i = Math.min(Math.floor(x), STOPS.length - 2), f = x - i;
  return [0, 1, 2].map((k) => (STOPS[i][k] * (1 - f) + STOPS[i + 1][k] * f) / 255);
}
// The 99th percentile (nearest rank below) of all values together.
function pooledP99(arrays) {
  const all = Float32Array.from(arrays.flatMap((a) => Array.from(a))).sort();
  return all[Math.floor(0.99 * (all.length - 1))];
}

// The largest difference between each drawn face's colour and the colour of its energy on a scale of `top`.
const colourError = (drawnColours, energy, top) => {
  let err = 0;
  for (let f = 0; f < energy.length; ++f) {
    const want = colour(energy[f] / top);
    for (let k = 0; k < 3; ++k) err = Math.max(err, Math.abs(drawnColours[9 * f + k] - want[k]));
  }
  return err;
};

// The garment drawn, projected with the camera that draws it: its bounds in normalized device
// coordinates (the canvas is [-1, 1]^2), vertices behind the camera, the camera's direction from what
// it looks at, and the face colours.
const projection = (page) => page.evaluate(() => {
  const v = window.kgd.view, cam = v.camera;
  cam.updateMatrixWorld();
  const V = cam.matrixWorldInverse.elements, P = cam.projectionMatrix.elements;
  const mul = (m, p) => [0, 1, 2, 3].map((r) => m[r] * p[0] + m[4 + r] * p[1] + m[8 + r] * p[2] + m[12 + r] * p[3]);
  const x = v.garment.geometry.attributes.position.array;
  const lo = [Infinity, Infinity], hi = [-Infinity, -Infinity];
  let behind = 0;
  for (let i = 0; i < x.length; i += 3) {
    const c = mul(P, mul(V, [x[i], x[i + 1], x[i + 2], 1]));
    if (c[3] <= 0) { behind++; continue; }
    for (let a = 0; a < 2; ++a) { lo[a] = Math.min(lo[a], c[a] / c[3]); hi[a] = Math.max(hi[a], c[a] / c[3]); }
  }
  const d = cam.position.clone().sub(v.controls.target).normalize();
  let sx = 0;
  for (let i = 0; i < x.length; i += 3) sx += x[i];
  // The area of the rectangle around the garment seen along a direction (orthographic, up +y).
  const area = (dir) => {
    const f = dir.clone().normalize(), r = f.clone().cross(cam.up).normalize(), u = r.clone().cross(f).normalize();
    const lo2 = [Infinity, Infinity], hi2 = [-Infinity, -Infinity];
    for (let i = 0; i < x.length; i += 3) {
      const p = [x[i] * r.x + x[i + 1] * r.y + x[i + 2] * r.z, x[i] * u.x + x[i + 1] * u.y + x[i + 2] * u.z];
      for (let a = 0; a < 2; ++a) { lo2[a] = Math.min(lo2[a], p[a]); hi2[a] = Math.max(hi2[a], p[a]); }
    }
    return (hi2[0] - lo2[0]) * (hi2[1] - lo2[1]);
  };
  const s = Math.sign(sx);
  return { lo, hi, behind, dir: [d.x, d.y, d.z], garmentX: sx / (x.length / 3), colours: Array.from(v.garment.geometry.attributes.color.array),
    areas: { shown: area(d), front: area(d.clone().set(0, 0.35, 1)), between: area(d.clone().set(0.6 * s, 0.35, 1)), side: area(d.clone().set(s, 0.35, 0.15)) } };
});
const inside = (p) => p.behind === 0 && p.lo[0] >= -1 && p.lo[1] >= -1 && p.hi[0] <= 1 && p.hi[1] <= 1;
const fills = (p) => Math.max(p.hi[0] - p.lo[0], p.hi[1] - p.lo[1]) >= 1.2;  // over 60 % of the canvas's width or height
const box = (p) => `x ${p.lo[0].toFixed(2)}..${p.hi[0].toFixed(2)}, y ${p.lo[1].toFixed(2)}..${p.hi[1].toFixed(2)}`;

await runBrowserTest('viewer', async ({ browser, page, base, check, until, artifacts }) => {
  const id = await submitJob(page, { scene: 'knee_flexion', budget: 0.9, maxIterations: 4, label: 'viewer test', quality: 'draft' });
  const started = Date.now();
  const job = await waitForEnd(base, id, 400000);
  console.log(`(the job ran ${((Date.now() - started) / 1000).toFixed(1)} s with its evaluation)`);
  check(job.state === 'SUCCEEDED', `the knee_flexion job succeeded (${job.state} after ${job.iterations} stored iterations)`);
  await until('the evaluation in the page', () => page.evaluate(() => !document.getElementById('explorer').hidden), 60000);
  await until('every iteration in the page', () => page.evaluate((n) => window.kgd.state.metrics.filter(Boolean).length === n, job.iterations), 20000);
  const evaluation = await apiJson(base, `v1/jobs/${id}/evaluation`);
  const frames = evaluation.frames?.length || 0, last = job.iterations - 1;
  check(frames >= 4 && evaluation.baselines?.length === 2, `the evaluation has ${frames} motion frames and ${evaluation.baselines?.length ?? 0} baselines`);

  // The jobs list and the scrubber name the same last iteration (iterations are 0..last).
  await until('the list to show the ended job', () => page.evaluate((i) => /SUCCEEDED/.test(document.querySelector(`tr[data-id="${i}"]`)?.textContent || ''), id), 10000);
  await until('the last iteration on screen', () => page.evaluate((n) => window.kgd.state.shown === n && !window.kgd.state.loading && !window.kgd.state.pending, last), 20000);
  const listed = await page.evaluate((i) => document.querySelector(`tr[data-id="${i}"]`).textContent, id);
  const scrub = await page.evaluate(() => ({ max: Number(document.getElementById('scrub').max), text: document.getElementById('scrub-value').textContent }));
  const listedN = Number(/iteration (\d+)/.exec(listed)?.[1]);
  check(listedN === last && scrub.max === last && scrub.text === `${last} / ${last}`,
    `the jobs list's iteration is the scrubber's: list "${listed.replace(/\s+/g, ' ').trim()}", scrubber "${scrub.text}" (max ${scrub.max}), stored 0..${last}`);

  // One energy scale for the job: the 99th percentile over the final design, its frames and the baselines.
  const energies = {
    final: await apiFloats(base, `v1/jobs/${id}/iterations/${evaluation.iteration}/energy.f32`),
    frames: await Promise.all(Array.from({ length: frames }, (_, k) => apiFloats(base, `v1/jobs/${id}/evaluation/frames/${k + 1}/energy.f32`))),
    line: await apiFloats(base, `v1/jobs/${id}/evaluation/baselines/line/energy.f32`),
    x: await apiFloats(base, `v1/jobs/${id}/evaluation/baselines/x/energy.f32`),
  };
  const top = pooledP99([energies.final, ...energies.frames, energies.line, energies.x]);
  const ownTops = energies.frames.map((e) => pooledP99([e]));
  check(ownTops[0] < 0.5 * ownTops[frames - 1], `the frames' own energies differ (99th percentiles ${ownTops.map((t) => t.toPrecision(3)).join(', ')} J/m²): one scale matters`);
  await page.selectOption('#color-mode', 'energy');
  const showFrame = async (k) => {
    await page.evaluate((v) => { const s = document.getElementById('frame'); s.value = v; s.dispatchEvent(new Event('input')); }, k);
    await until(`frame ${k} on screen`, () => page.evaluate((v) => window.kgd.state.target?.kind === 'frame' && window.kgd.state.target.k === v && !window.kgd.state.loading && !window.kgd.state.pending, k), 20000);
  };
  const showCompare = async (name) => {
    await page.check(`input[name=compare][value=${name}]`);
    await settled(page);
  };
  const bar = () => page.evaluate(() => ({ top: document.getElementById('colorbar-max').textContent, note: document.getElementById('colorbar-scale').textContent,
    hidden: document.getElementById('colorbar').hidden, scale: window.kgd.state.energyScale?.top }));
  const want = `≥ ${top.toPrecision(3)}`;
  const mid = Math.ceil(frames / 2);
  const seen = [];
  for (const k of [1, mid, frames]) {
    await showFrame(k);
    const b = await bar(), p = await projection(page);
    const err = colourError(p.colours, energies.frames[k - 1], top);
    seen.push(`frame ${k}: "${b.top}" (${b.note}), colours within ${err.toExponential(1)}`);
    check(!b.hidden && b.top === want && b.scale === top && err < 1e-5, `frame ${k}: the colour bar's top is the job's, ${want} J/m², and each face is drawn in its energy's colour on it (${seen.at(-1)})`);
    if (k === 1) await page.screenshot({ path: path.join(artifacts, 'energy-frame-1.png') });
    if (k === frames) await page.screenshot({ path: path.join(artifacts, 'energy-frame-last.png') });
  }
  for (const name of ['line', 'x', 'optimized']) {
    await showCompare(name);
    const b = await bar(), p = await projection(page);
    const err = colourError(p.colours, name === 'optimized' ? energies.frames[frames - 1] : energies[name], top);
    check(b.top === want && b.scale === top && err < 1e-5, `${name}: the colour bar's top is the job's ("${b.top}", ${b.note}; colours within ${err.toExponential(1)})`);
    if (name !== 'optimized') await page.screenshot({ path: path.join(artifacts, `energy-${name}.png`) });
  }
  // A typed top replaces the job's, on the bar and in the colours.
  await page.fill('#energy-top', '5');
  await page.dispatchEvent('#energy-top', 'change');
  await until('the typed scale', () => page.evaluate(() => window.kgd.state.energyScale?.source === 'fixed' && !window.kgd.state.loading && !window.kgd.state.pending), 10000);
  {
    const b = await bar(), p = await projection(page);
    const err = colourError(p.colours, energies.frames[frames - 1], 5);
    check(b.top === '≥ 5.00' && b.note === 'fixed' && err < 1e-5, `a typed top of 5 J/m² fixes the scale ("${b.top}", ${b.note}; colours within ${err.toExponential(1)})`);
  }
  await page.fill('#energy-top', '');
  await page.dispatchEvent('#energy-top', 'change');
  await until('the job scale again', () => page.evaluate(() => window.kgd.state.energyScale?.source === 'job' && !window.kgd.state.loading && !window.kgd.state.pending), 10000);

  // The garment framed at every frame of the motion, from the default view (front and the garment's side).
  const framing = [];
  let allInside = true, allFill = true;
  for (let k = 1; k <= frames; ++k) {
    await showFrame(k);
    const p = await projection(page);
    framing.push(`${k}: ${box(p)}`);
    allInside &&= inside(p);
    allFill &&= fills(p);
    if (k === 1) await page.screenshot({ path: path.join(artifacts, 'frame-1.png') });
  }
  check(allInside, `the garment's projected bounds are inside the canvas at every frame (${framing.join('; ')})`);
  check(allFill, 'the garment fills over 60 % of the canvas\'s width or height at every frame');

  // Front, back and side views: the camera looks from +z, -z and the garment's side; the image changes.
  const hash = () => page.evaluate(() => {
    const s = document.getElementById('view').toDataURL('image/png');
    let h = 0;
    for (let i = 0; i < s.length; ++i) h = (h * 31 + s.charCodeAt(i)) | 0;
    return h;
  });
  const views = {};
  for (const [name, want3] of [['front', (p) => [0, 0, 1]], ['back', () => [0, 0, -1]], ['side', (p) => [Math.sign(p.garmentX), 0, 0]]]) {
    await page.click(`#camera-controls button[data-view="${name}"]`);
    const p = await projection(page);
    const w = want3(p);
    const off = Math.max(...p.dir.map((c, a) => Math.abs(c - w[a])));
    views[name] = await hash();
    check(off < 1e-6 && inside(p), `${name} view: the camera looks from ${w.join(', ')} (direction ${p.dir.map((c) => c.toFixed(3)).join(', ')}), the garment inside (${box(p)})`);
    await page.screenshot({ path: path.join(artifacts, `view-${name}.png`) });
  }
  check(new Set(Object.values(views)).size === 3, 'front, back and side draw three different images');

  // Reset view, in the deformed pose: from the front half and the garment's side, seeing the garment as
  // broad as the broadest of the front, the front and side between and the side, each a little from
  // above (not down a sleeve's cut end, as the front sees a forearm bent forward).
  await page.click('#camera-controls button[data-view="reset"]');
  {
    const p = await projection(page);
    check(p.dir[2] > 0.1 && Math.sign(p.dir[0]) === Math.sign(p.garmentX) && p.areas.shown >= 0.999 * Math.max(p.areas.front, p.areas.between, p.areas.side) && inside(p),
      `the default view looks from the body's front half and the garment's side (direction ${p.dir.map((c) => c.toFixed(2)).join(', ')}; garment at x ${p.garmentX.toFixed(3)} m), seeing the garment broadest (${(1e4 * p.areas.shown).toFixed(0)} cm²; from the front ${(1e4 * p.areas.front).toFixed(0)}, between ${(1e4 * p.areas.between).toFixed(0)}, the side ${(1e4 * p.areas.side).toFixed(0)})`);
    await page.screenshot({ path: path.join(artifacts, 'view-reset.png') });
  }

  // The view as a PNG download, named after what it shows.
  const [image] = await Promise.all([page.waitForEvent('download'), page.click('#download-image')]);
  const imagePath = path.join(artifacts, image.suggestedFilename());
  await image.saveAs(imagePath);
  const png = fs.readFileSync(imagePath);
  const size = await page.evaluate(() => [document.getElementById('view').width, document.getElementById('view').height]);
  check(png.subarray(1, 4).toString() === 'PNG' && png.readUInt32BE(16) === size[0] && png.readUInt32BE(20) === size[1] && image.suggestedFilename() === `job-${id}-frame-${frames}-of-${frames}-energy.png`,
    `"Download image" gives a ${png.readUInt32BE(16)} x ${png.readUInt32BE(20)} PNG of the ${size.join(' x ')} canvas (${image.suggestedFilename()}, ${png.length} bytes)`);

  // A baseline shown: the slider, the scrubber and the download name it; its PLY is its design.
  await showCompare('line');
  const controls = await page.evaluate(() => ({ frameDisabled: document.getElementById('frame').disabled, frame: document.getElementById('frame-value').textContent,
    scrub: document.getElementById('scrub-value').textContent, links: [...document.querySelectorAll('#downloads a')].filter((a) => !a.closest('[hidden]')).map((a) => a.textContent) }));
  check(controls.frameDisabled && /^Line baseline: one frame/.test(controls.frame) && /^Line baseline/.test(controls.scrub) && controls.links.some((t) => /^Download the Line baseline/.test(t))
    && !controls.links.some((t) => /iteration/.test(t) && !/design file/.test(t)),
  `with Line shown the controls name it: frame "${controls.frame}" (slider ${controls.frameDisabled ? 'disabled' : 'enabled'}), scrubber "${controls.scrub}", downloads: ${controls.links.join(' | ')}`);
  const [ply] = await Promise.all([page.waitForEvent('download'), page.click('#downloads a[href$="baselines/line/design.ply"]')]);
  const plyPath = path.join(artifacts, ply.suggestedFilename());
  await ply.saveAs(plyPath);
  const bytes = fs.readFileSync(plyPath);
  const header = bytes.subarray(0, bytes.indexOf('end_header\n') + 11).toString();
  const nv = Number(/element vertex (\d+)/.exec(header)?.[1]), nf = Number(/element face (\d+)/.exec(header)?.[1]);
  const lineDesign = await apiBytes(base, `v1/jobs/${id}/evaluation/baselines/line/design.u8`);
  const linePositions = await apiFloats(base, `v1/jobs/${id}/evaluation/baselines/line/positions.f32`);
  const optimized = await apiBytes(base, `v1/jobs/${id}/iterations/${evaluation.iteration}/design.u8`);
  let designOff = 0, posOff = 0, differs = 0;
  if (bytes.length === header.length + 24 * nv + 22 * nf && nf === lineDesign.length) {
    for (let v = 0; v < 3 * nv; ++v) posOff = Math.max(posOff, Math.abs(Math.fround(bytes.readDoubleLE(header.length + 8 * v)) - linePositions[v]));
    for (let f = 0; f < nf; ++f) {
      const d = bytes[header.length + 24 * nv + 22 * f + 13];
      if (d !== lineDesign[f]) designOff++;
      if (d !== optimized[f]) differs++;
    }
  } else designOff = -1;
  check(ply.suggestedFilename() === `job-${id}-baseline-line.ply` && designOff === 0 && posOff === 0 && differs > 0,
    `the Line baseline downloads as PLY with its own design and positions (${ply.suggestedFilename()}, ${bytes.length} bytes; ${designOff} faces off its design, positions within ${posOff} m, ${differs} faces unlike the optimized design)`);
  await showCompare('optimized');

  // At 420 px (one column), choosing a job brings the viewer into sight.
  const { context: narrow, page: phone } = await openPage(browser, base, { width: 420, height: 800 });
  await until('the job in the narrow list', () => phone.locator(`tr[data-id="${id}"]`).count(), 10000);
  // Where the viewer's top and the 3D view's bottom are in the window.
  const where = () => phone.evaluate(() => ({ top: document.getElementById('viewer').getBoundingClientRect().top,
    bottom: document.getElementById('view').getBoundingClientRect().bottom, height: window.innerHeight }));
  const before = await where();
  await phone.click(`tr[data-id="${id}"]`);
  await until('the job selected', () => phone.evaluate((i) => window.kgd.state.selected === i, id), 10000);
  const after = await where();
  check(before.bottom > before.height && after.top >= -1 && after.top < 0.25 * after.height && after.bottom <= after.height,
    `at 420 px choosing a job brings the viewer into sight: its top at ${Math.round(before.top)} px, the 3D view's bottom at ${Math.round(before.bottom)} px before; ${Math.round(after.top)} and ${Math.round(after.bottom)} px after (window ${after.height} px)`);
  await until('the narrow view drawn', () => phone.evaluate(() => window.kgd.rendered > 0 && !window.kgd.state.loading), 20000).catch(() => {});
  await phone.screenshot({ path: path.join(artifacts, 'narrow-420.png') });
  await narrow.close();
});
