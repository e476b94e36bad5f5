// The web page in headless Chromium (Debian's chromium, driven by playwright-core from
// client/web/node_modules) against a real `kgd serve`: refuse an invalid form without asking the
// server, submit a job and follow it live (the chart grows, the 3D view draws each new iteration's
// positions and design), scrub to the first and the server's last iteration and compare what is drawn
// with the API's positions and design, download a PLY, cancel a second job (the server's state becomes
// CANCELLED), weigh a scene's two motions in the form and see each motion's lines in the charts, lay out
// at desktop and tablet widths, and follow a job through the event stream on a server with tokens. Screenshots go to --artifacts.
// Exit 77 (ctest: skipped) with a message where Chromium or playwright-core is absent.
//   node tests/web/page_test.mjs --kgd build/client/kgd --artifacts build/test-artifacts/web
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
const repo = path.resolve(here, '../..');
const arg = (name, fallback) => { const i = process.argv.indexOf(name); return i > 0 ? process.argv[i + 1] : fallback; };
const kgd = arg('--kgd', path.join(repo, 'build/client/kgd'));
const artifacts = arg('--artifacts', path.join(repo, 'build/test-artifacts/web'));
const chromiumPath = process.env.KGD_CHROMIUM || '/usr/bin/chromium';
const playwrightPath = path.join(repo, 'client/web/node_modules/playwright-core/index.mjs');

function skip(why) { console.log(`SKIPPED: ${why}`); process.exit(77); }
if (!fs.existsSync(chromiumPath)) skip(`no Chromium at ${chromiumPath} (apt-get install chromium; or set KGD_CHROMIUM)`);
if (!fs.existsSync(playwrightPath)) skip('playwright-core is not installed (npm ci --prefix client/web)');
const { chromium } = await import(playwrightPath);

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures++;
}
async function until(what, fn, timeoutMs = 60000) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await new Promise((r) => setTimeout(r, 100));
  }
}
// The HTTP API, beside the page (base: the server's address with a trailing slash).
async function apiGet(base, p, headers = {}) {
  const r = await fetch(base + p, { headers });
  if (!r.ok) throw new Error(`GET ${p}: HTTP ${r.status}`);
  return r;
}
const apiJson = async (base, p, headers) => (await apiGet(base, p, headers)).json();
const apiBytes = async (base, p, headers) => new Uint8Array(await (await apiGet(base, p, headers)).arrayBuffer());
const apiFloats = async (base, p, headers) => { const b = await apiBytes(base, p, headers); return new Float32Array(b.buffer, b.byteOffset, b.byteLength / 4); };

// The garment the 3D view draws (its vertex buffers: one vertex per face corner) and the iteration the
// page says it shows, read in one step so that no live update comes between them.
const drawn = (page) => page.evaluate(() => {
  const v = window.kgd.view, g = v.garment?.geometry;
  if (!g) return null;
  return { shown: window.kgd.state.shown, faces: Array.from(v.faces), pos: Array.from(g.attributes.position.array), col: Array.from(g.attributes.color.array) };
});

