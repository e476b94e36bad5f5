#!/usr/bin/env bash
# The design study of docs/RESULTS.md: every built-in scene of the paper optimized with the paper's
# settings (kgd design), then the final design beside a Line and an X of equal area (kgd baselines, for
# the sleeves) and over the motion's frames (kgd evaluate). Long (about ten minutes on two cores); not
# part of `make test`.
#   bash scripts/design_study.sh [BUILD_DIR] [OUT_DIR] [SCENE ...]
set -euo pipefail
source "$(dirname "$0")/study_scene.sh"
build=${1:-build}
out=${2:-$build/study}
shift $(( $# > 2 ? 2 : $# ))
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
  scenes=(arm_flexion arm_extension knee_flexion knee_extension slouch crouch lunge)
fi
kgd="$build/client/kgd"
mkdir -p "$out"
date -u; nproc; lscpu | grep -E "Model name" || true
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
