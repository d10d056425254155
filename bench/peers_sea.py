#!/usr/bin/python3
"""The distance by sea side by side: rvoronoi's exact engine against the raster tools users run
for "the nearest port by sea", on identical inputs, in one run (bench/peers.py --sea calls main()).

  peers_sea.py [--rvoronoi PATH] [--out DIR] [--results FILE] [--repeats N] [--quick]

The tools:
  - rvoronoi compute --barriers (exact, planar);
  - GRASS r.cost, 8 neighbours and with -k (16, the knight's move): land as null cost, the ports'
    cells as start points, the nearest= output for the owner;
  - scikit-image MCP_Geometric (8 neighbours): land as infinite cost, the owner found by following
    each cell's traceback to its start (pointer doubling over the whole grid).
The raster tools start from the cell holding each port (its cost made 1 where that cell is land:
a start in a null cell is ignored) and walk from cell centre to cell centre; their distances in
cells are multiplied by the cell size.

The reference: rvoronoi's exact engine by sea, which equals the brute-force oracle cell for cell
(tests/raster/sea/test_sea_field.cpp, tests/service/job/test_sea_job.cpp), once for all ports and
once per owner (the distance to that owner's nearest port, for telling a wrong owner from a tie).
Measured over the cells the reference gives an owner:
  wrong owner: the tool's owner is not the reference's, and that owner's distance by sea exceeds
               the least by more than 1e-3 of a cell (a tie is not wrong);
  no owner:    the tool leaves the cell without an owner or distance;
  distance:    |d_tool - d_ref|, mean and worst, in cells and in % of d_ref (cells 2 or more
               cells from every port, where a percentage means something).
Exit status non-zero when rvoronoi has a wrong or missing cell or an installed tool fails (the
CTest smoke test bench_peers_sea_quick). Time: the whole command, median of the repeats (GRASS's includes importing and exporting the
rasters, as a user's script pays them); memory: the child's peak resident set.
"""

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
import peers  # noqa: E402  (run_child, write_tif, epsg_wkt, machine, median)

UTM = 32633
TIE = 1e-3  # of a cell


def log(msg):
    print(msg, file=sys.stderr, flush=True)


class Case:
    """Ports (points with an owner), land (polygons), a grid in UTM 33N."""

    def __init__(self, name, title, ports, land, extent, res, work):
        self.name, self.title, self.ports, self.land = name, title, ports, land
        self.extent, self.res = extent, res
        self.dir = os.path.join(work, name)
        os.makedirs(self.dir, exist_ok=True)
        x0, y0, x1, y1 = extent
        self.width, self.height = int(round((x1 - x0) / res)), int(round((y1 - y0) / res))
        self.gt = (x0, res, 0.0, y1, 0.0, -res)
        self.wkt = peers.epsg_wkt(UTM)

    def cells(self):
        return self.width * self.height


def geojson_points(path, points):
    """points: [(x, y, owner)] in UTM 33N."""
    doc = {"type": "FeatureCollection",
           "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::%d" % UTM}},
           "features": [{"type": "Feature", "properties": {"owner": o, "port": i + 1},
                         "geometry": {"type": "Point", "coordinates": [x, y]}} for i, (x, y, o) in enumerate(points)]}
    with open(path, "w") as f:
        json.dump(doc, f)


def oresund_case(work, res):
    """The fixture's ports on the Øresund's coasts, the two states' land, in UTM 33N."""
    from osgeo import ogr, osr
    src = osr.SpatialReference()
    src.ImportFromEPSG(4326)
    src.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    dst = osr.SpatialReference()
    dst.ImportFromEPSG(UTM)
    dst.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    to_utm = osr.CoordinateTransformation(src, dst)
    with open(os.path.join(ROOT, "fixtures", "oresund_ports.geojson")) as f:
        doc = json.load(f)
    points = []
    for feat in doc["features"]:
        x, y, _ = to_utm.TransformPoint(*feat["geometry"]["coordinates"])
        points.append((x, y, feat["properties"]["owner"]))
    case = Case("oresund", "Øresund: 12 ports (DK, SE) on the coasts, the land as barriers", None,
                os.path.join(ROOT, "fixtures", "oresund.gpkg"), (330000.0, 6150000.0, 370000.0, 6220000.0), res, work)
    case.ports = os.path.join(case.dir, "ports.geojson")
    geojson_points(case.ports, points)
    return case


