#!/usr/bin/python3
"""How far the lines stray from their exact locus between their vertices, measured from the
files with GeographicLib (python3-geographiclib; bench/peers.sh --install-only installs it):
the analyst's case of issue 57 -- a point island at 50 N with a 12 nmi limit and the
equidistance line to a straight coast along the meridian 1 degree west, geodesic -- at 0.01,
0.002 and 0.0005 degrees, for one or more binaries.

Per binary and cell size: the 12 nmi limit's largest vertex error |d - D| and its worst segment
midpoint (both by GeographicLib's inverse to the island), the equidistance line's worst segment
midpoint |dI - dA| (dA: the least inverse distance to the meridian's points, golden-section
search), the vertex counts and the deliverables' wall time from the report.

usage: bench/line_tolerance.py LABEL=BINARY [LABEL=BINARY ...] [--extra ARGS]
e.g.   bench/line_tolerance.py old=/tmp/old/rvoronoi new=build/service/rvoronoi
"""
import json
import math
import os
import subprocess
import sys
import tempfile

try:
    from geographiclib.geodesic import Geodesic
except ImportError:
    sys.exit("line_tolerance.py: needs python3-geographiclib (bench/peers.sh --install-only)")

GEOD = Geodesic.WGS84
ISLAND = (0.0, 50.0)
D = 22224.0
SEEDS = {
    "type": "FeatureCollection",
    "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:OGC:1.3:CRS84"}},
    "features": [
        {"type": "Feature", "properties": {"o": "I"}, "geometry": {"type": "Point", "coordinates": list(ISLAND)}},
        {"type": "Feature", "properties": {"o": "A"},
         "geometry": {"type": "LineString", "coordinates": [[-1.0, 49.0], [-1.0, 51.0]]}},
    ],
}


def inverse(a, b):
    return GEOD.Inverse(a[1], a[0], b[1], b[0], Geodesic.DISTANCE)["s12"]


def to_meridian(p):
    lo, hi = 49.0, 51.0
    r = 0.5 * (math.sqrt(5.0) - 1.0)
    for _ in range(60):
        a, b = hi - r * (hi - lo), lo + r * (hi - lo)
        if inverse(p, (-1.0, a)) < inverse(p, (-1.0, b)):
            hi = b
        else:
            lo = a
    return inverse(p, (-1.0, 0.5 * (lo + hi)))


def lines(path, keep=lambda props: True):
    out = []
    for f in json.load(open(path))["features"]:
        if not keep(f["properties"]):
            continue
        g = f["geometry"]
        parts = g["coordinates"] if g["type"] == "MultiLineString" else [g["coordinates"]]
        out.extend(parts)
    return out


def mid(a, b):
    return (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]))


def measure(binary, res, extra, tmp):
    seeds = os.path.join(tmp, "seeds.geojson")
    json.dump(SEEDS, open(seeds, "w"))
    b, lim, rep = (os.path.join(tmp, n) for n in ("b.geojson", "l.geojson", "r.json"))
    cmd = [binary, "compute", seeds, "--owner-field", "o", "--extent", "-1.1", "49.7", "0.45", "50.3",
           "--resolution", repr(res), "--boundaries", b, "--limits", lim, "--limit-distances", "12nmi",
           "--limits-per-owner", "--report", rep, "--quiet", "--threads", "2"] + extra
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    arcs = lines(lim, lambda p: p.get("label") == "I")
    vertex = max(abs(inverse(ISLAND, v) - D) for l in arcs for v in l)
    worst = max(abs(inverse(ISLAND, mid(l[i], l[i + 1])) - D) for l in arcs for i in range(len(l) - 1))
    eq = lines(b)
    segs = [(l[i], l[i + 1]) for l in eq for i in range(len(l) - 1)]
    eq_worst = max(abs(inverse(ISLAND, mid(*s)) - to_meridian(mid(*s))) for s in segs)
    r = json.load(open(rep))
    d = r["deliverables"]
    return {
        "limit_vertices": sum(len(l) for l in arcs),
        "limit_vertex_error": vertex,
        "limit_worst_midpoint": worst,
        "boundary_vertices": sum(len(l) for l in eq),
        "equidistance_worst_midpoint": eq_worst,
        "deliverables_s": r["timings_s"]["deliverables"]["wall"],
        "report_limit_max_midpoint": d["limits"].get("along_lines", {}).get("max_midpoint"),
        "report_boundary_max_midpoint": d["boundaries"].get("along_lines", {}).get("max_midpoint"),
    }


def main():
    binaries, extra = [], []
    args = sys.argv[1:]
    if "--extra" in args:
        i = args.index("--extra")
        extra = args[i + 1:]
        args = args[:i]
    for a in args:
        label, _, path = a.partition("=")
        binaries.append((label, path))
    if not binaries:
        sys.exit(__doc__)
    print("| cell | binary | 12 nmi limit: vertices | vertex error m | worst midpoint m | equidistance: vertices "
          "| worst midpoint m (|dI - dA|) | deliverables s |")
    print("|---|---|---|---|---|---|---|---|")
    for res in (0.01, 0.002, 0.0005):
        for label, path in binaries:
            with tempfile.TemporaryDirectory() as tmp:
                m = measure(path, res, extra, tmp)
            print(f"| {res}° | {label} | {m['limit_vertices']} | {m['limit_vertex_error']:.1e} | "
                  f"{m['limit_worst_midpoint']:.2g} | {m['boundary_vertices']} | "
                  f"{m['equidistance_worst_midpoint']:.2g} | {m['deliverables_s']:.3f} |", flush=True)


if __name__ == "__main__":
    main()
