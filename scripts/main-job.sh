#!/usr/bin/env bash
# Fresh Debian 12 machine -> the main job, in minutes: set up, build the tool, bake every built-in
# scene with the tool's defaults, render the sphere's field beside its references, and write the
# report (out/report/report.md): fidelity against the physical reference, the error decomposition,
# error against frame and bake time per encoding, images side by side. Output goes to out/
# (override with OUT_DIR); `shrefract report --full` is the hours-long version.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${BUILD_DIR:-$root/build}"
out="${OUT_DIR:-$root/out}"
bash "$root/scripts/setup-debian.sh"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build "$build" -j "$(nproc)" --target shrefract
mkdir -p "$out"
# Lavapipe by default, so the job runs the same on any machine; set VK_DRIVER_FILES to choose.
export VK_DRIVER_FILES="${VK_DRIVER_FILES:-/usr/share/vulkan/icd.d/lvp_icd.x86_64.json}"
tool="$build/samples/shrefract"
# The default bakes: no flags, what a user's `bake SCENE` makes (each prints its time and memory).
for scene in sphere cube torus glass-of-water; do
  "$tool" bake "builtin:$scene" -o "$out/$scene.shrf"
done
"$tool" info "$out/sphere.shrf"
for mode in field exact full-tree single-interface; do
  "$tool" render "$out/sphere.shrf" --mode "$mode" --size 640x480 --spp 4 -o "$out/sphere_$mode.png"
done
"$tool" report -o "$out/report"
echo "main job done: $out/report/report.md (fidelity, error decomposition, error against frame and bake"
echo "  time, side-by-side images); $out/sphere_{field,exact,full-tree,single-interface}.png"
