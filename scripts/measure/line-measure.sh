#!/usr/bin/env bash
# The fidelity targets for one field, against a physical reference that shares no sub-sample
# position with the renders it judges (docs/performance.md, "Fidelity"): the full tree at 7x7
# (`--spp 49`). The 4x4 reference (`--spp 16`) traces the exact render's own 4x4 positions, and the
# 8x8 (`--spp 64`) the positions of a volume field's 2x2 paths at 4x4; what both sides alias alike
# reads there as agreement. Renders, 320x240, the tool's default view and the built-in environment,
# object pixels, colours clamped, linear (linear_psnr.py, beside this script):
# - the field at 4x4 and at 1 spp;
# - the exact render of the field's own path rule (`render FIELD --mode exact`) at 4x4 and 5x5, and
#   the highest-energy rule's (the floor: the exact highest-energy render less 3 dB), the better
#   of each pair standing for the exact render;
# - the single-interface shader at 4x4.
# Each is printed against the 4x4 tree and the 7x7 tree, then the three targets against the 7x7.
#
#   scripts/measure/line-measure.sh SHREFRACT SCENE OUTDIR FIELD.shrf    (SCENE: builtin:NAME or a glTF)
#
# The scene's renders are kept in OUTDIR and reused; the field's are named after it. Needs oiiotool
# (openimageio-tools, which scripts/setup-debian.sh installs).
set -euo pipefail
[ $# -eq 4 ] || { echo "usage: $0 SHREFRACT SCENE OUTDIR FIELD.shrf" >&2; exit 2; }
tool=$1 scene=$2 out=$3 field=$4
[ -f "$field" ] || { echo "$field: no such field" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$out"
name=$(basename "$field" .shrf)
# shellcheck source=scripts/measure/render-once.sh
source "$here/render-once.sh"
r() { render_once "$out" "$1" "$tool" "${@:2}"; }  # r NAME ARGS...: the image NAME, rendered once
r mask_a "$scene" --mode single-interface --ior 1.2
r mask_b "$scene" --mode single-interface --ior 1.9
r reference "$scene" --mode full-tree --spp 16
r reference49 "$scene" --mode full-tree --spp 49
r single16 "$scene" --mode single-interface --spp 16
r "$name.16" "$field" --spp 16
r "$name.1" "$field" --spp 1
r "$name.exact16" "$field" --mode exact --spp 16
r "$name.exact25" "$field" --mode exact --spp 25
r highest16 "$scene" --mode exact --path-rule highest-energy --spp 16
r highest25 "$scene" --mode exact --path-rule highest-energy --spp 25
images=("$name.16" "$name.1" "$name.exact16" "$name.exact25" highest16 highest25 single16)
files=()
for image in "${images[@]}"; do files+=("$out/$image.fits"); done
against() { python3 "$here/linear_psnr.py" "$out/mask_a.fits" "$out/mask_b.fits" "$out/$1.fits" "${files[@]}"; }
at4=$(against reference | awk '{print $2}' | xargs)
at7=$(against reference49 | awk '{print $2}' | xargs)
python3 - "$name" "$at4" "$at7" << 'EOF'
import sys
name, at4, at7 = sys.argv[1], [float(x) for x in sys.argv[2].split()], [float(x) for x in sys.argv[3].split()]
rows = ["field 4x4", "field 1 spp", "exact 4x4 (its rule)", "exact 5x5 (its rule)", "exact 4x4 (highest)",
        "exact 5x5 (highest)", "single interface 4x4"]
print(f"{name}: PSNR against the full tree 4x4 / 7x7 (dB)")
for row, a, b in zip(rows, at4, at7):
    print(f"  {row:22s} {a:6.2f} / {b:6.2f}")
field, own, highest, single = at7[0], max(at7[2], at7[3]), max(at7[4], at7[5]), at7[6]
met = lambda ok: "met" if ok else "NOT met"
print(f"lines against the 7x7, field {field:.2f}: within 3 dB of its rule's exact render {own:.2f} "
      f"({met(field >= own - 3)}); at least the highest-energy exact render {highest:.2f} less 3 "
      f"({met(field >= highest - 3)}); 10 dB over the single interface {single:.2f} ({met(field >= single + 10)})")
EOF
