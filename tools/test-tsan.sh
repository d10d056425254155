#!/usr/bin/env bash
# ThreadSanitizer stage: the raster engine tests (parallel_for, the scans' wavefront, the exact
# method's tiles, several concurrent computations) and the streamed job (the engine handing
# strips to one writer thread per GeoTIFF, and that hand-off alone) built with GCC
# -fsanitize=thread in build-tsan/ and run with several worker threads. GDAL itself is not
# instrumented. Any report fails (TSAN_OPTIONS in tests/CMakeLists.txt). Run by .ci/run when
# RV_CI_TSAN=1, and by hand.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
jobs=$(nproc)
t0=$(date +%s)
cmake -S . -B build-tsan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRV_TSAN=ON >/dev/null
targets="test_raster_engine test_raster_parallel test_raster_scan_paper test_raster_interior test_raster_grid
  test_raster_extremes test_raster_geodesic_engine test_service_stream test_service_strip_handoff"
# shellcheck disable=SC2086
cmake --build build-tsan -j "$jobs" --target $targets
t1=$(date +%s)
ctest --test-dir build-tsan --output-on-failure --timeout 900 -j "$jobs" -R "^($(echo $targets | tr ' ' '|'))\$"
echo "tsan: build $((t1 - t0)) s, tests $(($(date +%s) - t1)) s"