// Compares the drawn garment with the API's positions and design of the iteration the page shows: every
// corner at its vertex's position, every face one colour, the reinforced faces (design 1) in one dark
// colour and the others in one light colour ("Design (reinforced dark)"). Returns a list of problems.
async function compareDrawn(base, jobId, d) {
  const problems = [];
  const x = await apiFloats(base, `v1/jobs/${jobId}/iterations/${d.shown}/positions.f32`);
  const design = await apiBytes(base, `v1/jobs/${jobId}/iterations/${d.shown}/design.u8`);
  const nf = d.faces.length / 3;
  if (design.length !== nf) return [`${design.length} design values for ${nf} faces`];
  let posErr = 0, split = 0;
  const colours = [new Set(), new Set()];
  const wrong = [0, 0];
  for (let t = 0; t < nf; ++t) {
    for (let k = 0; k < 3; ++k) {
      const v = d.faces[3 * t + k], o = 9 * t + 3 * k;
      for (let a = 0; a < 3; ++a) posErr = Math.max(posErr, Math.abs(d.pos[o + a] - x[3 * v + a]));
      if (d.col[o] !== d.col[9 * t] || d.col[o + 1] !== d.col[9 * t + 1] || d.col[o + 2] !== d.col[9 * t + 2]) split++;
    }
    const r = design[t] ? 1 : 0, c = [d.col[9 * t], d.col[9 * t + 1], d.col[9 * t + 2]];
    colours[r].add(c.map((q) => q.toFixed(3)).join(','));
    const light = c[0] + c[1] + c[2] > 1.5;
    if (light !== (r === 0)) wrong[r]++;
  }
  if (posErr > 0) problems.push(`corners up to ${posErr} m from the API's positions`);
  if (split) problems.push(`${split} face corners coloured unlike their face`);
  if (wrong[1]) problems.push(`${wrong[1]} reinforced faces drawn light`);
  if (wrong[0]) problems.push(`${wrong[0]} unreinforced faces drawn dark`);
  for (const r of [0, 1]) if (colours[r].size > 1) problems.push(`${colours[r].size} colours for ${r ? '' : 'un'}reinforced faces`);
  return problems;
}

// The share of the canvas's pixels in the reinforced colour's hue (dark blue: blue well above red).
const bluePixels = (page) => page.evaluate(() => {
  const src = document.getElementById('view'), c = document.createElement('canvas');
  c.width = src.width; c.height = src.height;
  const ctx = c.getContext('2d');
  ctx.drawImage(src, 0, 0);
  const p = ctx.getImageData(0, 0, c.width, c.height).data;
  let n = 0;
  for (let i = 0; i < p.length; i += 4) if (p[i + 2] - p[i] > 25) n++;
  return n / (c.width * c.height);
});

// Starts `kgd serve`; a failure to start (e.g. the binary being relinked) is a failed check, not a crash
// that would leave the other server running.
function startServe(args, env = {}) {
  const child = spawn(kgd, ['serve', ...args, '--quiet'], { stdio: ['ignore', 'pipe', 'inherit'], env: { ...process.env, ...env } });
  child.out = '';
  child.stdout.on('data', (d) => { child.out += d; });
  child.on('error', (e) => { child.out += `(${e.message})`; });
  return child;
}
async function stopServe(child) {
  if (child.exitCode !== null || child.signalCode !== null || child.pid === undefined) return;
  const exited = new Promise((r) => child.on('exit', r));
  child.kill('SIGTERM');
  await exited;
}

function freePort() {
  return new Promise((resolve) => { const s = net.createServer(); s.listen(0, '127.0.0.1', () => { const p = s.address().port; s.close(() => resolve(p)); }); });
}

fs.mkdirSync(artifacts, { recursive: true });
const data = fs.mkdtempSync(path.join(os.tmpdir(), 'kgd_web_test_'));
const [grpcPort, httpPort] = [await freePort(), await freePort()];
// Each iteration reported at least 0.15 s after it is computed, on any machine: the live job (60
// iterations, >= 9 s) outlasts the page's first render and the few iterations it follows after it.
const serve = startServe(['--data', data, '--listen', `127.0.0.1:${grpcPort}`, '--http', `127.0.0.1:${httpPort}`],
  { KGD_FAULT_POINT: 'worker.before_report@sleep=0.15' });
