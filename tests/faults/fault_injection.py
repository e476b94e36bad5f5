#!/usr/bin/env python3
"""Random system faults during `kgd design`, injected by Debian's libfiu (fiu-run's POSIX preload).

Each run fails one kind of call at random (write: pwrite/write; fsync; open; mmap; allocation: malloc,
calloc, realloc) with the run's seed (FIU_PRNG_SEED), while a small design job writes its design
file. Every run is then judged against the uninterrupted run of the same job:

  same design   exit 0, and every iteration's design and energies equal the uninterrupted run's
  named error   a non-zero exit with a `kgd design: FILE: ...` message; what the file stores reads
                back (`kgd check`) or is repaired by `--resume`, which, run without faults, ends at
                the uninterrupted run's designs bit for bit
  anything else a crash (a signal), a hang (past the timeout), exit 0 with another design or an
                unreadable file, an error without a message, or a resume that differs: a defect

The summary (runs, seeds, faults injected by kind, outcomes) is printed as a table; the exit status is
non-zero when any run falls under "anything else". `make faults` runs it at length; `make test` runs a
short smoke (ctest `fault_injection_smoke`).

    python3 tests/faults/fault_injection.py --kgd build/client/kgd --runs 40 --seed 1
"""
import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile

# The job: the pull test from all reinforced down to 60 % (about 20 iterations, a second).
JOB = ["pull_test_all_cloth", "--budget", "0.6", "--er", "0.05", "--ar-max", "0.05", "--iterations", "16"]

# Fault kinds: libfiu failure points and the errno each fails with. Allocation faults start after the
# job's first iteration (through fiu-ctrl): from the start they fail the C++ runtime's own start-up,
# before kgd runs, and a machine runs out of memory while a job runs, not before it starts.
MID_RUN = {"allocation"}
KINDS = {
    "write": (["posix/io/rw/pwrite", "posix/io/rw/write", "posix/io/rw/pwritev", "posix/io/rw/writev"], [28, 5]),  # ENOSPC, EIO
    "fsync": (["posix/io/sync/fsync", "posix/io/sync/fdatasync"], [5]),  # EIO
    "open": (["posix/io/oc/open"], [5, 24, 28]),  # EIO, EMFILE, ENOSPC
    "mmap": (["posix/mm/mmap"], [12]),  # ENOMEM
    "allocation": (["libc/mm/malloc", "libc/mm/calloc", "libc/mm/realloc"], [12]),  # ENOMEM
}
# How likely each call of a kind fails: a job makes thousands of writes and allocations, but opens its
# files and maps memory only tens of times, so those fail more often, for a fault to land in most runs.
PROBABILITY = {"write": 0.01, "fsync": 0.3, "open": 0.2, "mmap": 0.2, "allocation": 0.01}


def run(cmd, env=None, timeout=120):
    try:
        r = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
        return r.returncode, r.stdout + r.stderr
    except subprocess.TimeoutExpired as e:
        return None, (e.stdout or b"").decode(errors="replace") if isinstance(e.stdout, bytes) else str(e.stdout or "")


