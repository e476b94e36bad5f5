#!/usr/bin/env bash
# Newton's tail on the built-in scenes: each scene's deformed pose, cold, fully reinforced and all
# cloth, solved by projected Newton to gradient tolerances 1e-6 and 1e-8, and fully reinforced by L-BFGS
# to 1e-8 (at most 10,000 iterations).
# Prints one row per scene and design: Newton's iterations to each tolerance, their ratio (the
# accuracy issue's target is at most 2) and the energy each reaches (Newton's at 1e-8 should be no
# higher than L-BFGS's at 1e-8), and what the iterations from 1e-6 to 1e-8 move: the vertices that
# moved more than 0.1 mm between the two equilibria, the largest move, the median move, and the share of
# the faces around the moved vertices that are slack (zero membrane energy), and how many faces the
# equilibrium at 1e-8 holds at the edge of slack (stretched, with an energy density below 1e-6 Pa: a
# strain of about 1e-6, where the relaxed energy's second derivative jumps). About twenty minutes on two
# cores with a warm scene cache.
#   bash scripts/newton_tail.sh [BUILD_DIR] [SCENE ...]
set -euo pipefail
build=${1:-build}
shift $(( $# > 0 ? 1 : 0 ))
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
  scenes=(arm_flexion arm_extension knee_flexion knee_extension slouch crouch lunge)
fi
kgd="$build/client/kgd"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
date -u; nproc; lscpu | grep -E "Model name" || true
printf "%-15s %-15s %7s %7s %6s %9s %9s %20s %20s %9s %11s %9s %9s %8s %8s\n" scene design it_1e-6 it_1e-8 ratio s_1e-6 s_1e-8 \
  "newton_1e-8_J" "lbfgs_1e-8_J" lbfgs_its moved_0.1mm max_mm median_um slack at_edge
for s in "${scenes[@]}"; do
  for d in all_reinforced all_cloth; do
    rm -f "$tmp"/*.ply
    a=$("$kgd" simulate "$s" --design "$d" --grad-tol 1e-6 --max-iterations 2000 --json --out "$tmp/a.ply" || true)
    b=$("$kgd" simulate "$s" --design "$d" --grad-tol 1e-8 --max-iterations 2000 --json --out "$tmp/b.ply" || true)
    c='{}'
    if [ "$d" = all_reinforced ]; then
      c=$("$kgd" simulate "$s" --design "$d" --grad-tol 1e-8 --method lbfgs --max-iterations 10000 --json || true)
    fi
    python3 - "$(dirname "$0")" "$s" "$d" "$a" "$b" "$c" "$tmp/a.ply" "$tmp/b.ply" <<'PY'
import json, math, os, sys
scripts, s, d, a, b, c, ply_a, ply_b = sys.argv[1:]
sys.path.insert(0, scripts)
from garment_energy_zones import read_ply
def load(t):
    try:
        return json.loads(t)
    except Exception:
        return {}
a, b, c = load(a), load(b), load(c)
def its(r):
    if not r:
        return "-"
    n = r.get("iterations", "-")
    return f"{n}" if r.get("status") == "converged" else f"{n}({r.get('status', 'failed')})"
ratio = b.get("iterations", 0) / max(a.get("iterations", 1), 1)
moved = max_mm = median_um = slack = at_edge = float("nan")
if os.path.exists(ply_a) and os.path.exists(ply_b):
    va = read_ply(ply_a)[0]
    vb, faces_b, _, density_b = read_ply(ply_b)
    fb = list(zip(faces_b, density_b))
    dist = [math.dist(p, q) for p, q in zip(va, vb)]
    moved = sum(x > 1e-4 for x in dist)
    max_mm = 1e3 * max(dist)
    median_um = 1e6 * sorted(dist)[len(dist) // 2]
    around = [w for f, w in fb if any(dist[v] > 1e-4 for v in f)]
    slack = sum(w == 0 for w in around) / len(around) if around else 0.0
    at_edge = sum(0 < w < 1e-6 for f, w in fb)
print(f"{s:15s} {d:15s} {its(a):>7s} {its(b):>7s} {ratio:6.2f} {a.get('seconds', 0):9.2f} {b.get('seconds', 0):9.2f}"
      f" {b.get('energy_J', float('nan')):20.12f} {c.get('energy_J', float('nan')):20.12f} {its(c):>9s}"
      f" {moved:>11} {max_mm:9.2f} {median_um:9.3f} {slack:8.2f} {at_edge:>8}")
PY
  done
done
