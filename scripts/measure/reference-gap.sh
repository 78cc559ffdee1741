#!/usr/bin/env bash
# The anti-aliasing target (at one sample per pixel with filtering, within 2 dB of the same mode at
# 4x4) for the CPU references (docs/technique.md, "The CPU references"): the exact mode and the full
# tree at 1 spp (`render --dev filtered`) and at 4x4 (`--spp 16`), each against the full tree at 4x4
# (the report's reference) and at 7x7 (`--spp 49`, which shares no sub-sample with the 4x4 renders,
# nor with the 1-spp probes and bisections, at sixteenths of the pixel; the report's denser
# reference), object pixels, colours clamped, linear (linear_psnr.py), 320x240, the tool's default
# views, built-in environment.
#
#   scripts/measure/reference-gap.sh SHREFRACT OUTDIR [SCENE...]    (SCENE: sphere cube torus glass-of-water)
#
# Renders are kept in OUTDIR/SCENE/ and reused. Prints one line per scene and reference: each mode's
# 1 spp and 4x4 figures and the gap (4x4 less 1 spp; the target is at most 2). The full tree's 4x4
# is the 4x4 reference itself, so its gap is printed against the 7x7 only. Needs oiiotool
# (openimageio-tools, which scripts/setup-debian.sh installs).
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: $0 SHREFRACT OUTDIR [SCENE...]" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=scripts/measure/render-once.sh
source "$here/render-once.sh"
# shellcheck source=scripts/measure/scene-runs.sh
source "$here/scene-runs.sh"
scene_args "$@"
for s in "${scenes[@]}"; do
  d=$out/$s
  mkdir -p "$d"
  r() { render_once "$d" "$1" "$tool" "builtin:$s" "${@:2}"; }  # r NAME FLAGS...: the scene's image NAME, once
  # The object mask: two IORs change every object pixel and no background pixel.
  r mask_a --mode single-interface --ior 1.2
  r mask_b --mode single-interface --ior 1.9
  r ref4 --mode full-tree --spp 16
  r ref7 --mode full-tree --spp 49
  r exact16 --mode exact --spp 16
  r exact1 --mode exact --dev filtered
  r tree1 --mode full-tree --dev filtered
  for ref in ref4 ref7; do
    psnr() { python3 "$here/linear_psnr.py" "$d/mask_a.fits" "$d/mask_b.fits" "$d/$ref.fits" "$@" | awk '{print $2}'; }
    read -r e16 e1 t1 t16 < <(psnr "$d/exact16.fits" "$d/exact1.fits" "$d/tree1.fits" "$d/ref4.fits" | xargs)
    line="$s against the full tree $([ $ref = ref4 ] && echo 4x4 || echo 7x7): exact 1 spp $e1, 4x4 $e16, gap"
    line="$line $(python3 -c "print(f'{$e16 - $e1:.2f}')"); full tree 1 spp $t1"
    [ $ref = ref7 ] && line="$line, 4x4 $t16, gap $(python3 -c "print(f'{$t16 - $t1:.2f}')")"
    echo "$line"
  done
done
