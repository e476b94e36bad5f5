#!/usr/bin/env python3
"""What each effect of the model costs: `kgd scene export arm_flexion DIR`, then one scene file per variant
(one effect of the scene changed) and `kgd simulate DIR/VARIANT.json --design all_reinforced --json`;
the solve's own time (`seconds`, after the body is built), its iterations and its energy.

  python3 bench/effects_benchmark.py [--build build] [--repeat 1] [--only VARIANT,...] [--json FILE]

--repeat R keeps the fastest of R solves (iterations and energy are the same every time); --json writes
one object ("kind": "effects") for bench/tables.py (`make bench`: docs/PERFORMANCE.md, "What each effect
costs").
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

# name -> the scene's "effects" changed (None: as built).
VARIANTS = {
    "as_built": None,
    "no_fold_barrier": {"fold_barrier": False},
    "friction": {"friction": 0.1},
    "bilateral_contact": {"contact": "bilateral"},
    "authors_relaxation": {"relaxation": "authors"},
    "no_relaxation": {"relaxation": "none"},
    "no_contact": {"contact": "none"},
    "no_attachments": {"attachments": False},
}


def variant(scene, change):
    """The scene file's JSON with its effects changed (a copy)."""
    s = json.loads(json.dumps(scene))
    if change:
        s.setdefault("effects", {}).update(change)
    return s


def best(results):
    """The fastest of repeated solves of one variant; ValueError when they disagree on iterations or status."""
    if len({(r["iterations"], r["status"]) for r in results}) != 1:
        raise ValueError("repeated solves differ in iterations or status")
    return min(results, key=lambda r: r["seconds"])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--only", default="", help="comma-separated variants (default: all)")
    ap.add_argument("--json", default="")
    a = ap.parse_args()
    kgd = os.path.join(a.build, "client", "kgd")
    names = a.only.split(",") if a.only else list(VARIANTS)
    rows = []
    with tempfile.TemporaryDirectory(prefix="kgd_effects_") as d:
        subprocess.run([kgd, "scene", "export", "arm_flexion", d], check=True, capture_output=True)
        with open(os.path.join(d, "scene.json")) as f:
            scene = json.load(f)
        for name in names:
            path = os.path.join(d, f"{name}.json")
            with open(path, "w") as f:
                json.dump(variant(scene, VARIANTS[name]), f)
            runs = []
            for _ in range(a.repeat):
                r = subprocess.run([kgd, "simulate", path, "--design", "all_reinforced", "--json"], capture_output=True, text=True)
                if r.returncode != 0 and not r.stdout.strip():
                    print(f"effects_benchmark.py: {name}: {r.stderr.strip()}", file=sys.stderr)
                    return 1
                runs.append(json.loads(r.stdout))
            b = best(runs)
            rows.append({"variant": name, "seconds": b["seconds"], "iterations": b["iterations"], "energy_J": b["energy_J"],
                         "status": b["status"], "repeat": a.repeat})
            print(f"{name:20s} {b['seconds']:7.2f} s {b['iterations']:5d} iterations  E = {b['energy_J']:.6f} J  {b['status']}", flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"kind": "effects", "scene": "arm_flexion", "design": "all_reinforced", "variants": rows}, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
