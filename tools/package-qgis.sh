#!/usr/bin/env bash
# Writes dist/rvoronoi-qgis-<version>.zip (or into the folder given as its argument): the QGIS plugin of qgis/rvoronoi, as QGIS's "Install
# from ZIP" takes it (one top-level folder rvoronoi/ holding metadata.txt and the package), with
# the project's version (CMakeLists.txt) in metadata.txt. Python sources only: no caches, no
# tests. Prints the zip's path last. tests/qgis/test_qgis_provider.py installs and uses it.
set -euo pipefail
cd "$(dirname "$0")/.."
version=$(sed -n 's/^project(rvoronoi VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
[ -n "$version" ] || { echo "package-qgis: no project version in CMakeLists.txt" >&2; exit 1; }
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
out_dir=$(realpath -m "${1:-dist}")
mkdir -p "$stage/rvoronoi" "$out_dir"
for f in qgis/rvoronoi/*.py qgis/rvoronoi/metadata.txt; do
  cp "$f" "$stage/rvoronoi/"
done
sed -i "s/^version=.*/version=$version/" "$stage/rvoronoi/metadata.txt"
out="$out_dir/rvoronoi-qgis-$version.zip"
rm -f "$out"
# Fixed times and order: the same sources give the same zip.
find "$stage/rvoronoi" -exec touch -d "2000-01-01 00:00:00 UTC" {} +
(cd "$stage" && find rvoronoi -type f | LC_ALL=C sort | /usr/bin/python3 -c '
import sys, zipfile
with zipfile.ZipFile(sys.argv[1], "w", zipfile.ZIP_DEFLATED) as z:
    for name in sys.stdin.read().split():
        info = zipfile.ZipInfo(name, (2000, 1, 1, 0, 0, 0))
        info.external_attr = 0o644 << 16
        info.compress_type = zipfile.ZIP_DEFLATED
        z.writestr(info, open(name, "rb").read())
' "$out")
echo "$out"
