// What a job's row in the page's list says (client/web/job_status.js), in Node without a browser: a job
// running counts down, a job stopped part-way and queued again says it waits to resume and on which
// kernel level's worker (a job resumes only on a worker of its iterations' level: server/job_store.h),
// an ended one gives its last iteration, a paused one (the server cannot store: its disk is full) why.
//   node tests/web/job_status_test.mjs
import assert from 'node:assert/strict';
import { jobNote, progressOf } from '../../client/web/job_status.js';

const job = { state: 'RUNNING', iterations: 11, kernels: 'x86-64-v3', spec: { optimizer: {} },
              last: { iteration: 10, densityRatio: 1.5, areaFraction: 0.8, totalS: 0.1 } };
const running = progressOf(job, 0.15);
assert.match(running.text, /^iteration 10, ratio 1\.50 · ~\d+ s left$/);
assert.ok(running.fraction > 0 && running.fraction < 1, `fraction ${running.fraction}`);

const waiting = progressOf({ ...job, state: 'QUEUED' }, 0.15);
assert.equal(waiting.text, 'iteration 10, ratio 1.50 · waits to resume on an x86-64-v3 worker');
assert.equal(waiting.fraction, running.fraction, 'a waiting job keeps its progress');
assert.equal(progressOf({ ...job, state: 'QUEUED', kernels: 'unknown' }, 0.15).text, 'iteration 10, ratio 1.50 · waits to resume');
assert.equal(progressOf({ ...job, state: 'QUEUED', iterations: 0, last: undefined }, 0.15).text, 'waiting');
assert.deepEqual(progressOf({ ...job, state: 'SUCCEEDED' }, 0.15), { text: 'iteration 10, ratio 1.50', fraction: 1 });
// A job the server cannot store for now (its disk is full) says so, with its progress kept.
const reason = "the server's disk is full (data folder /srv/kgd, 0 bytes free)";
const paused = progressOf({ ...job, paused: reason }, 0.15);
assert.equal(paused.text, `iteration 10, ratio 1.50 · paused: ${reason}`);
assert.equal(paused.fraction, running.fraction, 'a paused job keeps its progress');
assert.equal(progressOf({ ...job, paused: reason, iterations: 0, last: undefined }, 0.15).text, `paused: ${reason}`);
assert.deepEqual(jobNote({ ...job, id: 7, paused: reason }),
                 { kind: 'paused', text: `Job 7 paused: ${reason}; it continues by itself when the server can store again` });
console.log('job_status: ok');
