#!/usr/bin/env bash
# The previews of docs/FABRICATION.md: the built-in arm and knee flexion designed to their budgets,
# exported, and the cut files rendered to PNG (docs/images/). A few minutes on two cores.
set -euo pipefail
BUILD=${1:-build}
KGD=$BUILD/client/kgd
OUT=$BUILD/fabrication-previews
mkdir -p "$OUT" docs/images
for scene in arm_flexion knee_flexion; do
  "$KGD" design "$scene" --out "$OUT/$scene.h5" --json > "$OUT/$scene.design.jsonl"
  "$KGD" export "$OUT/$scene.h5" --out "$OUT/$scene" --json > "$OUT/$scene.export.json"
  for sheet in pattern patches; do
    node scripts/svg_to_png.mjs "$OUT/$scene/$sheet.svg" "docs/images/fabrication_${scene}_${sheet}.png" 1200
  done
  echo "$scene: $(python3 -c "import json; r = json.load(open('$OUT/$scene.export.json')); print('iteration', r['iteration'], 'density ratio %.3f, cleaned %.3f;' % (r['density_ratio'], r['cleaned']['density_ratio']), len(r['pieces']), 'pieces,', len(r['patches']), 'patches, sheet usage %.2f, %.2f s' % (r['sheet_usage'], r['seconds']))")"
done
