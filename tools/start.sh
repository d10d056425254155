#!/usr/bin/env bash
# Fresh machine to the main job: installs dependencies, builds, then starts the rvoronoi daemon
# (OGC API - Processes on http://127.0.0.1:8080, job store and results under ./rvoronoi-data).
# Extra arguments go to `rvoronoi serve` (e.g. --listen 127.0.0.1:9000 --config FILE).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
bash tools/build.sh
exec ./build/service/rvoronoi serve --data-dir "${RV_DATA_DIR:-rvoronoi-data}" "$@"