def archipelago_case(work, res, islands=60, ports_per_owner=6, seed=56):
    """Random islands (star-shaped polygons of 9-17 vertices, 1-4 km across, some overlapping)
    in a 100 km square, and ports of four owners on their coasts (island vertices)."""
    rng = np.random.default_rng(seed)
    x0, y0, size = 400000.0, 6100000.0, 100000.0
    rings = []
    for _ in range(islands):
        cx, cy = x0 + rng.uniform(5000, size - 5000), y0 + rng.uniform(5000, size - 5000)
        n = int(rng.integers(9, 18))
        angles = np.sort(rng.uniform(0, 2 * np.pi, n))
        radii = rng.uniform(500, 2000, n) * rng.uniform(0.8, 2.0)
        rings.append([(cx + r * np.cos(a), cy + r * np.sin(a)) for a, r in zip(angles, radii)])
    case = Case("archipelago", "Archipelago: %d random islands, %d ports of 4 owners on their coasts"
                % (islands, 4 * ports_per_owner), None, None, (x0, y0, x0 + size, y0 + size), res, work)
    case.land = os.path.join(case.dir, "land.geojson")
    features = [{"type": "Feature", "properties": {"island": i + 1},
                 "geometry": {"type": "Polygon", "coordinates": [[list(p) for p in ring + ring[:1]]]}}
                for i, ring in enumerate(rings)]
    with open(case.land, "w") as f:
        json.dump({"type": "FeatureCollection",
                   "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::%d" % UTM}},
                   "features": features}, f)
    # Ports: vertices of islands that lie inside no other island (on the coast, at sea side).
    from osgeo import ogr
    polys = [ogr.CreateGeometryFromJson(json.dumps(ft["geometry"])) for ft in features]
    points, owners = [], ["A", "B", "C", "D"]
    order = rng.permutation(len(rings))
    k = 0
    for i in order:
        if len(points) == 4 * ports_per_owner:
            break
        v = rings[i][int(rng.integers(0, len(rings[i])))]
        p = ogr.CreateGeometryFromWkt("POINT (%r %r)" % v)
        if any(j != i and polys[j].Intersects(p) for j in range(len(polys))):
            continue
        points.append((v[0], v[1], owners[k % 4]))
        k += 1
    case.ports = os.path.join(case.dir, "ports.geojson")
    geojson_points(case.ports, points)
    return case


def read(path, dtype):
    from osgeo import gdal
    return gdal.Open(path).ReadAsArray().astype(dtype)


def port_table(case):
    with open(case.ports) as f:
        doc = json.load(f)
    return [(ft["geometry"]["coordinates"][0], ft["geometry"]["coordinates"][1], ft["properties"]["owner"])
            for ft in doc["features"]]


def rvoronoi_cmd(exe, case, outdir, ports=None):
    return [exe, "compute", ports or case.ports, "--owner-field", "owner", "--barriers", case.land,
            "--crs", "EPSG:%d" % UTM, "--metric", "planar", "--resolution", repr(case.res),
            "--extent"] + [repr(v) for v in case.extent] + [
            "--ownership", os.path.join(outdir, "own.tif"), "--distance", os.path.join(outdir, "dist.tif"),
            "--report", os.path.join(outdir, "report.json"), "--no-edit-base", "--quiet"]


