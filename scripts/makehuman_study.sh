#!/usr/bin/env bash
# The design study of docs/RESULTS.md on the real bodies of ../shared/bodies/makehuman (MakeHuman meshes,
# CC0; not part of a clone): each of the seven motions as a scene file naming the shared meshes (garment
# regions subdivided twice, the paper's sizes; the paper's budgets), then the steps of
# scripts/study_scene.sh that scripts/design_study.sh runs for the built-in scenes. Long; not part of
# `make test`. With all seven motions designed, writes the table of docs/RESULTS.md, "On the MakeHuman
# bodies", between its markers (scripts/makehuman_tables.py, scripts/generated_block.py), headed by
# `kgd machine`.
#   bash scripts/makehuman_study.sh [BUILD_DIR] [OUT_DIR] [MOTION ...]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/scripts/study_scene.sh"
build=${1:-build}
out=${2:-$build/study-makehuman}
shift $(( $# > 2 ? 2 : $# ))
motions=("$@")
if [ ${#motions[@]} -eq 0 ]; then
  motions=(arm_flexion arm_extension knee_flexion knee_extension slouch crouch lunge)
fi
bodies=$root/../shared/bodies/makehuman
if [ ! -f "$bodies/rest.obj" ]; then
  echo "no MakeHuman bodies at $bodies (../shared/bodies is not part of a clone)" >&2
  exit 2
fi
bodies=$(cd "$bodies" && pwd)
kgd="$build/client/kgd"
mkdir -p "$out"
machine=$("$kgd" machine)  # date, CPU, cores: the table's header
echo "$machine"
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
  study_scene "$kgd" "$out" "$m" "$out/$m/scene.json" || failed+=("$m")
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "failed: ${failed[*]}"
  exit 3
fi
if table=$(python3 "$root/scripts/makehuman_tables.py" "$out"); then
  printf '%s\n' "$table" | python3 "$root/scripts/generated_block.py" replace "$root/docs/RESULTS.md" results-makehuman \
    --command "make study-makehuman" --machine "$machine"
else
  echo "docs/RESULTS.md: results-makehuman not written (it needs the seven motions' files in $out)"
fi
