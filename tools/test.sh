#!/usr/bin/env bash
# Fresh machine to passing tests: installs dependencies, builds, runs every test with CTest.
# Exits non-zero if any step or any test fails.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
bash tools/build.sh
cd "${RV_BUILD_DIR:-build}"
ctest --output-on-failure --timeout 900 -j "$(nproc)"
