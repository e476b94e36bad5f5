#!/usr/bin/env bash
# Runs every benchmark with tabular counters; figures belong in docs/PERFORMANCE.md (with date and machine).
set -euo pipefail
build=${1:-build}
nproc; lscpu | grep -E "Model name|^CPU\(s\)" || true
"$build/bench/simulate_benchmark" --benchmark_counters_tabular=true "${@:2}"
"$build/bench/body_benchmark" --benchmark_counters_tabular=true "${@:2}"
"$build/bench/design_benchmark" --benchmark_counters_tabular=true "${@:2}"
"$build/bench/service_benchmark"
bash bench/export_benchmark.sh "$build"
if [ -x /usr/bin/chromium ] && [ -d client/web/node_modules/playwright-core ]; then
  node bench/web_benchmark.mjs --kgd "$build/client/kgd"
else
  echo "web_benchmark: skipped (needs Debian's chromium and npm ci --prefix client/web; scripts/setup.sh --browser installs both)"
fi
