// The web page in headless Chromium (Debian's chromium, driven by playwright-core from
// client/web/node_modules) against a real `kgd serve`: submit a job, see the chart grow and the WebGL
// canvas change, scrub to the first and the last iteration, download a PLY, show a validation error,
// cancel a second job, and lay out at desktop and tablet widths. Screenshots go to --artifacts.
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
function freePort() {
  return new Promise((resolve) => { const s = net.createServer(); s.listen(0, '127.0.0.1', () => { const p = s.address().port; s.close(() => resolve(p)); }); });
}

fs.mkdirSync(artifacts, { recursive: true });
const data = fs.mkdtempSync(path.join(os.tmpdir(), 'kgd_web_test_'));
const [grpcPort, httpPort] = [await freePort(), await freePort()];
const serve = spawn(kgd, ['serve', '--data', data, '--listen', `127.0.0.1:${grpcPort}`, '--http', `127.0.0.1:${httpPort}`, '--quiet'], { stdio: ['ignore', 'pipe', 'inherit'] });
let serveOut = '';
serve.stdout.on('data', (d) => { serveOut += d; });
const base = `http://127.0.0.1:${httpPort}/`;
let browser;
try {
  await until('kgd serve to start', () => serveOut.includes('web page and HTTP API'), 30000);
  browser = await chromium.launch({
    executablePath: chromiumPath,
    args: ['--headless=new', '--no-sandbox', '--disable-gpu', '--enable-unsafe-swiftshader', '--use-angle=swiftshader', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const context = await browser.newContext({ viewport: { width: 1280, height: 800 }, acceptDownloads: true });
  const page = await context.newPage();
  const pageErrors = [];
  page.on('pageerror', (e) => pageErrors.push(e.message));
  await page.goto(base);
  await until('the scene list', () => page.evaluate(() => document.querySelectorAll('#scene option').length > 0));

  // A validation error shows next to its field, and nothing is submitted.
  await page.fill('#budget', '1.5');
  await page.click('#submit-button');
  const budgetError = await page.textContent('.error[data-for="budget"]');
  check(/budget/.test(budgetError) && /1\.5/.test(budgetError), `a budget of 1.5 is refused next to its field ("${budgetError}")`);
  check(await page.evaluate(() => window.kgd.state.jobs.size === 0), 'no job was created by the invalid form');

  // Submit a short arm-flexion job and follow it live.
  await page.selectOption('#scene', 'arm_flexion');
  await page.fill('#budget', '0.15');
  await page.fill('#max-iterations', '60');
  await page.fill('#label', 'browser test');
  await page.click('#submit-button');
  await until('the first rendered iteration', () => page.evaluate(() => window.kgd.rendered >= 1), 120000);
  const canvasHash = () => page.evaluate(() => {
    const s = document.getElementById('view').toDataURL('image/png');
    let h = 0;
    for (let i = 0; i < s.length; ++i) h = (h * 31 + s.charCodeAt(i)) | 0;
    return h;
  });
  const firstHash = await canvasHash();
  const firstShown = await page.evaluate(() => window.kgd.state.shown);
  const firstPoints = await page.evaluate(() => window.kgd.charts.ratio.data[0].length);
  await page.screenshot({ path: path.join(artifacts, 'live-early.png') });
  // The first render may come after several iterations have arrived, so the
  // view can catch up without new data: wait for the chart itself to grow.
  await until('a later iteration on screen and in the chart', () => page.evaluate(([n, p]) =>
    window.kgd.state.shown > n + 2 && window.kgd.charts.ratio.data[0].length > p, [firstShown, firstPoints]), 120000)
    .catch(() => {});
  const laterHash = await canvasHash();
  const laterPoints = await page.evaluate(() => window.kgd.charts.ratio.data[0].length);
  check(laterPoints > firstPoints, `the density-ratio chart grows (${firstPoints} -> ${laterPoints} points)`);
  check(laterHash !== firstHash, 'the WebGL canvas changes between iterations');

  // The job ends; scrub to the first and the last iteration.
  const jobId = await page.evaluate(() => window.kgd.state.selected);
  await until('the job to end', () => page.evaluate(() => window.kgd.state.job && window.kgd.state.job.state === 'SUCCEEDED'), 180000);
  const last = await page.evaluate(() => window.kgd.state.metrics.length - 1);
  const scrubTo = async (n) => {
    await page.evaluate((v) => { const s = document.getElementById('scrub'); s.value = v; s.dispatchEvent(new Event('input')); }, n);
    await until(`iteration ${n} on screen`, () => page.evaluate((v) => window.kgd.state.target?.kind === 'iteration' && window.kgd.state.shown === v && !window.kgd.state.loading && !window.kgd.state.pending, n));
  };
  await scrubTo(0);
  const hash0 = await canvasHash();
  const text0 = await page.textContent('#metrics');
  await page.screenshot({ path: path.join(artifacts, 'iteration-first.png') });
  await scrubTo(last);
  const hashLast = await canvasHash();
  const textLast = await page.textContent('#metrics');
  await page.screenshot({ path: path.join(artifacts, 'iteration-last.png') });
  check(/reinforced area 100\.0 %/.test(text0), `iteration 0 is fully reinforced ("${text0}")`);
  check(textLast.startsWith(`iteration ${last}:`), `the scrubber reaches the last iteration, ${last} ("${textLast}")`);
  check(hash0 !== hashLast, 'the first and the last design look different');
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
  await page.click('#submit-button');
  const secondId = await until('the second job', () => page.evaluate((first) => { const s = window.kgd.state.selected; return s !== first ? s : null; }, jobId));
  await until('its cancel button', () => page.locator(`tr[data-id="${secondId}"] button`).count());
  await page.click(`tr[data-id="${secondId}"] button`);
  await until('the second job cancelled', () => page.evaluate((id) => window.kgd.state.jobs.get(id)?.state === 'CANCELLED', secondId), 60000);
  check(true, `job ${secondId} is cancelled from the page`);
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
  const secured = spawn(kgd, ['serve', '--data', path.join(data, 'secured'), '--listen', `127.0.0.1:${grpc2}`, '--http', `127.0.0.1:${http2}`,
    '--auth-tokens', path.join(data, 'tokens.txt'), '--quiet'], { stdio: ['ignore', 'pipe', 'inherit'] });
  let securedOut = '';
  secured.stdout.on('data', (d) => { securedOut += d; });
  try {
    await until('kgd serve with tokens to start', () => securedOut.includes('web page and HTTP API'), 30000);
    const plain = await fetch(`http://127.0.0.1:${http2}/v1/jobs`);
    check(plain.status === 401, `without a token the API answers 401 (${plain.status})`);
    const tokenContext = await browser.newContext({ viewport: { width: 1280, height: 800 } });
    const tokenPage = await tokenContext.newPage();
    let asked = 0;
    tokenPage.on('dialog', (d) => { asked++; d.accept(token); });
    await tokenPage.goto(`http://127.0.0.1:${http2}/`);
    await until('the scene list behind a token', () => tokenPage.evaluate(() => document.querySelectorAll('#scene option').length > 0));
    check(asked === 1, `the page asked for the token once (${asked})`);
    await tokenPage.selectOption('#scene', 'sleeve_on_limb');
    await tokenPage.click('#submit-button');
    const followed = await until('the job to run behind a token',
      () => tokenPage.evaluate(() => [...window.kgd.state.jobs.values()].some((j) => (j.iterations || 0) > 0))).then(() => true, () => false);
    check(followed, 'a job submitted and followed live with a token (header for the API, cookie for the event stream)');
    await tokenContext.close();
  } finally {
    secured.kill('SIGTERM');
    await new Promise((r) => secured.on('exit', r));
  }
} catch (e) {
  console.log(`FAIL ${e.message}`);
  failures++;
} finally {
  if (browser) await browser.close();
  serve.kill('SIGTERM');
  await new Promise((r) => serve.on('exit', r));
  fs.rmSync(data, { recursive: true, force: true });
}
console.log(failures ? `${failures} check(s) failed; screenshots in ${artifacts}` : `all checks passed; screenshots in ${artifacts}`);
process.exit(failures ? 1 : 0);
