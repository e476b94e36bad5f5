#!/usr/bin/env python3
"""What pinning the numeric kernels costs (core/util/pinned_kernels.h): `kgd design arm_flexion --iterations N
--json` at each kernel level this machine runs (KGD_KERNELS=x86-64, and x86-64-v3 where the CPU has AVX2
and FMA: the level `kgd` and `kgd-worker` choose), and with the machine's own kernels
(KGD_NATIVE_KERNELS=1); each iteration's `total_s` from its JSON line.

  python3 bench/pinned_kernels.py [--build build] [--iterations 60] [--json FILE]

--json writes one object ("kind": "pinned") for bench/tables.py (`make bench`: docs/PERFORMANCE.md,
"Pinned kernels").
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def summary(lines):
    """Iteration 0's seconds, the mean of the later ones and the whole loop's sum, from `kgd design --json` lines."""
    its = {}
    for line in lines:
        try:
            j = json.loads(line)
        except ValueError:
            continue
        if "iteration" in j and "total_s" in j:
            its[j["iteration"]] = j["total_s"]
    if 0 not in its or len(its) < 2:
        raise ValueError("no iteration 0 and later in kgd design's output")
    later = [s for i, s in its.items() if i > 0]
    return {"iterations": len(later), "first_s": its[0], "mean_later_s": sum(later) / len(later), "loop_s": sum(its.values())}


def machine_levels():
    """The kernel levels this CPU runs, lowest first (x86-64-v3: AVX2 and FMA, as kgd decides)."""
    flags = set()
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("flags"):
                flags = set(line.split(":", 1)[1].split())
                break
    return ["x86-64"] + (["x86-64-v3"] if {"avx2", "fma", "bmi2", "movbe", "f16c"} <= flags else [])


def run(build, iterations, level):
    """`kgd design arm_flexion` at `level` (a kernel level, or "native")."""
    env = dict(os.environ)
    for k in ("KGD_NATIVE_KERNELS", "KGD_KERNELS"):
        env.pop(k, None)
    if level == "native":
        env["KGD_NATIVE_KERNELS"] = "1"
    else:
        env["KGD_KERNELS"] = level
    with tempfile.TemporaryDirectory(prefix="kgd_pinned_") as d:
        r = subprocess.run([os.path.join(build, "client", "kgd"), "design", "arm_flexion", "--iterations", str(iterations), "--json",
                            "--out", os.path.join(d, "arm.h5")], env=env, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"kgd design ({level}) failed: {r.stderr.strip()}")
    return summary(r.stdout.splitlines())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--iterations", type=int, default=60)
    ap.add_argument("--json", default="")
    a = ap.parse_args()
    try:
        result = {"kind": "pinned", "scene": "arm_flexion", "native": run(a.build, a.iterations, "native"),
                  "levels": {level: run(a.build, a.iterations, level) for level in machine_levels()}}
    except (RuntimeError, ValueError) as e:
        print(f"pinned_kernels.py: {e}", file=sys.stderr)
        return 1
    for k, r in [("native", result["native"])] + list(result["levels"].items()):
        print(f"{k:9s} iteration 0 {r['first_s']:.3f} s, mean of iterations 1-{r['iterations']} {r['mean_later_s']:.4f} s, loop {r['loop_s']:.2f} s")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
