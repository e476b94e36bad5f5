# The steps of a design study for one scene, shared by scripts/design_study.sh and
# scripts/makehuman_study.sh (sourced):
#   study_scene KGD OUT_DIR NAME SCENE
# runs `kgd design SCENE` (a built-in name or a scene file) into OUT_DIR/NAME.h5 with its iterations in
# NAME.jsonl, then `kgd designs` (NAME.table.txt), `kgd baselines` for the sleeves (NAME.baselines.txt)
# and `kgd evaluate` over the frames (NAME.frames.txt). Returns non-zero when the design failed; the
# other steps still run on what was stored.
study_scene() {
  local kgd=$1 out=$2 name=$3 scene=$4 status=0
  "$kgd" design "$scene" --out "$out/$name.h5" > "$out/$name.jsonl" || status=$?
  tail -n 1 "$out/$name.jsonl"
  "$kgd" designs "$out/$name.h5" > "$out/$name.table.txt"
  tail -n 1 "$out/$name.table.txt"
  case "$name" in
    arm_*|knee_*) "$kgd" baselines "$out/$name.h5" | tee "$out/$name.baselines.txt" || true ;;
  esac
  "$kgd" evaluate "$out/$name.h5" | tee "$out/$name.frames.txt" || true
  return $status
}
