#!/usr/bin/python3
"""Partial effect on each island of the western Baltic in turn: which runs are drawn, and are
their lines and regions the rule's cells?

First with every port at full effect; then for every island of fixtures/baltic_west.gpkg (each
part of a state's land other than its largest) that holds ports of
fixtures/baltic_west_ports.geojson, those ports get the effect (0.5 unless told) and `rvoronoi compute` runs on all 200 ports with ownership, boundaries, tripoints, regions
and a report, by sea (the land as barriers) or straight (geodesic, `--straight`). Each run is
"drawn" or "refused" (the CLI's one line). A drawn run is checked against its own ownership raster:

  - pairs without a line: two 4-neighbouring cells of two owners whose centres' segment crosses no
    line of those two owners, nor lines of each with a third (by sea, pairs whose segment crosses
    land are not asked);
  - region cells off: cells whose owner differs from the region their centre falls in (the regions
    rasterized at the cells' centres), land cells not counted.

  bench/sea/partial_islands.py build/service/rvoronoi --resolution 0.005 [--straight]
      [--effect 0.5] [--only NAME] [--keep DIR]

Prints one row per island (markdown) and a summary line. Exit code 0 whatever the runs give: it
measures, it does not judge. Run with Debian's /usr/bin/python3 (GDAL, NumPy, Shapely).
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import warnings

import numpy as np
from osgeo import gdal, ogr
from shapely import wkb
from shapely.geometry import LineString
from shapely.ops import unary_union
from shapely.strtree import STRtree

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURES = os.path.join(HERE, "..", "..", "fixtures")
LAND = os.path.join(FIXTURES, "baltic_west.gpkg")
PORTS = os.path.join(FIXTURES, "baltic_west_ports.geojson")
EXTENT = ["9.0", "53.8", "15.5", "56.2"]
ON_COAST = 1e-7  # degrees: a port on an island's outline (the ports are its vertices)

gdal.UseExceptions()
warnings.filterwarnings("ignore", message="STRtree will be changed")  # Shapely 1.8's notice of 2.0's STRtree


def islands():
    """(name, state, shapely polygon) for each part of a state's land but its largest, by area."""
    ds = ogr.Open(LAND)
    out = []
    for f in ds.GetLayer("states"):
        g = wkb.loads(bytes(f.GetGeometryRef().ExportToWkb()))
        parts = sorted(getattr(g, "geoms", [g]), key=lambda p: -p.area)
        for p in parts[1:]:
            c = p.representative_point()
            out.append(("%s %.2f %.2f" % (f.GetField("iso2"), c.x, c.y), f.GetField("iso2"), p))
    return sorted(out, key=lambda t: -t[2].area)


def land_union():
    ds = ogr.Open(LAND)
    return unary_union([wkb.loads(bytes(f.GetGeometryRef().ExportToWkb())) for f in ds.GetLayer("states")])


def seeds_with_effect(island, effect, path):
    with open(PORTS) as f:
        ports = json.load(f)
    n = 0
    for feat in ports["features"]:
        x, y = feat["geometry"]["coordinates"][:2]
        on = island is not None and island.exterior.distance(LineString([(x, y), (x, y + 1e-12)])) < ON_COAST
        feat["properties"]["effect"] = effect if on else 1.0
        n += on
    with open(path, "w") as f:
        json.dump(ports, f)
    return n


def read_lines(path):
    """{(owner_a, owner_b) sorted: STRtree of the lines' segments}."""
    ds = ogr.Open(path)
    by_pair = {}
    for f in ds.GetLayer(0):
        key = tuple(sorted((f.GetField("owner_a"), f.GetField("owner_b"))))
        g = wkb.loads(bytes(f.GetGeometryRef().ExportToWkb()))
        pts = list(g.coords)
        by_pair.setdefault(key, []).extend(LineString(pts[k:k + 2]) for k in range(len(pts) - 1))
    return {k: STRtree(v) for k, v in by_pair.items()}


def pairs_without_line(owner, gt, lines, land):
    """Pairs of 4-neighbouring cells of two owners a, b whose centres' segment meets neither an
    a-b line nor an a-c and a c-b line (a third owner's sliver between the centres). Lines end at
    the outermost cells' centres: "meets" allows 1e-9 degrees."""
    h, w = owner.shape
    cx = lambda c: gt[0] + (c + 0.5) * gt[1]
    cy = lambda r: gt[3] + (r + 0.5) * gt[5]
    valid = owner >= 0
    owners = sorted({o for pair in lines for o in pair})
    missing = asked = 0
    where = []

    def meets(a, b, seg):
        tree = lines.get(tuple(sorted((a, b))))
        return tree is not None and any(s.distance(seg) < 1e-9 for s in tree.query(seg.buffer(1e-9)))

    for dr, dc in ((0, 1), (1, 0)):
        first = owner[: h - dr, : w - dc]
        second = owner[dr:, dc:]
        rows, cols = np.nonzero(valid[: h - dr, : w - dc] & valid[dr:, dc:] & (first != second))
        for r, c in zip(rows, cols):
            seg = LineString([(cx(c), cy(r)), (cx(c + dc), cy(r + dr))])
            if land is not None and seg.intersects(land):
                continue
            asked += 1
            a, b = int(first[r, c]), int(second[r, c])
            if meets(a, b, seg) or any(meets(a, o, seg) and meets(o, b, seg) for o in owners if o not in (a, b)):
                continue
            missing += 1
            where.append((round(cx(c), 4), round(cy(r), 4)))
    return asked, missing, where[:3]


