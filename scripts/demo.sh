#!/usr/bin/env bash
# The main job on the embedded default: `kgd serve` (server + one in-process worker, SQLite and HDF5 in
# BUILD/demo-data) with the web page, the built-in arm-flexion design job submitted and watched through
# the CLI (and live on the page), its final design fetched as PLY. On a terminal the service then keeps
# serving until Ctrl-C, on the addresses the CLI and the browser use by default (gRPC 127.0.0.1:7447,
# the page 127.0.0.1:7448; KGD_DEMO_GRPC and KGD_DEMO_HTTP set others), so `kgd jobs` reaches it.
set -euo pipefail
BUILD=${1:-build}
KGD=$BUILD/client/kgd
DATA=$BUILD/demo-data
LOG=$BUILD/demo-serve.log

HTTP=${KGD_DEMO_HTTP:-127.0.0.1:7448}
GRPC=${KGD_DEMO_GRPC:-127.0.0.1:7447}
"$KGD" serve --data "$DATA" --listen "$GRPC" --http "$HTTP" --workers 1 > "$LOG.out" 2> "$LOG" &
SERVE=$!
trap 'kill -TERM $SERVE 2>/dev/null; wait $SERVE 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  grep -q "web page" "$LOG.out" 2>/dev/null && break
  kill -0 $SERVE 2>/dev/null || break
  sleep 0.1
done
ADDR=$(sed -n 's/^listening on \([^;]*\);.*/\1/p' "$LOG.out")
[ -n "$ADDR" ] || { echo "demo: kgd serve did not start:"; cat "$LOG"; exit 1; }
URL=$(sed -n 's/^web page and HTTP API: //p' "$LOG.out")
echo "demo: design service on $ADDR, data in $DATA (server log: $LOG)"
echo "demo: open $URL to watch the job live in 3D"

JOB=$("$KGD" submit arm_flexion --label demo --server "$ADDR" --json | sed -n 's/^{"id":\([0-9]*\),.*/\1/p')
echo "demo: submitted job $JOB (built-in arm flexion: sleeve over the elbow, 15 -> 100 degrees, budget 15 %)"
"$KGD" watch "$JOB" --server "$ADDR"
"$KGD" get "$JOB" --out "$BUILD/arm_flexion_design.ply" --server "$ADDR"
"$KGD" job "$JOB" --server "$ADDR" | tail -n 2
echo "demo: final design on the garment: $BUILD/arm_flexion_design.ply (per-face 'design' and 'energy_density_Pa')"
echo "demo: whole history: $DATA/jobs/job-$JOB.h5 (kgd designs FILE prints it; kgd serve --data $DATA serves it again)"
if [ -t 0 ]; then
  echo "demo: the web page stays at $URL until Ctrl-C; meanwhile \`kgd jobs --server $ADDR\` lists the jobs"
  wait $SERVE || true
fi
