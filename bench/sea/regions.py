#!/usr/bin/python3
"""How many pieces the field by sea is made of: what an engine that draws the answer region by
region (each region the cells whose path leaves the same seed feature and bends last at the same
barrier vertex) would have to draw.

Runs `rvoronoi compute` on the western Baltic's 200 ports (fixtures/baltic_west_ports.geojson)
with its land as barriers (fixtures/baltic_west.gpkg), geodesic, at each resolution asked, with
ownership, nearest-feature and via rasters, and counts:

  - sea cells, and the cells whose path bends (via > 0);
  - the distinct last bends (vias) those use, and the distinct (feature, via) labels of all sea
    cells: the regions;
  - the changes of label between neighbouring sea cells along each row: the regions' edges a row
    crosses, which a region engine must place exactly.

  bench/sea/regions.py build/service/rvoronoi [--resolution 0.01 0.002 0.001]

Prints one markdown row per resolution. Run with Debian's /usr/bin/python3 (GDAL, NumPy).
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np
from osgeo import gdal

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
FIXTURES = os.path.join(ROOT, "fixtures")


def band(path):
    ds = gdal.Open(path)  # (kept open while the array is read)
    return ds.GetRasterBand(1).ReadAsArray().astype(np.int64)


def count(binary, resolution, folder):
    own, feature, via = (os.path.join(folder, f"{n}.tif") for n in ("own", "feature", "via"))
    subprocess.run([binary, "compute", os.path.join(FIXTURES, "baltic_west_ports.geojson"), "--owner-field", "owner",
                    "--barriers", os.path.join(FIXTURES, "baltic_west.gpkg"), "--extent", "9.0", "53.8", "15.5",
                    "56.2", "--resolution", str(resolution), "--threads", "2", "--ownership", own,
                    "--nearest-feature", feature, "--via", via], check=True, capture_output=True)
    o, f, v = band(own), band(feature), band(via)
    sea = o != 0
    bent = sea & (v > 0)
    label = f * (int(v.max()) + 1) + v
    changes = (label[:, 1:] != label[:, :-1]) & sea[:, 1:] & sea[:, :-1]
    rows = o.shape[0]
    return (f"| {resolution} | {o.shape[1]} x {rows} | {sea.sum()} | {bent.sum()} ({100 * bent.sum() / sea.sum():.1f} %) "
            f"| {len(np.unique(v[bent]))} | {len(np.unique(label[sea]))} | {changes.sum()} "
            f"({changes.sum() / rows:.1f} a row) |")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("binary")
    ap.add_argument("--resolution", type=float, nargs="+", default=[0.01, 0.002, 0.001])
    args = ap.parse_args()
    print("| grid (deg) | cells | sea cells | bent cells | last bends | regions | label changes along rows |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory(prefix="rv_regions_") as folder:
        for res in args.resolution:
            print(count(args.binary, res, folder), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
