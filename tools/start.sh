#!/usr/bin/env bash
# Fresh machine to the main job: installs dependencies, builds, then runs rvoronoi on the
# bundled fixture and says where the GeoTIFFs are.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/setup.sh
bash tools/build.sh
out=${RV_OUT_DIR:-out}
mkdir -p "$out"
./build/service/rvoronoi compute fixtures/demo_basepoints.geojson --owner-field state \
  --resolution 100 --ownership "$out/ownership.tif" --distance "$out/distance.tif" \
  --report "$out/report.json"
echo "GeoTIFFs: $(pwd)/$out/ownership.tif and $(pwd)/$out/distance.tif (report: $out/report.json)"
