#!/usr/bin/python3
"""How much barrier a shortest-path-map engine would sweep: for every last bend (via) of the field
by sea, the farthest cell it serves (its region's radius from it), and the barrier edges within
that radius of it, which a visibility sweep from it must read at the least.

Runs `rvoronoi compute` on the western Baltic's 200 ports (fixtures/baltic_west_ports.geojson)
with its land as barriers (fixtures/baltic_west.gpkg), geodesic, at the resolution asked, with
ownership, via raster and report (the vias' positions), then measures in a local plane (degrees
scaled by the metres of a degree at 55 N: an estimate to a few per cent, for counting only).

  bench/sea/root_reach.py build/service/rvoronoi [--resolution 0.001]

Prints the counts as a markdown table. Run with Debian's /usr/bin/python3 (GDAL, NumPy).
"""
import argparse
import json
import os
import subprocess
import tempfile

import numpy as np
from osgeo import gdal, ogr

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURES = os.path.join(os.path.dirname(os.path.dirname(HERE)), "fixtures")
KX, KY = 111320.0 * np.cos(np.radians(55.0)), 110574.0  # metres per degree, at 55 N


def band(path):
    ds = gdal.Open(path)  # (kept open while the array is read)
    return ds.GetRasterBand(1).ReadAsArray().astype(np.int64), ds.GetGeoTransform()


def barrier_edges():
    """Every ring's edges of the western Baltic's land, in the local plane (x0, y0, x1, y1)."""
    source = ogr.Open(os.path.join(FIXTURES, "baltic_west.gpkg"))
    layer = source.GetLayer(0)
    features = [f for f in layer]  # (kept alive while their geometries are read)
    out = []

    def rings(g):
        if g.GetGeometryName() in ("MULTIPOLYGON", "POLYGON"):
            for i in range(g.GetGeometryCount()):
                yield from rings(g.GetGeometryRef(i))
        else:
            yield np.array([p[:2] for p in g.GetPoints()])

    for f in features:
        for ring in rings(f.GetGeometryRef().Clone()):
            out.append(np.c_[ring[:-1], ring[1:]])
    edges = np.vstack(out)
    edges[:, [0, 2]] *= KX
    edges[:, [1, 3]] *= KY
    return edges


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    ap.add_argument("--resolution", type=float, default=0.001)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        own_path, via_path, report = (os.path.join(folder, n) for n in ("own.tif", "via.tif", "r.json"))
        subprocess.run([args.binary, "compute", os.path.join(FIXTURES, "baltic_west_ports.geojson"), "--owner-field",
                        "owner", "--barriers", os.path.join(FIXTURES, "baltic_west.gpkg"), "--extent", "9.0", "53.8",
                        "15.5", "56.2", "--resolution", str(args.resolution), "--threads", "2", "--ownership", own_path,
                        "--via", via_path, "--report", report], check=True, capture_output=True)
        own, _ = band(own_path)
        via, gt = band(via_path)
        with open(report) as f:
            positions = {v[0]: (v[1] * KX, v[2] * KY) for v in json.load(f)["sea"]["via_vertices"]}
    rows, cols = via.shape
    xs = (gt[0] + gt[1] * (np.arange(cols) + 0.5)) * KX
    ys = (gt[3] + gt[5] * (np.arange(rows) + 0.5)) * KY
    r, c = np.nonzero((own != 0) & (via > 0))
    v = via[r, c]
    order = np.argsort(v, kind="stable")
    v, r, c = v[order], r[order], c[order]
    ids, starts = np.unique(v, return_index=True)
    ends = np.r_[starts[1:], len(v)]
    edges = barrier_edges()
    ax, ay, bx, by = edges.T
    dx, dy = bx - ax, by - ay
    l2 = np.where(dx * dx + dy * dy > 0, dx * dx + dy * dy, 1.0)
    radii, near = [], []
    for via_id, s, e in zip(ids, starts, ends):
        px, py = positions[int(via_id)]
        radius = np.hypot(xs[c[s:e]] - px, ys[r[s:e]] - py).max()
        t = np.clip(((px - ax) * dx + (py - ay) * dy) / l2, 0.0, 1.0)
        near.append(int((np.hypot(ax + t * dx - px, ay + t * dy - py) <= radius).sum()))
        radii.append(radius)
    radii, near = np.array(radii), np.array(near)
    print("| grid (deg) | barrier edges | vias | region radius median / 90 % / max (km) "
          "| edges within it: sum, median, 90 %, max |")
    print("|---|---|---|---|---|")
    print(f"| {args.resolution} | {len(edges)} | {len(ids)} | {np.median(radii) / 1e3:.1f} / "
          f"{np.percentile(radii, 90) / 1e3:.1f} / {radii.max() / 1e3:.1f} | {near.sum()}, {int(np.median(near))}, "
          f"{int(np.percentile(near, 90))}, {near.max()} |")


if __name__ == "__main__":
    main()
