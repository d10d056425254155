#!/usr/bin/python3
"""200 ports on a GSHHG coast (the western Baltic's by default), owned, for timing the whole job by
sea on a detailed coast (bench/RESULTS-sea.md, sessions 73 to 76 and 79).

The ports are sea_bench's for that coast (`--ports-out`: every k-th coast vertex, owner "XX");
each takes the owner of the nearest of the fixture's ports (fixtures/baltic_west_ports.geojson),
by distance on a plane scaled by the cosine of the latitude (the ports are a few kilometres from
their nearest; ties do not arise on these coasts). With the coast from gshhg_coast.py:

  bench/sea/gshhg_coast.py --res f --out /tmp/baltic_gshhg_f.gpkg
  bench/sea/gshhg_ports.py build/bench/sea_bench /tmp/baltic_gshhg_f.gpkg /tmp/gshhg_ports_owned.geojson
  rvoronoi compute /tmp/gshhg_ports_owned.geojson --owner-field owner --barriers /tmp/baltic_gshhg_f.gpkg \\
      --extent 9.0 53.8 15.5 56.2 --resolution 0.02 --threads 2 --ownership own.tif --boundaries lines.geojson

With `--bands NAME:LON,...,NAME` the owners are by longitude instead (each port takes the first
name whose bound lies east of it; the last has none), for coasts beyond the fixture's, such as the
Archipelago Sea (bench/RESULTS-sea.md, session 79):

  bench/sea/gshhg_ports.py build/bench/sea_bench /tmp/arch_f.gpkg /tmp/arch_ports_owned.geojson \\
      --bands SE:19.45,AX:21.1,FI

Debian's /usr/bin/python3.
"""
import json
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def points(path):
    with open(path) as f:
        return [(ft["geometry"]["coordinates"], ft["properties"].get("owner")) for ft in json.load(f)["features"]]


def banded(spec):
    """"SE:19.45,AX:21.1,FI" -> [(19.45, "SE"), (21.1, "AX"), (inf, "FI")]: owners west of each bound."""
    bands = []
    for part in spec.split(","):
        name, _, bound = part.partition(":")
        bands.append((float(bound) if bound else math.inf, name))
    return bands


def main():
    args = sys.argv[1:]
    bands = None
    if len(args) == 5 and args[3] == "--bands":
        bands = banded(args[4])
        args = args[:3]
    if len(args) != 3:
        sys.exit(__doc__)
    bench, coast, out = args
    with tempfile.TemporaryDirectory() as tmp:
        raw = os.path.join(tmp, "ports.geojson")
        subprocess.run([bench, "--data", coast, "--geodesic", "1", "--res", "0.02", "--runs", "1", "--ports-out", raw],
                       check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
        ports = points(raw)
    fixture = points(os.path.join(ROOT, "fixtures", "baltic_west_ports.geojson"))

    def owner(p):
        if bands:
            return next(name for bound, name in bands if p[0] < bound)

        def gap(q):
            c = math.cos(math.radians(0.5 * (p[1] + q[0][1])))
            return ((p[0] - q[0][0]) * c) ** 2 + (p[1] - q[0][1]) ** 2
        return min(fixture, key=gap)[1]

    features = [{"type": "Feature", "properties": {"owner": owner(p)}, "geometry": {"type": "Point", "coordinates": p}}
                for p, _ in ports]
    with open(out, "w") as f:
        json.dump({"type": "FeatureCollection", "features": features}, f)
    counts = {}
    for ft in features:
        counts[ft["properties"]["owner"]] = counts.get(ft["properties"]["owner"], 0) + 1
    print(f"gshhg_ports: {len(features)} ports, " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))


if __name__ == "__main__":
    main()
