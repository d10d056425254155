#!/usr/bin/python3
"""The analyst's whole job, timed: `rvoronoi compute` with every deliverable (ownership raster,
boundaries, tripoints, limits at 12 and 24 nmi, regions) on real coasts, geodesic, phase by
phase from the command's report, with each run's peak memory (its own high-water mark, from
wait4). One or more binaries, alternated round by round; medians over the rounds.

Cases (fixtures/):
  oresund   the Øresund pair (2 owners, 598 edges) at 0.0002 deg: 6,601 x 5,601 = 3.7e7 cells
  baltic    the western Baltic (4 owners, land borders, overlaps to the lower code) at 0.0005 deg:
            14,300 x 6,102 = 8.7e7 cells
  baltic1e9 the same at 0.000148 deg: about 1.0e9 cells (not run unless named in --cases)
  baltic-reach  the baltic case with a max distance of 24 nmi: regions bounded by the 24 nmi line
            too (not run unless named in --cases)
  oresund-half  the Øresund pair split into its islands, Ven (Swedish, 12.69 E 55.91 N) at half
            effect (--effect-field): two fields and two sets of lines, the rule and the traced
            partial line (not run unless named in --cases; the input is made in a temporary
            directory with GDAL's Python bindings)
  --quick   the same at 4x the cell size (16x fewer cells)
  --gpkg    the vector deliverables as GeoPackage (binary geometries) instead of GeoJSON, whose
            text formatting of every coordinate is a large part of writing them

usage:
  bench/deliverables.py [--rounds N] [--quick] [--gpkg] [--cases oresund,baltic] LABEL=BINARY ...
e.g.
  bench/deliverables.py --rounds 3 old=/tmp/old/rvoronoi new=build/service/rvoronoi
Debian's /usr/bin/python3. Run it on an otherwise idle machine (no build beside it). Checks that
every variant wrote the same deliverables, byte for byte, and says so.
"""
import filecmp
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIXTURES = os.path.join(ROOT, "fixtures")
CASES = {
    "oresund": (["oresund.gpkg", "--owner-field", "iso2"], 0.0002),
    "baltic": (["baltic_west.gpkg", "--owner-field", "iso2", "--on-conflict", "lower-code"], 0.0005),
    # The same coast at 1e9 cells (48,615 x 20,743): the streamed job's memory at scale.
    "baltic1e9": (["baltic_west.gpkg", "--owner-field", "iso2", "--on-conflict", "lower-code"], 0.000148),
    "baltic-reach": (["baltic_west.gpkg", "--owner-field", "iso2", "--on-conflict", "lower-code", "--max-distance",
                      "44448"], 0.0005),  # metres: 24 nmi
}
# Cases whose input is made from a fixture first: name -> the function that writes it.
def ven_at_half_effect(path):
    from osgeo import ogr
    src = ogr.Open(os.path.join(FIXTURES, "oresund.gpkg"))
    layer = src.GetLayer(0)
    out = ogr.GetDriverByName("GPKG").CreateDataSource(path)
    dst = out.CreateLayer("states", layer.GetSpatialRef(), ogr.wkbPolygon)
    dst.CreateField(ogr.FieldDefn("iso2", ogr.OFTString))
    dst.CreateField(ogr.FieldDefn("e", ogr.OFTReal))
    for feature in layer:
        geometry = feature.GetGeometryRef()
        for k in range(geometry.GetGeometryCount()):
            part = geometry.GetGeometryRef(k)
            xmin, _, ymin, _ = part.GetEnvelope()
            f = ogr.Feature(dst.GetLayerDefn())
            f.SetField("iso2", feature.GetField("iso2"))
            if 12.66 < xmin < 12.68 and ymin > 55.88:
                f.SetField("e", 0.5)
            f.SetGeometry(part.Clone())
            dst.CreateFeature(f)
    out = None


GENERATED = {"@ven-half": ven_at_half_effect}
CASES["oresund-half"] = (["@ven-half", "--owner-field", "iso2", "--effect-field", "e"], 0.0002)
OUTPUTS = {"boundaries": "b.geojson", "tripoints": "t.geojson", "limits": "l.geojson", "regions": "r.geojson"}
PHASES = ("compute", "boundaries", "limits", "regions", "deliverables", "total")


def outputs(gpkg):
    return {flag: (os.path.splitext(name)[0] + ".gpkg" if gpkg else name) for flag, name in OUTPUTS.items()}


