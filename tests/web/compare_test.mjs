// Charts, compare-and-choose and cut files in headless Chromium against a real `kgd serve`
// (tests/web/harness.mjs): two short jobs of different evolutionary ratios. On one job's
// charts, the pointer's iteration is in the legend, a click shows that iteration and the shown one is
// marked. Compared: both jobs in the table with the API's figures and on one chart, their 3D views
// orbit together, the pointer's point is described, a click shows that job's iteration; its cut files
// are named and made of that iteration, the options reach the files, one out of range is refused on the
// page, and the sheet preview's lines are visible where the SVG's hairlines are not.
//   node tests/web/compare_test.mjs --kgd build/client/kgd --artifacts build/test-artifacts/web/compare
import fs from 'node:fs';
import path from 'node:path';
import { runBrowserTest, apiJson, apiFloats, apiPost, submitJob, waitForEnd, settled } from './harness.mjs';

await runBrowserTest('compare', async ({ page, base, check, until, artifacts }) => {
  // Job A through the form, job B (a larger evolutionary ratio: another curve) through the API; the
  // sleeve on a capsule limb at draft accuracy, the shortest jobs with a body.
  await page.selectOption('#quality', 'draft');
  const a = await submitJob(page, { scene: 'sleeve_on_limb', budget: 0.3, maxIterations: 6, label: 'A', quality: 'draft' });
  const b = String((await apiPost(base, 'v1/jobs', { builtinScene: 'sleeve_on_limb', label: 'B',
    optimizer: { budget: 0.3, maxIterations: 5, evolutionaryRatio: 0.05, quality: 'draft' } })).id);
  const jobA = await waitForEnd(base, a), jobB = await waitForEnd(base, b);
  check(jobA.state === 'SUCCEEDED' && jobB.state === 'SUCCEEDED', `both jobs succeed (${jobA.state}, ${jobB.state}; ${jobA.spec.optimizer.quality}, ${jobB.spec.optimizer.quality})`);
  const metrics = async (id, n) => (await apiJson(base, `v1/jobs/${id}/iterations/${n}`)).record.metrics;

  // -- One job's charts: hover, click, mark ---------------------------------------------------------
  await until('job A in the page', () => page.evaluate((n) => window.kgd.state.metrics.filter(Boolean).length === n, jobA.iterations));
  await settled(page);
  // Where a chart draws a point, in page pixels (the chart's overlay is its plotting area).
  const pointAt = (chart, x, y, series = 1) => page.evaluate(([c, x, y, s]) => {
    const u = c === 'compare' ? window.kgd.compare.curve.u : window.kgd.charts[c];
    const r = u.over.getBoundingClientRect();
    return { x: r.left + u.valToPos(x, 'x'), y: r.top + u.valToPos(y, u.series[s].scale || 'y') };
  }, [chart, x, y, series]);
  const k = 2, mk = await metrics(a, k);
  await page.locator('#chart-ratio').scrollIntoViewIfNeeded();
  const p = await pointAt('ratio', k, mk.densityRatio);
  await page.mouse.move(p.x, p.y);
  const legend = await page.evaluate(() => [...document.querySelectorAll('#chart-ratio .u-legend .u-value')].map((e) => e.textContent));
  check(Number(legend[0]) === k && Math.abs(Number(legend[1]) - mk.densityRatio) < 1e-3,
    `the density-ratio chart's legend gives the pointer's iteration ${k} and its density ratio ${mk.densityRatio.toFixed(4)} (legend: ${legend.join(', ')})`);
  await page.mouse.click(p.x, p.y);
  await until(`iteration ${k} on screen`, () => page.evaluate((n) => window.kgd.state.shown === n && window.kgd.state.target?.kind === 'iteration', k), 10000).catch(() => {});
  await settled(page);
  const shownText = await page.textContent('#metrics');
  check(shownText.startsWith(`iteration ${k}:`) && Number(await page.inputValue('#scrub')) === k, `a click on the chart shows iteration ${k} ("${shownText.slice(0, 40)}…", scrubber ${await page.inputValue('#scrub')})`);
  // The mark: a near-black line down the plot at the shown iteration, none two iterations on.
  const markPixels = (n) => page.evaluate((n) => {
    const u = window.kgd.charts.ratio, x = Math.round(u.valToPos(n, 'x', true)), { top, height } = u.bbox;
    const px = u.ctx.getImageData(x, top, 1, height).data;
    let hits = 0;
    for (let i = 0; i < px.length; i += 4) if (px[i] < 70 && px[i + 1] < 70 && px[i + 2] < 70 && px[i + 3] > 200) hits++;
    return hits / height;
  }, n);
  const [atShown, elsewhere] = [await markPixels(k), await markPixels(k + 2)];
  check(atShown > 0.8 && elsewhere < 0.05, `the shown iteration is marked on the chart (mark colour in ${(100 * atShown).toFixed(0)} % of its column, ${(100 * elsewhere).toFixed(0)} % two iterations on)`);
  // The curve: a click on the point of iteration 1 shows it.
  const m1 = await metrics(a, 1);
  await page.locator('#chart-curve').scrollIntoViewIfNeeded();
  const c1 = await pointAt('curve', m1.areaFraction, m1.densityRatio);
  await page.mouse.move(c1.x, c1.y);
  const curveLegend = await page.evaluate(() => document.querySelector('#chart-curve .u-legend .u-value').textContent);
  await page.mouse.click(c1.x, c1.y);
  await until('iteration 1 on screen', () => page.evaluate(() => window.kgd.state.shown === 1), 10000).catch(() => {});
  check(/iteration 1\)/.test(curveLegend) && (await page.evaluate(() => window.kgd.state.shown)) === 1,
    `a click on the curve's point of iteration 1 shows it (legend "${curveLegend}")`);
  // Every point's ring (6 px) lies inside the curve's axes: the newest (least area) too.
  const rings = await page.evaluate(() => {
    const u = window.kgd.charts.curve, r = 6 * (devicePixelRatio || 1), { left, top, width, height } = u.bbox;
    const out = u.data[0].map((x, i) => [u.valToPos(x, 'x', true), u.valToPos(u.data[1][i], 'y', true)])
      .filter(([px, py]) => px - r < left || px + r > left + width || py - r < top || py + r > top + height);
    return { points: u.data[0].length, out: out.length };
  });
  check(rings.points > 2 && rings.out === 0, `the curve's ${rings.points} points' rings lie inside its axes (${rings.out} outside)`);
  await settled(page);
  // The cut-file options of the one job's view reach its download links; its sheets are previewed.
  await page.click('#cut-panel summary');
  await page.fill('#cut-sheet-width', '500');
  const linkHref = await page.getAttribute('#downloads a[href*="cut/patches.svg"]', 'href');
  await page.click('#cut-panel button');
  const singlePreview = await until('the one job\'s sheet previews', () => page.evaluate(() => {
    const s = document.querySelectorAll('#cut-panel .cut-sheets svg');
    return s.length === 2 ? s[1].getAttribute('viewBox') : null;
  }), 30000).catch(() => '');
  check(linkHref === `/v1/jobs/${a}/iterations/1/cut/patches.svg?sheetWidthMm=500` && singlePreview.startsWith('0 0 500 '),
    `the one job's cut-file options reach its links (${linkHref}) and its preview (patches viewBox ${singlePreview})`);
  await page.screenshot({ path: path.join(artifacts, 'charts-marked.png'), fullPage: true });
  await page.fill('#cut-sheet-width', '');

  // -- Compare the two ------------------------------------------------------------------------------
  await until('both jobs to compare', () => page.evaluate(() => document.querySelectorAll('#compare-list input').length >= 2), 10000);
  for (const id of [a, b]) await page.check(`#compare-list input[data-id="${id}"]`);
  await page.click('#compare-button');
  const drawnBoth = await until('both views drawn with every iteration', () => page.evaluate(([na, nb]) => {
    const c = window.kgd.compare;
    return c.entries.length === 2 && c.entries.every((e) => e.drawn != null && !e.loading) && c.entries[0].rows.filter(Boolean).length === na
      && c.entries[1].rows.filter(Boolean).length === nb;
  }, [jobA.iterations, jobB.iterations]), 20000).catch(() => false);
  check(drawnBoth && await page.isHidden('#viewer') && await page.isVisible('#compare'), 'the compare view replaces the viewer and draws both jobs');
  const table = await page.evaluate(() => [...document.querySelectorAll('#compare-table tbody tr')].map((tr) => [...tr.children].map((c) => c.textContent)));
  for (const [row, job] of [[table[0], jobA], [table[1], jobB]])
    check(row && row[0] === `Job ${job.id}` && row[3] === String(job.iterations) && row[5] === job.last.densityRatio.toFixed(3)
      && row[4] === `${(100 * job.last.areaFraction).toFixed(1)} %` && row[6] === job.last.reinforcedEnergyJ.toPrecision(4),
      `the table gives job ${job.id}'s iterations, area, density ratio and reinforced energy as the API (${row?.join(' | ')})`);
  const series = await page.evaluate(() => window.kgd.compare.curve.u.data.slice(1).map((s) => s.filter((v) => v != null).length));
  check(series.length === 2 && series[0] === jobA.iterations && series[1] === jobB.iterations,
    `one chart, a series per job with every stored iteration (${series.join(', ')} points)`);

  // Orbit one view: the other follows.
  const cameras = () => page.evaluate(() => window.kgd.compare.entries.map((e) => [...e.view.camera.position.toArray(), ...e.view.controls.target.toArray()]));
  const before = await cameras();
  const box = await page.locator('#compare-views canvas').first().boundingBox();
  await page.mouse.move(box.x + box.width / 2, box.y + box.height / 2);
  await page.mouse.down();
  await page.mouse.move(box.x + box.width / 2 + 90, box.y + box.height / 2 + 30, { steps: 5 });
  await page.mouse.up();
  const after = await cameras();
  const dist = (u, v) => Math.hypot(...u.map((x, i) => x - v[i]));
  check(dist(after[0], before[0]) > 1e-3 && dist(after[0], after[1]) < 1e-9,
    `dragging the first view orbits both (moved ${dist(after[0], before[0]).toFixed(3)} m, views ${dist(after[0], after[1]).toExponential(1)} m apart)`);

  // Point at job B's iteration 2 on the chart, then click it.
  const kb = 2, mb = await metrics(b, kb);
  await page.locator('#chart-compare').scrollIntoViewIfNeeded();
  const pb = await pointAt('compare', mb.areaFraction, mb.densityRatio, 2);
  await page.mouse.move(pb.x, pb.y);
  const readout = await page.textContent('#compare-readout');
  check(readout.startsWith(`job ${b}, iteration ${kb}: reinforced area ${(100 * mb.areaFraction).toFixed(1)} %, density ratio ${mb.densityRatio.toFixed(3)}`),
    `pointing at job ${b}'s iteration ${kb} reads its figures ("${readout}")`);
  await page.mouse.click(pb.x, pb.y);
  await until(`job ${b}'s view to draw iteration ${kb}`, () => page.evaluate((n) => { const e = window.kgd.compare.entries[1]; return e.drawn === n && !e.loading; }, kb), 10000).catch(() => {});
  const viewB = await page.evaluate(() => {
    const e = window.kgd.compare.entries[1], g = e.view.garment.geometry;
    return { drawn: e.drawn, faces: Array.from(e.view.faces.slice(0, 300)), pos: Array.from(g.attributes.position.array.slice(0, 900)), caption: e.caption.textContent };
  });
  const xb = await apiFloats(base, `v1/jobs/${b}/iterations/${kb}/positions.f32`);
  let err = 0;
  for (let c = 0; c < viewB.faces.length; ++c) for (let d = 0; d < 3; ++d) err = Math.max(err, Math.abs(viewB.pos[3 * c + d] - xb[3 * viewB.faces[c] + d]));
  check(viewB.drawn === kb && err === 0 && viewB.caption.startsWith(`Job ${b} · iteration ${kb}:`),
    `the click shows job ${b}'s iteration ${kb} in its view with the API's positions (caption "${viewB.caption}")`);
  check((await page.evaluate(() => window.kgd.compare.entries[0].drawn)) === jobA.iterations - 1, `job ${a}'s view keeps its last iteration`);
  const afterPick = await cameras();
  check(dist(afterPick[0], afterPick[1]) < 1e-9, 'the views keep one camera after the pick');

  // Its cut files: made of that iteration and named so.
  await page.click('#compare-use');
  await until('the sheet previews', () => page.evaluate(() => document.querySelectorAll('#compare-cut .cut-sheets svg').length === 2), 30000).catch(() => {});
  const summary = await page.textContent('#compare-cut .cut-summary');
  check(summary.startsWith(`Iteration ${kb}: `), `the cut files are of the picked iteration ("${summary.slice(0, 90)}…")`);
  const download = async (name) => {
    const [d] = await Promise.all([page.waitForEvent('download', { timeout: 30000 }), page.click(`#compare-cut a[href*="cut/${name}"]`)]);
    const file = path.join(artifacts, d.suggestedFilename());
    await d.saveAs(file);
    return { name: d.suggestedFilename(), text: fs.readFileSync(file, 'utf8') };
  };
  const report = await download('report.json');
  check(report.name === `job-${b}-iteration-${kb}-report.json` && JSON.parse(report.text).iteration === kb,
    `the report downloads as ${report.name} with iteration ${JSON.parse(report.text).iteration}`);
  const patches = await download('patches.svg');
  check(patches.name === `job-${b}-iteration-${kb}-patches.svg` && /<svg[^>]*width="305mm"/.test(patches.text),
    `the patches' sheet downloads as ${patches.name}, 305 mm wide by default`);
  const pattern = await download('pattern.svg');
  check(pattern.name === `job-${b}-iteration-${kb}-pattern.svg` && pattern.text.includes(`, iteration ${kb}</text>`),
    `the pattern downloads as ${pattern.name}, its pieces labelled with iteration ${kb}`);

  // The options reach the files: a seam allowance and a sheet width.
  const defaultPattern = pattern.text;
  await page.fill('#compare-cut-seam-allowance', '25');
  await page.fill('#compare-cut-sheet-width', '400');
  const widePattern = await download('pattern.svg');
  const widePatches = await download('patches.svg');
  const viewBoxWidth = (svg) => Number(/viewBox="0 0 ([\d.]+) /.exec(svg)?.[1]);
  check(/<svg[^>]*width="400mm"/.test(widePatches.text), `a sheet width of 400 mm reaches the patches' sheet (${/<svg[^>]*width="([^"]*)"/.exec(widePatches.text)?.[1]})`);
  check(widePattern.text !== defaultPattern && viewBoxWidth(widePattern.text) > viewBoxWidth(defaultPattern),
    `a seam allowance of 25 mm widens the pattern (${viewBoxWidth(defaultPattern)} -> ${viewBoxWidth(widePattern.text)} mm)`);
  // One out of range: refused on the page, naming it; no links to files that would not be made.
  await page.fill('#compare-cut-seam-allowance', '200');
  const optionError = await page.textContent('#compare-cut .error');
  check(/seamAllowanceMm: the seam allowance 200 mm is not a number in \[0, 100\] mm/.test(optionError)
    && (await page.locator('#compare-cut a').count()) === 0 && await page.isDisabled('#compare-cut button'),
    `a seam allowance of 200 mm is refused on the page ("${optionError}"), with no links`);
  await page.fill('#compare-cut-seam-allowance', '');
  // An export the server refuses (a 1 mm sheet): its message alone, no file links.
  await page.fill('#compare-cut-sheet-width', '1');
  await page.click('#compare-cut button');
  const refused = await until('the refused export', () => page.evaluate(() => /^No cut files/.test(document.querySelector('#compare-cut .cut-summary').textContent)
    && document.querySelector('#compare-cut .cut-summary').textContent), 30000).catch(() => '');
  check(/wider than the 1 mm sheet/.test(refused) && (await page.locator('#compare-cut a').count()) === 0,
    `an export refused by the server shows its message alone ("${refused}", ${await page.locator('#compare-cut a').count()} links)`);
  await page.fill('#compare-cut-sheet-width', '400');

  // The preview's lines are visible: drawn as an image at the preview's size, the sheet's cut lines
  // (red) cover many pixels; the SVG as exported covers none at that size.
  await page.click('#compare-cut button');
  await until('the previews again', () => page.evaluate(() => document.querySelectorAll('#compare-cut .cut-sheets svg').length === 2), 30000).catch(() => {});
  const red = await page.evaluate(async ([id, n]) => {
    const svg = document.querySelector('#compare-cut figure[data-file="patches.svg"] svg');
    const { width, height } = svg.getBoundingClientRect();
    const count = async (text) => {
      const img = new Image();
      img.src = `data:image/svg+xml;charset=utf-8,${encodeURIComponent(text)}`;
      await img.decode();
      const c = document.createElement('canvas');
      c.width = Math.round(width);
      c.height = Math.round(height);
      const ctx = c.getContext('2d');
      ctx.fillStyle = '#fff';
      ctx.fillRect(0, 0, c.width, c.height);
      ctx.drawImage(img, 0, 0, c.width, c.height);
      const p = ctx.getImageData(0, 0, c.width, c.height).data;
      let k = 0;
      for (let i = 0; i < p.length; i += 4) if (p[i] > 180 && p[i + 1] < 110 && p[i + 2] < 110) k++;
      return k;
    };
    const raw = await (await fetch(`/v1/jobs/${id}/iterations/${n}/cut/patches.svg?sheetWidthMm=400`)).text();
    const cut = svg.querySelector('[data-layer="1"] polygon, [data-layer="1"] polyline');
    return { width, preview: await count(new XMLSerializer().serializeToString(svg)), raw: await count(raw),
      strokeWidth: getComputedStyle(cut).strokeWidth, effect: cut.getAttribute('vector-effect') };
  }, [b, kb]);
  check(red.preview > 300 && red.raw < red.preview / 20 && red.strokeWidth === '1.5px' && red.effect === 'non-scaling-stroke',
    `the sheet preview (${Math.round(red.width)} px wide) draws its cut lines in ${red.preview} red pixels (${red.strokeWidth}, non-scaling), the exported SVG in ${red.raw}`);
  await page.locator('#compare').screenshot({ path: path.join(artifacts, 'compare.png') });

  // Back to one job.
  await page.click('#compare-close');
  check(await page.isVisible('#viewer') && await page.isHidden('#compare') && (await page.evaluate(() => window.kgd.compare.entries.length)) === 0,
    'Back to one job shows the viewer again and releases the compare views');
});
