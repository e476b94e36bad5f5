// The studio (#studio) in headless Chromium against a real `kgd serve` (tests/web/harness.mjs): the test
// body pair of tests/data/studio uploaded (a photo as the rest pose and a deformed pose of another mesh
// refused first, in words); a 5 cm brush click paints the faces within 5 cm of the point, an erase click
// takes them off, two patches apart are refused in `kgd region`'s words in the status box. Half the
// region of sleeve_rules.txt (its faces on the +x side) painted with pointer strokes, mirrored,
// attachment bands at the rules' width: the status box says valid with two loops; 'Save scene'
// downloads a zip whose face lists equal those `kgd region` writes with the same rules, whose poses are
// the uploads and whose scene.json is tests/data/studio/scene.json's; a keep-in click is saved as the
// garment faces under it; Mirror mirrors a painted band; 'Submit' runs the job, shown in the jobs view,
// and its cut files download.
// The built-in body option shows the parametric body the server poses, and a click paints on it.
//   node tests/web/studio_test.mjs --kgd build/client/kgd --artifacts build/test-artifacts/web/studio
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { runBrowserTest, repo, arg, apiJson, waitForEnd } from './harness.mjs';

const { unzipSync } = await import(path.join(repo, 'client/web/node_modules/fflate/esm/index.mjs')).catch(() => ({}));
const data = arg('--data', path.join(repo, 'tests/data/studio'));
const kgd = arg('--kgd', path.join(repo, 'build/client/kgd'));
const readList = (text) => text.split('\n').map((l) => l.trim()).filter((l) => l && !l.startsWith('#')).map(Number);
const sameList = (a, b) => a.length === b.length && a.every((x, i) => x === b[i]);

// The region and bands `kgd region` makes with the rules (one argument a line) and --attach WIDTH.
const rules = fs.readFileSync(path.join(data, 'sleeve_rules.txt'), 'utf8').split('\n').filter((l) => l.trim() && !l.trim().startsWith('#')).flatMap((l) => l.trim().split(/\s+/));
const expectedScene = JSON.parse(fs.readFileSync(path.join(data, 'scene.json'), 'utf8'));
const attachIndex = rules.indexOf('--attach');
const widthM = attachIndex >= 0 ? Number(rules[attachIndex + 1]) : 0.02;
const regionRules = attachIndex >= 0 ? rules.filter((_, i) => i !== attachIndex && i !== attachIndex + 1) : rules;
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'kgd_studio_test_'));
execFileSync(kgd, ['region', path.join(data, 'rest.obj'), ...regionRules, '--attach', String(widthM), '--out', path.join(tmp, 'expected')], { stdio: 'pipe' });
const expectedFaces = readList(fs.readFileSync(path.join(tmp, 'expected.faces.txt'), 'utf8'));
const expectedBands = readList(fs.readFileSync(path.join(tmp, 'expected.attach.txt'), 'utf8'));

