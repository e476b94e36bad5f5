// The page and the design service telling a designer what they will refuse and how a job went, in
// headless Chromium against a real `kgd serve` (harness.mjs): a body of 5 m refused on the page, next
// to its field, with no request sent; a photo chosen as a scene's garment OBJ refused on the page with
// a message that names the file and quotes its first line escaped (never raw bytes), and the server's
// own refusal of the same upload in the same words; a job that fails on the worker (a garment mesh
// without faces) shows its reason above the 3D view; a sleeve job limited to 3 iterations, far from its
// budget, says above the view and in the API that it stopped at the iteration limit above the budget,
// and while its final design is evaluated its row says so instead of counting down iterations.
// Screenshots go to --artifacts.
//   node tests/web/service_test.mjs --kgd build/client/kgd --artifacts build/test-artifacts/web/service
import path from 'node:path';
import { runBrowserTest, submitJob, waitForEnd, apiJson } from './harness.mjs';

const PNG = Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0, 0, 0, 0x0d, 0x49, 0x48, 0x44, 0x52, 0, 0, 0, 0x10]);
// Text a person can read: no control characters, no replacement characters (bytes that were not text).
const printable = (s) => !/[\u0000-\u0008\u000b-\u001f\u007f\ufffd]/.test(s);
const jobCount = async (base) => ((await apiJson(base, 'v1/jobs?pageSize=1000')).jobs || []).length;
const note = (page) => page.evaluate(() => { const n = document.getElementById('job-note'); return n.hidden ? '' : n.textContent; });

await runBrowserTest('service', async ({ page, base, check, until, artifacts }) => {
  // -- A body of 5 m: refused on the page, next to the body's fields, before any request.
  await page.selectOption('#scene', 'knee_flexion');
  await page.click('#body-details summary');
  await page.fill('#body-height_m', '5');
  await page.click('#submit-button');
  const bodyError = await until('the body error', () => page.textContent('.error[data-for="body"]'), 5000);
  check(bodyError === 'spec.body: body measurement height_m = 5 is outside [1.2, 2.2]', `a 5 m body is refused next to the body's fields: "${bodyError}"`);
  check(await page.evaluate(() => document.getElementById('body-height_m').classList.contains('invalid')), 'the height field is marked');
  check(await jobCount(base) === 0, 'no job was sent');
  await page.screenshot({ path: path.join(artifacts, 'refused_body.png') });
  await page.fill('#body-height_m', '');

  // -- A photo as the garment's OBJ: refused on the page in words, and by the server in the same words.
  await page.check('input[name=source][value=upload]');
  await page.setInputFiles('#scene-file', { name: 'scene.json', mimeType: 'application/json', buffer: Buffer.from('{"garment": {"rest": "garment.obj"}, "budget": 0.3}') });
  await page.setInputFiles('#mesh-files', { name: 'garment.obj', mimeType: 'application/octet-stream', buffer: PNG });
  await page.click('#submit-button');
  const uploadError = await until('the upload error', () => page.textContent('.error[data-for="scene"]'), 5000);
  check(uploadError === 'scene: garment.obj is not an OBJ or PLY mesh (line 1: "\\x89PNG" is not text)', `a PNG named garment.obj: "${uploadError}"`);
  check(printable(uploadError), 'the message quotes no raw bytes');
  check(await jobCount(base) === 0, 'no job was sent');
  const form = new FormData();
  form.append('scene', new Blob(['{"garment": {"rest": "garment.obj"}}']), 'scene.json');
  form.append('garment.obj', new Blob([PNG]), 'garment.obj');
  const served = await (await fetch(`${base}v1/jobs`, { method: 'POST', body: form })).json();
  check(served.error?.message === 'spec.scene_files.scene.garment.rest: garment.obj is not an OBJ or PLY mesh (line 1: "\\x89PNG" is not text)',
    `the server refuses it at submission: "${served.error?.message}"`);
  await page.screenshot({ path: path.join(artifacts, 'refused_upload.png') });

  // -- A job the worker fails (a garment without faces): its reason above the 3D view.
  const failing = new FormData();
  failing.append('scene', new Blob(['{"name": "faceless", "garment": {"rest": "garment.obj"}}']), 'scene.json');
  failing.append('garment.obj', new Blob(['v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\n']), 'garment.obj');
  const failed = await (await fetch(`${base}v1/jobs`, { method: 'POST', body: failing })).json();
  check(failed.state === 'QUEUED', `a scene the server cannot judge without loading it is queued (${failed.state ?? JSON.stringify(failed)})`);
  const failedJob = await waitForEnd(base, failed.id, 60000);
  check(failedJob.state === 'FAILED' && failedJob.failure, `the worker fails it: ${failedJob.failure}`);
  await until('the failed job in the list', () => page.$(`#jobs tr[data-id="${failed.id}"]`), 10000);
  await page.click(`#jobs tr[data-id="${failed.id}"]`);
  const failedNote = await until('the failed job\'s note', () => note(page), 10000);
  check(failedNote === `Job ${failed.id} failed: ${failedJob.failure}`, `the reason above the view: "${failedNote}"`);
  check(await page.evaluate(() => getComputedStyle(document.getElementById('job-note')).display !== 'none'), 'the note is shown, not a tooltip');
  await page.screenshot({ path: path.join(artifacts, 'failed_job.png') });

  // -- Three iterations, far from the budget: the job says how it ended; while its final design is
  // evaluated, its row says so.
  await page.check('input[name=source][value=builtin]');
  const id = await submitJob(page, { scene: 'sleeve_on_limb', budget: 0.3, maxIterations: 3, label: 'three' });
  let evaluating = '';
  const done = await until(`job ${id} to end`, async () => {
    const row = await page.evaluate((i) => document.querySelector(`#jobs tr[data-id="${i}"]`)?.children[3]?.textContent || '', id);
    if (row.includes('evaluating the final design')) evaluating = row;
    const j = await apiJson(base, `v1/jobs/${id}`);
    return ['SUCCEEDED', 'FAILED', 'CANCELLED'].includes(j.state) ? j : null;
  }, 60000);
  check(done.state === 'SUCCEEDED', `the job succeeded (${done.state} ${done.failure || ''})`);
  const area = (100 * done.last.areaFraction).toFixed(1);
  const sentence = `stopped at the iteration limit (3) at ${area} % of the garment, above the budget of 30 %`;
  check(done.ended === sentence, `the API says how it ended: "${done.ended}"`);
  const endedNote = await until('the ended note', async () => { const t = await note(page); return t.includes('iteration limit') ? t : null; }, 10000);
  check(endedNote === `Job ${id} ${sentence}`, `the page says it above the view: "${endedNote}"`);
  const row = await page.evaluate((i) => document.querySelector(`#jobs tr[data-id="${i}"]`).children[3].textContent, id);
  check(!row.includes('left'), `an ended job counts nothing down: "${row.trim()}"`);
  console.log(evaluating ? `seen while evaluating: "${evaluating.trim()}"` : '(the evaluation ended between two looks at the row)');
  check(!evaluating || !evaluating.includes('left'), 'while evaluating, no countdown of iterations');
  await page.screenshot({ path: path.join(artifacts, 'ended_job.png') });
});
