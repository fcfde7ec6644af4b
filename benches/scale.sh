#!/usr/bin/env bash
# The "industrial scale" table: wall time, peak memory and report size of
# `maamplan plan` on the data set's models, each time also as a ratio to the
# yardstick Y measured in the same run (Y = `maamplan check simple_curve
# --backend parry`: parry checking 41,494 poses, a fixed amount of
# third-party work, so ratios travel between machines).
#
# Usage: benches/scale.sh [DATASET] [MORE_TOOLPATH_DIR ...]
#   DATASET   the zhang2021 folder (default ../shared/datasets/zhang2021)
#   MORE_...  further toolpath folders of the same data set (e.g. the
#             held-back models); each is planned as given and tilted 50°.
#   REPEAT=n  runs per row, the median is reported (default 1).
#   YUP=dir1,dir2  those MORE_ folders are Y-up (--y-up).
#
# The head's cache (README) is filled by the Y run, so the rows are warm,
# as for a user planning part after part with one head; the row marked
# "head built" runs with the cache off to show what a first run costs.
set -euo pipefail
cd "$(dirname "$0")/.."
D=${1:-../shared/datasets/zhang2021}
shift || true
REPEAT=${REPEAT:-1}
cargo build --release --quiet
BIN=target/release/maamplan
H=(--head "$D/extruderHead.obj" --platform "$D/printingPlatform.obj" --place 0,0,40.5)
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

# median wall seconds and max peak KiB of REPEAT runs of "$@"
measure() {
  local t=() m=0
  for _ in $(seq "$REPEAT"); do
    /usr/bin/time -f "%e %M" -o "$TMP/time" "$@" >"$TMP/log" 2>&1 || {
      echo "failed: $*" >&2; tail -3 "$TMP/log" >&2; exit 1; }
    read -r s k <"$TMP/time"
    t+=("$s"); [ "$k" -gt "$m" ] && m=$k
  done
  printf '%s\n' "${t[@]}" | sort -g | awk -v m="$m" '{a[NR]=$1} END {print a[int((NR+1)/2)], m}'
}

read -r Y _ < <(measure "$BIN" check "$D/simple_curve" "${H[@]}" --backend parry)
printf '%-44s %9s %7s %9s %10s\n' row seconds "/ Y" "peak MiB" "report.html"
printf '%-44s %9.2f %7.2f\n' "Y: check simple_curve --backend parry" "$Y" 1
row() {
  local name=$1; shift
  rm -rf "$TMP/out"
  read -r s k < <(measure env "${CACHE[@]}" "$BIN" plan "$@" "${H[@]}" --backend cpu -o "$TMP/out")
  local html="-"
  [ -f "$TMP/out/report.html" ] && html=$(awk -v b="$(stat -c %s "$TMP/out/report.html")" 'BEGIN {printf "%.1f MB", b / 1e6}')
  printf '%-44s %9.2f %7.2f %9.0f %10s\n' "$name" "$s" "$(echo "$s / $Y" | bc -l)" "$(echo "$k / 1024" | bc -l)" "$html"
}
CACHE=()
row "simple_curve" "$D/simple_curve"
CACHE=(MAAMPLAN_CACHE_DIR=)
row "simple_curve, head built (cache off)" "$D/simple_curve"
CACHE=()
row "dome_cut (as the original software reads it)" "$D/dome_cut"
row "dome_cut, normals as given (--keep-normals)" "$D/dome_cut" --keep-normals
row "simple_curve, tilted 50° about x" "$D/simple_curve" --tilt 50
row "dome_cut, tilted 50°" "$D/dome_cut" --tilt 50
row "dome_cut, tilted 70°" "$D/dome_cut" --tilt 70
row "dome_cut, part from its beads (--part beads)" "$D/dome_cut" --part beads
row "dome_cut, beads, tilted 50°" "$D/dome_cut" --part beads --tilt 50
row "dome_cut, beads, tilted 70°" "$D/dome_cut" --part beads --tilt 70
for m in "$@"; do
  yup=()
  case ",${YUP:-}," in *",$m,"*) yup=(--y-up) ;; esac
  row "$(basename "$m")" "$m" "${yup[@]}"
  row "$(basename "$m"), tilted 50°" "$m" "${yup[@]}" --tilt 50
done
