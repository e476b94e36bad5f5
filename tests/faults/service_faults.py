#!/usr/bin/env python3
"""Random system faults in the design service (`kgd serve`), injected by Debian's libfiu (fiu-run's POSIX preload).

The service half of tests/faults/fault_injection.py, with its fault kinds, its job and its reading of a
design file (`kgd designs --json`). Each run starts `kgd serve --data DIR --listen 127.0.0.1:0` (one
in-process worker, no HTTP door) under `fiu-run -x` failing one kind of call at random with the run's
seed (FIU_PRNG_SEED); allocation faults, and the kinds "write, from iteration 1" and "open, from
iteration 1", are enabled through fiu-ctrl once the job has stored its first iteration. A client without faults submits the job (`kgd submit`) and follows it (`kgd job N --json`,
every 0.2 s). Every run is judged against the uninterrupted local `kgd design` of the same job:

  same design     the job SUCCEEDED under faults and its design file (DATA/jobs/job-N.h5) holds the
                  uninterrupted run's iterations
  paused          the job paused with a named reason (the server keeps the lease and retries); it then
                  ended with the same design by itself, or, still paused after the faulty phase's time,
                  once the server was stopped and started again on the data folder without faults
  stopped         the server exited naming an error, or was killed by a signal under allocation faults
                  (gRPC and the C++ runtime abort on a failed allocation), or aborted naming a failed
                  allocation under mmap faults; started again on the same data folder without faults,
                  the job ended with the same design
  named error     the job FAILED, or the server refused it, with a message; what the job stored, once
                  the server has started again on the folder without faults, reads back (`kgd check`)
                  and is the uninterrupted run's first iterations
  anything else   a crash under a kind other than allocation, a server or job that answers nothing or
                  makes no progress within the time allowed, a job that ends with another design or no
                  design, a failure without a message, or a restart without faults that does not end at
                  the same design: a defect

Every process runs on loopback and is bounded in time; each server is stopped (SIGTERM, then SIGKILL)
by its process id at the end of its phase. The summary table is printed; the exit status is non-zero
when any run is "anything else". `make faults` runs it at length and writes docs/RELIABILITY.md's block
reliability-faults-service.

    python3 tests/faults/service_faults.py --kgd build/client/kgd --runs 20 --seed 1
"""
import argparse
import json
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fault_injection as fi  # noqa: E402  (the local half: fault kinds, job, reading a design file)

# The local half's kinds, and write and open faults enabled once the job has stored its first iteration
# (from the start, most of them stop the server at its first write or open, before any job runs).
KINDS = {kind: (kind, kind in fi.MID_RUN) for kind in fi.KINDS}
KINDS.update({"write, from iteration 1": ("write", True), "open, from iteration 1": ("open", True)})
DEFAULT_KINDS = ["write", "write, from iteration 1", "fsync", "open", "open, from iteration 1", "mmap", "allocation"]
OUTCOMES = ["same design", "paused", "stopped", "named error", "anything else"]
START_S = 30  # a server prints "listening on" within this
FAULTY_S = 45  # the job under faults ends within this, or the run goes on without faults
CLEAN_S = 90  # without faults, a restarted server's job ends within this
DRAIN_S = 15  # a stopped server exits within this after SIGTERM, or is killed
POLL_S = 0.2


class Server:
    """One `kgd serve` process on a data folder, optionally under fiu-run, its output in a log file."""

    def __init__(self, kgd, data, log, env, fiu=None, ctrl=None):
        cmd = [kgd, "serve", "--data", data, "--listen", "127.0.0.1:0", "--no-http", "--workers", "1", "--lease-s", "5",
               "--drain-s", "10"]
        if fiu is not None:
            pre = ["fiu-run", "-x", "-f", ctrl or ""]
            for c in fiu:
                pre += ["-c", c]
            cmd = pre + cmd
        self.log = log
        self.offset = os.path.getsize(log) if os.path.exists(log) else 0  # this process's output starts here
        with open(log, "ab") as out:
            self.p = subprocess.Popen(cmd, env=env, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                      start_new_session=True)

    def text(self):
        try:
            with open(self.log, "rb") as f:
                f.seek(self.offset)
                return f.read().decode(errors="replace")
        except OSError:
            return ""

    def address(self, timeout):
        """host:port once the server listens; None when it exits or does not listen in time."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            m = re.search(r"listening on (127\.0\.0\.1:\d+);", self.text())
            if m:
                return m.group(1)
            if self.p.poll() is not None:
                return None
            time.sleep(0.05)
        return None

    def exited(self):
        return self.p.poll()

    def stop(self):
        """SIGTERM (the server drains), SIGKILL after DRAIN_S; the exit code."""
        if self.p.poll() is None:
            try:
                self.p.send_signal(signal.SIGTERM)
                self.p.wait(timeout=DRAIN_S)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait(timeout=30)
        return self.p.returncode

    def last_words(self):
        lines = [line for line in self.text().splitlines() if line.strip() and not line.startswith("{")]
        return " | ".join(lines[-3:])[-400:]


def client(kgd, args, timeout=15):
    """(exit code, stdout, stderr) of a kgd client command without faults; exit None on a timeout."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("FIU_") and k != "LD_PRELOAD"}
    try:
        r = subprocess.run([kgd, *args], env=env, capture_output=True, text=True, timeout=timeout)
        return r.returncode, r.stdout, r.stderr
    except subprocess.TimeoutExpired:
        return None, "", "timeout"


