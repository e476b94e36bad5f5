#!/usr/bin/env bash
# Newton's tail on the built-in scenes: each scene's deformed pose, cold, fully reinforced and all
# cloth, solved by projected Newton to gradient tolerances 1e-6 and 1e-8, and fully reinforced by L-BFGS
# to 1e-8 (at most 10,000 iterations).
# Prints one row per scene and design: Newton's iterations to each tolerance, their ratio (the target
# is at most 2), the seconds of each solve, and the energy each reaches (Newton's at 1e-8 beside
# L-BFGS's at 1e-8). Run on all seven scenes, it writes docs/PERFORMANCE.md's block
# performance-newton-tail (scripts/newton_tail_table.py, scripts/generated_block.py; the iteration
# counts do not depend on the machine: the kernels are pinned). About twenty minutes on two cores with a
# warm scene cache; not part of `make bench`.
#   bash scripts/newton_tail.sh [BUILD_DIR] [SCENE ...]
set -euo pipefail
build=${1:-build}
shift $(( $# > 0 ? 1 : 0 ))
root=$(cd "$(dirname "$0")/.." && pwd)
all=(arm_flexion arm_extension knee_flexion knee_extension slouch crouch lunge)
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
  scenes=("${all[@]}")
fi
kgd="$build/client/kgd"
rows=$(mktemp)
trap 'rm -f "$rows"' EXIT
machine=$("$kgd" machine)
echo "$machine"
printf "%-15s %-15s %7s %7s %6s %9s %9s %20s %20s %9s\n" scene design it_1e-6 it_1e-8 ratio s_1e-6 s_1e-8 \
  "newton_1e-8_J" "lbfgs_1e-8_J" lbfgs_its
for s in "${scenes[@]}"; do
  for d in all_reinforced all_cloth; do
    a=$("$kgd" simulate "$s" --design "$d" --grad-tol 1e-6 --max-iterations 2000 --json || true)
    b=$("$kgd" simulate "$s" --design "$d" --grad-tol 1e-8 --max-iterations 2000 --json || true)
    c='{}'
    if [ "$d" = all_reinforced ]; then
      c=$("$kgd" simulate "$s" --design "$d" --grad-tol 1e-8 --method lbfgs --max-iterations 10000 --json || true)
    fi
    python3 - "$s" "$d" "$a" "$b" "$c" "$rows" <<'PY'
import json, sys
s, d, a, b, c, rows = sys.argv[1:]
def load(t):
    try:
        return json.loads(t)
    except Exception:
        return {}
a, b, c = load(a), load(b), load(c)
with open(rows, "a") as f:
    f.write(json.dumps({"scene": s, "design": d, "newton_1e-6": a, "newton_1e-8": b, "lbfgs_1e-8": c}) + "\n")
def its(r):
    if not r:
        return "-"
    n = r.get("iterations", "-")
    return f"{n}" if r.get("status") == "converged" else f"{n}({r.get('status', 'failed')})"
ratio = b.get("iterations", 0) / max(a.get("iterations", 1), 1)
print(f"{s:15s} {d:15s} {its(a):>7s} {its(b):>7s} {ratio:6.2f} {a.get('seconds', 0):9.2f} {b.get('seconds', 0):9.2f}"
      f" {b.get('energy_J', float('nan')):20.12f} {c.get('energy_J', float('nan')):20.12f} {its(c):>9s}")
PY
  done
done
if [ "${scenes[*]}" = "${all[*]}" ]; then
  table=$(python3 "$root/scripts/newton_tail_table.py" "$rows")
  printf '%s\n' "$table" | python3 "$root/scripts/generated_block.py" replace "$root/docs/PERFORMANCE.md" performance-newton-tail \
    --command "bash scripts/newton_tail.sh $build" --machine "$machine"
else
  echo "docs/PERFORMANCE.md: performance-newton-tail not written (not all seven scenes)"
fi
