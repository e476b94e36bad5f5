# The steps of a design study for one run, shared by scripts/design_study.sh and
# scripts/makehuman_study.sh (sourced):
#   study_scene KGD OUT_DIR NAME SCENE [FLAG ...]
# runs `kgd design SCENE FLAG...` (a built-in name or a scene file; FLAGs of kgd design, e.g.
# --resist-only) into OUT_DIR/NAME.h5 with its iterations in NAME.jsonl and its wall time (s) in
# NAME.wall_s, then `kgd designs` (NAME.table.txt), `kgd baselines` for the paper's four sleeves
# (NAME.baselines.txt) and `kgd evaluate` over the frames for the paper's seven motions
# (NAME.frames.txt). Returns non-zero when the design failed; the other steps still run on what was
# stored.
study_scene() {
  local kgd=$1 out=$2 name=$3 scene=$4 status=0 start
  shift 4
  start=$(date +%s.%N)
  "$kgd" design "$scene" "$@" --overwrite --out "$out/$name.h5" > "$out/$name.jsonl" || status=$?
  echo "$start $(date +%s.%N)" | awk '{ printf "%.3f\n", $2 - $1 }' > "$out/$name.wall_s"
  tail -n 1 "$out/$name.jsonl"
  "$kgd" designs "$out/$name.h5" > "$out/$name.table.txt"
  tail -n 1 "$out/$name.table.txt"
  case "$name" in
    arm_flexion|arm_extension|knee_flexion|knee_extension) "$kgd" baselines "$out/$name.h5" | tee "$out/$name.baselines.txt" || true ;;
  esac
  case "$name" in
    arm_flexion|arm_extension|knee_flexion|knee_extension|slouch|crouch|lunge) "$kgd" evaluate "$out/$name.h5" | tee "$out/$name.frames.txt" || true ;;
  esac
  return $status
}
