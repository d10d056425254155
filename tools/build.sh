#!/usr/bin/env bash
# Configures and builds rvoronoi in ./build (Release with debug info). Extra arguments go to
# CMake's configure step, e.g. tools/build.sh -DRV_SANITIZE=ON.
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir=${RV_BUILD_DIR:-build}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" >/dev/null
cmake --build "$build_dir" -j "$(nproc)"
