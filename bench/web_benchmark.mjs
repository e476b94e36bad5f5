// Benchmarks of the web client, against a real
// `kgd serve` on loopback:
//   sse    worker report to Server-Sent Event: an arm-flexion job watched by W SSE connections at once;
//          latency = arrival - the iteration's reportTimeS (the worker's clock; same machine)
//   page   page ready: navigation to the jobs list and scene list shown, in headless Chromium
//   view   a 28k-vertex iteration applied to the 3D view (geometry and colours updated and drawn), on a
//          synthetic 28,000-vertex garment, in headless Chromium (software WebGL)
//   node bench/web_benchmark.mjs [--kgd build/client/kgd] [--watchers 100] [--iterations 30] [--pages 5] [--draws 10] [--json FILE]
// --json: the figures as one JSON object ("kind": "web"), which `make bench` (bench/run.sh, bench/tables.py)
// writes into docs/PERFORMANCE.md, "Web client".
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import http from 'node:http';
import net from 'node:net';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const repo = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..');
const arg = (name, fallback) => { const i = process.argv.indexOf(name); return i > 0 ? process.argv[i + 1] : fallback; };
const kgd = arg('--kgd', path.join(repo, 'build/client/kgd'));
const watchers = Number(arg('--watchers', 100));
const iterations = Number(arg('--iterations', 30));
const pages = Number(arg('--pages', 5));
const draws = Number(arg('--draws', 10));
const jsonPath = arg('--json', '');
const result = { kind: 'web' };
const { chromium } = await import(path.join(repo, 'client/web/node_modules/playwright-core/index.mjs'));

const freePort = () => new Promise((resolve) => { const s = net.createServer(); s.listen(0, '127.0.0.1', () => { const p = s.address().port; s.close(() => resolve(p)); }); });
const percentile = (v, p) => { const s = [...v].sort((a, b) => a - b); return s[Math.min(s.length - 1, Math.floor(p * s.length))]; };

const data = fs.mkdtempSync(path.join(os.tmpdir(), 'kgd_web_bench_'));
const [grpcPort, httpPort] = [await freePort(), await freePort()];
const serve = spawn(kgd, ['serve', '--data', data, '--listen', `127.0.0.1:${grpcPort}`, '--http', `127.0.0.1:${httpPort}`, '--max-watchers-per-job', '0', '--quiet'], { stdio: ['ignore', 'pipe', 'inherit'] });
let out = '';
serve.stdout.on('data', (d) => { out += d; });
while (!out.includes('web page')) await new Promise((r) => setTimeout(r, 50));
const base = `http://127.0.0.1:${httpPort}`;

function request(method, p, body) {
  return new Promise((resolve, reject) => {
    const req = http.request(base + p, { method, headers: { 'Content-Type': 'application/json' } }, (res) => {
      let text = '';
      res.on('data', (d) => { text += d; });
      res.on('end', () => resolve(JSON.parse(text)));
    });
    req.on('error', reject);
    req.end(body ? JSON.stringify(body) : undefined);
  });
}