def get_job(kgd, address, job_id):
    code, out, err = client(kgd, ["job", str(job_id), "--json", "--server", address])
    if code != 0:
        return None, (err or out).strip()
    try:
        return json.loads(out), ""
    except ValueError:
        return None, f"not JSON: {out[:200]}"


def submit(kgd, address):
    """(job id or None, message)."""
    code, out, err = client(kgd, ["submit", *fi.JOB, "--json", "--server", address], timeout=30)
    if code == 0:
        try:
            return json.loads(out)["id"], ""
        except (ValueError, KeyError):
            return None, f"submit printed no job: {out[:200]}"
    return None, (err or out).strip() or f"exit {code} without a message"


def follow(kgd, server, address, job_id, timeout, on_progress=None):
    """Polls the job until it ends, the server exits or `timeout` passes.

    Returns (job or None, paused reasons seen, client errors seen)."""
    end = time.monotonic() + timeout
    paused, errors, job = [], [], None
    while time.monotonic() < end:
        if server.exited() is not None:
            break
        got, err = get_job(kgd, address, job_id)
        if got is None:
            errors.append(err)
        else:
            job = got
            if job.get("paused") and job["paused"] not in paused:
                paused.append(job["paused"])
            if on_progress:
                on_progress(job)
            if job.get("state") in ("SUCCEEDED", "FAILED", "CANCELLED"):
                return job, paused, errors
        time.sleep(POLL_S)
    return job, paused, errors


def stored_prefix(kgd, ref, path):
    """None when what `path` stores reads back and is the reference's first iterations; else what is wrong."""
    if not os.path.exists(path):
        return None
    code, out, err = client(kgd, ["check", path], timeout=60)
    if code not in (0, 5):
        return f"kgd check exit {code}: {(out + err).strip()[-200:]}"
    got = fi.designs(kgd, path)
    if got is None:
        return f"its iterations do not read back (kgd check exit {code}: {(out + err).strip()[-200:]})"
    if got != ref[:len(got)]:
        return "its stored iterations differ from the uninterrupted run's"
    return None


def finish_without_faults(kgd, ref, data, log, env, job_id):
    """Starts the server again on `data` without faults; (True, "") when job `job_id` (submitted anew
    when None) ends SUCCEEDED with the reference's design, else (False, what happened)."""
    server = Server(kgd, data, log, env)
    try:
        address = server.address(START_S)
        if address is None:
            return False, f"the restart without faults did not listen (exit {server.exited()}): {server.last_words()}"
        if job_id is None:
            job_id, message = submit(kgd, address)
            if job_id is None:
                return False, f"the restart without faults refused the job: {message[-200:]}"
        job, _, errors = follow(kgd, server, address, job_id, CLEAN_S)
        if server.exited() is not None:
            return False, f"the restart without faults exited ({server.exited()}): {server.last_words()}"
        if job is None or job.get("state") not in ("SUCCEEDED", "FAILED", "CANCELLED"):
            state = job.get("state") if job else f"unanswered ({errors[-1][:120] if errors else ''})"
            return False, f"without faults the job did not end within {CLEAN_S} s: {state}"
        if job["state"] != "SUCCEEDED":
            return False, f"without faults the job ended {job['state']}: {job.get('failure', '')[:200]}"
        if fi.designs(kgd, os.path.join(data, "jobs", f"job-{job_id}.h5")) != ref:
            return False, "without faults the job ended with another design"
        return True, ""
    finally:
        code = server.stop()
        if code not in (0, None) and code != -signal.SIGTERM:
            print(f"service_faults: the server without faults exited {code}: {server.last_words()}", file=sys.stderr)


