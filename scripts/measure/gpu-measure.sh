#!/usr/bin/env bash
# On a GPU machine, with DEST from scripts/gpu-pack.sh (docs/performance.md, "On a GPU"): unpacks
# the Vulkan loader and validation layer, runs the engine-only GPU tests (validation on inside each;
# any message fails the test), the frame and decompression benchmarks with --validation (exit 1 on
# any message), then times: the synthetic field filling the view (BEFORE's build against this one,
# alternated), each packed field in a row of 4 at 1, 2 and 4 taps per axis, the single-interface
# shading, the host's 4x MSAA and 4K, each field's decompression, and the encodings table (54289 and
# 1M samples). Writes ${OUT:-.}/gpu.log. As root (dpkg -x to /).
#
#   bash scripts/measure/gpu-measure.sh DEST
set -uo pipefail
G=$1 B=$1/bin F=$1/fields
log=${OUT:-.}/gpu.log
exec > >(tee "$log") 2>&1
for f in "$G"/*.deb; do dpkg -x "$f" /; done
ldconfig
export VK_DRIVER_FILES=${VK_DRIVER_FILES:-/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json}
unxz() { if command -v xz > /dev/null; then xz -dc "$1"; else python3 -c 'import lzma,sys,shutil; shutil.copyfileobj(lzma.open(sys.argv[1]), sys.stdout.buffer)' "$1"; fi; }
unxz "$G/bins.tar.xz" | tar -x -C "$G"
for f in "$F"/*.xz; do [ -e "$f" ] && unxz "$f" > "${f%.xz}"; done
fields=("$F"/*.shrf)
[ -e "${fields[0]}" ] || fields=()
clocks() { nvidia-smi --query-gpu=clocks.sm,clocks.mem,temperature.gpu,power.draw --format=csv,noheader 2> /dev/null; }
nvidia-smi --query-gpu=name,driver_version --format=csv 2> /dev/null
echo "clocks (SM, memory, temperature, power): $(clocks)"
frame() { "$B/shrefract_frame_benchmark" "$@"; }

echo "== engine-only GPU tests"
for t in "$B"/*_test; do
  timeout 300 "$t" --gtest_brief=1 > /tmp/gpu-test.log 2>&1
  echo "$(basename "$t") rc=$? $(grep -E '^\[  (PASSED|FAILED|SKIPPED) ' /tmp/gpu-test.log | tr '\n' ' ')"
done
echo "== validation (rc 0: no message)"
frame --validation --frames 10 --env-taps 1,2,4 --msaa 4 "${fields[@]}" > /dev/null; echo "frame, fields, taps 1,2,4, 4x MSAA: rc=$?"
frame --validation --frames 10 --cube-env --shading single-interface "${fields[@]:0:1}" > /dev/null; echo "frame, single interface, cube map: rc=$?"
for f in "${fields[@]}"; do
  "$B/shrefract_decompression_benchmark" --validation "$f" --reps 2 > /dev/null; echo "decompression $f: rc=$?"
done

echo "== synthetic field filling the view (worst case: random coefficients, every texel a jump), still and moving eye"
for r in 1 2; do
  if [ -x "$G/old/shrefract_frame_benchmark" ]; then
    echo "-- round $r, before"; "$G/old/shrefract_frame_benchmark" --instances 1 --frames 300 --env-taps 1,2,4 | grep -A4 "ratios to 1"
  fi
  echo "-- round $r, this build"; frame --instances 1 --frames 300 --env-taps 1,2,4 | grep -A4 "ratios to 1"
done
echo "-- exit direction only (no lookup): this build, then before"
frame --instances 1 --frames 300 --shading exit-direction | grep "still eye, 1"
[ -x "$G/old/shrefract_frame_benchmark" ] && "$G/old/shrefract_frame_benchmark" --instances 1 --frames 300 --shading exit-direction | grep "still eye, 1"
echo "-- single interface, taps 1,2,4"
frame --instances 1 --frames 300 --shading single-interface --env-taps 1,2,4 | grep -A4 "ratios to 1"

for f in "${fields[@]}"; do
  echo "== $f, row of 4, taps 1,2,4"; frame --frames 300 --env-taps 1,2,4 "$f" | grep -v "^field:\|^frame:\|^device:"
  echo "-- 4x MSAA"; frame --frames 200 --msaa 4 "$f" | grep -A3 "^MSAA"
  echo "-- 3840x2160, taps 1,4"; frame --size 3840x2160 --frames 100 --env-taps 1,4 "$f" | grep -A4 "ratios to 1"
  echo "-- decompression"; "$B/shrefract_decompression_benchmark" "$f" --reps 15 | grep 'field:\|decompression pass\|fastest copy'
done

echo "== encodings (synthetic fields; the tool's default is the N=64 row); clocks: $(clocks)"
"$B/shrefract_decompression_benchmark" --encodings --reps 2 --validation > /dev/null; echo "validation rc=$?"
"$B/shrefract_decompression_benchmark" --encodings --reps 15
echo "clocks before 1M samples: $(clocks)"
"$B/shrefract_decompression_benchmark" --encodings --size 1000x1000 --reps 5
echo "clocks after: $(clocks)"
