#!/usr/bin/env bash
# The design study of docs/RESULTS.md on the real bodies of ../shared/bodies/makehuman (MakeHuman meshes,
# CC0; not part of a clone): each of the seven motions as a scene file naming the shared meshes (garment
# regions subdivided twice, the paper's sizes; the paper's budgets), then what scripts/design_study.sh
# does for the built-in scenes: kgd design, kgd designs, kgd baselines (sleeves), kgd evaluate. About
# fifteen minutes on two cores; not part of `make test`.
#   bash scripts/makehuman_study.sh [BUILD_DIR] [OUT_DIR] [MOTION ...]
set -euo pipefail
build=${1:-build}
out=${2:-$build/study-makehuman}
shift $(( $# > 2 ? 2 : $# ))
motions=("$@")
if [ ${#motions[@]} -eq 0 ]; then
  motions=(arm_flexion arm_extension knee_flexion knee_extension slouch crouch lunge)
fi
bodies=$(cd "$(dirname "$0")/.." && pwd)/../shared/bodies/makehuman
if [ ! -f "$bodies/rest.obj" ]; then
  echo "no MakeHuman bodies at $bodies (../shared/bodies is not part of a clone)" >&2
  exit 2
fi
bodies=$(cd "$bodies" && pwd)
kgd="$build/client/kgd"
mkdir -p "$out"
date -u; nproc; lscpu | grep -E "Model name" || true
failed=()
for m in "${motions[@]}"; do
  case "$m" in
    arm_*) region=sleeve_arm budget=0.15 ;;
    knee_flexion) region=sleeve_knee budget=0.10 ;;
    knee_*) region=sleeve_knee budget=0.15 ;;
    slouch) region=shirt budget=0.10 ;;
    *) region=shorts budget=0.15 ;;
  esac
  rest="$bodies/rest.obj"
  [ -f "$bodies/$m/rest.obj" ] && rest="$bodies/$m/rest.obj"
  frames=$(ls "$bodies/$m/frames"/frame_*.obj | sort | sed 's/.*/"&"/' | paste -sd, -)
  mkdir -p "$out/$m"
  cat > "$out/$m/scene.json" <<JSON
{"name": "makehuman_$m", "budget": $budget,
 "body": {"rest": "$rest", "deformed": "$bodies/$m/pose.obj", "frames": [$frames]},
 "garment": {"region": "$bodies/regions/$region.faces.txt", "subdivisions": 2},
 "attachments": {"body_faces": "$bodies/regions/$region.attach.txt"},
 "effects": {"contact": "unilateral", "attachments": true}}
JSON
  echo "== makehuman $m"
  if ! "$kgd" design "$out/$m/scene.json" --out "$out/$m.h5" > "$out/$m.jsonl"; then
    failed+=("$m")
  fi
  tail -n 1 "$out/$m.jsonl"
  "$kgd" designs "$out/$m.h5" > "$out/$m.table.txt"
  tail -n 1 "$out/$m.table.txt"
  case "$m" in
    arm_*|knee_*) "$kgd" baselines "$out/$m.h5" | tee "$out/$m.baselines.txt" || true ;;
  esac
  "$kgd" evaluate "$out/$m.h5" | tee "$out/$m.frames.txt" || true
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "failed: ${failed[*]}"
  exit 3
fi
