#!/usr/bin/env bash
# The figures and previews of docs/FABRICATION.md: the built-in arm and knee flexion designed to their
# budgets and exported with the defaults, the cut files rendered to PNG (docs/images/), the pull test's
# Line exported, and the MakeHuman sleeve's pattern (core/fabrication/pattern_test, when the MakeHuman
# bodies are present); then the table "Today's figures" written between its markers
# (scripts/fabrication_table.py, scripts/generated_block.py), headed by `kgd machine`. A few minutes
# on two cores.
#   bash scripts/fabrication_previews.sh [BUILD_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
BUILD=${1:-build}
KGD=$BUILD/client/kgd
OUT=$BUILD/fabrication-previews
mkdir -p "$OUT" "$root/docs/images"
machine=$("$KGD" machine)  # date, CPU, cores: the table's header
echo "$machine"
for scene in arm_flexion knee_flexion; do
  "$KGD" design "$scene" --out "$OUT/$scene.h5" --json > "$OUT/$scene.design.jsonl"
  "$KGD" export "$OUT/$scene.h5" --out "$OUT/$scene" --json > "$OUT/$scene.export.json"
  for sheet in pattern patches; do
    node "$root/scripts/svg_to_png.mjs" "$OUT/$scene/$sheet.svg" "$root/docs/images/fabrication_${scene}_${sheet}.png" 1200
  done
done
"$KGD" export pull_test_line --out "$OUT/pull_test_line" --json > "$OUT/pull_test_line.export.json"
rm -f "$OUT/makehuman_pattern.txt"
if [ -x "$BUILD/core/pattern_test" ]; then
  "$BUILD/core/pattern_test" --gtest_filter='Pattern.TheMakeHumanArmSleeve*' > "$OUT/makehuman_pattern.txt"
fi
table=$(python3 "$root/scripts/fabrication_table.py" "$OUT")
printf '%s\n' "$table"
printf '%s\n' "$table" | python3 "$root/scripts/generated_block.py" replace "$root/docs/FABRICATION.md" fabrication-figures \
  --command "bash scripts/fabrication_previews.sh" --machine "$machine"
