#!/usr/bin/python3
"""Digests of every output of `rvoronoi compute` on the bench cases, to show that a change of the
code leaves every output bit for bit as it was (issue 29: "record digests before the first change
and compare after the last").

Cases: random points at two of the paper's sizes (every method), the Øresund polygons planar
(UTM 33N) and geodesic (geographic grid), the Øresund on a projected geodesic grid, the western
Baltic (four owners, land borders, geodesic), and the synthetic coastlines of fixtures/. Every
case writes the ownership, distance and nearest-feature rasters and, where the method is exact,
the deliverables (boundaries, tripoints, limits at two distances, regions, and the margin raster
where it exists). A raster's digest is SHA-256 over its size, geotransform, CRS, nodata, data
type and cells (read with GDAL, so compression and tiling do not matter); a vector file's over
its features' properties and coordinates as written (GeoJSON text, parsed and re-serialised with
sorted keys, so only the content counts). Timings and paths are left out.

usage:
  bench/digests.py RVORONOI OUT.json [--quick]     # compute and write the digests
  bench/digests.py --compare A.json B.json         # exit 1 and list the differences, if any
Debian's /usr/bin/python3 (python3-gdal). Reads the Øresund and the western Baltic from fixtures/.
"""
import hashlib
import json
import os
import random
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def raster_digest(path):
    from osgeo import gdal
    gdal.UseExceptions()
    ds = gdal.Open(path)
    b = ds.GetRasterBand(1)
    h = hashlib.sha256()
    h.update(json.dumps([ds.RasterXSize, ds.RasterYSize, ds.GetGeoTransform(), ds.GetProjection(),
                         b.GetNoDataValue(), gdal.GetDataTypeName(b.DataType)]).encode())
    h.update(b.ReadRaster())
    rat = b.GetDefaultRAT()
    if rat is not None:
        for r in range(rat.GetRowCount()):
            h.update(json.dumps([rat.GetValueAsString(r, c) for c in range(rat.GetColumnCount())]).encode())
    return h.hexdigest()


def vector_digest(path):
    doc = json.load(open(path))
    return hashlib.sha256(json.dumps(doc.get("features", doc), sort_keys=True).encode()).hexdigest()


X0, Y0 = 400000.0, 6000000.0  # the points' grid origin, UTM 33N metres


def points_geojson(path, n, size, seed):
    """n uniform random points over a size x size metre square at (X0, Y0), one owner each."""
    rng = random.Random(seed)
    feats = [{"type": "Feature", "properties": {"id": i + 1},
              "geometry": {"type": "Point", "coordinates": [X0 + rng.uniform(0, size), Y0 + rng.uniform(0, size)]}}
             for i in range(n)]
    crs = {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}}
    json.dump({"type": "FeatureCollection", "crs": crs, "features": feats}, open(path, "w"))
    return path


def cases(tmp, quick):
    fixtures = os.path.join(ROOT, "fixtures")
    out = []
    p1 = points_geojson(os.path.join(tmp, "p1000.geojson"), 1000, 1000.0, 1)
    p2 = points_geojson(os.path.join(tmp, "p10000.geojson"), 10000, 2000.0, 2)
    def extent(size):
        return ["--extent", str(X0), str(Y0), str(X0 + size), str(Y0 + size)]
    for method in ("exact", "hv-scan", "h-scan", "brute-force"):
        out.append((f"points1000_{method}", [p1, "--resolution", "1"] + extent(1000) + ["--method", method],
                    method == "exact"))
    if not quick:
        out.append(("points10000_exact", [p2, "--resolution", "1"] + extent(2000), True))
        out.append(("points10000_hv-scan", [p2, "--resolution", "1"] + extent(2000) + ["--method", "hv-scan"], False))
    oresund = os.path.join(fixtures, "oresund.gpkg")
    baltic = os.path.join(fixtures, "baltic_west.gpkg")
    out.append(("oresund_planar_utm", [oresund, "--owner-field", "iso2", "--crs", "EPSG:32633",
                                       "--resolution", "400"], True))
    out.append(("oresund_geodesic", [oresund, "--owner-field", "iso2", "--resolution", "0.004"], True))
    out.append(("oresund_projected_geodesic", [oresund, "--owner-field", "iso2", "--crs", "EPSG:32633",
                                               "--metric", "geodesic", "--resolution", "800"], True))
    if not quick:
        out.append(("baltic_geodesic", [baltic, "--owner-field", "iso2", "--on-conflict", "lower-code",
                                        "--resolution", "0.01"], True))
    out.append(("coast_planar", [os.path.join(fixtures, "coast.gpkg"), "--owner-field", "owner",
                                 "--on-conflict", "lower-code", "--resolution", "100"], True))
    return out


def run_case(binary, tmp, name, args, exact, projected_geodesic):
    d = os.path.join(tmp, name)
    os.makedirs(d)
    outs = {"ownership": "own.tif", "distance": "dist.tif", "nearest-feature": "feat.tif"}
    if exact:
        outs.update({"boundaries": "b.geojson", "tripoints": "t.geojson", "limits": "l.geojson",
                     "regions": "r.geojson"})
        if not projected_geodesic:
            outs["margin-raster"] = "m.tif"
    cmd = [binary, "compute"] + args + ["--quiet", "--threads", "2"]
    for flag, f in outs.items():
        cmd += [f"--{flag}", os.path.join(d, f)]
    if exact:
        unit = "nmi" if "oresund" in name or "baltic" in name else ""
        cmd += ["--limit-distances", "3nmi,6nmi" if unit else "20,60"]
    # A refused or failed case is a result too (one binary may fail where the other does not):
    # its message is recorded in place of the digests, and the run goes on.
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        lines = [x for x in done.stderr.splitlines() if x.strip()]
        return {"failed": f"exit {done.returncode}: " + (lines[-1] if lines else "")}
    digests = {}
    for flag, f in outs.items():
        path = os.path.join(d, f)
        digests[flag] = raster_digest(path) if f.endswith(".tif") else vector_digest(path)
    return digests


def main():
    if sys.argv[1] == "--compare":
        a, b = json.load(open(sys.argv[2])), json.load(open(sys.argv[3]))
        diffs = [f"{c}/{o}" for c in sorted(set(a) | set(b)) for o in sorted(set(a.get(c, {})) | set(b.get(c, {})))
                 if a.get(c, {}).get(o) != b.get(c, {}).get(o)]
        for d in diffs:
            print("differs:", d)
        print(f"{sum(len(v) for v in a.values())} digests compared, {len(diffs)} differ")
        sys.exit(1 if diffs else 0)
    binary, target = sys.argv[1], sys.argv[2]
    quick = "--quick" in sys.argv
    result = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, args, exact in cases(tmp, quick):
            result[name] = run_case(binary, tmp, name, args, exact, "projected_geodesic" in name)
            print(name, "ok", flush=True)
    json.dump(result, open(target, "w"), indent=1, sort_keys=True)


if __name__ == "__main__":
    main()
