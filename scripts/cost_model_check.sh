#!/usr/bin/env bash
# The job cost model (core/beso/quality.h) against measured design jobs: each built-in scene designed
# at a preset from a fresh process (set-up included), its wall time next to the prediction that
# `kgd scenes` shows. About fifteen minutes for the seven scenes at standard on two cores.
#   bash scripts/cost_model_check.sh [BUILD_DIR] [QUALITY] [SCENE ...]
set -euo pipefail
build=${1:-build}
quality=${2:-standard}
shift $(( $# > 2 ? 2 : $# ))
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
  scenes=(arm_flexion arm_extension knee_flexion knee_extension slouch crouch lunge)
fi
kgd="$build/client/kgd"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
column=$(case "$quality" in draft) echo 1 ;; standard) echo 2 ;; precise) echo 3 ;; esac)
date -u; nproc; lscpu | grep -E "Model name" || true
printf "%-16s %10s %10s %8s %12s\n" scene predicted_s measured_s error iterations
for s in "${scenes[@]}"; do
  predicted=$("$kgd" scenes | awk -v s="$s" -v c="$column" '$1 == s { split($6, p, "/"); print p[c] }')
  start=$(date +%s.%N)
  "$kgd" design "$s" --quality "$quality" --overwrite --out "$out/$s.h5" --json > "$out/$s.jsonl" || true
  end=$(date +%s.%N)
  iterations=$(tail -1 "$out/$s.jsonl" | python3 -c 'import json,sys; print(json.load(sys.stdin).get("iterations", "-"))')
  python3 - "$s" "$predicted" "$start" "$end" "$iterations" <<'PY'
import sys
s, p, a, b, n = sys.argv[1:]
m = float(b) - float(a)
print(f"{s:16s} {float(p):10.0f} {m:10.1f} {100 * (float(p) - m) / m:+7.0f}% {n:>12s}")
PY
done