def region_cells_off(regions, ownership, owner):
    src = gdal.Open(ownership)
    mem = gdal.GetDriverByName("MEM").Create("", src.RasterXSize, src.RasterYSize, 1, gdal.GDT_Int32)
    mem.SetGeoTransform(src.GetGeoTransform())
    mem.SetProjection(src.GetProjection())
    mem.GetRasterBand(1).Fill(-1)
    gdal.Rasterize(mem, regions, attribute="owner")
    drawn = mem.GetRasterBand(1).ReadAsArray()
    valid = owner >= 0
    return int(np.count_nonzero(valid & (drawn != owner)))


def run(rv, seeds, out, args):
    cmd = [rv, "compute", seeds, "--owner-field", "owner", "--effect-field", "effect", "--extent", *EXTENT,
           "--resolution", str(args.resolution), "--threads", "2",
           "--ownership", os.path.join(out, "own.tif"), "--boundaries", os.path.join(out, "b.geojson"),
           "--tripoints", os.path.join(out, "t.geojson"), "--regions", os.path.join(out, "r.geojson"),
           "--report", os.path.join(out, "rep.json")]
    if not args.straight:
        cmd += ["--barriers", LAND]
    t = time.monotonic()
    p = subprocess.run(cmd, capture_output=True, text=True)
    return p, time.monotonic() - t


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("rvoronoi")
    ap.add_argument("--resolution", type=float, default=0.005)
    ap.add_argument("--effect", type=float, default=0.5)
    ap.add_argument("--straight", action="store_true")
    ap.add_argument("--only", help="islands whose name starts with this")
    ap.add_argument("--keep", help="keep each run's outputs under this folder")
    args = ap.parse_args()
    land = None if args.straight else land_union()
    work = tempfile.mkdtemp(prefix="partial_islands_")
    print("| island | ports | result | s | lines | pairs asked | pairs without a line | region cells off |")
    print("|---|---|---|---|---|---|---|---|")
    drawn = refused = 0
    # First every port at full effect (no partial effect): what the checks give without it.
    cases = [("none (all at full effect)", None)] + [(name, poly) for name, _, poly in islands()]
    try:
        for name, poly in cases:
            if args.only and not name.startswith(args.only):
                continue
            out = os.path.join(args.keep or work, name.split(" (")[0].replace(" ", "_"))
            os.makedirs(out, exist_ok=True)
            seeds = os.path.join(out, "seeds.geojson")
            n = seeds_with_effect(poly, args.effect, seeds)
            if n == 0 and poly is not None:
                continue
            p, secs = run(args.rvoronoi, seeds, out, args)
            if p.returncode != 0:
                refused += 1
                line = (p.stderr.strip().splitlines() or ["exit %d" % p.returncode])[-1]
                print("| %s | %d | refused: %s | %.1f | | | | |" % (name, n, line[:160], secs))
                continue
            drawn += 1
            src = gdal.Open(os.path.join(out, "own.tif"))
            band = src.GetRasterBand(1)
            owner = band.ReadAsArray().astype(np.int64)
            nodata = band.GetNoDataValue()
            if nodata is not None:
                owner[owner == int(nodata)] = -1
            lines = read_lines(os.path.join(out, "b.geojson"))
            asked, missing, where = pairs_without_line(owner, src.GetGeoTransform(), lines, land)
            off = region_cells_off(os.path.join(out, "r.geojson"), os.path.join(out, "own.tif"), owner)
            bds = ogr.Open(os.path.join(out, "b.geojson"))
            nlines = bds.GetLayer(0).GetFeatureCount()
            print("| %s | %d | drawn | %.1f | %d | %d | %d%s | %d |" %
                  (name, n, secs, nlines, asked, missing, (" at %s" % where) if missing else "", off))
            sys.stdout.flush()
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    print("\n%d drawn, %d refused (%s, resolution %g, effect %g)" %
          (drawn, refused, "straight" if args.straight else "by sea", args.resolution, args.effect))


if __name__ == "__main__":
    main()