const base = `http://127.0.0.1:${httpPort}/`;
let browser;
try {
  await until('kgd serve to start', () => serve.out.includes('web page and HTTP API'), 30000);
  browser = await chromium.launch({
    executablePath: chromiumPath,
    args: ['--headless=new', '--no-sandbox', '--disable-gpu', '--enable-unsafe-swiftshader', '--use-angle=swiftshader', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const context = await browser.newContext({ viewport: { width: 1280, height: 800 }, acceptDownloads: true });
  const page = await context.newPage();
  const pageErrors = [];
  page.on('pageerror', (e) => pageErrors.push(e.message));
  const jobPosts = [];
  page.on('request', (r) => { if (r.method() === 'POST' && new URL(r.url()).pathname === '/v1/jobs') jobPosts.push(r.url()); });
  await page.goto(base);
  await until('the scene list', () => page.evaluate(() => document.querySelectorAll('#scene option').length > 0));

  // The page refuses an invalid form itself: the message shows next to its field, and no job is posted
  // (the server would refuse a budget of 1.5 too, with a message of the same words).
  await page.fill('#budget', '1.5');
  await page.click('#submit-button');
  const budgetError = await until('the budget error', () => page.textContent('.error[data-for="budget"]'), 10000).catch(() => '');
  const besideBudget = await page.evaluate(() => document.getElementById('budget').nextElementSibling?.matches('.error[data-for="budget"]'));
  check(/budget/.test(budgetError) && /1\.5/.test(budgetError) && besideBudget, `a budget of 1.5 is refused right after its field ("${budgetError}")`);
  check(jobPosts.length === 0, `the page posted no job for the invalid form (${jobPosts.length} POST /v1/jobs)`);
  check(!(await apiJson(base, 'v1/jobs')).jobs?.length, 'the server has no job');

  // Submit a short arm-flexion job and follow it live.
  await page.selectOption('#scene', 'arm_flexion');
  await page.fill('#budget', '0.15');
  await page.fill('#max-iterations', '60');
  await page.fill('#label', 'browser test');
  await page.click('#submit-button');
  // With a cold scene cache the worker first measures the machine and builds the scene (minutes on a busy machine).
  await until('the first rendered iteration', () => page.evaluate(() => window.kgd.rendered >= 1), 300000);
  const canvasHash = () => page.evaluate(() => {
    const s = document.getElementById('view').toDataURL('image/png');
    let h = 0;
    for (let i = 0; i < s.length; ++i) h = (h * 31 + s.charCodeAt(i)) | 0;
    return h;
  });
  const jobId = await page.evaluate(() => window.kgd.state.selected);
  const firstShown = await page.evaluate(() => window.kgd.state.shown);
  const firstPoints = await page.evaluate(() => window.kgd.charts.ratio.data[0].length);
  await page.screenshot({ path: path.join(artifacts, 'live-early.png') });
  // The first render may come after several iterations have arrived, so the
  // view can catch up without new data: wait for the chart itself to grow.
  await until('a later iteration on screen and in the chart', () => page.evaluate(([n, p]) =>
    window.kgd.state.shown > n + 2 && window.kgd.charts.ratio.data[0].length > p, [firstShown, firstPoints]), 120000)
    .catch(() => {});
  const laterPoints = await page.evaluate(() => window.kgd.charts.ratio.data[0].length);
  const live = await drawn(page);
  check(laterPoints > firstPoints, `the density-ratio chart grows (${firstPoints} -> ${laterPoints} points)`);
  const liveProblems = await compareDrawn(base, jobId, live);
  check(live.shown > firstShown && liveProblems.length === 0,
    `the 3D view follows the run: it draws iteration ${live.shown} (first ${firstShown}) with the API's positions and design${liveProblems.length ? ': ' + liveProblems.join('; ') : ''}`);

  // The job ends; the page has every iteration the server stored; scrub to the first and the last.
  await until('the job to end', async () => (await apiJson(base, `v1/jobs/${jobId}`)).state === 'SUCCEEDED', 180000);
  const stored = await apiJson(base, `v1/jobs/${jobId}`);
  const last = stored.iterations - 1;
  const received = await until('every stored iteration in the page', () => page.evaluate((n) => {
    const s = window.kgd.state;
    return s.job?.state === 'SUCCEEDED' && s.metrics.length === n && s.metrics.filter(Boolean).length === n ? n : 0;
  }, stored.iterations), 20000).catch(() => page.evaluate(() => `${window.kgd.state.metrics.filter(Boolean).length} of ${window.kgd.state.metrics.length}`));
  const pageCounts = await page.evaluate(() => ({ scrubMax: Number(document.getElementById('scrub').max), points: window.kgd.charts.ratio.data[0].length }));
  check(received === stored.iterations && pageCounts.scrubMax === last && pageCounts.points === stored.iterations,
    `the page has the server's ${stored.iterations} iterations (received ${received}, scrubber up to ${pageCounts.scrubMax}, ${pageCounts.points} chart points)`);
  // The server ends an ended job's stream after its last iteration; the page then stops watching
  // (EventSource would otherwise reconnect every two seconds).
  const watchClosed = await until('the page to stop watching the ended job', () => page.evaluate(() => window.kgd.state.watch?.readyState === EventSource.CLOSED), 10000)
    .then(() => true, () => false);
  check(watchClosed, `the page closes the ended job's event stream (readyState ${await page.evaluate(() => window.kgd.state.watch?.readyState)})`);
  const scrubTo = async (n) => {
    await page.evaluate((v) => { const s = document.getElementById('scrub'); s.value = v; s.dispatchEvent(new Event('input')); }, n);
    await until(`iteration ${n} on screen`, () => page.evaluate((v) => window.kgd.state.target?.kind === 'iteration' && window.kgd.state.shown === v && !window.kgd.state.loading && !window.kgd.state.pending, n));
  };
  await scrubTo(0);
  const drawn0 = await drawn(page);
  const blue0 = await bluePixels(page);
  const text0 = await page.textContent('#metrics');
  await page.screenshot({ path: path.join(artifacts, 'iteration-first.png') });
  await scrubTo(last);
  const drawnLast = await drawn(page);
  const blueLast = await bluePixels(page);
  const textLast = await page.textContent('#metrics');
  await page.screenshot({ path: path.join(artifacts, 'iteration-last.png') });
  check(/reinforced area 100\.0 %/.test(text0), `iteration 0 is fully reinforced ("${text0}")`);
  check(textLast.startsWith(`iteration ${last}:`) && textLast.includes(`density ratio ${stored.last.densityRatio.toFixed(3)}`),
    `the scrubber reaches the server's last iteration, ${last}, with its density ratio ${stored.last.densityRatio.toFixed(3)} ("${textLast}")`);
  for (const [n, d] of [[0, drawn0], [last, drawnLast]]) {
    const problems = d.shown === n ? await compareDrawn(base, jobId, d) : [`iteration ${d.shown} is drawn`];
    check(problems.length === 0, `iteration ${n} is drawn with the API's positions and design${problems.length ? ': ' + problems.join('; ') : ''}`);
  }
  // The colours reach the screen: the reinforced colour covers much less of the canvas at the end.
  check(blue0 > 0.02 && blueLast < 0.6 * blue0, `the canvas shows the designs: ${(100 * blue0).toFixed(1)} % of it in the reinforced colour at iteration 0, ${(100 * blueLast).toFixed(1)} % at ${last}`);
  // The final design over the motion and beside the Line and X (the evaluation after the last iteration).
  await until('the explorer', () => page.evaluate(() => !document.getElementById('explorer').hidden), 120000);
  const frames = Number(await page.getAttribute('#frame', 'max'));
  check(frames === 8, `the frame slider spans the motion's ${frames} frames`);
  const showFrame = async (k) => {
    await page.evaluate((v) => { const s = document.getElementById('frame'); s.value = v; s.dispatchEvent(new Event('input')); }, k);
    await until(`frame ${k} on screen`, () => page.evaluate((v) => window.kgd.state.target?.kind === 'frame' && window.kgd.state.target.k === v && !window.kgd.state.loading && !window.kgd.state.pending, k));
  };
  await showFrame(frames);
  const hashDeformed = await canvasHash();
  await showFrame(1);
  const hashFrame1 = await canvasHash();
  const textFrame1 = await page.textContent('#metrics');
  await page.screenshot({ path: path.join(artifacts, 'frame-1.png') });
  check(/motion frame 1 of 8/.test(textFrame1), `frame 1 is described ("${textFrame1}")`);
  check(hashFrame1 !== hashDeformed, 'the first frame of the motion looks different from the deformed pose');
  for (const name of ['line', 'x']) {
    await page.check(`input[name=compare][value=${name}]`);
    await until(`the ${name} baseline on screen`, () => page.evaluate((n) => window.kgd.state.target?.kind === 'baseline' && window.kgd.state.target.name === n && !window.kgd.state.loading && !window.kgd.state.pending, name));
    const text = await page.textContent('#metrics');
    check(new RegExp(`^${name === 'x' ? 'X' : 'Line'} baseline of the same area: .*density ratio \\d`).test(text), `the ${name} baseline is shown with its density ratio ("${text}")`);
    await page.screenshot({ path: path.join(artifacts, `baseline-${name}.png`) });
  }
  const figures = await page.textContent('#baseline-figures');
  check(/optimized [\d.]+, Line [\d.]+, X [\d.]+/.test(figures), `the density ratios side by side ("${figures}")`);
  await page.check('input[name=compare][value=optimized]');
  await scrubTo(last);
  await page.selectOption('#color-mode', 'energy');
  await until('the energy colouring', () => page.evaluate(() => !document.getElementById('colorbar').hidden && !window.kgd.state.loading));
  await page.screenshot({ path: path.join(artifacts, 'energy.png') });
  // Skin pressure: the final design's pressure in the chosen frame coloured on the body, with its peak and p95.
  await page.selectOption('#color-mode', 'pressure');
  await until('the skin pressure', () => page.evaluate(() => window.kgd.state.pressureFigures?.peak > 0 && !window.kgd.state.loading && !window.kgd.state.pending));
  const pressureText = await page.textContent('#metrics');
  check(/skin pressure peak [\d.]+ kPa \([\d.]+ mmHg\), p95 [\d.]+ kPa/.test(pressureText), `the skin pressure is described ("${pressureText}")`);
  check((await page.textContent('#colorbar-unit')) === 'kPa', 'the colour bar of the skin pressure is in kPa');
  await page.screenshot({ path: path.join(artifacts, 'pressure.png') });
  await page.selectOption('#color-mode', 'energy');
  await until('the energy colouring again', () => page.evaluate(() => window.kgd.state.target?.kind === 'iteration' && !window.kgd.state.loading && !window.kgd.state.pending));

  // Download the shown iteration as PLY.
  const [download] = await Promise.all([page.waitForEvent('download'), page.click('#downloads a[href$="design.ply"]')]);
  const plyPath = path.join(artifacts, download.suggestedFilename());
  await download.saveAs(plyPath);
  const ply = fs.readFileSync(plyPath);
  check(ply.subarray(0, 4).toString() === 'ply\n' && ply.includes('element face'), `the PLY download is a PLY file (${download.suggestedFilename()}, ${ply.length} bytes)`);

  // The cut files of the shown iteration.
  const [cutDownload] = await Promise.all([page.waitForEvent('download', { timeout: 60000 }), page.click('#downloads a[href$="cut/patches.svg"]')]);
  const cutPath = path.join(artifacts, cutDownload.suggestedFilename());
  await cutDownload.saveAs(cutPath);
  const cutSvg = fs.readFileSync(cutPath, 'utf8');
  check(/<svg[^>]*width="305mm"/.test(cutSvg) && cutSvg.includes('data-layer="1"'), `the patches' cut file is an SVG in mm (${cutDownload.suggestedFilename()})`);

  // A second, long job: cancel it from the jobs list.
  await page.fill('#max-iterations', '400');
  await page.fill('#budget', '0.05');
  await page.check('#resist-only');
  await page.click('#submit-button');
  const secondId = await until('the second job', () => page.evaluate((first) => { const s = window.kgd.state.selected; return s !== first ? s : null; }, jobId));
  const secondSpec = (await apiJson(base, `v1/jobs/${secondId}`)).spec?.optimizer ?? {};
  check(secondSpec.resistOnly === true && (await apiJson(base, `v1/jobs/${jobId}`)).spec?.optimizer?.resistOnly !== true,
    `the resisted-motions-only box reaches the job spec (second job: resistOnly ${secondSpec.resistOnly}; the first job unticked)`);
  await until('its cancel button', () => page.locator(`tr[data-id="${secondId}"] button`).count());
  check((await apiJson(base, `v1/jobs/${secondId}`)).state !== 'CANCELLED', `job ${secondId} is not cancelled before the click`);
  await page.click(`tr[data-id="${secondId}"] button`);
  const cancelled = await until('the server to cancel the second job', async () => (await apiJson(base, `v1/jobs/${secondId}`)).state === 'CANCELLED', 60000)
    .then(() => true, () => false);
  check(cancelled, `the Cancel button cancels job ${secondId} on the server (state ${(await apiJson(base, `v1/jobs/${secondId}`)).state})`);
  const listed = await until('the jobs list to show it cancelled', () => page.evaluate((id) => window.kgd.state.jobs.get(id)?.state === 'CANCELLED'
    && document.querySelector(`tr[data-id="${id}"] .state-CANCELLED`) !== null, secondId), 10000).then(() => true, () => false);
  check(listed, `the jobs list shows job ${secondId} CANCELLED`);
  // A symmetric design of the right arm's sleeve: the worker refuses it, naming the mirror plane.
  await page.uncheck('#resist-only');
  await page.check('#symmetric');
  await page.fill('#max-iterations', '5');
  await page.fill('#max-pressure', '3');
  await page.click('#submit-button');
  const thirdId = await until('the third job', () => page.evaluate((ids) => { const s = window.kgd.state.selected; return ids.includes(s) ? null : s; }, [jobId, secondId]));
  await page.uncheck('#symmetric');
  await page.fill('#max-pressure', '');
  const third = await until('the symmetric job to fail', async () => { const j = await apiJson(base, `v1/jobs/${thirdId}`); return ['FAILED', 'SUCCEEDED'].includes(j.state) ? j : null; }, 120000).catch(() => ({}));
  check(third.spec?.optimizer?.symmetric === true && third.state === 'FAILED' && /not symmetric/.test(third.failure ?? ''),
    `the symmetric box reaches the job spec, and a one-armed sleeve is refused as not symmetric (state ${third.state}: ${third.failure ?? ''})`);
  check(third.spec?.optimizer?.maxPressurePa === 3000, `the pressure limit (kPa) reaches the job spec in Pa (maxPressurePa ${third.spec?.optimizer?.maxPressurePa})`);
  const shownFailure = await until('the failure on the page', () => page.evaluate(() => document.getElementById('metrics').textContent), 10000).catch(() => '');
  check(/^failed: .*not symmetric/.test(shownFailure), `the page shows the failed job's reason ("${shownFailure.slice(0, 80)}")`);

  // A scene of two motions (knee_brace): the form lists them with their roles and weights; a negative
  // weight is refused on the page (nothing posted) and by the server, each naming the motion; a weight
  // typed reaches the job; its charts draw one line per motion, and once it has ended its summary lists
  // the final motions.
  await page.selectOption('#scene', 'knee_brace');
  const formMotions = await page.evaluate(() => [...document.querySelectorAll('#motion-list label')].map((l) => l.textContent));
  check(await page.isVisible('#motions-fields') && formMotions.join(', ') === 'hyperextend (resisted), flex (allowed)'
    && (await page.inputValue('#motion-weight-flex')) === '1', `the form lists knee_brace's motions with their roles and weights (${formMotions.join(', ')})`);
  await page.fill('#budget', '');
  await page.fill('#max-iterations', '2');
  await page.fill('#motion-weight-flex', '-1');
  const postsBefore = jobPosts.length;
  await page.click('#submit-button');
  const weightError = await until('the weight error', () => page.textContent('.error[data-for="motions"]'), 10000).catch(() => '');
  check(/motion 'flex'.*>= 0/.test(weightError) && jobPosts.length === postsBefore && await page.evaluate(() => document.getElementById('motion-weight-flex').classList.contains('invalid')),
    `a negative weight is refused on the page, next to the motions ("${weightError}"; ${jobPosts.length - postsBefore} job posted)`);
  const refused = await fetch(`${base}v1/jobs`, { method: 'POST', headers: { 'Content-Type': 'application/json' },
    body: JSON.stringify({ builtinScene: 'knee_brace', optimizer: { motionWeights: { flex: -1 } } }) });
  const refusedText = await refused.text();
  check(refused.status === 400 && /motion 'flex'.*>= 0/.test(refusedText), `the server refuses it too (HTTP ${refused.status}: ${refusedText.trim().slice(0, 140)})`);
  await page.fill('#motion-weight-flex', '0.5');
  await page.click('#submit-button');
  const fourthId = await until('the knee_brace job', () => page.evaluate((ids) => { const s = window.kgd.state.selected; return ids.includes(s) ? null : s; }, [jobId, secondId, thirdId]));
  const weights = (await apiJson(base, `v1/jobs/${fourthId}`)).spec?.optimizer?.motionWeights;
  check(JSON.stringify(weights) === '{"flex":0.5}', `the weight typed reaches the job spec, the unchanged one left to the scene (${JSON.stringify(weights)})`);
  const lines = await until('two motion lines in the charts', () => page.evaluate(() => {
    const r = window.kgd.charts.motionRatio, e = window.kgd.charts.motionEnergy;
    if (!r || !e || r.data[0].length < 2 || document.getElementById('figure-motion-ratio').hidden) return null;
    return { series: r.series.slice(1).map((x) => ({ label: x.label, dashed: !!x.dash })), ratio: r.data.slice(1), energy: e.data.slice(1) };
  }), 240000).catch(() => null);
  const stored1 = lines && (await apiJson(base, `v1/jobs/${fourthId}/iterations/1`)).record.metrics.motions;
  check(lines?.series.length === 2 && lines.energy.length === 2 && /^hyperextend \(resisted, weight 1\)/.test(lines.series[0].label) && !lines.series[0].dashed
    && /^flex \(allowed, weight 0\.5\)/.test(lines.series[1].label) && lines.series[1].dashed
    && [0, 1].every((k) => lines.ratio[k][1] === stored1[k].densityRatio && lines.energy[k][1] === stored1[k].reinforcedEnergyJ),
    `the charts draw each motion's density ratio and reinforced energy, the allowed one dashed, as the API has them (${lines ? lines.series.map((x) => `${x.label}${x.dashed ? ' dashed' : ''}`).join('; ') : 'no lines'})`);
  // Ended early (its design is not evaluated): the summary then shows the last stored iteration's motions.
  await fetch(`${base}v1/jobs/${fourthId}:cancel`, { method: 'POST' });
  await until('the knee_brace job to end', async () => ['SUCCEEDED', 'CANCELLED', 'FAILED'].includes((await apiJson(base, `v1/jobs/${fourthId}`)).state), 240000).catch(() => {});
  const summary = await until('the final motions', () => page.evaluate(() => {
    const t = document.getElementById('motions-summary');
    return !t.hidden && /^Final motions/.test(t.textContent) ? [...t.querySelectorAll('li')].map((li) => li.textContent) : null;
  }), 20000).catch(() => []);
  check(summary.length === 2 && /^hyperextend \(resisted, weight 1\): density ratio [\d.]+, reinforced energy/.test(summary[0]) && /^flex \(allowed, weight 0\.5\)/.test(summary[1]),
    `the finished job's summary lists its final motions (${summary.join('; ')})`);
  await page.screenshot({ path: path.join(artifacts, 'desktop-1280x800.png') });

  // Tablet width: one column, nothing wider than the screen.
  await page.setViewportSize({ width: 800, height: 1100 });
  await page.waitForTimeout(300);
  const overflow = await page.evaluate(() => document.documentElement.scrollWidth - window.innerWidth);
  check(overflow <= 0, `no horizontal scrolling at 800 px (overflow ${overflow} px)`);
  await page.screenshot({ path: path.join(artifacts, 'tablet-800.png'), fullPage: true });

  // Every control has a label for screen readers.
  const unlabelled = await page.evaluate(() => [...document.querySelectorAll('input, select, button, canvas')].filter((e) => {
    if (e.closest('[hidden]') || e.type === 'hidden') return false;
    const id = e.id && document.querySelector(`label[for="${e.id}"]`);
    return !(id || e.closest('label') || e.getAttribute('aria-label') || (e.tagName === 'BUTTON' && e.textContent.trim()));
  }).map((e) => e.outerHTML.slice(0, 80)));
  check(unlabelled.length === 0, `every control is labelled${unlabelled.length ? ': ' + unlabelled.join(', ') : ''}`);
  check(pageErrors.length === 0, `no script errors${pageErrors.length ? ': ' + pageErrors.join('; ') : ''}`);

  // A server with tokens: the page asks once, then lists and follows the user's jobs.
  const token = 'page-test-token-0123456789abcdef';
  fs.writeFileSync(path.join(data, 'tokens.txt'), `${token} carol user\n`);
  const [grpc2, http2] = [await freePort(), await freePort()];
  const secured = startServe(['--data', path.join(data, 'secured'), '--listen', `127.0.0.1:${grpc2}`, '--http', `127.0.0.1:${http2}`,
    '--auth-tokens', path.join(data, 'tokens.txt')]);
  try {
    await until('kgd serve with tokens to start', () => secured.out.includes('web page and HTTP API'), 30000);
    const plain = await fetch(`http://127.0.0.1:${http2}/v1/jobs`);
    check(plain.status === 401, `without a token the API answers 401 (${plain.status})`);
    const tokenContext = await browser.newContext({ viewport: { width: 1280, height: 800 } });
    const tokenPage = await tokenContext.newPage();
    let asked = 0;
    tokenPage.on('dialog', (d) => { asked++; d.accept(token); });
    const watches = [];
    tokenPage.on('response', (r) => { if (new URL(r.url()).pathname.endsWith(':watch')) watches.push(`${r.status()} ${r.headers()['content-type']}`); });
    await tokenPage.goto(`http://127.0.0.1:${http2}/`);
    await until('the scene list behind a token', () => tokenPage.evaluate(() => document.querySelectorAll('#scene option').length > 0));
    check(asked === 1, `the page asked for the token once (${asked})`);
    await tokenPage.selectOption('#scene', 'sleeve_on_limb');
    await tokenPage.click('#submit-button');
    // The iterations' metrics come to the page only through the event stream (the jobs list's poll
    // carries a count and the last metrics): wait for the first two, and compare them with the API's.
    const streamed = await until('two iterations through the event stream behind a token', () => tokenPage.evaluate(() => {
      const s = window.kgd.state;
      return s.metrics[0] && s.metrics[1] ? { id: s.selected, metrics: [s.metrics[0], s.metrics[1]] } : null;
    }), 120000).catch(() => null);
    const auth = { Authorization: `Bearer ${token}` };
    const base2 = `http://127.0.0.1:${http2}/`;
    const close = (a, b) => typeof a === 'number' && typeof b === 'number' && Math.abs(a - b) <= 1e-12 * Math.max(1, Math.abs(a));
    const same = streamed && (await Promise.all([0, 1].map(async (n) => {
      const m = (await apiJson(base2, `v1/jobs/${streamed.id}/iterations/${n}`, auth)).record.metrics, s = streamed.metrics[n];
      return (m.iteration ?? 0) === (s.iteration ?? 0) && ['areaFraction', 'energyJ', 'densityRatio'].every((k) => close(m[k], s[k]));
    }))).every(Boolean);
    check(streamed && same && watches.some((w) => w.startsWith('200 text/event-stream')),
      `a job submitted and followed live with a token through the event stream (header for the API, cookie for the stream; watch responses: ${watches.join(', ') || 'none'}; iterations 0 and 1 ${streamed ? (same ? 'as the API has them' : 'unlike the API') : 'never streamed'})`);
    await tokenContext.close();
  } finally {
    await stopServe(secured);
  }
} catch (e) {
  console.log(`FAIL ${e.message}`);
  failures++;
  for (const p of browser?.contexts().flatMap((c) => c.pages()) || []) await p.screenshot({ path: path.join(artifacts, 'failure.png') }).catch(() => {});
} finally {
  if (browser) await browser.close();
  await stopServe(serve);
  fs.rmSync(data, { recursive: true, force: true });
}
console.log(failures ? `${failures} check(s) failed; screenshots in ${artifacts}` : `all checks passed; screenshots in ${artifacts}`);
process.exit(failures ? 1 : 0);
