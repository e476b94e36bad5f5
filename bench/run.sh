#!/usr/bin/env bash
# Runs every benchmark with tabular counters, then writes the tables Google Benchmark measures into
# docs/PERFORMANCE.md between their markers (bench/tables.py, scripts/generated_block.py), headed by
# `kgd machine` (date, CPU, cores). A table a filter left incomplete is not written.
#   bash bench/run.sh [BUILD_DIR] [GOOGLE BENCHMARK FLAGS ...]
set -euo pipefail
build=${1:-build}
root=$(cd "$(dirname "$0")/.." && pwd)
results="$build/bench-results"
mkdir -p "$results"
rm -f "$results"/*.json
machine=$("$build/client/kgd" machine)  # date, CPU, cores: the tables' header
echo "$machine"
# A benchmark program that fails leaves its tables as they were; the others are still written.
failed=()
for b in simulate body design; do
  "$build/bench/${b}_benchmark" --benchmark_counters_tabular=true --benchmark_out="$results/$b.json" --benchmark_out_format=json "${@:2}" ||
    failed+=("${b}_benchmark")
done
for block in performance-simulator-cold performance-simulator-warm performance-design-engine performance-bodies; do
  if table=$(python3 "$root/bench/tables.py" "$block" "$results"/*.json); then
    printf '%s\n' "$table" | python3 "$root/scripts/generated_block.py" replace "$root/docs/PERFORMANCE.md" "$block" \
      --command "make bench" --machine "$machine"
  else
    echo "docs/PERFORMANCE.md: $block not written"
  fi
done
"$build/bench/service_benchmark"
bash bench/export_benchmark.sh "$build"
if [ -x /usr/bin/chromium ] && [ -d client/web/node_modules/playwright-core ]; then
  node bench/web_benchmark.mjs --kgd "$build/client/kgd"
else
  echo "web_benchmark: skipped (needs Debian's chromium and npm ci --prefix client/web; scripts/setup.sh --browser installs both)"
fi
if [ ${#failed[@]} -gt 0 ]; then
  echo "failed: ${failed[*]}"
  exit 1
fi
