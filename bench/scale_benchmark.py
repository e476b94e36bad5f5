#!/usr/bin/env python3
"""How one design server scales with worker processes (docs/SCALING.md).

For each worker count W: a fresh kgd-server on a temporary data folder, W kgd-worker processes, J jobs
queued at once; measured until every job has ended:
  throughput   iterations stored per second (all jobs), and jobs per minute
  server CPU   the kgd-server process's user + system time per stored iteration
  commits/s    SQLite commits per second: one per stored iteration plus one per lease, renewal or
               state change (counted from the server's figures at /metrics: iterations stored, and the
               jobs' attempts)
With one worker, also the worker's own seconds per iteration (the mean `total_s` of every job's
iterations after the first, replayed by `kgd watch`), and from it and the server's CPU per iteration of
the same run how many such workers one server core sustains (`sustain`).

Usage: bench/scale_benchmark.py [--build build] [--workers 1,2,4,8] [--jobs 20] [--scene sleeve_on_limb]
                                [--iterations 60] [--threads 1] [--json FILE]
--threads is OMP_NUM_THREADS per worker (the machine's cores are shared by all workers); --json writes
one object ("kind": "scale") for bench/tables.py (`make bench`: docs/SCALING.md).
"""
import argparse
import json
import os
import re
import shutil
import socket
import subprocess
import tempfile
import time
import urllib.request


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def cpu_seconds(pid):
    fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def metric(text, name):
    m = re.search(rf"^{re.escape(name)} (\S+)$", text, re.M)
    return float(m.group(1)) if m else 0.0


def worker_seconds_per_iteration(kgd, server, ids):
    """The mean `total_s` of the jobs' iterations after the first (cold) one, replayed by `kgd watch --json`."""
    seconds = []
    for i in ids:
        out = subprocess.run([kgd, "watch", str(i), "--json", "--server", server], capture_output=True, text=True).stdout
        for line in out.splitlines():
            try:
                j = json.loads(line)
            except ValueError:
                continue
            m = j.get("metrics", j)
            if isinstance(m, dict) and m.get("iteration", 0) > 0 and "total_s" in m:
                seconds.append(m["total_s"])
    return sum(seconds) / len(seconds) if seconds else 0.0


def sustain(one_worker):
    """How many workers like the measured one a server core sustains: a worker stores one iteration every
    worker_s_per_iteration seconds, each costing the server server_cpu_ms_per_iteration of CPU; and the
    iterations per second the store's one writer lock lets through (one HDF5 append and one SQLite commit
    each). None without the worker's rate."""
    w, cpu = one_worker.get("worker_s_per_iteration", 0.0), one_worker["server_cpu_ms_per_iteration"]
    if w <= 0 or cpu <= 0:
        return None
    store_ms = one_worker["hdf5_ms_per_iteration"] + one_worker["sqlite_ms_per_commit"]
    return {"worker_s_per_iteration": w, "worker_iterations_per_s": 1 / w, "server_cpu_ms_per_iteration": cpu,
            "workers_per_server_core": w / (cpu / 1000), "store_ms_per_iteration": store_ms,
            "store_iterations_per_s": 1000 / store_ms if store_ms > 0 else 0.0}