def reference(exe, case):
    """The exact field by sea, and per owner the distance to its nearest port."""
    out = os.path.join(case.dir, "ref")
    os.makedirs(out, exist_ok=True)
    subprocess.run(rvoronoi_cmd(exe, case, out), check=True)
    with open(os.path.join(out, "report.json")) as f:
        report = json.load(f)
    labels = [o["label"] for o in report["seeds"]["owners"]]
    ref = {"owner": read(os.path.join(out, "own.tif"), np.int32),
           "dist": read(os.path.join(out, "dist.tif"), np.float64), "labels": labels, "report": report, "per_owner": {}}
    table = port_table(case)
    for label in labels:
        sub = os.path.join(case.dir, "ref_" + label)
        os.makedirs(sub, exist_ok=True)
        mine = os.path.join(sub, "ports.geojson")
        geojson_points(mine, [p for p in table if p[2] == label])
        subprocess.run(rvoronoi_cmd(exe, case, sub, mine), check=True)
        ref["per_owner"][label] = read(os.path.join(sub, "dist.tif"), np.float64)
    return ref


def rasters_for_raster_tools(case):
    """Land mask (cell centres inside the land), start ids (port number in its cell), as arrays."""
    from osgeo import gdal
    mem = gdal.GetDriverByName("MEM").Create("", case.width, case.height, 1, gdal.GDT_Byte)
    mem.SetGeoTransform(case.gt)
    mem.SetProjection(case.wkt)
    land = gdal.OpenEx(case.land, gdal.OF_VECTOR)
    warped = gdal.VectorTranslate("/vsimem/land_utm.gpkg", land, dstSRS="EPSG:%d" % UTM, format="GPKG")
    warped = None
    gdal.Rasterize(mem, "/vsimem/land_utm.gpkg", burnValues=[1])
    gdal.Unlink("/vsimem/land_utm.gpkg")
    mask = mem.GetRasterBand(1).ReadAsArray().astype(bool)
    starts = np.zeros((case.height, case.width), np.int32)
    for i, (x, y, _) in enumerate(port_table(case)):
        c = int((x - case.extent[0]) // case.res)
        r = int((case.extent[3] - y) // case.res)
        if 0 <= r < case.height and 0 <= c < case.width:
            starts[r, c] = i + 1
    return mask, starts


def mcp_worker(costs_path, starts_path, out_prefix):
    """In its own process (for its time and memory): MCP_Geometric from every start at once."""
    from skimage.graph import MCP_Geometric
    costs = np.load(costs_path)
    starts = np.load(starts_path)
    where = np.argwhere(starts > 0)
    m = MCP_Geometric(costs, fully_connected=True)
    cum, tb = m.find_costs([tuple(p) for p in where])
    # Owner: follow each cell's traceback to its start, all cells at once by pointer doubling.
    h, w = costs.shape
    offsets = np.asarray(m.offsets)
    tbf = tb.ravel()
    parent = np.arange(h * w)
    moving = np.flatnonzero(tbf >= 0)  # cells reached from a neighbour: pred = cell - offset
    step = offsets[tbf[moving]]
    parent[moving] = (moving // w - step[:, 0]) * w + (moving % w - step[:, 1])
    for _ in range(64):
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            break
        parent = nxt
    label = starts.ravel()[parent].reshape(h, w)
    label[~np.isfinite(cum)] = 0
    np.save(out_prefix + "_cost.npy", cum)
    np.save(out_prefix + "_port.npy", label)


GRASS_JOB = """set -e
r.in.gdal -o input={cost} output=cost --q
r.in.gdal -o input={starts} output=starts --q
g.region raster=cost
r.cost {flags} input=cost start_raster=starts output=acc nearest=near --q --o
r.out.gdal input=acc output={acc} type=Float64 --q -f --o
r.out.gdal input=near output={near} type=Int32 --q -f --o
"""


def run_tools(args, case, ref):
    mask, starts = rasters_for_raster_tools(case)
    work = os.path.join(case.dir, "tools")
    os.makedirs(work, exist_ok=True)
    costs = np.where(mask, np.nan, 1.0)
    costs[starts > 0] = 1.0  # a start in a null cell is ignored: the port's own cell is passable
    owner_of_port = [None] + [p[2] for p in port_table(case)]
    code = {label: i + 1 for i, label in enumerate(ref["labels"])}
    port_to_code = np.array([0] + [code[o] for o in owner_of_port[1:]], np.int32)
    results = []

    def repeat(name, cmd, collect):
        times, rss = [], []
        for _ in range(args.repeats):
            rc, wall, peak, out, err = peers.run_child(cmd, args.timeout, cwd=work)
            if rc != 0:
                log("%s failed (%s): %s" % (name, rc, (err or out)[-600:]))
                results.append({"tool": name, "failed": True})
                return
            times.append(wall)
            rss.append(peak)
        owner, dist = collect()
        results.append({"tool": name, "seconds": peers.median(times), "rss": max(rss), "owner": owner, "dist": dist})

    # rvoronoi
    out = os.path.join(work, "rvoronoi")
    os.makedirs(out, exist_ok=True)
    repeat("rvoronoi exact (by sea)", rvoronoi_cmd(args.rvoronoi, case, out),
           lambda: (read(os.path.join(out, "own.tif"), np.int32), read(os.path.join(out, "dist.tif"), np.float64)))

    # GRASS r.cost
    if shutil.which("grass"):
        cost_tif, starts_tif = os.path.join(work, "cost.tif"), os.path.join(work, "starts.tif")
        peers.write_tif(cost_tif, costs.astype(np.float32), case.gt, case.wkt, nodata=float("nan"))
        peers.write_tif(starts_tif, starts, case.gt, case.wkt, nodata=0)
        for flags, name in (("", "GRASS r.cost (8 neighbours)"), ("-k", "GRASS r.cost -k (16 neighbours)")):
            acc, near = os.path.join(work, "acc%s.tif" % flags), os.path.join(work, "near%s.tif" % flags)
            script = os.path.join(work, "grass%s.sh" % flags)
            with open(script, "w") as f:
                f.write(GRASS_JOB.format(cost=cost_tif, starts=starts_tif, flags=flags, acc=acc, near=near))

            def collect(acc=acc, near=near):
                a = read(acc, np.float64)
                n = read(near, np.int64)
                ok = np.isfinite(a) & (n > 0) & (n < len(port_to_code))
                owner = np.where(ok, port_to_code[np.clip(n, 0, len(port_to_code) - 1)], 0)
                return owner, np.where(ok, a * case.res, -1.0)
            repeat(name, ["grass", "--tmp-location", "EPSG:%d" % UTM, "--exec", "bash", script], collect)
    else:
        results.append({"tool": "GRASS r.cost", "missing": True})

    # scikit-image
    if subprocess.run([peers.PY, "-c", "import skimage.graph"], capture_output=True).returncode == 0:
        costs_path, starts_path = os.path.join(work, "mcp_costs.npy"), os.path.join(work, "mcp_starts.npy")
        np.save(costs_path, np.where(np.isnan(costs), np.inf, costs))
        np.save(starts_path, starts)
        prefix = os.path.join(work, "mcp")

        def collect():
            cum = np.load(prefix + "_cost.npy")
            port = np.load(prefix + "_port.npy")
            ok = np.isfinite(cum) & (port > 0)
            return np.where(ok, port_to_code[port], 0), np.where(ok, cum * case.res, -1.0)
        repeat("scikit-image MCP_Geometric", [peers.PY, os.path.abspath(__file__), "--mcp-worker", costs_path,
                                              starts_path, prefix], collect)
    else:
        results.append({"tool": "scikit-image MCP_Geometric", "missing": True})
    return results


def evaluate(case, ref, r):
    sea = ref["owner"] > 0
    owner, dist = r["owner"], r["dist"]
    none = sea & (owner <= 0)
    have = sea & (owner > 0)
    per = np.stack([ref["per_owner"][label] for label in ref["labels"]])  # owner code - 1
    chosen = np.where(have, owner - 1, 0)
    chosen_d = np.take_along_axis(per, chosen[None], axis=0)[0]
    wrong = have & (owner != ref["owner"]) & (np.where(chosen_d < 0, np.inf, chosen_d) - ref["dist"] > TIE * case.res)
    d_ok = have & (dist >= 0)
    err = np.abs(dist - ref["dist"])[d_ok] / case.res
    far = d_ok & (ref["dist"] >= 2 * case.res)
    rel = (np.abs(dist - ref["dist"])[far] / ref["dist"][far]) * 100.0
    return {"wrong": int(wrong.sum()), "none": int(none.sum()), "sea": int(sea.sum()),
            "mean_cells": float(err.mean()) if err.size else 0.0, "max_cells": float(err.max()) if err.size else 0.0,
            "mean_pct": float(rel.mean()) if rel.size else 0.0, "max_pct": float(rel.max()) if rel.size else 0.0}


def table(case, ref, results):
    rep = ref["report"]["sea"]
    lines = ["### %s" % case.title, "",
             "Grid %d x %d = %.2e cells of %g m (UTM 33N); %d sea cells, %d land cells; %d barrier vertices, "
             "largest detour %.2f." % (case.width, case.height, case.cells(), case.res, int((ref["owner"] > 0).sum()),
                                       rep["land_cells"], rep["barriers"]["vertices"], rep["max_detour"]), "",
             "| tool | wrong owners | no owner | distance error mean / worst (cells) | mean / worst (%) | time s | "
             "memory MB |", "|---|---|---|---|---|---|---|"]
    for r in results:
        if r.get("missing"):
            lines.append("| %s | not installed | | | | | |" % r["tool"])
            continue
        if r.get("failed"):
            lines.append("| %s | failed | | | | | |" % r["tool"])
            continue
        e = r["eval"]
        lines.append("| %s | %d (%.2f %%) | %d | %.4f / %.3f | %.3f / %.2f | %.2f | %.0f |" % (
            r["tool"], e["wrong"], 100.0 * e["wrong"] / max(e["sea"], 1), e["none"], e["mean_cells"], e["max_cells"],
            e["mean_pct"], e["max_pct"], r["seconds"], r["rss"] / 2 ** 20))
    return "\n".join(lines) + "\n"


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--rvoronoi", default=os.path.join(ROOT, "build", "service", "rvoronoi"))
    p.add_argument("--out", default=None)
    p.add_argument("--results", default=None, help="write the tables here (markdown)")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--timeout", type=float, default=600)
    p.add_argument("--quick", action="store_true", help="coarse grids (a smoke test)")
    p.add_argument("--mcp-worker", nargs=3, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.mcp_worker:
        mcp_worker(*args.mcp_worker)
        return 0
    work = args.out or tempfile.mkdtemp(prefix="rv_peers_sea_")
    cases = [oresund_case(work, 250.0 if args.quick else 50.0), archipelago_case(work, 500.0 if args.quick else 100.0)]
    model, cpus, mem = peers.machine()
    md = ["## Peers by sea", "",
          "`%s` on %s, %d CPUs, %.0f GiB; medians of %d runs." % (
              " ".join(["bench/peers.py --sea"] + (["--quick"] if args.quick else [])), model, cpus, mem,
              args.repeats), ""]
    worst = 0
    for case in cases:
        log("case %s: %d x %d cells" % (case.name, case.width, case.height))
        ref = reference(args.rvoronoi, case)
        results = run_tools(args, case, ref)
        for r in results:
            if "owner" in r:
                r["eval"] = evaluate(case, ref, r)
        mine = [r for r in results if r["tool"].startswith("rvoronoi")][0]
        # Exit status: rvoronoi with any wrong or missing cell, or an installed tool that failed.
        worst = max(worst, mine["eval"]["wrong"] + mine["eval"]["none"] if "eval" in mine else 1)
        worst = max(worst, sum(1 for r in results if r.get("failed")))
        md.append(table(case, ref, results))
    text = "\n".join(md)
    print(text)
    if args.results:
        with open(args.results, "w") as f:
            f.write(text)
    if not args.out:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if worst else 0


if __name__ == "__main__":
    sys.exit(main())
