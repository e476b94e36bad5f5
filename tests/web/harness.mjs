// Start-up for the browser tests: a real `kgd serve` on free ports with a data folder of its own,
// Debian's chromium driven by playwright-core (client/web/node_modules), the page opened, a job
// submitted through the form and waited for. Exit 77 (ctest: skipped) with a message where Chromium or
// playwright-core is absent. A test is one call:
//   import { runBrowserTest } from './harness.mjs';
//   await runBrowserTest('viewer', async ({ page, base, check, until, artifacts }) => { ... });
// run as `node tests/web/<name>_test.mjs --kgd build/client/kgd --artifacts build/test-artifacts/web/<name> [--web DIR]`.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const here = path.dirname(fileURLToPath(import.meta.url));
export const repo = path.resolve(here, '../..');
export const arg = (name, fallback) => { const i = process.argv.indexOf(name); return i > 0 ? process.argv[i + 1] : fallback; };
export const chromiumPath = process.env.KGD_CHROMIUM || '/usr/bin/chromium';
const playwrightPath = path.join(repo, 'client/web/node_modules/playwright-core/index.mjs');

export function skip(why) { console.log(`SKIPPED: ${why}`); process.exit(77); }

// playwright-core's chromium, or exit 77.
export async function loadChromium() {
  if (!fs.existsSync(chromiumPath)) skip(`no Chromium at ${chromiumPath} (apt-get install chromium; or set KGD_CHROMIUM)`);
  if (!fs.existsSync(playwrightPath)) skip('playwright-core is not installed (npm ci --prefix client/web)');
  return (await import(playwrightPath)).chromium;
}

// Checks that print "ok"/"FAIL" and count the failures.
export function checker() {
  const c = { failures: 0 };
  c.check = (ok, what) => {
    console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
    if (!ok) c.failures++;
    return !!ok;
  };
  return c;
}

// fn's first truthy value; throws after timeoutMs.
export async function until(what, fn, timeoutMs = 60000) {
  const end = Date.now() + timeoutMs;
  for (;;) {
    const v = await fn();
    if (v) return v;
    if (Date.now() > end) throw new Error(`timed out waiting for ${what}`);
    await new Promise((r) => setTimeout(r, 100));
  }
}

// The HTTP API, beside the page (base: the server's address with a trailing slash; p without a leading slash).
export async function apiGet(base, p, headers = {}) {
  const r = await fetch(base + p, { headers });
  if (!r.ok) throw new Error(`GET ${p}: HTTP ${r.status}`);
  return r;
}
export const apiJson = async (base, p, headers) => (await apiGet(base, p, headers)).json();
export const apiBytes = async (base, p, headers) => new Uint8Array(await (await apiGet(base, p, headers)).arrayBuffer());
export const apiFloats = async (base, p, headers) => { const b = await apiBytes(base, p, headers); return new Float32Array(b.buffer, b.byteOffset, b.byteLength / 4); };
export async function apiPost(base, p, body) {
  const r = await fetch(base + p, { method: 'POST', headers: { 'Content-Type': 'application/json' }, body: JSON.stringify(body ?? {}) });
  if (!r.ok) throw new Error(`POST ${p}: HTTP ${r.status} ${await r.text()}`);
  return r.json();
}

export function freePort() {
  return new Promise((resolve) => { const s = net.createServer(); s.listen(0, '127.0.0.1', () => { const p = s.address().port; s.close(() => resolve(p)); }); });
}

// `kgd serve` on free ports with `data` (made if absent) and extra arguments; resolves once it serves the
// page. { child, base, grpc, data, stop() }. A failure to start is an exception, not a stray server.
export async function startServer({ kgd = arg('--kgd', path.join(repo, 'build/client/kgd')), data, args = [] } = {}) {
  data ??= fs.mkdtempSync(path.join(os.tmpdir(), 'kgd_web_test_'));
  // --web DIR: the page's files from DIR (kgd serve's default: the source tree's client/web).
  if (arg('--web')) args = ['--web', arg('--web'), ...args];
  fs.mkdirSync(data, { recursive: true });
  const [grpcPort, httpPort] = [await freePort(), await freePort()];
  const child = spawn(kgd, ['serve', '--data', data, '--listen', `127.0.0.1:${grpcPort}`, '--http', `127.0.0.1:${httpPort}`, ...args, '--quiet'],
    { stdio: ['ignore', 'pipe', 'inherit'] });
  child.out = '';
  child.stdout.on('data', (d) => { child.out += d; });
  child.on('error', (e) => { child.out += `(${e.message})`; });
  const stop = async () => {
    if (child.exitCode !== null || child.signalCode !== null || child.pid === undefined) return;
    const exited = new Promise((r) => child.on('exit', r));
    child.kill('SIGTERM');
    await exited;
  };
  try {
    await until('kgd serve to start', () => child.out.includes('web page and HTTP API') || child.exitCode !== null, 30000);
    if (child.exitCode !== null) throw new Error(`kgd serve exited (${child.exitCode}): ${child.out}`);
  } catch (e) {
    await stop();
    throw e;
  }
  return { child, base: `http://127.0.0.1:${httpPort}/`, grpc: `127.0.0.1:${grpcPort}`, data, stop };
}

