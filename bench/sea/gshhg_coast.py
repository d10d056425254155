#!/usr/bin/python3
"""Land polygons of the western Baltic at GSHHG's own resolutions, for sea_bench --data.

How the distance by sea's time grows with a real coast's detail needs coasts finer than the
fixture's (fixtures/baltic_west.gpkg, about 7,300 vertices). GSHHG (Wessel and Smith) has them, in
Debian as GMT's data packages (gmt-gshhg-high, gmt-gshhg-full), installed here when missing. GMT 6.4
dumps its shorelines only as lines, cut where GSHHG's bins cut them and at the region's edge; this
script joins them into polygons:

  1. `gmt coast -R... -D<res> -A0/1/1 -M -W`: the level-1 shorelines (land against the sea; no lakes)
     inside the region, as pieces;
  2. the pieces merged where they meet, noded with the region's outline, and polygonized;
  3. each face is land when most of it lies in the fixture's land (the faces alternate land and
     sea across a shoreline, and the fixture's coasts are the same coasts at a coarser scale;
     islands the fixture's land lacks are dropped as sea), or with `--land gshhg` when a point
     inside it is GSHHG's land (`gmt select -N`: every island kept, and any `--region`); faces
     smaller than a cell of the bench (`--min-area`) are dropped either way.

The result (EPSG:4326, one polygon per feature, field `iso2` = "XX": the bench ignores owners of
barriers) goes to the output file. Real vertices only: nothing is densified.

  bench/sea/gshhg_coast.py --res f --out /tmp/baltic_gshhg_f.gpkg [--no-install]
  bench/sea/gshhg_coast.py --res f --region 19 23 59.5 60.8 --land gshhg --out /tmp/archipelago.gpkg
"""
import argparse
import os
import subprocess
import sys
import tempfile

REGION = (9.0, 15.5, 53.8, 56.2)  # the fixture's extent: west, east, south, north
PACKAGES = {"h": "gmt-gshhg-high", "f": "gmt-gshhg-full", "i": "gmt-gshhg-high", "l": "gmt-gshhg-low"}


def ensure(packages, install):
    missing = [p for p in packages
               if subprocess.run(["dpkg-query", "-W", "-f=${Status}", p], capture_output=True, text=True)
               .stdout.find("install ok installed") < 0]
    if not missing:
        return
    if not install:
        sys.exit("gshhg_coast: missing " + " ".join(missing) + " (run without --no-install, as root)")
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    subprocess.run(["apt-get", "install", "-y", "--no-install-recommends"] + missing, check=True, env=env)


def pieces(res, region):
    w, e, s, n = region
    # (GMT writes its gmt.history where it runs: a scratch folder, not the caller's.)
    with tempfile.TemporaryDirectory() as scratch:
        out = subprocess.run(["gmt", "coast", f"-R{w}/{e}/{s}/{n}", f"-D{res}", "-A0/1/1", "-M", "-W"],
                             capture_output=True, text=True, check=True, cwd=scratch).stdout
    lines, current = [], []
    for row in out.splitlines():
        if row.startswith(">"):
            if len(current) > 1:
                lines.append(current)
            current = []
            continue
        x, y = row.split()[:2]
        current.append((float(x), float(y)))
    if len(current) > 1:
        lines.append(current)
    return lines


def on_land(points, res, region):
    """Whether each (x, y) lies on GSHHG's land (a lake or a pond in it counts as land: the faces
    come from level-1 shorelines alone), by `gmt select -N` at the same resolution."""
    w, e, s, n = region
    text = "".join(f"{x:.10f} {y:.10f} {i}\n" for i, (x, y) in enumerate(points))
    with tempfile.TemporaryDirectory() as scratch:
        out = subprocess.run(["gmt", "select", f"-R{w}/{e}/{s}/{n}", f"-D{res}", "-Ns/k/k/k/k", "-fg"],
                             input=text, capture_output=True, text=True, check=True, cwd=scratch).stdout
    kept = {int(float(row.split()[2])) for row in out.splitlines() if row and not row.startswith(">")}
    return [i in kept for i in range(len(points))]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--res", default="f", choices=sorted(PACKAGES), help="GSHHG resolution (GMT's -D)")
    ap.add_argument("--out", required=True, help="output GeoPackage")
    ap.add_argument("--land", default="fixtures/baltic_west.gpkg",
                    help="the coarse land that classifies faces, or 'gshhg': a point inside each face tested "
                         "against GSHHG itself (for regions beyond the fixture's)")
    ap.add_argument("--region", nargs=4, type=float, metavar=("W", "E", "S", "N"), default=REGION,
                    help="degrees; the fixture's extent by default")
    ap.add_argument("--min-area", type=float, default=1e-6, help="smallest face kept, square degrees")
    ap.add_argument("--no-install", action="store_true")
    a = ap.parse_args()
    ensure(["gmt", PACKAGES[a.res]], not a.no_install)

    import geopandas
    from shapely.geometry import LineString, box
    from shapely.ops import linemerge, polygonize, unary_union

    region = tuple(a.region)
    w, e, s, n = region
    shore = [LineString(p) for p in pieces(a.res, region)]
    merged = linemerge(shore)
    outline = box(w, s, e, n).exterior
    noded = unary_union([merged, outline])  # nodes the shorelines where they meet the outline
    faces = list(polygonize(noded))
    faces = [f for f in faces if f.area >= a.min_area]
    if a.land == "gshhg":
        inside = [f.representative_point() for f in faces]
        kept = [f for f, land in zip(faces, on_land([(p.x, p.y) for p in inside], a.res, region)) if land]
    else:
        land = unary_union(list(geopandas.read_file(a.land).to_crs("EPSG:4326").geometry))
        kept = [f for f in faces if f.intersection(land).area > 0.5 * f.area]
    vertices = sum(len(f.exterior.coords) - 1 + sum(len(i.coords) - 1 for i in f.interiors) for f in kept)
    frame = geopandas.GeoDataFrame({"iso2": ["XX"] * len(kept)}, geometry=kept, crs="EPSG:4326")
    if os.path.exists(a.out):
        os.remove(a.out)
    frame.to_file(a.out, driver="GPKG")
    print(f"gshhg_coast: resolution {a.res}: {len(shore)} shoreline pieces, {len(faces)} faces of at least --min-area, "
          f"{len(kept)} land polygons, {vertices} vertices -> {a.out}")


if __name__ == "__main__":
    main()
