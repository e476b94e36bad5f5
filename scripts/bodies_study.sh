#!/usr/bin/env bash
# One design for sizes S-L (docs/RESULTS.md, "One design for sizes S-L"; docs/MODEL.md, "Range of
# bodies"): the knee-flexion sleeve designed for M alone (knee_flexion), for the worst of S, M and L
# (knee_flexion_sizes) and for their mean (knee_flexion_sizes_mean), each design then worn by all three
# bodies (kgd evaluate --on knee_flexion_sizes: the deformed pose from the body, against each body's
# fully reinforced garment). Writes the block results-bodies of docs/RESULTS.md between its markers,
# headed by `kgd machine`, and the designs' pattern previews to docs/images/bodies/; first checks that
# knee_flexion_sizes exported as a scene file designs as the built-in one, bit for bit (about five
# minutes on two quiet cores).
#   bash scripts/bodies_study.sh [BUILD_DIR] [OUT_DIR]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-build}
out=${2:-$build/study-bodies}
kgd="$build/client/kgd"
mkdir -p "$out" "$root/docs/images/bodies"
machine=$("$kgd" machine)  # date, CPU, cores: the block's header
echo "$machine"
# The built-in scene exported as a scene file designs as the built-in does, bit for bit (two iterations;
# the records without their times).
rm -rf "$out/knee_flexion_sizes.scene" "$out"/two_*.h5
"$kgd" scene export knee_flexion_sizes "$out/knee_flexion_sizes.scene" > /dev/null
"$kgd" design knee_flexion_sizes --iterations 2 --overwrite --out "$out/two_builtin.h5" --json > "$out/two_builtin.jsonl"
"$kgd" design "$out/knee_flexion_sizes.scene/scene.json" --iterations 2 --overwrite --out "$out/two_file.h5" --json > "$out/two_file.jsonl"
python3 - "$out/two_builtin.jsonl" "$out/two_file.jsonl" <<'PY'
import json, sys
def records(path):
    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if not (k.endswith("_s") or k in ("file", "seconds", "predicted_s", "machine_factor", "machine_factor_jobs"))}
        return [strip(v) for v in x] if isinstance(x, list) else x
    return [strip(json.loads(l)) for l in open(path) if l.startswith("{")]
a, b = records(sys.argv[1]), records(sys.argv[2])
if a != b or len(a) < 3:
    sys.exit("the exported knee_flexion_sizes does not design as the built-in one")
print(f"knee_flexion_sizes exported as a scene file designs as the built-in one, bit for bit ({len(a) - 1} iterations)")
PY
runs=(knee_flexion knee_flexion_sizes knee_flexion_sizes_mean)
# The three designs side by side (one core's work each), then each worn by the three bodies.
pids=()
for run in "${runs[@]}"; do
  rm -f "$out/$run.h5"
  ("$kgd" design "$run" --overwrite --out "$out/$run.h5" --json > "$out/$run.jsonl" &&
     "$kgd" evaluate "$out/$run.h5" --on knee_flexion_sizes --json > "$out/$run.evaluate.json") &
  pids+=($!)
done
for p in "${pids[@]}"; do wait "$p"; done
for run in "${runs[@]}"; do
  echo "== $run"
  tail -1 "$out/$run.jsonl"
  cat "$out/$run.evaluate.json"
done
for run in knee_flexion knee_flexion_sizes; do
  rm -rf "$out/$run.export"
  "$kgd" export "$out/$run.h5" --out "$out/$run.export" --formats png > /dev/null
  cp "$out/$run.export/pattern.png" "$root/docs/images/bodies/$run.png"
done

python3 - "$out" "${runs[@]}" <<'PY' | python3 "$root/scripts/generated_block.py" replace "$root/docs/RESULTS.md" results-bodies \
  --command "make study-bodies" --machine "$machine"
import json, sys
out, runs = sys.argv[1], sys.argv[2:]
what = {"knee_flexion": "M alone", "knee_flexion_sizes": "the worst of S, M, L", "knee_flexion_sizes_mean": "the mean of S, M, L"}
print("| design (`kgd design`) | designed for | iterations | reinforced | S | M | L | worst body |")
print("|---|---|---:|---:|---:|---:|---:|---:|")
worst = {}
for run in runs:
    done = [json.loads(l) for l in open(f"{out}/{run}.jsonl") if l.startswith("{")]
    done = [d for d in done if d.get("event") == "done"][-1]
    ev = json.load(open(f"{out}/{run}.evaluate.json"))
    ratio = {b["body"]: b["density_ratio"] for b in ev["bodies"]}
    w = min(ratio, key=ratio.get)
    worst[run] = ratio[w]
    print(f"| `{run}` | {what[run]} | {done['iterations']} ({done['end']}) | {100 * done['area_fraction']:.1f} % | {ratio['S']:.3f} | {ratio['M']:.3f} | {ratio['L']:.3f} "
          f"| {ratio[w]:.3f} ({w}) |")
print()
print("Density ratio of each design worn by each body: the reinforced garment's energy per reinforced area in the")
print("body's deformed pose over that of the body's own fully reinforced garment, both simulated from the body")
print("(`kgd evaluate DESIGN.h5 --on knee_flexion_sizes`); reinforced: the fraction of M's garment area.")
m, r = worst["knee_flexion"], worst["knee_flexion_sizes"]
print(f"The design for the worst body keeps its worst body at {r:.3f} against {m:.3f} for the design for M alone "
      f"({100 * (r / m - 1):+.1f} %).")
print()
print("| designed for M alone | designed for the worst of S, M, L |")
print("|---|---|")
print("| ![knee_flexion pattern](images/bodies/knee_flexion.png) | ![knee_flexion_sizes pattern](images/bodies/knee_flexion_sizes.png) |")
PY
