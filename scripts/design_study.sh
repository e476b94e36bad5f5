#!/usr/bin/env bash
# The design study of docs/RESULTS.md and the job times of docs/PERFORMANCE.md: built-in scenes optimized
# with the paper's settings (kgd design), then for the paper's sleeves the final design beside a Line
# and an X of equal area (kgd baselines), for the paper's seven the design over the motion's frames
# (kgd evaluate), for the scenes with roles the design on its pattern pieces (kgd export's preview).
# Long; not part of `make test`. Writes every generated block whose runs it made and finished
# (scripts/study_tables.py, scripts/generated_block.py), headed by `kgd machine`:
# docs/RESULTS.md: results-table-1, results-curves (the paper's seven), results-roles (the role runs);
# docs/PERFORMANCE.md: performance-motions (arm_flexion, knee_flexion, slouch and the three with roles),
# performance-predicted (the paper's seven, and every other built-in run made).
#   bash scripts/design_study.sh [BUILD_DIR] [OUT_DIR] [RUN ...]
# RUN: a built-in scene (knee_flexion), one with flags of kgd design joined by + (arm_brace+resist-only:
# `kgd design arm_brace --resist-only`), or a group: paper (the paper's seven scenes), roles (arm_brace,
# knee_brace, posture_shirt, each with and without --resist-only, and posture_shirt --symmetric).
# Default: paper roles. STUDY_COMMAND names the command in the blocks' headers.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/scripts/study_scene.sh"
build=${1:-build}
out=${2:-$build/study}
shift $(( $# > 2 ? 2 : $# ))
paper=(arm_flexion arm_extension knee_flexion knee_extension slouch crouch lunge)
roles=(arm_brace arm_brace+resist-only knee_brace knee_brace+resist-only posture_shirt posture_shirt+resist-only posture_shirt+symmetric)
runs=()
for a in "${@:-paper roles}"; do
  for r in $a; do
    case "$r" in
      paper) runs+=("${paper[@]}") ;;
      roles) runs+=("${roles[@]}") ;;
      *) runs+=("$r") ;;
    esac
  done
done
command=${STUDY_COMMAND:-bash scripts/design_study.sh $build $out${*:+ $*}}
kgd="$build/client/kgd"
mkdir -p "$out"
machine=$("$kgd" machine)  # date, CPU, cores: the tables' header
echo "$machine"
# The reference predictions: `kgd scenes` with a cache folder of its own, where nothing was learned.
fresh=$(mktemp -d)
KGD_CACHE_DIR="$fresh" "$kgd" scenes > "$out/scenes.txt"
rm -rf "$fresh"
: > "$out/runs.txt"  # the runs made and finished by this study, the blocks' sources
failed=()
declare -A warm=()
for run in "${runs[@]}"; do
  echo "== $run"
  IFS=+ read -r scene flags <<< "$run"
  # Each design job reads its scene from the scene cache (built here first when absent), so every
  # measured wall time is a job's with the cache warm.
  if [ -z "${warm[$scene]:-}" ]; then
    "$kgd" simulate "$scene" --max-iterations 0 > /dev/null 2>&1 || true
    warm[$scene]=1
  fi
  args=()
  [ -n "$flags" ] && for f in ${flags//+/ }; do args+=("--$f"); done
  # A failed design (exit 3) is reported and the study goes on with what was stored.
  if study_scene "$kgd" "$out" "$run" "$scene" "${args[@]}"; then
    echo "$run" >> "$out/runs.txt"
  else
    failed+=("$run")
  fi
  case " ${roles[*]} " in
    *" $run "*) rm -rf "$out/$run.export"
                # The preview of the pattern pieces; a sheet wide enough for the shirt's back panel.
                "$kgd" export "$out/$run.h5" --out "$out/$run.export" --formats png --sheet-width-mm 1000 > /dev/null 2> "$out/$run.export.log" || true ;;
  esac
done
for block in results-table-1 results-curves results-roles performance-motions performance-predicted; do
  doc="$root/$(python3 "$root/scripts/study_tables.py" doc "$block")"
  if table=$(python3 "$root/scripts/study_tables.py" "$block" "$out"); then
    if [ "$block" = results-roles ]; then  # the pictures its table shows
      mkdir -p "$root/docs/images/roles"
      for run in "${roles[@]}"; do
        [ -f "$out/$run.export/pattern.png" ] && cp "$out/$run.export/pattern.png" "$root/docs/images/roles/$run.png"
      done
    fi
    printf '%s\n' "$table" | python3 "$root/scripts/generated_block.py" replace "$doc" "$block" \
      --command "$command" --machine "$machine" || echo "$doc: $block not written"
  else
    echo "$doc: $block not written"
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "failed: ${failed[*]}"
  exit 3
fi