try {
  // -- sse ---------------------------------------------------------------------------------------------
  const agent = new http.Agent({ maxSockets: watchers + 4 });
  let failed = 0, complete = 0;
  const job = await request('POST', '/v1/jobs', { builtinScene: 'arm_flexion', optimizer: { maxIterations: iterations }, label: 'bench' });
  const latencies = [];
  let open = 0;
  const done = [];
  for (let w = 0; w < watchers; ++w) {
    done.push(new Promise((resolve) => {
      const req = http.get(`${base}/v1/jobs/${job.id}:watch?view=metrics`, { agent }, (res) => {
        if (res.statusCode !== 200) {  // refused (a limit): a failed watcher, not a connected one
          ++failed;
          console.error(`watcher: HTTP ${res.statusCode}`);
          res.resume();
          res.on('end', resolve);
          return;
        }
        ++open;
        let buffer = '', events = 0;
        res.on('data', (chunk) => {
          const now = Date.now() / 1000;
          buffer += chunk;
          let end;
          while ((end = buffer.indexOf('\n\n')) >= 0) {
            const block = buffer.slice(0, end);
            buffer = buffer.slice(end + 2);
            if (!block.includes('event: iteration')) continue;
            ++events;
            const data = JSON.parse(block.split('\n').find((l) => l.startsWith('data: ')).slice(6));
            const t = data.metrics.reportTimeS;
            if (t && data.metrics.iteration > 0) latencies.push(1000 * (now - t));
          }
        });
        res.on('end', () => { if (events === iterations + 1) ++complete; resolve(); });
        res.on('error', (e) => { ++failed; console.error(`watcher: ${e.message}`); resolve(); });
      });
      req.on('error', (e) => { ++failed; console.error(`watcher: ${e.message}`); resolve(); });
    }));
  }
  await Promise.all(done);
  result.sse = { scene: 'arm_flexion', watchers, connected: open, complete, failed, iterations, events: latencies.length,
    p50_ms: percentile(latencies, 0.5), p99_ms: percentile(latencies, 0.99) };
  console.log(`sse: ${watchers} watchers (${open} connected, ${complete} saw every iteration, ${failed} failed), ${iterations} iterations: p50 ${percentile(latencies, 0.5).toFixed(1)} ms, p99 ${percentile(latencies, 0.99).toFixed(1)} ms over ${latencies.length} events`);

  // -- page --------------------------------------------------------------------------------------------
  const browser = await chromium.launch({ executablePath: process.env.KGD_CHROMIUM || '/usr/bin/chromium',
    args: ['--headless=new', '--no-sandbox', '--disable-gpu', '--enable-unsafe-swiftshader', '--use-angle=swiftshader', '--disable-background-networking', '--disable-component-update'] });
  const ready = [];
  for (let k = 0; k < pages; ++k) {
    const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    const t0 = Date.now();
    await page.goto(base + '/');
    await page.waitForFunction(() => document.querySelectorAll('#scene option').length > 0 && document.querySelectorAll('#jobs tbody tr').length > 0);
    ready.push(Date.now() - t0);
    await page.close();
  }
  result.page = { pages, median_ms: percentile(ready, 0.5), min_ms: Math.min(...ready), max_ms: Math.max(...ready) };
  console.log(`page: ready in ${percentile(ready, 0.5)} ms (median of ${pages}; min ${Math.min(...ready)}, max ${Math.max(...ready)})`);

  // -- view --------------------------------------------------------------------------------------------
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  await page.goto(base + '/');
  await page.waitForFunction(() => window.kgd);
  const times = await page.evaluate((draws) => {
    // A 140 x 200 grid rolled into a tube: 28,000 vertices, 55,720 faces.
    const nu = 140, nv = 200, n = nu * nv;
    const faces = [];
    for (let j = 0; j + 1 < nv; ++j)
      for (let i = 0; i < nu; ++i) {
        const a = j * nu + i, b = j * nu + ((i + 1) % nu), c = a + nu, d = b + nu;
        faces.push(a, b, d, a, d, c);
      }
    const f = new Uint32Array(faces);
    const view = window.kgd.view;
    view.setMeshes(f, null);
    const out = [];
    for (let k = 0; k < draws + 2; ++k) {
      const x = new Float32Array(3 * n), design = new Uint8Array(f.length / 3);
      for (let v = 0; v < n; ++v) {
        const t = (2 * Math.PI * (v % nu)) / nu, y = Math.floor(v / nu) * 0.002;
        x[3 * v] = 0.05 * Math.cos(t) * (1 + 0.01 * k); x[3 * v + 1] = y; x[3 * v + 2] = 0.05 * Math.sin(t);
      }
      for (let t = 0; t < design.length; ++t) design[t] = (t + k) % 7 === 0 ? 1 : 0;
      const t0 = performance.now();
      view.update(x, 'design', design, 0);
      view.renderer.getContext().finish();
      out.push(performance.now() - t0);
    }
    return out.slice(2);  // the first calls compile shaders
  }, draws);
  result.view = { vertices: 28000, faces: 55720, draws: times.length, median_ms: percentile(times, 0.5), max_ms: Math.max(...times) };
  console.log(`view: a 28,000-vertex iteration applied and drawn in ${percentile(times, 0.5).toFixed(1)} ms (median of ${times.length}; max ${Math.max(...times).toFixed(1)})`);
  await browser.close();
  if (jsonPath) fs.writeFileSync(jsonPath, JSON.stringify(result, null, 1) + '\n');
} finally {
  serve.kill('SIGTERM');
  await new Promise((r) => serve.on('exit', r));
  fs.rmSync(data, { recursive: true, force: true });
}