export async function launchBrowser(chromium) {
  return chromium.launch({
    executablePath: chromiumPath,
    args: ['--headless=new', '--no-sandbox', '--disable-gpu', '--enable-unsafe-swiftshader', '--use-angle=swiftshader', '--disable-quic', '--no-first-run',
      '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
}

// A page of `base` at width x height with downloads on, once its scene list has loaded; pageErrors
// collects the page's uncaught script errors.
export async function openPage(browser, base, { width = 1280, height = 800 } = {}) {
  const context = await browser.newContext({ viewport: { width, height }, acceptDownloads: true });
  const page = await context.newPage();
  const pageErrors = [];
  page.on('pageerror', (e) => pageErrors.push(e.message));
  await page.goto(base);
  await until('the scene list', () => page.evaluate(() => document.querySelectorAll('#scene option').length > 0));
  return { context, page, pageErrors };
}

// Submits a built-in scene's job through the page's form (fields left empty keep the scene's values;
// quality: draft, standard or precise) and returns its id once the page has selected it.
export async function submitJob(page, { scene, budget = '', maxIterations = '', label = '', quality = 'standard' }) {
  const before = await page.evaluate(() => window.kgd.state.selected);
  await page.selectOption('#scene', scene);
  await page.selectOption('#quality', quality);
  await page.fill('#budget', String(budget));
  await page.fill('#max-iterations', String(maxIterations));
  await page.fill('#label', label);
  await page.click('#submit-button');
  return until('the submitted job to be selected', () => page.evaluate((b) => { const s = window.kgd.state.selected; return s && s !== b ? s : null; }, before));
}

// The job once it has ended (SUCCEEDED, FAILED or CANCELLED), from the API.
export async function waitForEnd(base, id, timeoutMs = 120000) {
  return until(`job ${id} to end`, async () => { const j = await apiJson(base, `v1/jobs/${id}`); return ['SUCCEEDED', 'FAILED', 'CANCELLED'].includes(j.state) ? j : null; }, timeoutMs);
}

// Waits until the page shows what its controls select and nothing is loading.
export const settled = (page) => until('the view to settle', () => page.evaluate(() => !window.kgd.state.loading && !window.kgd.state.pending));

// Runs `body({ browser, page, pageErrors, base, server, check, until, artifacts, chromium })` against a
// fresh server and a 1280 x 800 page; a thrown error is a failed check (with a screenshot failure.png).
// Stops the server, removes its data and exits 0 when every check passed, else 1.
export async function runBrowserTest(name, body) {
  const chromium = await loadChromium();
  const artifacts = arg('--artifacts', path.join(repo, 'build/test-artifacts/web', name));
  fs.mkdirSync(artifacts, { recursive: true });
  const c = checker();
  let server, browser;
  try {
    server = await startServer();
    browser = await launchBrowser(chromium);
    const { page, pageErrors } = await openPage(browser, server.base);
    await body({ browser, page, pageErrors, base: server.base, server, check: c.check, until, artifacts, chromium });
    c.check(pageErrors.length === 0, `no script errors${pageErrors.length ? ': ' + pageErrors.join('; ') : ''}`);
  } catch (e) {
    c.check(false, e.stack || e.message);
    for (const p of browser?.contexts().flatMap((x) => x.pages()) || []) await p.screenshot({ path: path.join(artifacts, 'failure.png') }).catch(() => {});
  } finally {
    if (browser) await browser.close();
    if (server) {
      await server.stop();
      fs.rmSync(server.data, { recursive: true, force: true });
    }
  }
  console.log(c.failures ? `${c.failures} check(s) failed; screenshots in ${artifacts}` : `all checks passed; screenshots in ${artifacts}`);
  process.exit(c.failures ? 1 : 0);
}
