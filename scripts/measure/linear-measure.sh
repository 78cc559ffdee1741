#!/usr/bin/env bash
# The linear measure (docs/performance.md, "Fidelity"): each FIELD rendered 4x4 supersampled and at
# 1 spp (`render FIELD --spp 16|1 --size 320x240`, the GPU; EXR) against the full tree at 4x4
# (`render SCENE --mode full-tree --spp 16`), object pixels, colours clamped (linear_psnr.py, beside
# this script).
#
#   scripts/measure/linear-measure.sh SHREFRACT SCENE OUTDIR FIELD.shrf [RENDER_FLAGS...]
#
# The reference and the masks are rendered once into OUTDIR and kept. Needs oiiotool (Debian's
# openimageio-tools, which scripts/setup-debian.sh installs). Prints "IMAGE PSNR" per render.
set -euo pipefail
tool=$1 scene=$2 out=$3 field=$4
shift 4
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
r() { "$tool" render "$@" --size 320x240 > /dev/null; }
fits() { oiiotool "$1" --ch R,G,B -d float -o "${1%.exr}.fits"; }
if [ ! -f "$out/reference.fits" ]; then
  r "$scene" --mode full-tree --spp 16 -o "$out/reference.exr" && fits "$out/reference.exr"
  r "$scene" --mode single-interface --ior 1.2 -o "$out/mask_a.exr" && fits "$out/mask_a.exr"
  r "$scene" --mode single-interface --ior 1.9 -o "$out/mask_b.exr" && fits "$out/mask_b.exr"
fi
name=$(basename "$field" .shrf)
r "$field" "$@" --spp 16 -o "$out/$name.16.exr" && fits "$out/$name.16.exr"
r "$field" "$@" --spp 1 -o "$out/$name.1.exr" && fits "$out/$name.1.exr"
python3 "$here/linear_psnr.py" "$out/mask_a.fits" "$out/mask_b.fits" "$out/reference.fits" \
  "$out/$name.16.fits" "$out/$name.1.fits"