def run(binary, case, quick, gpkg, out):
    args, res = CASES[case]
    os.makedirs(out, exist_ok=True)
    source = os.path.join(FIXTURES, args[0])
    if args[0] in GENERATED:
        source = os.path.join(os.path.dirname(os.path.dirname(out)), args[0][1:] + ".gpkg")
        if not os.path.exists(source):
            GENERATED[args[0]](source)
    cmd = [binary, "compute", source] + args[1:] + [
        "--resolution", repr(res * 4 if quick else res), "--threads", "2", "--quiet",
        "--ownership", os.path.join(out, "o.tif"), "--limit-distances", "12nmi,24nmi",
        "--report", os.path.join(out, "report.json")]
    for flag, name in outputs(gpkg).items():
        cmd += [f"--{flag}", os.path.join(out, name)]
    # (The Baltic's overlapping land borders are warned about on stderr, shown only on failure.)
    errors = os.path.join(out, "stderr.txt")
    with open(errors, "w") as err:
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
    if status != 0:
        sys.exit(f"{binary} failed on {case} (status {status}): {open(errors).read()}")
    report = json.load(open(os.path.join(out, "report.json")))
    t = report["timings_s"]
    row = {"compute": t["compute"], "total": t["total"], "peak_mib": usage.ru_maxrss / 1024.0}
    for name in ("boundaries", "limits", "regions"):
        row[name] = t["deliverables"].get(name, 0.0)  # (partial effect: the lines are in compute)
    # The deliverables' own wall time (their files are written side by side, so the three above
    # overlap); builds before it had none, and ran them one after the other.
    row["deliverables"] = t["deliverables"].get("wall", row["boundaries"] + row["limits"] + row["regions"])
    b = report["deliverables"]["boundaries"]
    row["unresolved_tripoints"] = b["unresolved_tripoints"]
    row["max_residual_m"] = max(b["max_residual"], report["deliverables"]["limits"]["max_residual"])
    row["cells"] = report["grid"]["cells"]
    return row


def main():
    argv = sys.argv[1:]
    rounds, quick, gpkg, cases, variants = 3, False, False, ["oresund", "baltic"], []
    while argv:
        a = argv.pop(0)
        if a == "--rounds":
            rounds = int(argv.pop(0))
        elif a == "--quick":
            quick = True
        elif a == "--gpkg":
            gpkg = True
        elif a == "--cases":
            cases = argv.pop(0).split(",")
        elif "=" in a:
            variants.append(tuple(a.split("=", 1)))
        else:
            sys.exit(__doc__)
    if not variants or any(c not in CASES for c in cases):
        sys.exit(__doc__)
    with tempfile.TemporaryDirectory() as tmp:
        for case in cases:
            rows = {label: [] for label, _ in variants}
            for r in range(rounds):
                for label, binary in variants:
                    rows[label].append(run(binary, case, quick, gpkg, os.path.join(tmp, case, label)))
            differ = sorted({f for label, _ in variants[1:] for f in outputs(gpkg).values()
                             if not filecmp.cmp(os.path.join(tmp, case, variants[0][0], f),
                                                os.path.join(tmp, case, label, f), shallow=False)})
            same = not differ
            verdict = "identical" if same else "DIFFER (" + ", ".join(differ) + ")"
            if gpkg:  # a GeoPackage records when it was written
                verdict = "not compared (GeoPackage files carry their time of writing)"
            cells = rows[variants[0][0]][0]["cells"]
            print(f"\n{case}: {cells:.3g} cells, {rounds} alternated rounds, medians (s); deliverables "
                  f"{verdict} across variants\n")
            print("| variant | " + " | ".join(PHASES) + " | deliverables / compute | peak MiB | unresolved tripoints | max residual m |")
            print("|---" * (len(PHASES) + 5) + "|")
            for label, _ in variants:
                med = {k: statistics.median(x[k] for x in rows[label]) for k in PHASES + ("peak_mib",)}
                deliver = med["deliverables"]
                last = rows[label][-1]
                print(f"| {label} | " + " | ".join(f"{med[k]:.3f}" for k in PHASES) +
                      f" | {deliver / med['compute']:.1f} | {med['peak_mib']:.0f} | {last['unresolved_tripoints']} | "
                      f"{last['max_residual_m']:.2g} |")


if __name__ == "__main__":
    main()