await runBrowserTest('studio', async ({ page, base, check, until, artifacts }) => {
  if (!unzipSync) return check(false, 'fflate is installed (npm ci --prefix client/web)');
  await page.goto(`${base}#studio`);
  await until('the studio', () => page.evaluate(() => !!window.kgdStudio && !document.getElementById('studio').hidden));
  check(await page.isHidden('#jobs-view'), '#studio shows the studio in the jobs view\'s place');
  // The built-in body chosen: the status box says how to make it.
  await page.check('input[name=studio-source][value=builtin]');
  const builtinStatus = await page.textContent('#studio-status');
  check(/press 'Make the body'/.test(builtinStatus), `the built-in body's status says what to do: "${builtinStatus}"`);
  await page.check('input[name=studio-source][value=upload]');

  // A photo as the rest pose: refused on the page, naming the file.
  const png = path.join(tmp, 'rest.obj');
  fs.writeFileSync(png, Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0, 0, 0, 13, 0x49, 0x48, 0x44, 0x52]));
  await page.setInputFiles('#studio-rest', png);
  const refusal = await until('the refusal', () => page.textContent('#studio-file-error'), 5000);
  const statusBox = await page.textContent('#studio-status');
  check(refusal.startsWith('rest.obj is not an OBJ or PLY mesh (line 1:') && !/[\u0000-\u0008]/.test(refusal) && statusBox.startsWith(refusal),
    `a PNG chosen as the rest pose is refused, in the status box too: "${refusal}"`);

  // The body pair; a deformed pose of another mesh refused first, naming both files.
  await page.setInputFiles('#studio-rest', path.join(data, 'rest.obj'));
  const other = path.join(tmp, 'triangle.obj');
  fs.writeFileSync(other, 'v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n');
  await page.setInputFiles('#studio-deformed', other);
  const poseRefusal = await until('the pose refusal', () => page.textContent('#studio-file-error'), 5000);
  check(poseRefusal === 'triangle.obj has 3 vertices and 1 faces, the rest pose rest.obj 1242 and 2480: a pose must be the rest pose\'s mesh moved',
    `a deformed pose of another mesh is refused: "${poseRefusal}"`);
  // A deformed pose in centimetres: refused as the server would (more than 20 m across).
  const cmPose = path.join(tmp, 'deformed_cm.obj');
  fs.writeFileSync(cmPose, fs.readFileSync(path.join(data, 'deformed.obj'), 'utf8').split('\n')
    .map((l) => (l.startsWith('v ') ? `v ${l.trim().split(/\s+/).slice(1).map((x) => 100 * Number(x)).join(' ')}` : l)).join('\n'));
  await page.setInputFiles('#studio-deformed', cmPose);
  const cmRefusal = await until('the cm refusal', () => page.evaluate(() => /deformed_cm/.test(document.getElementById('studio-file-error').textContent) && document.getElementById('studio-file-error').textContent), 5000).catch(() => '');
  check(/^deformed_cm\.obj: the mesh is [\d,]+ m across: centimetres\? kgd reads metres \(SI\); scale the mesh by 0\.01$/.test(cmRefusal),
    `a deformed pose in centimetres is refused on the page: "${cmRefusal}"`);
  await page.setInputFiles('#studio-deformed', path.join(data, 'deformed.obj'));
  const nf = await until('the body in the view', () => page.evaluate(() => window.kgdStudio.paint.faceCount), 10000);
  const restFaces = fs.readFileSync(path.join(data, 'rest.obj'), 'utf8').split('\n').filter((l) => l.startsWith('f ')).reduce((n, l) => n + l.trim().split(/\s+/).length - 3, 0);
  check(nf === restFaces && (await page.textContent('#studio-file-error')) === '', `the rest pose's ${nf} triangles are shown (the file's polygons fanned: ${restFaces})`);

  // One click of a 5 cm brush on the chest: the face under the pointer and every face whose centroid lies
  // within 5 cm of the point (the surface there is one piece); an erase click clears them.
  await page.locator('#studio-canvas').scrollIntoViewIfNeeded();
  const canvas = await page.locator('#studio-canvas').boundingBox();
  const cx = canvas.x + canvas.width / 2, cy = canvas.y + canvas.height / 2;
  await page.fill('#studio-radius', '5');
  await page.dispatchEvent('#studio-radius', 'input');
  await page.mouse.click(cx, cy);
  const brush = await page.evaluate(([x, y]) => {
    const p = window.kgdStudio.paint, h = p.hit(x, y), c = p.centroids, painted = p.layerFaces('region');
    const dist = (t) => Math.hypot(c[3 * t] - h.point.x, c[3 * t + 1] - h.point.y, c[3 * t + 2] - h.point.z);
    let near = 0, nearPainted = 0;
    for (let t = 0; t < p.faceCount; ++t) if (dist(t) <= 0.05) { near++; nearPainted += p.layers.region[t]; }
    return { face: h.face, painted: painted.length, hasFace: painted.includes(h.face), far: Math.max(...painted.map(dist)), near, nearPainted };
  }, [cx, cy]);
  check(brush.hasFace && brush.far <= 0.05 && brush.near > 1 && brush.nearPainted === brush.near && brush.painted === brush.near,
    `a 5 cm brush click paints ${brush.painted} faces: face ${brush.face} under the pointer and all ${brush.near} within 5 cm, none beyond (${(100 * brush.far).toFixed(1)} cm)`);
  await page.check('#studio-erase');
  await page.mouse.click(cx, cy);
  check((await page.evaluate(() => window.kgdStudio.paint.layerFaces('region').length)) === 0, 'an erase click at the same point leaves nothing painted');
  await page.uncheck('#studio-erase');

  // Two patches apart: refused in kgd region's words, in the status box; Clear empties it.
  await page.mouse.click(cx, cy);
  await page.mouse.click(cx, cy - 0.3 * canvas.height);
  const settledAnswer = () => until('the region checked', () => page.evaluate(() => { const s = window.kgdStudio.studio; return !s.timer && !s.checking && s.answer ? s.answer : null; }), 20000);
  const refused = await settledAnswer();
  const refusedText = await page.textContent('#studio-status');
  check(!refused.valid && /the region is 2 edge-connected pieces, not one: \d+ faces with face \d+ at \(/.test(refused.refusal) && refusedText.includes(refused.refusal)
    && await page.getAttribute('#studio-status', 'data-valid') === 'false', `two patches apart are refused in the status box: "${refused.refusal}"`);
  await page.click('#studio-clear');
  await until('nothing painted', () => page.evaluate(() => { const s = window.kgdStudio.studio; return !s.timer && !s.checking && !s.answer; }), 10000);
  check((await page.textContent('#studio-status')).startsWith('Paint the garment region'), 'Clear leaves nothing painted and says so');

  // Half the region: its faces with a centroid on the +x side, painted by pointer strokes from views
  // round that side (then along a face's normal for a face they all miss), a brush of 5 cm, 2.5, 1.2
  // and 0.1 cm in turn at the faces whose brush (5 % wider) stays inside the half and paints faces left.
  await page.locator('#studio-canvas').scrollIntoViewIfNeeded();
  const half = await page.evaluate((faces) => { const c = window.kgdStudio.paint.centroids; return faces.filter((t) => c[3 * t] > 0); }, expectedFaces);
  const strokes = [];
  const views = [[0, 0, 1], [1, 0, 1], [1, 0, 0], [1, 0, -1], [0, 0, -1], [1, 1, 1], [1, 1, -1], [1, -1, 1], [1, -1, -1], 'face'];
  for (const radiusCm of [5, 2.5, 1.2, 0.1]) {
    await page.fill('#studio-radius', String(radiusCm));
    await page.dispatchEvent('#studio-radius', 'input');
    let events = 0;
    for (const view of views) {
      for (;;) {
        // The points this view shows, each a face's centroid whose brush paints faces left.
        const left = await page.evaluate(({ half, view, radius }) => {
          const p = window.kgdStudio.paint, c = p.centroids, inHalf = new Set(half);
          const todo = new Set(half.filter((t) => !p.layers.region[t]));
          if (!todo.size) return { points: [] };
          if (view === 'face') p.lookAtFace(todo.values().next().value, 0.4);
          else p.lookFrom(view);
          const points = [];
          for (const t of view === 'face' ? [todo.values().next().value] : [...todo]) {
            if (!todo.has(t)) continue;
            const at = { x: c[3 * t], y: c[3 * t + 1], z: c[3 * t + 2] };
            if (!p.facesNear(t, at, 1.05 * radius).every((u) => inHalf.has(u))) continue;
            const s = p.screenPoint(at.x, at.y, at.z);
            if (!s.inside || p.hit(s.x, s.y)?.face !== t) continue;
            points.push({ t, x: s.x, y: s.y });
            for (const u of p.facesNear(t, at, radius)) todo.delete(u);
          }
          return { points };
        }, { half, view, radius: radiusCm / 100 });
        if (!left.points.length) break;
        const pts = left.points.sort((a, b) => a.y - b.y || a.x - b.x);
        await page.mouse.move(pts[0].x, pts[0].y);
        await page.mouse.down();
        for (const q of pts.slice(1)) await page.mouse.move(q.x, q.y);
        await page.mouse.up();
        events += pts.length;
        if (view !== 'face') break;
      }
    }
    strokes.push(`${events} at ${radiusCm} cm`);
  }
  const painted = await page.evaluate(() => window.kgdStudio.paint.layerFaces('region'));
  check(sameList(painted, half), `pointer strokes (${strokes.join(', ')}) paint the ${half.length} faces of the region's +x half (${painted.length} painted)`);
  await page.evaluate(() => window.kgdStudio.paint.setView('front'));
  await page.screenshot({ path: path.join(artifacts, 'half.png'), fullPage: true });

  // Mirror, bands at the rules' width.
  await page.evaluate((cmWidth) => { const s = document.getElementById('studio-band-width'); s.value = String(cmWidth); s.dispatchEvent(new Event('input')); }, 100 * widthM);
  await page.click('#studio-mirror');
  const answer = await until('the mirrored region checked', () => page.evaluate(() => {
    const s = window.kgdStudio.studio;
    return !s.timer && !s.checking && s.answer?.mirrored === false && s.answer?.bands ? s.answer : null;
  }), 20000);
  const status = await page.textContent('#studio-status');
  check(await page.getAttribute('#studio-status', 'data-valid') === 'true' && answer.loops.length === 2 && /2 boundary loops: [\d.]+ cm, [\d.]+ cm/.test(status)
    && /Predicted job time \(standard\): (about \d+|under a second)/.test(status),
    `after Mirror the status box says valid, two loops and a predicted time: "${status}"`);
  check(sameList(answer.faces, expectedFaces), `the mirrored region is sleeve_rules.txt's (${answer.faces.length} faces, kgd region ${expectedFaces.length})`);
  await page.screenshot({ path: path.join(artifacts, 'mirrored.png'), fullPage: true });

  // Save scene: the zip of the folder `kgd scene export` writes.
  await page.fill('#studio-budget', String(expectedScene.budget));
  const [download] = await Promise.all([page.waitForEvent('download', { timeout: 20000 }), page.click('#studio-save')]);
  const zipPath = path.join(artifacts, download.suggestedFilename());
  await download.saveAs(zipPath);
  const zip = unzipSync(new Uint8Array(fs.readFileSync(zipPath)));
  const text = (name) => (zip[name] ? new TextDecoder().decode(zip[name]) : '');
  const scene = JSON.parse(text('scene.json') || '{}');
  const region = readList(text(scene.garment?.region || 'garment_region.txt'));
  const bands = readList(text(scene.attachments?.body_faces || 'attachment_body_faces.txt'));
  check(sameList(region, expectedFaces), `the saved garment.region equals kgd region's (${region.length} and ${expectedFaces.length} faces)`);
  check(sameList(bands, expectedBands), `the saved attachments.body_faces equal kgd region --attach ${widthM}'s (${bands.length} and ${expectedBands.length} faces)`);
  const same = (name, file) => zip[name] && Buffer.compare(Buffer.from(zip[name]), fs.readFileSync(path.join(data, file))) === 0;
  check(same(scene.body?.rest, 'rest.obj') && same(scene.body?.deformed, 'deformed.obj'), `the saved body poses are the uploads (${scene.body?.rest}, ${scene.body?.deformed})`);
  // The rest of scene.json: the hand-made one's (the poses named as `kgd scene export` names them).
  const strip = (s) => JSON.stringify({ ...s, name: undefined, description: undefined, body: { ...s.body, rest: undefined, deformed: undefined } });
  check(strip(scene) === strip(expectedScene) && scene.body.rest === 'body_rest.obj' && scene.body.deformed === 'body_deformed.obj',
    `scene.json is tests/data/studio/scene.json's but for its name, description and the poses' file names${strip(scene) === strip(expectedScene) ? '' : `: ${strip(scene)} vs ${strip(expectedScene)}`}`);

  // Keep-in painted inside the region (a 3 cm click): the garment faces under it (4 per body face, one
  // subdivision) saved as garment.keep_in.
  await page.check('input[name=studio-layer][value=keepIn]');
  await page.fill('#studio-radius', '3');
  await page.dispatchEvent('#studio-radius', 'input');
  await page.locator('#studio-canvas').scrollIntoViewIfNeeded();
  const front = await page.evaluate((faces) => {
    const p = window.kgdStudio.paint, c = p.centroids;
    p.lookFrom([0, 0, 1]);
    const t = faces.filter((f) => Math.abs(c[3 * f + 1] - 1.1) < 0.03).sort((a, b) => c[3 * b + 2] - c[3 * a + 2])[0];
    return p.screenPoint(c[3 * t], c[3 * t + 1], c[3 * t + 2]);
  }, expectedFaces);
  await page.mouse.click(front.x, front.y);
  const kept = await until('the keep-in checked', () => page.evaluate(() => { const s = window.kgdStudio.studio; return !s.timer && !s.checking && s.answer?.keepIn?.length ? s.answer : null; }), 20000);
  const [again] = await Promise.all([page.waitForEvent('download', { timeout: 20000 }), page.click('#studio-save')]);
  const zip2 = unzipSync(new Uint8Array(fs.readFileSync(await again.path())));
  const scene2 = JSON.parse(new TextDecoder().decode(zip2['scene.json']));
  const keepIn = readList(new TextDecoder().decode(zip2[scene2.garment.keep_in] || new Uint8Array()));
  check(kept.valid && kept.keepIn.length > 1 && kept.keepInGarmentFaces.length === 4 * kept.keepIn.length && sameList(keepIn, kept.keepInGarmentFaces),
    `a keep-in click marks ${kept.keepIn.length} body faces, saved as their ${keepIn.length} garment faces (garment.keep_in ${scene2.garment.keep_in})`);

  // A band painted on the +x side near the region's lower edge, then Mirror: the band's mirror images
  // (the faces whose centroids mirror its faces' about x = 0) are painted too. Back to the loops' bands.
  await page.check('input[name=studio-bands][value=painted]');
  await page.check('input[name=studio-layer][value=band]');
  const edge = await page.evaluate((faces) => {
    const p = window.kgdStudio.paint, c = p.centroids;
    p.lookFrom([1, 0, 1]);
    const t = faces.filter((f) => c[3 * f] > 0.04 && c[3 * f + 2] > 0.04).sort((a, b) => c[3 * a + 1] - c[3 * b + 1])[0];
    return p.screenPoint(c[3 * t], c[3 * t + 1], c[3 * t + 2]);
  }, expectedFaces);
  await page.mouse.click(edge.x, edge.y);
  await page.click('#studio-mirror');
  await until('the mirrored bands checked', () => page.evaluate(() => { const s = window.kgdStudio.studio; return !s.timer && !s.checking && s.answer && !s.answer.mirrored; }), 20000);
  const bandMirror = await page.evaluate(() => {
    const p = window.kgdStudio.paint, c = p.centroids, band = p.layerFaces('band'), set = new Set(band);
    const mirrorOf = (t) => {
      let best = -1, d = Infinity;
      for (let u = 0; u < p.faceCount; ++u) {
        const e = Math.hypot(c[3 * u] + c[3 * t], c[3 * u + 1] - c[3 * t + 1], c[3 * u + 2] - c[3 * t + 2]);
        if (e < d) { d = e; best = u; }
      }
      return best;
    };
    return { band: band.length, left: band.filter((t) => c[3 * t] < 0).length, paired: band.every((t) => set.has(mirrorOf(t))) };
  });
  check(bandMirror.band > 2 && bandMirror.left === bandMirror.band / 2 && bandMirror.paired,
    `Mirror mirrors a painted band: ${bandMirror.band} faces, ${bandMirror.left} on the -x side, each face's mirror image painted`);
  await page.check('input[name=studio-bands][value=loops]');
  await page.check('input[name=studio-layer][value=region]');

  // Submit: the jobs view shows the job; it runs; its cut files download.
  await page.selectOption('#studio-quality', 'draft');
  await page.fill('#studio-iterations', '3');
  await page.fill('#studio-label', 'studio');
  await page.click('#studio-submit');
  const id = await until('the job in the jobs view', () => page.evaluate(() => (!document.getElementById('jobs-view').hidden && window.kgd.state.selected) || null), 20000);
  // The jobs view shows it without a reload: its garment in the 3D view, an iteration on the scrubber.
  const live = await until('the job\'s garment on screen', () => page.evaluate((id) => {
    const v = window.kgd.view, title = document.getElementById('viewer-title').textContent, scrub = document.getElementById('scrub-value').textContent;
    return v.garment && v.x && scrub !== '–' && title === `Job ${id}` ? { title, scrub, state: window.kgd.state.job?.state } : null;
  }, id), 120000).catch(() => null);
  check(!!live, `after Submit the jobs view shows job ${id}'s garment (${live ? `"${live.title}", iteration ${live.scrub}, job ${live.state}` : 'none'})`);
  const job = await waitForEnd(base, id, 120000);
  check(job.state === 'SUCCEEDED' && job.spec.label === 'studio' && job.spec.optimizer.maxIterations === 3,
    `the submitted job ${id} ends ${job.state}${job.failure ? ` (${job.failure})` : ''} after ${job.iterations} iterations`);
  const row = await until('the row SUCCEEDED', () => page.evaluate((id) => document.querySelector(`#jobs tr[data-id="${id}"] td:nth-child(3)`)?.textContent === 'SUCCEEDED'
    && document.querySelector(`#jobs tr[data-id="${id}"]`).textContent, id), 20000).catch(() => '');
  // A scene file's budget (its scene.json's, 30 %) is the chart's budget line, not 1.
  const budgetLine = await page.evaluate(() => window.kgd.charts.area.data[2]);
  check(!!row && budgetLine.length > 0 && budgetLine.every((b) => b === 0.3),
    `the job's row reaches SUCCEEDED without a reload ("${row}"); the area chart's budget line is the scene file's 0.3 (${budgetLine[0]})`);
  await until('the cut file links', () => page.evaluate(() => !!document.querySelector('#downloads a[href*="cut/report.json"]')), 20000);
  const href = await page.getAttribute('#downloads a[href*="cut/report.json"]', 'href');
  const made = await fetch(new URL(href, base));
  check(made.ok, `the page's cut file link ${href} answers ${made.status}${made.ok ? '' : `: ${await made.text()}`}`);
  const [cut] = await Promise.all([page.waitForEvent('download', { timeout: 30000 }), page.click('#downloads a[href*="cut/report.json"]')]);
  const reportPath = path.join(artifacts, cut.suggestedFilename());
  await cut.saveAs(reportPath);
  const report = JSON.parse(fs.readFileSync(reportPath, 'utf8'));
  const last = (await apiJson(base, `v1/jobs/${id}`)).iterations - 1;
  check(cut.suggestedFilename().startsWith(`job-${id}-iteration-`) && Number.isInteger(report.iteration) && report.iteration <= last,
    `its cut files download (${cut.suggestedFilename()}, iteration ${report.iteration} of 0..${last})`);
  await page.screenshot({ path: path.join(artifacts, 'job.png'), fullPage: true });

  // The built-in body: knee_flexion's parametric body at a height of 1.70 m (the default body, whose
  // scene the scene cache holds after a first run), the poses the server makes
  // (GET /v1/scenes/knee_flexion/body/...), painted with a click and checked.
  await page.goto(`${base}#studio`);
  await page.check('input[name=studio-source][value=builtin]');
  await until('the built-in scenes', () => page.evaluate(() => document.querySelectorAll('#studio-builtin-scene option').length > 0), 10000);
  await page.selectOption('#studio-builtin-scene', 'knee_flexion');
  await page.click('#studio-builtin summary');
  await page.fill('#studio-body-height_m', '1.7');
  await page.click('#studio-builtin-load');
  await until('the built-in body', () => page.evaluate(() => /^knee_flexion's body: /.test(document.getElementById('studio-builtin-note').textContent) || document.getElementById('studio-file-error').textContent), 120000);
  const served = new TextDecoder().decode(await (await fetch(`${base}v1/scenes/knee_flexion/body/rest.obj?height_m=1.7`)).arrayBuffer());
  const servedFaces = served.split('\n').filter((l) => l.startsWith('f ')).length;
  const shown = await page.evaluate(() => ({ faces: window.kgdStudio.paint.faceCount, error: document.getElementById('studio-file-error').textContent, note: document.getElementById('studio-builtin-note').textContent }));
  await page.check('input[name=studio-layer][value=region]');
  await page.locator('#studio-canvas').scrollIntoViewIfNeeded();
  const box = await page.locator('#studio-canvas').boundingBox();
  await page.mouse.click(box.x + box.width / 2, box.y + box.height / 2);
  const builtin = await until('the built-in body\'s region checked', () => page.evaluate(() => { const s = window.kgdStudio.studio; return !s.timer && !s.checking && s.answer ? s.answer : null; }), 20000);
  check(!shown.error && shown.faces === servedFaces && builtin.valid && builtin.faces.length > 1,
    `the built-in body (${shown.note || shown.error}) shows the served rest pose's ${servedFaces} faces; a click paints a valid region of ${builtin.faces.length} faces`);
  await page.screenshot({ path: path.join(artifacts, 'builtin.png'), fullPage: true });
  fs.rmSync(tmp, { recursive: true, force: true });
});
