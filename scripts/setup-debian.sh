#!/usr/bin/env bash
# Installs the Debian 12 packages shrefract needs to build, test and run.
# Idempotent: only packages that are missing are installed. Works as root or through sudo.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config
  libvulkan-dev vulkan-validationlayers mesa-vulkan-drivers glslang-tools
  libglm-dev libembree-dev libtinygltf-dev nlohmann-json3-dev
  libopenimageio-dev openimageio-tools python3-imath libopencv-core-dev libglfw3-dev libgtest-dev
  xvfb xauth
  # openimageio-tools, python3-imath, libopencv-core-dev: Debian 12's OpenImageIO and Imath CMake configs
  # reference files from these packages and fail to import without them.
  clang libclang-rt-14-dev
  # clang, libclang-rt-14-dev: libFuzzer for the fuzz targets (tests/fuzz, built and run by fuzz_* tests).
  libeigen3-dev
  # libeigen3-dev: the Table fit and the Pca basis of the bake (third_party_notes/README.md).
  openmpi-bin libopenmpi-dev
  # openmpi-bin, libopenmpi-dev: `mpirun -np N shrefract bake` (optional at build time; shard_test runs a
  # 2-rank bake with it). As root mpirun needs OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1.
  libtbb-dev
  # libtbb-dev: oneTBB, the bake's parallel loops (third_party_notes/README.md).
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} Debian packages present"
  exit 0
fi

if [ "$(id -u)" -eq 0 ]; then
  sudo_cmd=()
elif command -v sudo >/dev/null 2>&1; then
  sudo_cmd=(sudo)
else
  echo "setup: missing packages (${missing[*]}) and neither root nor sudo is available" >&2
  exit 1
fi

echo "setup: installing ${missing[*]}"
"${sudo_cmd[@]}" apt-get update -qq
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
