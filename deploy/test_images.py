#!/usr/bin/env python3
"""Runs kgd's images (deploy/images.sh builds them) with buildah, on loopback, as a lab would:

  - the server image's ENTRYPOINT and CMD (listen addresses moved to free loopback ports, a 3 s lease),
    with the TLS certificate and token file of deploy/make-secrets.sh mounted where the CMD reads them;
    its HEALTHCHECK command answers;
  - two worker images with the worker token, over TLS; every image runs as uid 10001;
  - a design job submitted from the cli image with a user's token; the worker running it is killed
    (SIGKILL) mid-job and a new one started: the job ends SUCCEEDED with every iteration, and its density
    ratio and reinforced area are those of `kgd design` of the same scene outside the images, bit for bit;
  - twenty jobs from four users, each with their own token, while the worker running one is killed: every
    job ends SUCCEEDED, each user lists exactly their own jobs and cannot read another's.

Usage: deploy/test_images.py [--kgd build/client/kgd]   (root; buildah; prints each step and its time)
"""
import argparse
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ENV = dict(os.environ, STORAGE_DRIVER="vfs", BUILDAH_ISOLATION="chroot")
UID = 10001
RATIO_JOB = ["knee_flexion", "--iterations", "30"]          # the job compared with `kgd design`
SMALL_JOB = ["sleeve_on_limb", "--iterations", "3", "--budget", "0.3"]
USERS = ["alice", "bob", "carol", "dave"]
T0 = time.monotonic()
failures = []


def log(msg):
    print(f"[{time.monotonic() - T0:6.1f} s] {msg}", flush=True)


def check(ok, what):
    log(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)
    return ok


def buildah(*args, check_rc=True):
    r = subprocess.run(["buildah", *args], env=ENV, capture_output=True, text=True)
    if check_rc and r.returncode != 0:
        raise RuntimeError(f"buildah {' '.join(args)}: {r.stderr.strip()}")
    return r.stdout.strip()


def free_ports(n):
    socks = [socket.socket() for _ in range(n)]
    for s in socks:
        s.bind(("127.0.0.1", 0))
    ports = [s.getsockname()[1] for s in socks]
    for s in socks:
        s.close()
    return ports


def pids_with_arg(marker):
    """Processes whose command line has the argument `marker` (unique per container of this run)."""
    found = []
    for d in os.listdir("/proc"):
        if not d.isdigit():
            continue
        try:
            with open(f"/proc/{d}/cmdline", "rb") as f:
                args = f.read().split(b"\0")
        except OSError:
            continue
        if marker.encode() in args and not args[0].endswith(b"buildah"):
            found.append(int(d))
    return found


class Container:
    """A working container of an image; its commands run with `buildah run` (chroot, host network)."""

    def __init__(self, image, name, volumes=(), env=()):
        self.image, self.name = image, name
        self.id = buildah("from", "--pull=never", "--name", name, image)
        self.volumes, self.env = list(volumes), list(env)
        self.proc, self.marker = None, None
        cfg = json.loads(buildah("inspect", "--type", "image", image))
        self.config = cfg["OCIv1"]["config"]
        self.docker_config = cfg.get("Docker", {}).get("config", {})

    def _argv(self, cmd):
        a = ["buildah", "run", "--isolation", "chroot", "--network", "host"]
        for v in self.volumes:
            a += ["-v", v]
        for e in self.env:
            a += ["-e", e]
        return a + [self.id, "--", *cmd]

    def run(self, cmd, timeout=120):
        return subprocess.run(self._argv(cmd), env=ENV, capture_output=True, text=True, timeout=timeout)

    def start(self, cmd, marker, logfile):
        """Runs cmd in the background; marker is an argument of cmd unique to this process."""
        self.marker = marker
        self.proc = subprocess.Popen(self._argv(cmd), env=ENV, stdout=open(logfile, "w"), stderr=subprocess.STDOUT)

    def kill(self, sig=signal.SIGKILL):
        pids = pids_with_arg(self.marker) if self.marker else []
        for p in pids:
            try:
                os.kill(p, sig)
            except ProcessLookupError:
                pass
        if self.proc:
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        return pids

    def remove(self):
        if self.proc and self.proc.poll() is None:
            for p in pids_with_arg(self.marker):
                os.kill(p, signal.SIGTERM)
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.kill()
        buildah("rm", self.id, check_rc=False)


