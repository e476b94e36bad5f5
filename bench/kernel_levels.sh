#!/usr/bin/env bash
# What each kernel set costs a design job, in CPU seconds on one OpenMP thread (robust on a loaded
# machine): `kgd design SCENE --iterations N` minus `--iterations 1`, at each kernel level kgd pins
# (core/util/pinned_kernels.h: x86-64, KGD_KERNELS=x86-64; x86-64-v3, where the CPU runs it) and with
# the machine's own kernels. Designs differ between the sets (the last iteration's density ratio shows
# it) and repeat within one. bench/pinned_kernels.py measures the same in wall time per iteration.
#   bash bench/kernel_levels.sh [KGD] [SCENE] [N] [REPEATS]
set -uo pipefail
kgd=$(realpath "${1:-build/client/kgd}"); scene=${2:-arm_flexion}; n=${3:-41}; repeats=${4:-2}
work=$(mktemp -d); trap 'rm -rf "$work"' EXIT
export OMP_NUM_THREADS=1
# run SET ITERATIONS: "CPU-seconds Newton-iterations-after-0 last-density-ratio"
run() {
  local envs=()
  case $1 in
    x86-64|x86-64-v3) envs=(KGD_KERNELS=$1) ;;
    native) envs=(KGD_NATIVE_KERNELS=1) ;;
  esac
  env "${envs[@]}" /usr/bin/time -f "%U %S" -o "$work/cpu" "$kgd" design "$scene" --iterations "$2" --json --overwrite --out "$work/d.h5" > "$work/lines" || return 1
  python3 - "$work/cpu" "$work/lines" <<'PY'
import json, sys
u, s = map(float, open(sys.argv[1]).read().split()[-2:])
its = [json.loads(l) for l in open(sys.argv[2]) if l.startswith('{"iteration"')]
print(u + s, sum(j["solver_iterations"] for j in its if j["iteration"] > 0), its[-1]["density_ratio"])
PY
}
run x86-64 1 > /dev/null || exit 1  # a first run builds the scene into the cache: not measured
for r in $(seq "$repeats"); do
  for k in x86-64 x86-64-v3 native; do
    read -r c0 n0 _ <<< "$(run $k 1)" || exit 1
    read -r c1 n1 d1 <<< "$(run $k "$n")" || exit 1
    python3 -c "import sys; c0, c1, n0, n1, n = map(float, sys.argv[1:6]); print(f'$scene $k: iterations 0-1 {c0:.2f} CPU s; iterations 2-{n:.0f}: {(c1 - c0) / (n - 1):.4f} CPU s and {(n1 - n0) / (n - 1):.2f} Newton iterations each, {(c1 - c0) / max(1, n1 - n0):.4f} CPU s per Newton iteration; density ratio at {n:.0f} $d1')" "$c0" "$c1" "$n0" "$n1" "$n"
  done
done
