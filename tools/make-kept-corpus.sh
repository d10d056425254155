#!/usr/bin/env bash
# Remakes the seed corpora of the fuzz targets fuzz_kept_* (tests/fuzz/fuzz_kept.cpp) from real
# bases: a run of rvoronoi on the project's fixtures keeps seeds.bin and lines_*.bin, and an edit
# of it (one feature removed) keeps site_codes.bin as well. Run after a change of those layouts:
#   bash tools/make-kept-corpus.sh [build/service/rvoronoi]
# The corpora also hold hostile classes made from those files by hand (numbering_*: feature numbers
# zero, negative, huge; site_*: a site named twice, one beyond the seeds); the script leaves them.
set -euo pipefail
cd "$(dirname "$0")/.."
rvoronoi=${1:-build/service/rvoronoi}
corpus=tests/fuzz/corpus
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

run() {  # run NAME SEEDS [options]: a streamed run with lines, keeping its base beside its report
  local name=$1 seeds=$2
  shift 2
  mkdir -p "$work/$name"
  "$rvoronoi" compute "$seeds" --ownership "$work/$name/own.tif" --distance "$work/$name/dist.tif" \
    --boundaries "$work/$name/b.geojson" --tripoints "$work/$name/t.geojson" --limits "$work/$name/l.geojson" \
    --report "$work/$name/report.json" --strip-rows 64 "$@" >/dev/null
}

# Every geometry type, each feature its own owner (UTM); then the same with the points gone.
/usr/bin/python3 - "$work" <<'EOF'
import json, sys
doc = json.load(open("fixtures/all_types.geojson"))
doc["features"] = [f for f in doc["features"] if f["geometry"] and f["geometry"]["type"] != "Point"]
json.dump(doc, open(sys.argv[1] + "/edited.geojson", "w"))
EOF
cp fixtures/all_types.geojson "$work/seeds.geojson"
run base "$work/seeds.geojson" --owner-field owner --resolution 100 --limit-distances 500
cp "$work/edited.geojson" "$work/seeds.geojson"
run edit "$work/seeds.geojson" --owner-field owner --resolution 100 --limit-distances 500 --base "$work/base/report.json"
# The Øresund on its geographic grid (geodesic), with a 12 nmi limit.
run oresund fixtures/oresund.gpkg --owner-field iso2 --resolution 0.01 --limit-distances 12nmi

mkdir -p "$corpus/fuzz_kept_seed_archive" "$corpus/fuzz_kept_site_codes" "$corpus/fuzz_kept_line_pieces"
for name in base edit oresund; do
  kept="$work/$name/report.json.rvbase"
  cp "$kept/seeds.bin" "$corpus/fuzz_kept_seed_archive/$name"
  for lines in "$kept"/lines_*.bin; do
    cp "$lines" "$corpus/fuzz_kept_line_pieces/${name}_$(basename "$lines" .bin)"
  done
done
# The site-codes target reads 4 bytes of site count first (fuzz_kept.cpp).
sites=$(/usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['sites'])" "$work/edit/report.json.rvbase/manifest.json")
{
  /usr/bin/python3 -c "import struct,sys; sys.stdout.buffer.write(struct.pack('<I', int(sys.argv[1])))" "$sites"
  cat "$work/edit/report.json.rvbase/site_codes.bin"
} >"$corpus/fuzz_kept_site_codes/edit"
ls -l "$corpus"/fuzz_kept_*