def secrets(tmp):
    """make-secrets.sh's files, mounted as compose does: owned by uid 10001, mode 0400."""
    s = os.path.join(tmp, "secrets")
    subprocess.run([os.path.join(ROOT, "deploy/make-secrets.sh"), s], check=True, capture_output=True,
                   env=dict(os.environ, KGD_USERS=" ".join(USERS)))
    tokens = {}
    with open(os.path.join(s, "tokens.txt")) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                token, user, _ = line.split()
                tokens[user] = token
    mounts = {"tls": ["tls.crt", "tls.key"], "tokens": ["tokens.txt"], "client": ["ca.pem"],
              "worker": ["ca.pem", "worker-token"]}
    for d, files in mounts.items():
        os.makedirs(os.path.join(tmp, d))
        for f in files:
            shutil.copy(os.path.join(s, f), os.path.join(tmp, d, f))
            os.chown(os.path.join(tmp, d, f), UID, UID)
            os.chmod(os.path.join(tmp, d, f), 0o400)
        os.chown(os.path.join(tmp, d), UID, UID)
        os.chmod(os.path.join(tmp, d), 0o500)
    return tokens


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--kgd", default=os.path.join(ROOT, "build/client/kgd"), help="kgd built outside the images")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder and containers")
    args = ap.parse_args()
    for image in ("kgd-server", "kgd-worker", "kgd-cli"):
        if subprocess.run(["buildah", "inspect", "--type", "image", image], env=ENV, capture_output=True).returncode:
            sys.exit(f"test_images: no image {image}: run `make images` first")
    tmp = tempfile.mkdtemp(prefix="kgd-test-images.", dir="/var/tmp")
    os.chmod(tmp, 0o755)
    run_id = f"{os.getpid()}"
    containers = []
    try:
        tokens = secrets(tmp)
        grpc, https, internal = free_ports(3)
        server_addr = f"127.0.0.1:{grpc}"

        # The job outside the images, with the kgd built here.
        t = time.monotonic()
        local = subprocess.run([args.kgd, "design", *RATIO_JOB, "--json", "--out", os.path.join(tmp, "local.h5")],
                               capture_output=True, text=True, env=dict(os.environ, KGD_CACHE_DIR=os.path.join(tmp, "local-cache")))
        done = [json.loads(l) for l in local.stdout.splitlines() if '"event":"done"' in l]
        if not check(local.returncode == 0 and len(done) == 1, f"kgd design {' '.join(RATIO_JOB)} outside the images"):
            print(local.stderr[-2000:])
            return 1
        local_done = done[0]
        log(f"outside: density ratio {local_done['density_ratio']!r}, {local_done['iterations']} iterations "
            f"({time.monotonic() - t:.0f} s)")

        # The server: the image's ENTRYPOINT and CMD, on loopback ports of this run.
        server = Container("kgd-server", f"kgd-test-server-{run_id}",
                           volumes=[f"{tmp}/tls:/run/secrets/kgd-tls:ro", f"{tmp}/tokens:/run/secrets/kgd-tokens:ro"])
        containers.append(server)
        moves = {"0.0.0.0:7447": server_addr, "0.0.0.0:7448": f"127.0.0.1:{https}", "127.0.0.1:7449": f"127.0.0.1:{internal}"}
        cmd = [moves.get(a, a) for a in server.config["Entrypoint"] + server.config["Cmd"]]
        check(all(a not in cmd for a in ("0.0.0.0:7447", "0.0.0.0:7448", "127.0.0.1:7449")) and "--listen" in cmd,
              "the server image's CMD listens where it says (moved to loopback ports here)")
        server.start(cmd + ["--lease-s", "3"], f"127.0.0.1:{internal}", os.path.join(tmp, "server.log"))

        # Its HEALTHCHECK, run in the server's container as Docker would.
        health = server.docker_config.get("Healthcheck", {}).get("Test", [])
        check(health[:1] == ["CMD"] and "kgd" in health, f"the server image has a HEALTHCHECK: {health}")
        health_cmd = [moves.get(a, a) for a in health[1:]]
        deadline, healthy = time.monotonic() + 90, False
        while time.monotonic() < deadline and not healthy:
            healthy = server.run(health_cmd, timeout=30).returncode == 0
            if not healthy:
                time.sleep(1)
        if not check(healthy, f"the health command answers: {' '.join(health_cmd)}"):
            print(open(os.path.join(tmp, "server.log")).read()[-3000:])
            return 1
        for c in (server,):
            check(c.run(["id", "-u"]).stdout.strip() == str(UID), f"{c.image} runs as uid {UID}")

        # Workers: the image's ENTRYPOINT with the worker token over TLS; each its own scene cache.
        worker_image = json.loads(buildah("inspect", "--type", "image", "kgd-worker"))["OCIv1"]["config"]
        n_workers = [0]

        def start_worker():
            n_workers[0] += 1
            name = f"kgd-test-w{n_workers[0]}-{run_id}"
            cache = os.path.join(tmp, f"cache-w{n_workers[0]}")
            os.makedirs(cache)
            os.chown(cache, UID, UID)
            w = Container("kgd-worker", name, volumes=[f"{tmp}/worker:/run/secrets:ro", f"{cache}:/cache"],
                          env=["KGD_CACHE_DIR=/cache"])
            containers.append(w)
            token = open(os.path.join(tmp, "secrets", "worker-token")).read().strip()
            w.start(worker_image["Entrypoint"] + ["--server", server_addr, "--tls-ca", "/run/secrets/ca.pem",
                                                  "--token", token, "--name", name],
                    name, os.path.join(tmp, f"{name}.log"))
            return w

        workers = {}
        for _ in range(2):
            w = start_worker()
            workers[w.name] = w
        check(next(iter(workers.values())).run(["id", "-u"]).stdout.strip() == str(UID), f"kgd-worker runs as uid {UID}")

        cli = Container("kgd-cli", f"kgd-test-cli-{run_id}", volumes=[f"{tmp}/client:/run/secrets:ro"])
        containers.append(cli)
        check(cli.run(["id", "-u"]).stdout.strip() == str(UID), f"kgd-cli runs as uid {UID}")
        kgd = cli.config["Entrypoint"]

        def kgd_as(user, *cmd, timeout=120):
            r = cli.run(kgd + list(cmd) + ["--server", server_addr, "--tls-ca", "/run/secrets/ca.pem",
                                          "--token", tokens[user]], timeout=timeout)
            return r

        def job(user, jid):
            r = kgd_as(user, "job", str(jid), "--json")
            return json.loads(r.stdout) if r.returncode == 0 else None

        def kill_worker(name):
            w = workers.pop(name)
            pids = w.kill()
            log(f"killed {name} (pids {pids})")
            nw = start_worker()
            workers[nw.name] = nw
            log(f"started {nw.name}")
            return pids

        # 1. A job over TLS with a user's token; its worker killed mid-job; the result bit for bit.
        t = time.monotonic()
        r = kgd_as("alice", "submit", *RATIO_JOB, "--json")
        if not check(r.returncode == 0, "alice submits from the cli image over TLS with her token"):
            print(r.stdout, r.stderr)
            return 1
        jid = json.loads(r.stdout)["id"]
        killed_at, deadline = None, time.monotonic() + 600
        j = None
        while time.monotonic() < deadline:
            j = job("alice", jid)
            if j and killed_at is None and j["state"] == "RUNNING" and j.get("iterations", 0) >= 3 and j.get("worker") in workers:
                killed_at = j["iterations"]
                check(len(kill_worker(j["worker"])) > 0, f"the worker running job {jid} is killed at iteration {killed_at}")
            if j and j["state"] in ("SUCCEEDED", "FAILED", "CANCELLED"):
                break
            time.sleep(0.5)
        check(j is not None and j["state"] == "SUCCEEDED", f"job {jid} ends SUCCEEDED ({j and j['state']})")
        check(killed_at is not None and j["attempts"] >= 2, f"its worker was killed mid-job and another finished it "
              f"(attempts {j and j['attempts']})")
        last = (j or {}).get("last", {})
        check(j is not None and j["iterations"] == local_done["iterations"],
              f"every iteration is kept: {j and j['iterations']} in the service, {local_done['iterations']} outside")
        check(last.get("density_ratio") == local_done["density_ratio"] and last.get("area_fraction") == local_done["area_fraction"],
              f"density ratio inside the images {last.get('density_ratio')!r}, outside {local_done['density_ratio']!r}: bit for bit")
        log(f"job {jid}: {time.monotonic() - t:.0f} s")

        # 2. Twenty jobs from four users while the worker running one of them is killed.
        t = time.monotonic()
        owned = {u: set() for u in USERS}
        killed = False
        for i in range(20):
            user = USERS[i % 4]
            r = kgd_as(user, "submit", *SMALL_JOB, "--label", f"{user}-{i}", "--json")
            if not check(r.returncode == 0, f"{user} submits job {i + 1} of 20"):
                print(r.stderr)
                return 1
            owned[user].add(json.loads(r.stdout)["id"])
            if not killed and i >= 4:
                running = [x for x in json.loads(kgd_as("admin", "jobs", "--state", "running", "--json").stdout or "[]")
                           if x.get("worker") in workers]
                if running:
                    kill_worker(running[0]["worker"])
                    killed = True
        deadline = time.monotonic() + 600
        while time.monotonic() < deadline:
            listed = json.loads(kgd_as("admin", "jobs", "--limit", "100", "--json").stdout or "[]")
            if sum(1 for x in listed if x["state"] in ("SUCCEEDED", "FAILED", "CANCELLED")) == len(listed):
                break
            if not killed:
                running = [x for x in listed if x["state"] == "RUNNING" and x.get("worker") in workers]
                if running:
                    kill_worker(running[0]["worker"])
                    killed = True
            time.sleep(1)
        check(killed, "a worker was killed while the twenty jobs ran")
        mine_all = set().union(*owned.values())
        states = {x["id"]: x["state"] for x in listed if x["id"] in mine_all}
        check(len(states) == 20 and all(s == "SUCCEEDED" for s in states.values()),
              f"all twenty jobs SUCCEEDED ({sorted(set(states.values()))}, {len(states)} listed)")
        for user in USERS:
            r = kgd_as(user, "jobs", "--limit", "100", "--json")
            seen = {x["id"] for x in json.loads(r.stdout or "[]")}
            expect = owned[user] | ({jid} if user == "alice" else set())
            check(r.returncode == 0 and seen == expect, f"{user} lists exactly their own {len(expect)} jobs")
        other = next(iter(owned["bob"]))
        r = kgd_as("alice", "job", str(other), "--json")
        missing = kgd_as("alice", "job", "999999", "--json")
        check(r.returncode == 2 and missing.returncode == 2 and r.stdout == "",
              f"alice cannot read bob's job {other}: as for a missing job (exit 2: {r.stderr.strip()})")
        log(f"twenty jobs: {time.monotonic() - t:.0f} s")
    finally:
        for c in reversed(containers):
            c.remove()
        if failures or args.keep:
            log(f"logs in {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    log(f"{'FAILED: ' + str(len(failures)) if failures else 'passed'} in {time.monotonic() - T0:.0f} s")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