def run_enabling_mid_run(cmd, env, commands, timeout=120):
    """Runs `cmd` under fiu-run with remote control, enabling `commands` after its first iteration line."""
    import threading
    ctrl = tempfile.mktemp(prefix="kgd-fiu-")
    full = cmd[:1] + ["-x", "-f", ctrl] + cmd[1:]
    p = subprocess.Popen(full, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    timer = threading.Timer(timeout, p.kill)
    timer.start()
    out, enabled = [], False
    for line in p.stdout:
        out.append(line)
        if not enabled and line.startswith('{"iteration"'):
            enabled = True
            c = []
            for command in commands:
                c += ["-c", command]
            try:  # a process that ended meanwhile leaves fiu-ctrl waiting on its control pipe
                subprocess.run(["fiu-ctrl", "-f", ctrl, *c, str(p.pid)], capture_output=True, timeout=10)
            except subprocess.TimeoutExpired:
                pass
    code = p.wait()
    hung = not timer.is_alive()
    timer.cancel()
    for suffix in (".in", ".out"):
        try:
            os.remove(f"{ctrl}-{p.pid}{suffix}")
        except OSError:
            pass
    return (None if hung else code), "".join(out)


def designs(kgd, path):
    """The file's iterations (design-relevant figures), or None when it does not read back."""
    code, out = run([kgd, "designs", "--json", path])
    if code != 0:
        return None
    d = json.loads(out)
    return [(it["iteration"], it["energy_J"], it["density_ratio"], it["area_fraction"]) for it in d["iterations"]]


def judge(kgd, ref, path, code, out):
    """(outcome, detail) of one faulty run."""
    if code is None:
        return "anything else", "hang (timeout)"
    last = " | ".join(line for line in out.splitlines() if not line.startswith("{"))[-300:]
    if code == 255:
        return "anything else", f"exit 255: {last}"
    if code < 0 or code >= 129:
        return "anything else", f"killed by signal {-code if code < 0 else code - 128}: {last}"
    if code == 0:
        got = designs(kgd, path)
        if got != ref:
            return "anything else", "exit 0 with another design or an unreadable file"
        return "same design", ""
    if "kgd design: " not in out and "kgd: " not in out:
        return "anything else", f"exit {code} without a message"
    message = [line for line in out.splitlines() if line.startswith("kgd")][-1]
    if not os.path.exists(path):
        return "named error", message  # refused before the file was made: nothing stored, nothing to resume
    check_code, check_out = run([kgd, "check", path])
    if check_code not in (0, 5):
        return "anything else", f"kgd check exit {check_code}: {check_out.strip()[-200:]}"
    rcode, rout = run([kgd, "design", "--resume", path, "--iterations", "16"])
    if rcode == 2 and "no iteration" in rout:
        return "named error", message
    if rcode != 0:
        return "anything else", f"the resume failed (exit {rcode}): {rout.strip()[-300:]}"
    if designs(kgd, path) != ref:
        return "anything else", "the resume ended at another design"
    return "named error", message


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--kgd", required=True)
    p.add_argument("--runs", type=int, default=40)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--kinds", default=",".join(KINDS), help="comma-separated: " + ", ".join(KINDS))
    p.add_argument("--probability", type=float, help="of each call of the chosen kind failing (default: per kind, PROBABILITY)")
    p.add_argument("--keep", help="keep the runs' files in this folder")
    p.add_argument("--write-docs", metavar="FILE", help="write the summary into FILE's block reliability-faults (docs/RELIABILITY.md)")
    a = p.parse_args()
    if not shutil.which("fiu-run"):
        print("fault_injection: fiu-run (Debian's fiu-utils) is not installed; skipped")
        return 0
    kgd = os.path.abspath(a.kgd)
    work = a.keep or tempfile.mkdtemp(prefix="kgd_faults_")
    os.makedirs(work, exist_ok=True)
    ref_path = os.path.join(work, "reference.h5")
    code, out = run([kgd, "design", *JOB, "--overwrite", "--out", ref_path])
    if code != 0:
        print(f"fault_injection: the reference run failed (exit {code}): {out[-500:]}")
        return 1
    ref = designs(kgd, ref_path)
    kinds = [k for k in a.kinds.split(",") if k]
    rng = random.Random(a.seed)
    counts = {k: {"runs": 0, "same design": 0, "named error": 0, "anything else": 0} for k in kinds}
    defects = []
    samples = {}
    for i in range(a.runs):
        kind = kinds[i % len(kinds)]
        seed = rng.randrange(1, 2**31)
        points, errnos = KINDS[kind]
        errno = rng.choice(errnos)
        probability = a.probability if a.probability is not None else PROBABILITY[kind]
        commands = [f"enable_random name={point},probability={probability},failinfo={errno}" for point in points]
        path = os.path.join(work, f"run{i:04d}_{kind}.h5")
        env = dict(os.environ, FIU_PRNG_SEED=str(seed), KGD_CACHE_DIR=os.path.join(work, "cache"))
        job = [kgd, "design", *JOB, "--json", "--out", path]
        if kind in MID_RUN:
            code, out = run_enabling_mid_run(["fiu-run"] + job, env, commands)
        else:
            cmd = ["fiu-run", "-x", "-f", ""]
            for c in commands:
                cmd += ["-c", c]
            code, out = run(cmd + job, env=env)
        outcome, detail = judge(kgd, ref, path, code, out)
        counts[kind]["runs"] += 1
        counts[kind][outcome] += 1
        if outcome == "named error":
            samples.setdefault(kind, detail)
        if outcome == "anything else":
            defects.append(f"run {i} ({kind}, errno {errno}, FIU_PRNG_SEED={seed}): {detail}")
        if not a.keep:
            for f in os.listdir(work):
                if f.startswith(f"run{i:04d}_"):
                    os.remove(os.path.join(work, f))
    lines = [f"{a.runs} runs of `kgd design {' '.join(JOB)}` from seed {a.seed}, each call of the run's kind failing with "
             f"probability {a.probability if a.probability is not None else ', '.join(f'{k} {PROBABILITY[k]}' for k in kinds)} "
             "(`fiu-run -x`, a seed per run), each run judged against the uninterrupted run:", "",
             "| fault kind | runs | same design | named error | anything else |", "|---|---:|---:|---:|---:|"]
    total = {"runs": 0, "same design": 0, "named error": 0, "anything else": 0}
    for k in kinds:
        c = counts[k]
        lines.append(f"| {k} | {c['runs']} | {c['same design']} | {c['named error']} | {c['anything else']} |")
        for key in total:
            total[key] += c[key]
    lines.append(f"| all | {total['runs']} | {total['same design']} | {total['named error']} | {total['anything else']} |")
    lines += [f"- defect: {d}" for d in defects]
    print("\n".join(lines))
    for k, m in samples.items():
        print(f"a named error ({k}): {m[:300]}")
    if a.write_docs:
        root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
        machine = subprocess.run([kgd, "machine"], capture_output=True, text=True).stdout.strip()
        command = f"python3 tests/faults/fault_injection.py --runs {a.runs} --seed {a.seed}" + (f" --probability {a.probability}" if a.probability is not None else "")
        subprocess.run([sys.executable, os.path.join(root, "scripts", "generated_block.py"), "replace", a.write_docs, "reliability-faults",
                        "--command", command, "--machine", machine], input="\n".join(lines) + "\n", text=True, check=True)
    if not a.keep:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if defects else 0


if __name__ == "__main__":
    sys.exit(main())
