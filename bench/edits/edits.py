#!/usr/bin/env python3
"""Edits of a finished job against fresh runs (issue 32), the whole `rvoronoi compute` command.

    /usr/bin/python3 bench/edits/edits.py --binary build/service/rvoronoi [--side 10000] [--seeds 50000]
        [--repeats 3] [--work DIR] [--outputs ownership,distance] > table.md
    /usr/bin/python3 bench/edits/edits.py --binary build/service/rvoronoi --coast [--resolution 0.0004] > table.md

--coast: the western Baltic of fixtures/ (four states, each one multipolygon, geodesic on
WGS84) with boundaries, tripoints and 12 / 24 nmi limits besides the rasters. The edit moves one
vertex of Denmark's coast near Copenhagen by 0.002 degrees east (about 125 m): one basepoint of a
feature of thousands. The edit and a fresh run alternate --repeats times; every file of the edit
is compared byte for byte with the fresh run's.

The case is the 1e8-cell grid of bench/RESULTS.md: SIDE x SIDE cells of 1 m, SEEDS random points,
one owner per point (--owner-field id). A base run keeps its field (--report). Then, for each
edit (one point moved by (5, -3) m, one removed, one added beside another), the seed file is
edited in place and two commands alternate --repeats times: the edit (`--base` the base's
report) and a fresh run of the edited file. Every edit's files are compared byte for byte with
the fresh run's (the script stops on a difference).

--old BIN: the same edits by another build too (its own base run), alternated with the others:
the column "old edit s" (the two builds' kept bases differ in format, so each edits its own);
with --coast, a row "old build's edit".

A last pair measures what keeping the field costs every run: the fresh command with --report
(which keeps it) against the same without --report (which keeps nothing), alternated.

Every timed command starts after `sync` (untimed): the runs before it wrote hundreds of megabytes,
whose write-back would otherwise throttle its writes.

Columns: medians over the repeats of the command's wall time, of the report's "compute" (the
edit's: reading the base's strips, planning, recomputing and tallying; the fresh run's: the
engine), and the edit's cells recomputed against cells changed (owner or distance).
"""
import argparse
import filecmp
import json
import os
import random
import statistics
import subprocess
import sys
import time

X0, Y0, EPSG = 400000.0, 6100000.0, 32633


def write_points(path, pts):
    """Points (id, x, y) owned by their id, or (id, x, y, owner)."""
    with open(path, "w") as f:
        f.write('{"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::%d"}},'
                '"features":[\n' % EPSG)
        f.write(",\n".join('{"type":"Feature","id":%d,"properties":{"id":%d},"geometry":{"type":"Point",'
                           '"coordinates":[%r,%r]}}' % (p[0], p[3] if len(p) > 3 else p[0], p[1], p[2]) for p in pts))
        f.write("]}\n")


def mixed(p, k):
    """Issue 54's case: three points removed, two moved, two added, one point given another's owner."""
    q = list(p)
    q[k + 300] = (q[k + 300][0], q[k + 300][1] + 5.0, q[k + 300][2] - 3.0)
    q[k + 400] = (q[k + 400][0], q[k + 400][1] - 4.0, q[k + 400][2] + 6.0)
    q[k + 500] = (q[k + 500][0], q[k + 500][1], q[k + 500][2], q[k + 501][0])
    for i in (k + 200, k, k - 200):
        del q[i]
    return q + [(len(p) + 1, p[k][1] + 7.0, p[k][2] + 2.0), (len(p) + 2, p[k + 50][1] - 6.0, p[k + 50][2] + 1.0)]


def command(binary, seeds, side, outdir, outputs, report=True, base=None):
    os.makedirs(outdir, exist_ok=True)
    cmd = [binary, "compute", seeds, "--owner-field", "id", "--resolution", "1", "--extent", str(X0), str(Y0),
           str(X0 + side), str(Y0 + side), "--quiet"]
    for o in outputs:
        cmd += ["--" + o.replace("_", "-"), os.path.join(outdir, o + ".tif")]
    if report:
        cmd += ["--report", os.path.join(outdir, "report.json")]
    if base:
        cmd += ["--base", base]
    return cmd


