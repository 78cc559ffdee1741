#!/usr/bin/env bash
# Fresh Debian 12 machine -> everything built and the whole ctest suite passed.
# Usage: scripts/test.sh [BUILD_DIR] [CMAKE_ARGS...]   (default: build; CI passes
#        -DSHREFRACT_REQUIRE_GPU=ON so that a missing Vulkan device fails instead of skipping)
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${1:-$root/build}"
shift || true
bash "$root/scripts/setup-debian.sh"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release "$@"
cmake --build "$build" -j "$(nproc)"
ctest --test-dir "$build" --output-on-failure -j "$(nproc)"
