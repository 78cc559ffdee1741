#!/usr/bin/env bash
# The raster pass's GPU time of two builds or two settings (docs/performance.md, "Frame"): the
# raster pass's GPU time (render --json, gpu_ms.raster, a median over the frames) of BEFORE and
# AFTER, alternated in one run on the same machine, for a field and a single-interface render
# (FRAMES frames each, default 20). Prints each run and the after / before ratio of the medians.
#
#   scripts/measure/aa-cost.sh BEFORE_SHREFRACT AFTER_SHREFRACT FIELD.shrf SCENE [ROUNDS]
#
# BEFORE_ARGS and AFTER_ARGS (words) are added to each side's render commands, so that one build
# compares two settings, e.g. the tap count of the filtered lookups:
#   BEFORE_ARGS="--dev env-taps=1" AFTER_ARGS="--dev env-taps=2" scripts/measure/aa-cost.sh T T FIELD SCENE
set -euo pipefail
before=$1 after=$2 field=$3 scene=$4 rounds=${5:-3}
read -r -a beforeArgs <<< "${BEFORE_ARGS:-}"
read -r -a afterArgs <<< "${AFTER_ARGS:-}"
ms() { "$1" render "${@:2}" --size 640x480 --dev frames=${FRAMES:-20} --json -o /tmp/aa-cost.png 2>/dev/null |
  python3 -c 'import json,sys; print(json.load(sys.stdin)["gpu_ms"]["raster"])'; }
for what in field single-interface; do
  if [ $what = field ]; then args=("$field"); else args=("$scene" --mode single-interface); fi
  b=() a=()
  for ((i = 0; i < rounds; ++i)); do
    b+=("$(ms "$before" "${args[@]}" ${beforeArgs[@]+"${beforeArgs[@]}"})")
    a+=("$(ms "$after" "${args[@]}" ${afterArgs[@]+"${afterArgs[@]}"})")
  done
  python3 - "$what" "${b[*]}" "${a[*]}" <<'PY'
import statistics, sys
what, b, a = sys.argv[1], [float(x) for x in sys.argv[2].split()], [float(x) for x in sys.argv[3].split()]
mb, ma = statistics.median(b), statistics.median(a)
print(f"{what}: raster GPU ms before {b} after {a}; medians {mb:.3f} -> {ma:.3f}, ratio {ma / mb:.3f}")
PY
done