def run(build, workers, jobs, scene, iterations, threads):
    tmp = tempfile.mkdtemp(prefix="kgd_scale_")
    grpc, http = free_port(), free_port()
    kgd = os.path.join(build, "client", "kgd")
    server = subprocess.Popen([os.path.join(build, "server", "kgd-server"), "--data", tmp + "/data", "--listen", f"127.0.0.1:{grpc}",
                               "--http", f"127.0.0.1:{http}", "--quiet", "--max-queued-per-user", "0", "--max-jobs-per-minute", "0"],
                              stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    while "http on" not in server.stdout.readline():
        pass
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    procs = [subprocess.Popen([os.path.join(build, "worker", "kgd-worker"), "--server", f"127.0.0.1:{grpc}", "--quiet", "--name", f"w{i}"],
                              env=env) for i in range(workers)]
    try:
        cpu0 = cpu_seconds(server.pid)
        t0 = time.time()
        for _ in range(jobs):
            subprocess.run([kgd, "submit", scene, "--iterations", str(iterations), "--server", f"127.0.0.1:{grpc}", "--json"],
                           check=True, capture_output=True)
        while True:
            listed = json.loads(subprocess.run([kgd, "jobs", "--json", "--limit", "1000", "--server", f"127.0.0.1:{grpc}"],
                                               check=True, capture_output=True, text=True).stdout)
            if all(j["state"] in ("SUCCEEDED", "FAILED", "CANCELLED") for j in listed):
                break
            time.sleep(0.2)
        seconds = time.time() - t0
        cpu = cpu_seconds(server.pid) - cpu0
        text = urllib.request.urlopen(f"http://127.0.0.1:{http}/metrics").read().decode()
        stored = metric(text, "kgd_iterations_total")
        states = sum(1 for j in listed if j["state"] == "SUCCEEDED")
        # One commit per iteration, per lease, per job end; renewals ride on the iteration commits.
        commits = stored + 2 * jobs
        worker_s = worker_seconds_per_iteration(kgd, f"127.0.0.1:{grpc}", [j["id"] for j in listed]) if workers == 1 else 0.0
        return {"workers": workers, "worker_s_per_iteration": worker_s, "jobs": jobs, "succeeded": states, "iterations": int(stored), "seconds": seconds,
                "iterations_per_s": stored / seconds, "jobs_per_min": 60 * jobs / seconds, "server_cpu_ms_per_iteration": 1000 * cpu / stored,
                "commits_per_s": commits / seconds,
                "sqlite_ms_per_commit": 1000 * metric(text, "kgd_sqlite_commit_seconds_sum") / max(1, metric(text, "kgd_sqlite_commit_seconds_count")),
                "hdf5_ms_per_iteration": 1000 * metric(text, "kgd_hdf5_write_seconds_sum") / max(1, metric(text, "kgd_hdf5_write_seconds_count"))}
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            p.wait()
        server.terminate()
        server.wait()
        shutil.rmtree(tmp, ignore_errors=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--workers", default="1,2,4,8")
    ap.add_argument("--jobs", type=int, default=20)
    ap.add_argument("--scene", default="sleeve_on_limb")
    ap.add_argument("--iterations", type=int, default=60)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--json", default="")
    a = ap.parse_args()
    print(f"{os.cpu_count()} cores; {a.jobs} jobs of {a.scene}, up to {a.iterations} iterations; OMP_NUM_THREADS={a.threads} per worker")
    print("| workers | jobs/min | iterations/s | server CPU per iteration | SQLite commits/s | SQLite per commit | HDF5 per iteration |")
    print("|---|---|---|---|---|---|---|")
    runs = []
    for w in [int(x) for x in a.workers.split(",")]:
        r = run(a.build, w, a.jobs, a.scene, a.iterations, a.threads)
        runs.append(r)
        print(f"| {w} | {r['jobs_per_min']:.1f} | {r['iterations_per_s']:.1f} | {r['server_cpu_ms_per_iteration']:.2f} ms | "
              f"{r['commits_per_s']:.1f} | {r['sqlite_ms_per_commit']:.2f} ms | {r['hdf5_ms_per_iteration']:.2f} ms |"
              + ("" if r["succeeded"] == r["jobs"] else f" ({r['succeeded']} of {r['jobs']} succeeded)"), flush=True)
    one = next((r for r in runs if r["workers"] == 1), None)
    s = sustain(one) if one else None
    if s:
        print(f"one worker: {s['worker_s_per_iteration']:.3f} s per iteration; one server core sustains {s['workers_per_server_core']:.0f} such workers; "
              f"the store's lock {s['store_iterations_per_s']:.0f} iterations/s")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"kind": "scale", "scene": a.scene, "jobs": a.jobs, "iterations": a.iterations, "threads": a.threads,
                       "cores": os.cpu_count(), "runs": runs, "sustain": s}, f, indent=1)


if __name__ == "__main__":
    main()
