#!/usr/bin/env bash
# Packs what scripts/measure/gpu-measure.sh needs on a GPU machine that has a Vulkan driver and nothing
# else (docs/performance.md, "On a GPU"): the engine-only binaries of BUILD (they link only the
# Vulkan loader and the C++ runtime), optionally a BEFORE build's frame benchmark, the Debian 12
# loader, GL-vendor and validation-layer packages (the NVIDIA ICD needs libglvnd), and fields,
# xz-compressed (a default Pca field is 35 MB, 24 MB packed).
#
#   scripts/gpu-pack.sh BUILD DEST [BEFORE_FRAME_BENCHMARK] [FIELD.shrf ...]
#
# DEST must be a folder git ignores (e.g. .gl, listed in .git/info/exclude); copy it to the
# machine beside the checkout and run `bash scripts/measure/gpu-measure.sh DEST` there.
set -euo pipefail
if [ $# -lt 2 ] || [ ! -x "${1}/samples/shrefract_frame_benchmark" ]; then
  echo "usage: scripts/gpu-pack.sh BUILD DEST [BEFORE_FRAME_BENCHMARK] [FIELD.shrf ...] (BUILD: a build folder with the benchmarks)" >&2
  exit 2
fi
build=$1 dest=$2
shift 2
before=""
if [ $# -gt 0 ] && [[ $1 != *.shrf ]]; then before=$1; shift; fi
tests="sh_gpu_test environment_level_test decompression_test decompression_encodings_test decompress_paths_test
  synchronization_test object_memory_test msaa_test stability_field_test soak_test"
mkdir -p "$dest/fields" "$dest/stage/bin" "$dest/stage/old"
cp "$build/samples/shrefract_frame_benchmark" "$build/samples/shrefract_decompression_benchmark" "$dest/stage/bin/"
for t in $tests; do cp "$build/tests/$t" "$dest/stage/bin/"; done
[ -n "$before" ] && cp "$before" "$dest/stage/old/shrefract_frame_benchmark"
for b in "$dest"/stage/bin/* "$dest"/stage/old/*; do
  if ldd "$b" | grep -qi 'embree\|OpenImageIO\|tbb'; then echo "gpu-pack: $b links more than the engine" >&2; exit 1; fi
done
strip "$dest"/stage/bin/* "$dest"/stage/old/* 2>/dev/null || true
tar -C "$dest/stage" -cJf "$dest/bins.tar.xz" bin old
rm -rf "$dest/stage"
for f in "$@"; do xz -T0 -6 -c "$f" > "$dest/fields/$(basename "$f").xz"; done
if ! ls "$dest"/libvulkan1_*.deb > /dev/null 2>&1; then
  o='-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=/tmp/amd64'
  mkdir -p /tmp/amd64/partial
  apt-get $o update > /dev/null
  (cd "$dest" && apt-get $o download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2 vulkan-validationlayers)
fi
du -sh "$dest"
