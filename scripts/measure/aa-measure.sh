#!/usr/bin/env bash
# Anti-aliasing measurement (docs/technique.md, "Anti-aliasing"): every mode at 1 sample per pixel
# and at 4x4 against the physical reference (full tree, depth 8, 4x4), PSNR over the object pixels
# with colours clamped (8-bit PNGs), on the built-in scenes with the built-in environment, the
# tool's default views, 320x240.
#
#   scripts/measure/aa-measure.sh SHREFRACT OUTDIR [SCENE...]     (SCENE: sphere cube torus glass-of-water)
#
# MASK_FROM=DIR (another run's OUTDIR) measures against that run's mask and reference instead, so
# that two builds are compared on the same pixels (the mask comes from single-interface renders,
# whose filtering moves a few silhouette pixels in or out).
#
# Fields are baked with --samples 4000 (a few minutes on 2 cores): the comparison is each mode at 1
# spp against the same mode at 4x4, so the field's own angular error is common to both.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=scripts/measure/scene-runs.sh
source "$here/scene-runs.sh"
scene_args "$@"
size=320x240
for s in "${scenes[@]}"; do
  d=$out/$s
  mkdir -p "$d"
  scene=builtin:$s
  bake_once "$d" "$scene"
  r() { "$tool" render "$@" --size $size > /dev/null; }
  # The object mask: two IORs change every object pixel and no background pixel.
  r "$scene" --mode single-interface --ior 1.2 -o "$d/mask_a.png"
  r "$scene" --mode single-interface --ior 1.9 -o "$d/mask_b.png"
  [ -f "$d/reference.png" ] || r "$scene" --mode full-tree --spp 16 -o "$d/reference.png"
  r "$scene" --mode full-tree -o "$d/full-tree_1.png"  # at 4x4 it is the reference itself
  filtered=()
  if "$tool" render --help-dev 2>&1 | grep -- filtered > /dev/null; then  # builds before the filtered lookups lack it
    r "$scene" --mode full-tree --dev filtered -o "$d/full-tree_filtered_1.png"
    filtered=("$d/full-tree_filtered_1.png" "$d/exact_filtered_1.png" "$d/exact_filtered_16.png")
  fi
  for spp in 1 16; do
    r "$scene" --mode exact --spp $spp -o "$d/exact_$spp.png"
    [ ${#filtered[@]} = 0 ] || r "$scene" --mode exact --dev filtered --spp $spp -o "$d/exact_filtered_$spp.png"
    r "$d/field.shrf" --spp $spp -o "$d/field_$spp.png"
    r "$scene" --mode single-interface --spp $spp -o "$d/single-interface_$spp.png"
  done
  echo "== $s"
  m=${MASK_FROM:-$out}/$s
  python3 "$here/aa_psnr.py" "$m/mask_a.png" "$m/mask_b.png" "$m/reference.png" \
    "$d"/full-tree_1.png "$d"/exact_1.png "$d"/exact_16.png "$d"/field_1.png "$d"/field_16.png \
    "$d"/single-interface_1.png "$d"/single-interface_16.png "${filtered[@]}"
done