def one_run(kgd, ref, work, env, kind, seed, errno, probability, index):
    """(outcome, detail) of one run."""
    points, _ = fi.KINDS[KINDS[kind][0]]
    commands = [f"enable_random name={point},probability={probability},failinfo={errno}" for point in points]
    data = os.path.join(work, f"run{index:04d}_{KINDS[kind][0]}")
    log = data + ".log"
    faulty_env = dict(env, FIU_PRNG_SEED=str(seed))
    mid_run = KINDS[kind][1]
    ctrl = os.path.join(work, f"fiu-{index:04d}") if mid_run else None
    server = Server(kgd, data, log, faulty_env, fiu=[] if mid_run else commands, ctrl=ctrl)
    job_id, job, paused, note = None, None, [], ""
    enabled = [False]

    def enable(job_now):
        if mid_run and not enabled[0] and job_now.get("iterations", 0) >= 1:
            c = []
            for command in commands:
                c += ["-c", command]
            enabled[0] = True
            try:  # fiu-ctrl waits for the answer on the control pipe, which a process failing allocations may never write
                subprocess.run(["fiu-ctrl", "-f", ctrl, *c, str(server.p.pid)], capture_output=True, timeout=10)
            except subprocess.TimeoutExpired:
                pass

    try:
        address = server.address(START_S)
        if address is None and server.exited() is None:
            return "anything else", f"hang: no 'listening on' within {START_S} s"
        if address is not None:
            job_id, message = submit(kgd, address)
            if job_id is None:
                if server.exited() is None and "kgd submit: " not in message and "kgd: " not in message:
                    return "anything else", f"the job was refused without a message: {message[-200:]}"
                note = f"refused the job: {message.splitlines()[-1][:200] if message else ''}"
            else:
                job, paused, errors = follow(kgd, server, address, job_id, FAULTY_S, enable)
        state = job.get("state") if job else None
        exited = server.exited()
        if exited is None:
            if state == "SUCCEEDED":
                got = fi.designs(kgd, os.path.join(data, "jobs", f"job-{job_id}.h5"))
                if got != ref:
                    return "anything else", "SUCCEEDED with another design or an unreadable file"
                if paused:
                    return "paused", paused[0][:200]
                return "same design", ""
            if state == "FAILED":
                if not job.get("failure"):
                    return "anything else", "FAILED without a message"
                # What it stored, as the next server finds it: the server started again on the folder
                # (without faults) repairs the design files a failed writer left before it reads them.
                server.stop()
                clean = Server(kgd, data, log, env)
                listening = clean.address(START_S)
                clean.stop()
                if listening is None:
                    return "anything else", f"FAILED ({job['failure'][:150]}), and the server does not start again: {clean.last_words()}"
                wrong = stored_prefix(kgd, ref, os.path.join(data, "jobs", f"job-{job_id}.h5"))
                if wrong:
                    return "anything else", f"FAILED ({job['failure'][:150]}), and {wrong}"
                return "named error", f"FAILED: {job['failure'][:200]}"
            if state == "CANCELLED":
                return "anything else", "CANCELLED, and nobody cancelled it"
            if job_id is not None and not paused:
                where = f"{state}, {job.get('iterations')} iterations" if job else "never answered"
                return "anything else", f"hang: the job did not end within {FAULTY_S} s ({where})"
            if job_id is not None and job.get("paused") is None and paused:
                pass  # paused before, running now and slow: judged by the restart below
        # The server exited, refused the job, or the job is paused at the end of the faulty phase: the
        # server is stopped and started again without faults, and the job must end with the same design.
        code = server.stop()
        words = server.last_words()
        if exited is not None:
            # Memory that cannot be had ends the process: any signal under allocation faults, and an abort
            # naming it under mmap faults (ENOMEM to an allocator: abseil's, in gRPC, aborts "mmap error: 12").
            out_of_memory = exited == -signal.SIGABRT and re.search(r"mmap error: 12|bad_alloc|out of memory|Cannot allocate memory", words)
            if exited < 0 and not (KINDS[kind][0] == "allocation" or (KINDS[kind][0] == "mmap" and out_of_memory)):
                return "anything else", f"killed by signal {-exited}: {words}"
            if exited > 0 and not words:
                return "anything else", f"exit {exited} without a message"
        ok, why = finish_without_faults(kgd, ref, data, log, env, job_id)
        if not ok:
            return "anything else", (f"server exit {exited}: {words[-200:]}; " if exited is not None else "") + why
        if exited is not None:
            return "stopped", f"exit {exited}: {words[-200:]}" if exited >= 0 else f"signal {-exited}: {words[-200:]}"
        if paused:
            return "paused", paused[0][:200]
        return "named error", note
    finally:
        if server.exited() is None:
            server.stop()
        if ctrl:
            for suffix in (".in", ".out"):
                try:
                    os.remove(f"{ctrl}-{server.p.pid}{suffix}")
                except OSError:
                    pass


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--kgd", required=True)
    p.add_argument("--runs", type=int, default=20)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--kinds", default=";".join(DEFAULT_KINDS), help="semicolon-separated: " + "; ".join(KINDS))
    p.add_argument("--probability", type=float, default=0.01, help="of each call of the chosen kind failing")
    p.add_argument("--keep", help="keep the runs' data folders and logs in this folder")
    p.add_argument("--write-docs", metavar="FILE", help="write the summary into FILE's block reliability-faults-service")
    a = p.parse_args()
    if not shutil.which("fiu-run"):
        print("service_faults: fiu-run (Debian's fiu-utils) is not installed; skipped")
        return 0
    kgd = os.path.abspath(a.kgd)
    work = os.path.abspath(a.keep or tempfile.mkdtemp(prefix="kgd_service_faults_"))
    os.makedirs(work, exist_ok=True)
    env = {k: v for k, v in os.environ.items() if not k.startswith("FIU_") and k != "LD_PRELOAD"}
    env.setdefault("KGD_CACHE_DIR", os.path.join(work, "cache"))
    ref_path = os.path.join(work, "reference.h5")
    code, out = fi.run([kgd, "design", *fi.JOB, "--overwrite", "--out", ref_path], env=env)
    if code != 0:
        print(f"service_faults: the reference run failed (exit {code}): {out[-500:]}")
        return 1
    ref = fi.designs(kgd, ref_path)
    kinds = [k.strip() for k in a.kinds.split(";") if k.strip()]
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        p.error(f"unknown fault kinds {unknown}: choose from " + "; ".join(KINDS))
    rng = random.Random(a.seed)
    counts = {k: dict({"runs": 0}, **{o: 0 for o in OUTCOMES}) for k in kinds}
    defects, samples = [], {}
    started = time.monotonic()
    for i in range(a.runs):
        kind = kinds[i % len(kinds)]
        seed = rng.randrange(1, 2**31)
        errno = rng.choice(fi.KINDS[KINDS[kind][0]][1])
        t = time.monotonic()
        outcome, detail = one_run(kgd, ref, work, env, kind, seed, errno, a.probability, i)
        print(f"run {i} ({kind}, errno {errno}, FIU_PRNG_SEED={seed}): {outcome}{': ' + detail if detail else ''} "
              f"({time.monotonic() - t:.1f} s)", flush=True)
        counts[kind]["runs"] += 1
        counts[kind][outcome] += 1
        if outcome == "anything else":
            defects.append(f"run {i} ({kind}, errno {errno}, FIU_PRNG_SEED={seed}): {detail}")
        elif detail:
            samples.setdefault((kind, outcome), detail)
        if not a.keep:
            for f in os.listdir(work):
                if f.startswith(f"run{i:04d}_"):
                    path = os.path.join(work, f)
                    shutil.rmtree(path, ignore_errors=True) if os.path.isdir(path) else os.remove(path)
    elapsed = time.monotonic() - started
    lines = [f"{a.runs} runs of `kgd serve` (one in-process worker) under `fiu-run -x` from seed {a.seed}, each call of the run's "
             f"kind failing with probability {a.probability} (a seed per run; allocation, and the rows 'from iteration 1', enabled through fiu-ctrl once the job has stored its first iteration), "
             f"each running `kgd submit {' '.join(fi.JOB)}` judged against the uninterrupted local `kgd design` "
             f"({elapsed / max(a.runs, 1):.1f} s a run):", "",
             "| fault kind | runs | same design | paused, then same design | server stopped, restarted: same design | named error | anything else |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    total = dict({"runs": 0}, **{o: 0 for o in OUTCOMES})
    for k in kinds:
        c = counts[k]
        lines.append(f"| {k} | {c['runs']} | " + " | ".join(str(c[o]) for o in OUTCOMES) + " |")
        for key in total:
            total[key] += c[key]
    lines.append(f"| all | {total['runs']} | " + " | ".join(str(total[o]) for o in OUTCOMES) + " |")
    lines += [f"- defect: {d}" for d in defects]
    print("\n".join(lines))
    for (k, o), m in samples.items():
        print(f"{o} ({k}): {m[:300]}")
    if a.write_docs:
        root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        machine = subprocess.run([kgd, "machine"], capture_output=True, text=True).stdout.strip()
        command = f"python3 tests/faults/service_faults.py --runs {a.runs} --seed {a.seed} --probability {a.probability}"
        subprocess.run([sys.executable, os.path.join(root, "scripts", "generated_block.py"), "replace", a.write_docs,
                        "reliability-faults-service", "--command", command, "--machine", machine],
                       input="\n".join(lines) + "\n", text=True, check=True)
    if not a.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if defects else 0


if __name__ == "__main__":
    sys.exit(main())
