#!/usr/bin/env bash
# Temporal stability (docs/technique.md, "Temporal stability"): an orbit of FRAMES frames around
# each built-in scene (the eye turning about the vertical axis, 3 degrees a frame, at the tool's
# default distance), rendered with the field at 1 sample per pixel and with the supersampled
# physical reference (full tree, 4x4); flicker.py (beside this script) prints each one's flicker
# (mean absolute frame-to-frame change over object pixels) and the field's relative to the
# reference's.
#
#   scripts/measure/flicker-measure.sh SHREFRACT OUTDIR [SCENE...]    (FRAMES=16 SIZE=160x120 by default)
#
# The frames stay in OUTDIR/SCENE/ (PNG sequences: field_T.png, reference_T.png) for people to flip
# through. Fields are baked with --samples 4000, as in aa-measure.sh; a field already at
# OUTDIR/SCENE/field.shrf is used as it is (place the field you want to measure there).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=scripts/measure/scene-runs.sh
source "$here/scene-runs.sh"
scene_args "$@"
frames=${FRAMES:-16}
size=${SIZE:-160x120}
for s in "${scenes[@]}"; do
  d=$out/$s
  mkdir -p "$d"
  scene=builtin:$s
  bake_once "$d" "$scene"
  for ((t = 0; t < frames; ++t)); do
    eye=$(python3 -c "import math; a = math.radians(3 * $t); print(f'{4 * math.sin(a):.5f},1.2,{4 * math.cos(a):.5f}')")
    # Progress lines go to render.log; a failing render stops the script (set -e) and its line is there.
    r() { "$tool" render "$@" --size "$size" --eye "$eye" --target 0,0,0 > /dev/null 2>> "$d/render.log"; }
    r "$scene" --mode single-interface --ior 1.2 -o "$d/mask_a_$t.png"
    r "$scene" --mode single-interface --ior 1.9 -o "$d/mask_b_$t.png"
    r "$scene" --mode full-tree --spp 16 -o "$d/reference_$t.png"
    r "$d/field.shrf" -o "$d/field_$t.png"
  done
  echo "== $s ($frames frames, $size)"
  python3 "$here/flicker.py" "$d" "$frames" reference field
done
