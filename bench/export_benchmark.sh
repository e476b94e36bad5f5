#!/usr/bin/env bash
# The fabrication export's time: the built-in arm and knee flexion designed to their budgets once (kept
# in BUILD/fabrication-previews, as scripts/fabrication_previews.sh makes them), then `kgd export` with
# the defaults RUNS times each (default 5) after one warm-up run that fills the scene cache. Prints the
# median and the fastest of the report's `seconds` and the median of each stage; with JSON, writes them
# as one object ("kind": "export") for bench/tables.py (`make bench`: docs/PERFORMANCE.md,
# "Fabrication export").
#   bash bench/export_benchmark.sh [BUILD_DIR] [RUNS] [JSON]
set -euo pipefail
BUILD=${1:-build}
RUNS=${2:-5}
JSON=${3:-}
KGD=$BUILD/client/kgd
DIR=$BUILD/fabrication-previews
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
mkdir -p "$DIR"
for scene in arm_flexion knee_flexion; do
  [ -f "$DIR/$scene.h5" ] || "$KGD" design "$scene" --out "$DIR/$scene.h5" --json > "$DIR/$scene.design.jsonl"
  "$KGD" export "$DIR/$scene.h5" --out "$OUT/warm" --json > /dev/null
  "$KGD" designs "$DIR/$scene.h5" --json > "$OUT/$scene.designs.json"
  for i in $(seq "$RUNS"); do "$KGD" export "$DIR/$scene.h5" --out "$OUT/$i" --json > "$OUT/$scene.run.$i.json"; done
done
python3 - "$OUT" "$RUNS" "$JSON" <<'PY'
import json, os, statistics, sys
out, runs, path = sys.argv[1], int(sys.argv[2]), sys.argv[3]
designs = []
for scene in ("arm_flexion", "knee_flexion"):
    reports = [json.load(open(os.path.join(out, f"{scene}.run.{i}.json"))) for i in range(1, runs + 1)]
    header = json.load(open(os.path.join(out, f"{scene}.designs.json")))
    total = [r["seconds"] for r in reports]
    stages = {stage: statistics.median(r["stage_seconds"][stage] for r in reports) for stage in reports[0]["stage_seconds"]}
    d = {"scene": scene, "faces": header["garment_faces"], "iteration": reports[0]["iteration"], "runs": runs,
         "median_s": statistics.median(total), "fastest_s": min(total),
         "pattern_median_s": statistics.median(r["pattern_seconds"] for r in reports), "stage_median_s": stages}
    designs.append(d)
    print(f"{scene}, iteration {d['iteration']}: export median {d['median_s']:.3f} s, fastest {d['fastest_s']:.3f} s over {runs} runs")
    for stage, s in stages.items():
        print(f"  {stage:62s} {s:.3f} s")
if path:
    with open(path, "w") as f:
        json.dump({"kind": "export", "designs": designs}, f, indent=1)
PY
