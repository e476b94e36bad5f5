#!/usr/bin/env bash
# The fabrication export's time (docs/PERFORMANCE.md, "Fabrication export"): the built-in arm and knee
# flexion designed to their budgets once (kept in BUILD/fabrication-previews, as
# scripts/fabrication_previews.sh makes them), then `kgd export` with the defaults RUNS times each
# (default 7) after one warm-up run that fills the scene cache. Prints the median and the fastest of the
# report's `seconds` and the median of each stage.
set -euo pipefail
BUILD=${1:-build}
RUNS=${2:-7}
KGD=$BUILD/client/kgd
DIR=$BUILD/fabrication-previews
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
mkdir -p "$DIR"
for scene in arm_flexion knee_flexion; do
  [ -f "$DIR/$scene.h5" ] || "$KGD" design "$scene" --out "$DIR/$scene.h5" --json > "$DIR/$scene.design.jsonl"
  "$KGD" export "$DIR/$scene.h5" --out "$OUT/warm" --json > /dev/null
  for i in $(seq "$RUNS"); do "$KGD" export "$DIR/$scene.h5" --out "$OUT/$i" --json > "$OUT/$scene.$i.json"; done
  python3 - "$scene" "$OUT"/"$scene".*.json <<'PY'
import json, statistics, sys
runs = [json.load(open(f)) for f in sys.argv[2:]]
total = [r["seconds"] for r in runs]
print(f"{sys.argv[1]}, iteration {runs[0]['iteration']}: export median {statistics.median(total):.3f} s, fastest {min(total):.3f} s over {len(runs)} runs")
for stage in runs[0]["stage_seconds"]:
    print(f"  {stage:62s} {statistics.median(r['stage_seconds'][stage] for r in runs):.3f} s")
PY
done
