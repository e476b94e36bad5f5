#!/usr/bin/env bash
# The design study of docs/RESULTS.md: every built-in scene of the paper optimized with the paper's
# settings (kgd design), then the final design beside a Line and an X of equal area (kgd baselines, for
# the sleeves) and over the motion's frames (kgd evaluate). Long (about ten minutes on two cores); not
# part of `make test`. With all seven scenes designed, writes Table 1 and the curves into docs/RESULTS.md
# between their markers (scripts/study_tables.py, scripts/generated_block.py), headed by `kgd machine`.
#   bash scripts/design_study.sh [BUILD_DIR] [OUT_DIR] [SCENE ...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/scripts/study_scene.sh"
build=${1:-build}
out=${2:-$build/study}
shift $(( $# > 2 ? 2 : $# ))
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
  scenes=(arm_flexion arm_extension knee_flexion knee_extension slouch crouch lunge)
fi
kgd="$build/client/kgd"
mkdir -p "$out"
machine=$("$kgd" machine)  # date, CPU, cores: the tables' header
echo "$machine"
failed=()
for s in "${scenes[@]}"; do
  echo "== $s"
  # A failed design (exit 3) is reported and the study goes on with what was stored.
  study_scene "$kgd" "$out" "$s" "$s" || failed+=("$s")
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "failed: ${failed[*]}"
  exit 3
fi
for block in results-table-1 results-curves; do
  if table=$(python3 "$root/scripts/study_tables.py" "$block" "$out"); then
    printf '%s\n' "$table" | python3 "$root/scripts/generated_block.py" replace "$root/docs/RESULTS.md" "$block" \
      --command "make study" --machine "$machine"
  else
    echo "docs/RESULTS.md: $block not written (it needs the seven built-in scenes' files in $out)"
  fi
done
