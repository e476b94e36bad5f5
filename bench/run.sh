#!/usr/bin/env bash
# `make bench`: every benchmark once, then every table they measure written into docs/PERFORMANCE.md and
# docs/SCALING.md between its markers (bench/tables.py write, scripts/generated_block.py), headed by the
# command that measured it (recorded in BUILD/bench-results/commands.tsv) and `kgd machine` (date, CPU,
# cores). A block whose results are missing or incomplete (a program failed, a filter left it out) is not
# written and is named at the end. About 20 minutes on two cores.
#   bash bench/run.sh [BUILD_DIR] [GOOGLE BENCHMARK FLAGS ...]
# Environment: KGD_BENCH_DOCS, the folder whose PERFORMANCE.md and SCALING.md are written (default: the
# source's docs/); KGD_BENCH_ONLY, the kinds to run (default all: simulate body design service web export
# pinned effects scale).
set -uo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
docs=$(cd "${KGD_BENCH_DOCS:-$root/docs}" && pwd)
# From the source folder, so that the recorded commands read as one types them there.
build=$(cd "${1:-build}" && pwd) && cd "$root" && build=$(python3 -c 'import os, sys; print(os.path.relpath(sys.argv[1]))' "$build") || exit 1
only=" ${KGD_BENCH_ONLY:-simulate body design service web export pinned effects scale} "
results="$build/bench-results"
mkdir -p "$results"
rm -f "$results"/*.json "$results/commands.tsv"
# The benchmarks' design jobs keep their scene cache and their machine factor in the build folder, not
# the user's (the web page's, the service's and the pinned-kernel runs' workers inherit it).
export KGD_CACHE_DIR=${KGD_CACHE_DIR:-$root/$build/bench-cache}
machine=$("$build/client/kgd" machine)  # date, CPU, cores: the tables' header
echo "$machine"
failed=()

# An argument as a shell reads it back (quoted when it holds more than a path or a flag).
quote() {
  local a out=()
  for a in "$@"; do
    if [[ $a =~ ^[A-Za-z0-9_./:=,@+-]+$ ]]; then out+=("$a"); elif [[ $a != *\'* ]]; then out+=("'$a'"); else out+=("$(printf '%q' "$a")"); fi
  done
  printf '%s' "${out[*]}"
}
# measure KIND COMMAND...: runs COMMAND, recording it as what measured KIND's results.
measure() {
  local kind=$1
  shift
  [[ $only == *" ${kind%%:*} "* ]] || return 0
  printf '%s\t%s\n' "$kind" "$(quote "$@")" >> "$results/commands.tsv"
  echo "== $kind: $(quote "$@")"
  local start=$SECONDS
  "$@" || failed+=("$kind")
  echo "== $kind: $((SECONDS - start)) s"
}

# Google Benchmark: the simulator's benchmarks the tables read (not the tolerance sweeps), bodies, designs.
simulate_filter='BM_NewtonCold/reinforced:./tol_exp:(4|6)/project:1|BM_NewtonCold/reinforced:./tol_exp:6/project:0|BM_LbfgsCold/reinforced:./tol_exp:(4|6)|BM_WarmResolve/method:./tol_exp:4|BM_WarmResolveBeso|BM_WarmResolveSmooth|BM_Evaluate|BM_Factorize'
measure simulate "$build/bench/simulate_benchmark" --benchmark_counters_tabular=true "--benchmark_filter=$simulate_filter" \
  --benchmark_out="$results/simulate.json" --benchmark_out_format=json "${@:2}"
measure body "$build/bench/body_benchmark" --benchmark_counters_tabular=true --benchmark_out="$results/body.json" \
  --benchmark_out_format=json "${@:2}"
measure design "$build/bench/design_benchmark" --benchmark_counters_tabular=true --benchmark_out="$results/design.json" \
  --benchmark_out_format=json "${@:2}"
# The service, the web client, the fabrication export, the pinned kernels, the model's effects.
measure service "$build/bench/service_benchmark" all --scene arm_flexion --iterations 30 --watchers 100 --arm-iterations 20 \
  --repeat 2 --json "$results/service.json"
if [ -x /usr/bin/chromium ] && [ -d client/web/node_modules/playwright-core ]; then
  measure web node "bench/web_benchmark.mjs" --kgd "$build/client/kgd" --json "$results/web.json"
else
  echo "web_benchmark: skipped (needs Debian's chromium and npm ci --prefix client/web; scripts/setup.sh --browser installs both)"
fi
measure export bash "bench/export_benchmark.sh" "$build" 5 "$results/export.json"
measure pinned python3 "bench/pinned_kernels.py" --build "$build" --iterations 60 --json "$results/pinned.json"
measure effects python3 "bench/effects_benchmark.py" --build "$build" --json "$results/effects.json"
# One server and several workers (docs/SCALING.md).
measure scale:sleeve_on_limb python3 "bench/scale_benchmark.py" --build "$build" --workers 1,2,4,8 --jobs 20 \
  --scene sleeve_on_limb --iterations 60 --threads 1 --json "$results/scale_sleeve.json"
measure scale:arm_flexion python3 "bench/scale_benchmark.py" --build "$build" --workers 1,2 --jobs 2 \
  --scene arm_flexion --iterations 30 --threads 2 --json "$results/scale_arm.json"

# A partial run (KGD_BENCH_ONLY, Google Benchmark flags) leaves the blocks it did not measure as they were.
if ! python3 "bench/tables.py" write "$results" --docs "$docs" --machine "$machine" && [ -z "${KGD_BENCH_ONLY:-}" ] && [ $# -le 1 ]; then
  failed+=("tables")
fi
if [ ${#failed[@]} -gt 0 ]; then
  echo "failed: ${failed[*]}"
  exit 1
fi