def timed(cmd):
    # The commands before wrote hundreds of megabytes: flushed first (not timed), so that their
    # write-back does not throttle this command's writes.
    os.sync()
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def same_files(a, b, outputs):
    for o in outputs:
        if not filecmp.cmp(os.path.join(a, o + ".tif"), os.path.join(b, o + ".tif"), shallow=False):
            sys.exit(f"{o}: the edit's file differs from the fresh run's ({a} vs {b})")


FIXTURES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "fixtures")
COAST_FILES = ["ownership.tif", "distance.tif", "boundaries.geojson", "tripoints.geojson", "limits.geojson"]


def coast_command(binary, seeds, res, outdir, base=None):
    os.makedirs(outdir, exist_ok=True)
    o = lambda n: os.path.join(outdir, n)  # noqa: E731
    cmd = [binary, "compute", seeds, "--owner-field", "iso2", "--on-conflict", "lower-code", "--resolution", str(res),
           "--ownership", o("ownership.tif"), "--distance", o("distance.tif"), "--boundaries", o("boundaries.geojson"),
           "--tripoints", o("tripoints.geojson"), "--limits", o("limits.geojson"), "--limit-distances",
           "12nmi,24nmi", "--report", o("report.json"), "--quiet"]
    return cmd + (["--base", base] if base else [])


def move_vertex(gpkg, near=(12.6, 55.7), shift=0.002):
    from osgeo import ogr

    ds = ogr.Open(gpkg, update=1)
    lyr = ds.GetLayer(0)
    best = None
    for f in lyr:
        if f.GetField("iso2") != "DK":
            continue
        g = f.GetGeometryRef()
        for p in range(g.GetGeometryCount()):
            for r in range(g.GetGeometryRef(p).GetGeometryCount()):
                ring = g.GetGeometryRef(p).GetGeometryRef(r)
                for k in range(ring.GetPointCount() - 1):
                    x, y = ring.GetX(k), ring.GetY(k)
                    d = (x - near[0]) ** 2 + (y - near[1]) ** 2
                    if best is None or d < best[0]:
                        best = (d, f.GetFID(), p, r, k)
    _, fid, p, r, k = best
    f = lyr.GetFeature(fid)
    g = f.GetGeometryRef().Clone()
    ring = g.GetGeometryRef(p).GetGeometryRef(r)
    x, y = ring.GetX(k), ring.GetY(k)
    ring.SetPoint_2D(k, x + shift, y)
    if k == 0:
        ring.SetPoint_2D(ring.GetPointCount() - 1, x + shift, y)
    f.SetGeometry(g)
    lyr.SetFeature(f)
    ds = None
    return x, y


