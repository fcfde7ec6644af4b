#!/usr/bin/env bash
# The gpu backend against the cpu backend (and parry) on one machine with a
# GPU: BENCHMARKS.md's "On a real GPU" tables in one command. Run it where
# the GPU is; the cpu figures come from that machine's cores, so the ratios
# are the machine's own.
#
# Usage: benches/gpu.sh [DATASET]
#   DATASET   the zhang2021 folder (default ../shared/datasets/zhang2021)
#   BIN=path  a maamplan binary built elsewhere (default: build one here)
#   ROUNDS=n  rounds of the bench rows and the plan pairs (default 3)
#
# Prints, per round: `bench` on simple_curve's mix at 20,000 poses
# (gpu, cpu, parry) and at 160,000 (gpu, cpu); then `plan` on each model
# (and dome_cut tilted 50° and 70°, the dense rows) with each backend:
# the stages that ask collision queries, each with the backend calls that
# answered them and the seconds those took (the rest of a stage is the
# planner's own work), the gpu's own line and the wall time; and whether
# the gpu's plan is byte-identical to the cpu's (plan.csv, and the G-code
# but for its command line). Exits 1 when a plan differs or any command
# fails.
set -euo pipefail
cd "$(dirname "$0")/.."
D=${1:-../shared/datasets/zhang2021}
ROUNDS=${ROUNDS:-3}
if [ -z "${BIN:-}" ]; then
  cargo build --release --quiet
  BIN=target/release/maamplan
fi
H=(--head "$D/extruderHead.obj" --platform "$D/printingPlatform.obj" --place 0,0,40.5)
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

"$BIN" info | head -3
for k in $(seq "$ROUNDS"); do
  echo "== round $k: bench simple_curve, 20,000 and 160,000 poses"
  "$BIN" bench "$D/simple_curve" "${H[@]}" --backends gpu,cpu,parry | tail -n +2
  "$BIN" bench "$D/simple_curve" "${H[@]}" --backends gpu,cpu --queries 160000 | tail -n +2
done

# plan NAME BACKEND ARGS...: the stage lines, the gpu's line and the total
plan() {
  local name=$1 backend=$2
  shift 2
  "$BIN" plan "$@" "${H[@]}" --backend "$backend" --no-plots -v -o "$TMP/$name-$backend" \
    >"$TMP/$name-$backend.log" 2>&1 || {
    echo "failed: plan $name --backend $backend" >&2
    tail -3 "$TMP/$name-$backend.log" >&2
    exit 1
  }
  grep -E '^stage (load|columns|graph|program|input)|gpu:|planned in' "$TMP/$name-$backend.log" |
    sed -E 's/; wrote .*//; s/ \[batches of.*//'
}
status=0
for k in $(seq "$ROUNDS"); do
  for row in "simple_curve $D/simple_curve" "tilted $D/simple_curve --tilt 50" \
    "freeform $D/freeform" "dome_cut $D/dome_cut" \
    "dome_cut_tilt50 $D/dome_cut --tilt 50" "dome_cut_tilt70 $D/dome_cut --tilt 70"; do
    set -- $row
    name=$1
    shift
    echo "== round $k: plan $name"
    plan "$name" cpu "$@"
    plan "$name" gpu "$@"
    if cmp -s "$TMP/$name-cpu/plan.csv" "$TMP/$name-gpu/plan.csv" &&
      cmp -s <(grep -v '^; command' "$TMP/$name-cpu/toolpath.gcode") \
        <(grep -v '^; command' "$TMP/$name-gpu/toolpath.gcode"); then
      echo "$name: gpu plan == cpu plan"
    else
      echo "$name: gpu plan DIFFERS from the cpu's"
      status=1
    fi
  done
done
exit $status