def coast(a):
    import shutil

    os.makedirs(a.work, exist_ok=True)
    seeds = os.path.join(a.work, "baltic.gpkg")
    shutil.copy(os.path.join(FIXTURES, "baltic_west.gpkg"), seeds)
    base_dir = os.path.join(a.work, "base")
    t_base = timed(coast_command(a.binary, seeds, a.resolution, base_dir))
    if a.old:
        timed(coast_command(a.old, seeds, a.resolution, os.path.join(a.work, "base_old")))
    x, y = move_vertex(seeds)
    e_dir, f_dir = os.path.join(a.work, "edit"), os.path.join(a.work, "fresh")
    e_wall, f_wall, o_wall = [], [], []
    for _ in range(a.repeats):
        e_wall.append(timed(coast_command(a.binary, seeds, a.resolution, e_dir,
                                          base=os.path.join(base_dir, "report.json"))))
        f_wall.append(timed(coast_command(a.binary, seeds, a.resolution, f_dir)))
        if a.old:
            o_wall.append(timed(coast_command(a.old, seeds, a.resolution, os.path.join(a.work, "edit_old"),
                                              base=os.path.join(a.work, "base_old", "report.json"))))
        for n in COAST_FILES:
            if not filecmp.cmp(os.path.join(e_dir, n), os.path.join(f_dir, n), shallow=False):
                sys.exit(f"{n}: the edit's file differs from the fresh run's")
    r = json.load(open(os.path.join(e_dir, "report.json")))
    fr = json.load(open(os.path.join(f_dir, "report.json")))
    e, g = r["edit"], r["grid"]
    print(f"Western Baltic, geodesic, {g['width']} x {g['height']} cells ({g['cells']:.2e}) at {a.resolution} deg; "
          f"rasters, boundaries, tripoints, 12 / 24 nmi limits. One vertex of DK at {x:.5f} E {y:.5f} N moved "
          f"0.002 deg east. Medians of {a.repeats}, edit and fresh alternated (the base run took {t_base:.1f} s).\n")
    print("| | edit | fresh | ratio |")
    print("|---|---|---|---|")
    em, fm = statistics.median(e_wall), statistics.median(f_wall)
    print(f"| whole command, s | {em:.2f} | {fm:.2f} | {em / fm:.0%} |")
    if o_wall:
        om = statistics.median(o_wall)
        print(f"| whole command, old build's edit, s | {om:.2f} | | {om / fm:.0%} |")
    print(f"| compute, s (edit: read, plan, recompute, tally) | {r['timings_s']['compute']:.2f} | "
          f"{fr['timings_s']['compute']:.2f} | {r['timings_s']['compute'] / fr['timings_s']['compute']:.0%} |")
    print(f"| deliverables, s | {r['timings_s']['deliverables']['wall']:.2f} | "
          f"{fr['timings_s']['deliverables']['wall']:.2f} | |")
    t = e["timings_s"]
    print(f"\nThe edit: cells recomputed {e['cells_recomputed']}, changed {e['owner_changed_cells']} (owner) + "
          f"{e['distance_only_changed_cells']} (distance only), tiles read {e['tiles_read']} of {e['tiles']} (the plan could not rule out "
          f"{e.get('tiles_planned', '-')}); "
          f"read {t['read_base']:.2f} s, plan {t['plan']:.2f} s, recompute {t['recompute']:.2f} s, "
          f"tally {t['tally']:.2f} s; area moved {e['area_moved']}.")
    if "lines" in e:
        print(f"Lines: rows extracted again {e['lines']['rows_extracted']}, taken from the base "
              f"{e['lines']['rows_taken']} (of {g['height']}).")
    print("\nEdit timings: " + json.dumps(r["timings_s"]))
    print("\nFresh timings: " + json.dumps(fr["timings_s"]))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--coast", action="store_true")
    ap.add_argument("--resolution", type=float, default=0.0004)
    ap.add_argument("--binary", required=True)
    ap.add_argument("--side", type=int, default=10000)
    ap.add_argument("--seeds", type=int, default=50000)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--work", default="/tmp/rv_edits_bench")
    ap.add_argument("--outputs", default="ownership,distance")
    ap.add_argument("--old", help="another build's binary, whose edits are timed alongside")
    ap.add_argument("--only", help="only the edits whose name starts so (e.g. remove)")
    a = ap.parse_args()
    if a.coast:
        return coast(a)
    outputs = a.outputs.split(",")
    os.makedirs(a.work, exist_ok=True)
    rng = random.Random(2032)
    pts = [(i + 1, X0 + rng.uniform(0, a.side), Y0 + rng.uniform(0, a.side)) for i in range(a.seeds)]
    seeds = os.path.join(a.work, "seeds.geojson")
    write_points(seeds, pts)
    base_dir = os.path.join(a.work, "base")
    subprocess.run(command(a.binary, seeds, a.side, base_dir, outputs), check=True)
    base_report = os.path.join(base_dir, "report.json")
    old_report = None
    if a.old:
        subprocess.run(command(a.old, seeds, a.side, os.path.join(a.work, "base_old"), outputs), check=True)
        old_report = os.path.join(a.work, "base_old", "report.json")

    rows = []
    k = len(pts) // 2
    edits = [("move one point", lambda p: p[:k] + [(p[k][0], p[k][1] + 5.0, p[k][2] - 3.0)] + p[k + 1:]),
             ("remove one point", lambda p: p[:k] + p[k + 1:]),
             ("add one point", lambda p: p + [(len(p) + 1, p[k][1] + 7.0, p[k][2] + 2.0)]),
             ("remove 3, move 2, add 2, one owner changed", lambda p: mixed(p, k))]
    if a.only:
        edits = [e for e in edits if e[0].startswith(a.only)]
    for name, edit in edits:
        write_points(seeds, edit(pts))
        e_dir, f_dir = os.path.join(a.work, "edit"), os.path.join(a.work, "fresh")
        e_wall, f_wall, e_compute, f_compute, o_wall = [], [], [], [], []
        report = None
        for _ in range(a.repeats):
            e_wall.append(timed(command(a.binary, seeds, a.side, e_dir, outputs, base=base_report)))
            f_wall.append(timed(command(a.binary, seeds, a.side, f_dir, outputs)))
            if a.old:
                o_dir = os.path.join(a.work, "edit_old")
                o_wall.append(timed(command(a.old, seeds, a.side, o_dir, outputs, base=old_report)))
                same_files(o_dir, f_dir, outputs)
            report = json.load(open(os.path.join(e_dir, "report.json")))
            fresh = json.load(open(os.path.join(f_dir, "report.json")))
            e_compute.append(report["timings_s"]["compute"])
            f_compute.append(fresh["timings_s"]["compute"])
            same_files(e_dir, f_dir, outputs)
        e = report["edit"]
        rows.append((name, statistics.median(e_wall), statistics.median(f_wall), statistics.median(e_compute),
                     statistics.median(f_compute), e["cells_recomputed"],
                     e["owner_changed_cells"] + e["distance_only_changed_cells"], e["timings_s"],
                     statistics.median(o_wall) if o_wall else None, e))
    write_points(seeds, pts)

    keep, plain = [], []
    for _ in range(a.repeats):
        keep.append(timed(command(a.binary, seeds, a.side, os.path.join(a.work, "keep"), outputs)))
        plain.append(timed(command(a.binary, seeds, a.side, os.path.join(a.work, "plain"), outputs, report=False)))
    kept_dir = os.path.join(a.work, "keep", "report.json.rvbase")
    kept_mb = sum(os.path.getsize(os.path.join(kept_dir, f)) for f in os.listdir(kept_dir)) / 1e6
    out_mb = sum(os.path.getsize(os.path.join(a.work, "keep", o + ".tif")) for o in outputs) / 1e6

    cells = a.side * a.side
    print(f"{a.side} x {a.side} cells ({cells:.1e}), {a.seeds} points, outputs {', '.join(outputs)}; "
          f"medians of {a.repeats}, edit and fresh alternated.\n")
    print("| edit | edit command s | fresh command s | ratio | " + ("old edit s | " if a.old else "") +
          "edit compute s | fresh compute s | ratio | cells recomputed | cells changed "
          "| read / plan / recompute / tally s | tiles read / encoded of | copied / recoded per file |")
    print("|---|---|---|---|" + ("---|" if a.old else "") + "---|---|---|---|---|---|---|---|")
    for name, ew, fw, ec, fc, rec, chg, t, ow, e in rows:
        per_file = ", ".join(f"{k} {v}" for k, v in e.get("tiles_copied", {}).items())
        recoded = ", ".join(f"{k} {v}" for k, v in e.get("tiles_recoded", {}).items())
        print(f"| {name} | {ew:.2f} | {fw:.2f} | {ew / fw:.0%} | " + (f"{ow:.2f} | " if a.old else "") +
              f"{ec:.3f} | {fc:.3f} | {ec / fc:.0%} | {rec} | {chg} "
              f"| {t['read_base']:.3f} / {t['plan']:.3f} / {t['recompute']:.3f} / {t['tally']:.3f} "
              f"| {e.get('tiles_read')} / {e.get('tiles_encoded', '-')} of {e.get('tiles')} "
              f"| {per_file or '-'}; recoded: {recoded or '-'} |")
    print(f"\nKeeping the field: the fresh command with --report {statistics.median(keep):.2f} s against "
          f"{statistics.median(plain):.2f} s without (medians, alternated); the kept directory holds "
          f"{kept_mb:.0f} MB beside {out_mb:.0f} MB of outputs.")


if __name__ == "__main__":
    main()
