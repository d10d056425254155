#!/usr/bin/python3
"""rvoronoi side by side with the tools users would pick instead, on identical inputs, in one run.

Run through bench/peers.sh (which installs the peers from Debian's archive first). For every case
and tool it measures the wall time of the computation and of the whole command (GeoTIFFs
written), the child's peak resident memory, and the accuracy against an exact reference, then
prints a markdown table and writes it, with the machine and the command line, to RESULTS.md.

  peers.py [--quick] [--out DIR] [--results FILE] [--rvoronoi PATH] [--timeout S]
           [--repeats N] [--max-cells N] [--cases NAME,...] [--profile]
  peers.py --sea [--quick] [--out DIR] [--results FILE] [--rvoronoi PATH] [--repeats N]
           (the distance by sea against GRASS r.cost and scikit-image: bench/peers_sea.py)

Accuracy. Every cell is measured against an exact reference computed by rvoronoi (brute force
where cells x seeds is small, exact otherwise: exact equals brute force cell for cell, which the
test suite asserts). Point cases: the reference gives each cell its true nearest seed; the
distances are recomputed here in float64 from the seeds' real coordinates, so the 1e-6-cell
threshold is meaningful (the GeoTIFFs hold Float32). Owner cases (coastline, geographic): the
reference is one rvoronoi distance raster per owner (Float32), and the tolerance adds that
storage rounding.
  label tools:    dd = d(cell, assigned seed's real geometry) - d(cell, true nearest seed);
                  wrong when dd > 1e-6 cell.
  distance tools: |d_tool - d_true|; wrong when above 1e-6 cell plus the rounding of the
                  tool's own output type (a Float32 raster cannot hold 1e-6 of a cell at
                  distance 1000).

Exit status: non-zero when rvoronoi exact has any wrong cell, or when any tool that is installed
fails in --quick mode (the CI smoke test: adapters must not rot). Timeouts are reported, not fatal.
"""

import argparse
import datetime
import json
import math
import os
import platform
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
PY = "/usr/bin/python3"  # Debian's Python: the one python3-scipy / python3-opencv install into
UTM = 32633
X0, Y0 = 400000.0, 6100000.0  # origin of the point cases: real UTM 33N coordinates, 1 m cells
OFFSETS_F32 = 2.0 ** -24  # half an ulp of float32, relative

# The paper's Table 1 rows (grid side, seeds). Paper timings are in notes/seeds.md and engine_bench.
TABLE1 = [(100, 20), (300, 50), (1000, 100), (1000, 1000), (3000, 10000), (10000, 50000)]


# --------------------------------------------------------------------------------------------
# helpers


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def have_module(name):
    r = subprocess.run([PY, "-c", "import " + name], capture_output=True)
    return r.returncode == 0


def median(v):
    v = sorted(v)
    return v[len(v) // 2] if v else None


TIME = "/usr/bin/time"  # GNU time (package `time`)


def run_child(cmd, timeout, cwd=None, env=None):
    """Runs cmd, returns (rc, wall_s, peak_rss_bytes, stdout, stderr). rc None on timeout.

    Peak memory comes from GNU time, which forks the command itself: a child forked straight from
    this script inherits this script's high-water RSS (Linux keeps it across fork and exec), so
    os.wait4's ru_maxrss would be at least this process's peak. GNU time's own footprint is a
    megabyte or two. ru_maxrss includes the descendants the command waited for (GRASS modules).
    Without GNU time, wait4's figure is used and is an upper bound.
    """
    out_path = os.path.join(cwd or ".", ".child_stdout")
    err_path = os.path.join(cwd or ".", ".child_stderr")
    rss_path = os.path.join(cwd or ".", ".child_rss")
    if os.path.exists(rss_path):
        os.remove(rss_path)
    if os.access(TIME, os.X_OK):
        cmd = [TIME, "-f", "%M", "-o", rss_path] + list(cmd)
    with open(out_path, "wb") as fo, open(err_path, "wb") as fe:
        t0 = time.perf_counter()
        p = subprocess.Popen(cmd, stdout=fo, stderr=fe, cwd=cwd, env=env, start_new_session=True)
        deadline = t0 + timeout
        rc = None
        ru = None
        while True:
            pid, status, ru = os.wait4(p.pid, os.WNOHANG)
            if pid == p.pid:
                rc = os.waitstatus_to_exitcode(status)
                break
            if time.perf_counter() > deadline:
                # The whole process group: GRASS and gdal_proximity.py start children of their own.
                os.killpg(p.pid, signal.SIGKILL)
                _, status, ru = os.wait4(p.pid, 0)
                rc = None
                break
            time.sleep(0.005)
        wall = time.perf_counter() - t0
    p.returncode = 0 if rc is None else rc  # reaped by wait4 already
    with open(out_path, encoding="utf-8", errors="replace") as f:
        out = f.read()
    with open(err_path, encoding="utf-8", errors="replace") as f:
        err = f.read()
    rss = ru.ru_maxrss * 1024
    if os.path.exists(rss_path):
        with open(rss_path) as f:
            lines = [ln.strip() for ln in f if ln.strip()]
        # GNU time writes "Command exited with non-zero status N" before the figure on failure.
        if lines and lines[-1].isdigit():
            rss = int(lines[-1]) * 1024
    return rc, wall, rss, out, err


def write_tif(path, arr, gt, wkt, nodata=None):
    from osgeo import gdal

    types = {np.dtype(np.int32): gdal.GDT_Int32, np.dtype(np.float64): gdal.GDT_Float64,
             np.dtype(np.float32): gdal.GDT_Float32, np.dtype(np.uint8): gdal.GDT_Byte}
    h, w = arr.shape
    # BIGTIFF=IF_SAFER: the 1e8-cell Float64 rasters are 800 MB, over classic TIFF's 4 GB only
    # with compression off and several bands, but GDAL's guess is cheap insurance.
    ds = gdal.GetDriverByName("GTiff").Create(path, w, h, 1, types[arr.dtype], ["BIGTIFF=IF_SAFER"])
    ds.SetGeoTransform(gt)
    ds.SetProjection(wkt)
    b = ds.GetRasterBand(1)
    if nodata is not None:
        b.SetNoDataValue(nodata)
    b.WriteArray(arr)
    ds = None


def epsg_wkt(code):
    from osgeo import osr

    s = osr.SpatialReference()
    s.ImportFromEPSG(code)
    return s.ExportToWkt()


def read_rows(path, r0, r1, dtype):
    from osgeo import gdal

    ds = gdal.Open(path)
    b = ds.GetRasterBand(1)
    a = b.ReadAsArray(0, r0, ds.RasterXSize, r1 - r0)
    return a.astype(dtype, copy=False)


# --------------------------------------------------------------------------------------------
# workers: in-process peers run as their own child so that time and memory are theirs alone


def worker(kind, seeds_tif, outdir):
    from osgeo import gdal

    # Imports first: the transform's time must not include loading SciPy or OpenCV.
    if kind == "scipy":
        from scipy import ndimage
    else:
        import cv2
    t0 = time.perf_counter()
    ds = gdal.Open(seeds_tif)
    gt, wkt = ds.GetGeoTransform(), ds.GetProjection()
    ids = ds.GetRasterBand(1).ReadAsArray()  # seed id (1-based) in its cell, 0 elsewhere
    ds = None
    t1 = time.perf_counter()
    res = {}
    if kind == "scipy":
        # Non-zero input = "not a seed": the transform measures to the nearest zero cell's centre.
        d, idx = ndimage.distance_transform_edt(ids == 0, return_indices=True)
        t2 = time.perf_counter()
        labels = ids[idx[0], idx[1]]  # the seed whose cell is nearest: what a user keeps
        del idx
        t3 = time.perf_counter()
        write_tif(os.path.join(outdir, "labels.tif"), labels.astype(np.int32, copy=False), gt, wkt, 0)
        write_tif(os.path.join(outdir, "distance.tif"), d, gt, wkt)
    elif kind in ("opencv-labels", "opencv-precise"):
        src = np.where(ids == 0, 255, 0).astype(np.uint8)  # zero pixels are the sources
        t1b = time.perf_counter()
        if kind == "opencv-labels":
            # DIST_MASK_PRECISE is not available with labels; the 5x5 chamfer mask is the best.
            d, lab = cv2.distanceTransformWithLabels(src, cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL)
            t2 = time.perf_counter()
            # Labels number the zero pixels; map each back to the seed burnt there.
            seed_pix = np.flatnonzero(ids.ravel())
            lut = np.zeros(int(lab.max()) + 1, np.int32)
            lut[lab.ravel()[seed_pix]] = ids.ravel()[seed_pix]
            labels = lut[lab]
            del lab
            t3 = time.perf_counter()
            write_tif(os.path.join(outdir, "labels.tif"), labels, gt, wkt, 0)
        else:
            d = cv2.distanceTransform(src, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
            t2 = time.perf_counter()
            t3 = t2
        t1 = t1 + (t1b - t1)  # the uint8 source image is preparation, not the transform
        write_tif(os.path.join(outdir, "distance.tif"), d, gt, wkt)
    else:
        raise SystemExit("unknown worker " + kind)
    t4 = time.perf_counter()
    res.update(read_s=t1 - t0, compute_s=t2 - t1, labels_s=t3 - t2, write_s=t4 - t3)
    print("WORKER " + json.dumps(res))


# --------------------------------------------------------------------------------------------
# cases


class Case:
    """A grid, the seeds on it, and how to rasterise them for raster-source peers."""

    def __init__(self, name, title, kind, width, height, xmin, ymax, res, epsg):
        self.name, self.title, self.kind = name, title, kind  # kind: points | owners
        self.width, self.height, self.xmin, self.ymax, self.res, self.epsg = width, height, xmin, ymax, res, epsg
        self.geographic = epsg == 4326
        self.nseeds = 0
        self.pending = None  # why rvoronoi cannot run this case yet (e.g. geodesic not in this build)

    @property
    def cells(self):
        return self.width * self.height

    @property
    def extent(self):
        return [self.xmin, self.ymax - self.height * self.res, self.xmin + self.width * self.res, self.ymax]

    @property
    def gt(self):
        return (self.xmin, self.res, 0.0, self.ymax, 0.0, -self.res)

    def cell_m(self):
        # Distances are compared in cells. On the geographic grid a cell is not square in metres;
        # the north-south size of a cell (res degrees of latitude) is the unit there.
        return self.res * math.pi / 180 * 6371008.8 if self.geographic else self.res


def make_points_case(side, nseeds, work, rng_seed=2019):
    c = Case(f"pts{side}x{nseeds}", f"{side}×{side} cells, {nseeds} random points", "points", side, side,
             X0, Y0 + side, 1.0, UTM)
    d = os.path.join(work, c.name)
    os.makedirs(d, exist_ok=True)
    rng = np.random.default_rng(rng_seed + side * 7919 + nseeds)
    # Real-valued positions anywhere in the grid, as in the paper (not at cell centres).
    x = X0 + rng.uniform(0, side, nseeds)
    y = Y0 + rng.uniform(0, side, nseeds)
    c.nseeds = nseeds
    c.dir = d
    c.field = "id"
    c.vector = os.path.join(d, "seeds.geojson")
    # GeoJSON with the (deprecated, still honoured by GDAL) crs member: RFC 7946 GeoJSON would be
    # WGS84, which rvoronoi would rightly treat as geographic.
    with open(c.vector, "w") as f:
        f.write('{"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::%d"}},'
                '"features":[\n' % UTM)
        f.write(",\n".join('{"type":"Feature","properties":{"id":%d},"geometry":{"type":"Point","coordinates":[%r,%r]}}'
                           % (i + 1, float(x[i]), float(y[i])) for i in range(nseeds)))
        f.write("]}\n")
    # Seed positions in grid units (cell centres at k + 0.5), recomputed the way they are read back.
    c.sx = (np.array([float(repr(float(v))) for v in x]) - c.xmin) / c.res
    c.sy = (c.ymax - np.array([float(repr(float(v))) for v in y])) / c.res
    # Rasterised seeds: seed i burnt into the cell containing it. Burn in reverse order so that
    # where two seeds share a cell the lower index wins (the engines' tie rule).
    ids = np.zeros((side, side), np.int32)
    col = np.minimum(np.floor(c.sx).astype(np.int64), side - 1)
    row = np.minimum(np.floor(c.sy).astype(np.int64), side - 1)
    ids[row[::-1], col[::-1]] = np.arange(nseeds, 0, -1, dtype=np.int32)
    c.burnt = int(np.count_nonzero(ids))
    c.raster = os.path.join(d, "seeds.tif")
    write_tif(c.raster, ids, c.gt, epsg_wkt(UTM), 0)
    return c


def ogr_features(path, layer, field):
    from osgeo import ogr

    ds = ogr.Open(path)
    lyr = ds.GetLayerByName(layer)
    names = [f.GetField(field) for f in lyr]
    lyr.ResetReading()
    env = lyr.GetExtent()  # xmin, xmax, ymin, ymax
    return names, env


def make_owner_case(name, title, src, layer, field, epsg, res, work):
    """Coastline (projected) or geographic case: polygons/lines belonging to owners."""
    d = os.path.join(work, name)
    os.makedirs(d, exist_ok=True)
    vec = os.path.join(d, "seeds.gpkg")
    subprocess.run(["ogr2ogr", "-f", "GPKG", "-overwrite", "-t_srs", f"EPSG:{epsg}", "-nln", "seeds", vec, src, layer],
                   check=True)
    owners, env = ogr_features(vec, "seeds", field)
    # Grid: the seeds' box grown by 5 % of its larger side, snapped outward to whole cells.
    m = 0.05 * max(env[1] - env[0], env[3] - env[2])
    xmin = math.floor((env[0] - m) / res) * res
    xmax = math.ceil((env[1] + m) / res) * res
    ymin = math.floor((env[2] - m) / res) * res
    ymax = math.ceil((env[3] + m) / res) * res
    c = Case(name, title, "owners", int(round((xmax - xmin) / res)), int(round((ymax - ymin) / res)), xmin, ymax, res,
             epsg)
    c.dir, c.vector, c.field, c.owners = d, vec, field, owners
    c.nseeds = len(owners)
    # One file per owner: its distance raster is the reference distance to that owner.
    c.owner_vectors = []
    for i, o in enumerate(owners):
        p = os.path.join(d, f"owner{i + 1}.gpkg")
        subprocess.run(["ogr2ogr", "-f", "GPKG", "-overwrite", "-where", f"{field} = '{o}'", "-nln", "seeds", p, vec,
                        "seeds"], check=True)
        c.owner_vectors.append(p)
    # Rasterised for raster peers: every cell the geometry touches gets its feature index
    # (ALL_TOUCHED, so that thin lines and narrow islands are not lost); burnt from the last owner
    # to the first so that on a shared cell the lower index wins.
    c.raster = os.path.join(d, "seeds.tif")
    if os.path.exists(c.raster):
        os.remove(c.raster)
    te = [str(v) for v in c.extent]
    subprocess.run(["gdal_rasterize", "-q", "-init", "0", "-a_nodata", "0", "-ot", "Int32", "-te", *te, "-tr", str(res),
                    str(res), "-burn", str(len(owners)), "-at", "-where", f"{field} = '{owners[-1]}'", vec, c.raster],
                   check=True)
    for i in range(len(owners) - 2, -1, -1):
        subprocess.run(["gdal_rasterize", "-q", "-burn", str(i + 1), "-at", "-where", f"{field} = '{owners[i]}'", vec,
                        c.raster], check=True)
    return c


# --------------------------------------------------------------------------------------------
# tools


class Result:
    def __init__(self, case, tool, seeds_as, threads="1"):
        self.case, self.tool, self.seeds_as, self.threads = case, tool, seeds_as, threads
        self.status = "ok"  # ok | skipped: ... | timeout | failed | pending
        self.compute_s = None
        self.command_s = None
        self.rss = None
        self.labels = None  # path of a label raster (seed / feature index, 1-based)
        self.distance = None  # path of a distance raster
        self.dist_scale = 1.0  # multiply the raster's distance by this to get cells
        self.dist_f32 = False
        self.wrong = self.max_dd = self.dwrong = self.max_derr = None
        self.note = ""
        self.outdir = None
        self.lut = None  # raster value -> 1-based seed / owner index, where they differ


def rvoronoi_cmd(exe, case, method, outdir, threads=None, owner_vector=None, extra=()):
    cmd = [exe, "compute", owner_vector or case.vector, "--resolution", repr(case.res), "--extent",
           *[repr(v) for v in case.extent], "--method", method, "--quiet",
           "--ownership", os.path.join(outdir, "own.tif"), "--distance", os.path.join(outdir, "dist.tif"),
           "--report", os.path.join(outdir, "report.json")]
    # Two outputs, like the peers: ownership and distance. With one owner per point (owner field
    # `id`, the seed's 1-based index) the ownership raster is also the nearest-seed label.
    if owner_vector is None:
        cmd += ["--owner-field", case.field]
    if threads:
        cmd += ["--threads", str(threads)]
    return cmd + list(extra)


class Runner:
    def __init__(self, args):
        self.args = args
        self.exe = args.rvoronoi
        self.avail = {
            "scipy": have_module("scipy.ndimage"),
            "cv2": have_module("cv2"),
            "gdal_proximity": shutil.which("gdal_proximity.py") is not None,
            "grass": shutil.which("grass") is not None,
            "saga": shutil.which("saga_cmd") is not None,
        }
        self.failed = []

    def repeat(self, case, res, cmd_fn, parse):
        """Runs the command `repeats` times (once for big grids); medians of time, memory."""
        reps = self.args.repeats if case.cells <= 1_000_000 else 1
        walls, comps, rsss = [], [], []
        for _ in range(reps):
            if os.path.isdir(res.outdir):
                shutil.rmtree(res.outdir)
            os.makedirs(res.outdir)
            cmd = cmd_fn()
            rc, wall, rss, out, err = run_child(cmd, self.args.timeout, cwd=res.outdir)
            if rc is None:
                res.status = f"timeout: > {self.args.timeout:.0f} s"
                res.command_s = wall
                return
            if rc != 0:
                res.status = "failed"
                tail = (err.strip() or out.strip()).splitlines()[-3:]
                res.note = f"exit {rc}: " + " / ".join(tail)
                return
            walls.append(wall)
            rsss.append(rss)
            comps.append(parse(out, err))
        res.command_s, res.rss = median(walls), median(rsss)
        res.compute_s = median([c for c in comps if c is not None]) if any(c is not None for c in comps) else None
        res.cmdline = " ".join(shlex.quote(str(a)) for a in cmd)

    # ---- rvoronoi

    def rvoronoi(self, case, method, threads=None, label=None, extra=()):
        res = Result(case, label or f"rvoronoi {method}", "vector (real geometry)",
                     str(threads) if threads else str(os.cpu_count()))
        res.outdir = os.path.join(case.dir, "out", res.tool.replace(" ", "_").replace("(", "").replace(")", ""))
        if case.pending:
            res.status = "pending"
            res.note = case.pending
            return res

        def parse(out, err):
            with open(os.path.join(res.outdir, "report.json")) as f:
                rep = json.load(f)
            res.report = rep
            return rep["timings_s"]["compute"]

        self.repeat(case, res, lambda: rvoronoi_cmd(self.exe, case, method, res.outdir, threads, extra=extra), parse)
        if res.status == "ok":
            res.labels = os.path.join(res.outdir, "own.tif")
            # Owner code -> seed / owner index (1-based), from the report's code table.
            owners = res.report["seeds"]["owners"]
            lut = np.zeros(max(o["code"] for o in owners) + 1, np.int64)
            for o in owners:
                lut[o["code"]] = int(o["label"]) if case.kind == "points" else case.owners.index(o["label"]) + 1
            res.lut = lut
            res.distance = os.path.join(res.outdir, "dist.tif")
            res.dist_scale = 1.0 / case.cell_m()
            res.dist_f32 = True
        return res

    # ---- in-process Python peers, each in a child of its own

    def pyworker(self, case, kind, tool, module):
        res = Result(case, tool, "raster (seed → its cell)",
                     "1" if kind == "scipy" else str(os.cpu_count()))
        res.outdir = os.path.join(case.dir, "out", kind)
        if not self.avail[module]:
            res.status = "skipped: not installed"
            return res
        if case.geographic:
            res.status = "n/a"
            res.note = "no geodesic metric (pixel distances on a lat/lon grid)"
            return res
        holder = {}

        def parse(out, err):
            line = [ln for ln in out.splitlines() if ln.startswith("WORKER ")][-1]
            holder.update(json.loads(line[7:]))
            return holder["compute_s"]

        self.repeat(case, res, lambda: [PY, os.path.abspath(__file__), "--worker", kind, case.raster, res.outdir],
                    parse)
        if res.status == "ok":
            res.distance = os.path.join(res.outdir, "distance.tif")
            res.dist_f32 = kind != "scipy"
            if kind != "opencv-precise":
                res.labels = os.path.join(res.outdir, "labels.tif")
            res.note = "compute = the transform alone"
        return res

    # ---- GDAL proximity (distance only)

    def gdal_proximity(self, case):
        res = Result(case, "GDAL gdal_proximity.py", "raster (seed → its cell)")
        res.outdir = os.path.join(case.dir, "out", "gdal_proximity")
        if not self.avail["gdal_proximity"]:
            res.status = "skipped: not installed"
            return res
        if case.geographic:
            res.status = "n/a"
            res.note = "no geodesic metric"
            return res
        self.repeat(case, res, lambda: ["gdal_proximity.py", "-q", case.raster, os.path.join(res.outdir, "distance.tif"),
                                        "-distunits", "PIXEL", "-ot", "Float64"], lambda o, e: None)
        if res.status == "ok":
            res.distance = os.path.join(res.outdir, "distance.tif")
            res.note = "distance only; no separate compute timing"
        return res

    # ---- GRASS r.grow.distance (distance and value)

    def grass(self, case):
        metric = "geodesic" if case.geographic else "euclidean"
        res = Result(case, f"GRASS r.grow.distance ({metric})", "raster (seed → its cell)")
        res.outdir = os.path.join(case.dir, "out", "grass")
        if not self.avail["grass"]:
            res.status = "skipped: not installed"
            return res
        script = os.path.join(case.dir, "grass_job.sh")
        # The timestamps around r.grow.distance separate the computation from GRASS's import
        # and export, which the whole command includes.
        with open(script, "w") as f:
            f.write(f"""set -euo pipefail
r.in.gdal -o --quiet input={shlex.quote(case.raster)} output=seeds
g.region raster=seeds
t0=$(date +%s.%N)
r.grow.distance --quiet input=seeds distance=dist value=val metric={metric}
t1=$(date +%s.%N)
echo "GRASS_COMPUTE $t0 $t1"
r.out.gdal --quiet input=dist output=distance.tif type=Float64
r.out.gdal --quiet -f input=val output=labels.tif type=Int32
""")
        epsg = 4326 if case.geographic else case.epsg

        def parse(out, err):
            m = re.search(r"GRASS_COMPUTE ([\d.]+) ([\d.]+)", out + err)
            return float(m.group(2)) - float(m.group(1)) if m else None

        self.repeat(case, res, lambda: ["grass", "--tmp-location", f"EPSG:{epsg}", "--exec", "bash", script], parse)
        if res.status == "ok":
            res.distance = os.path.join(res.outdir, "distance.tif")
            res.labels = os.path.join(res.outdir, "labels.tif")
            res.dist_scale = 1.0 / case.cell_m()
            res.note = "command includes a temporary location, import and export"
        return res

    # ---- SAGA Proximity Grid (distance and allocation)

    def saga(self, case):
        res = Result(case, "SAGA grid_tools 26 Proximity Grid", "raster (seed → its cell)", str(os.cpu_count()))
        res.outdir = os.path.join(case.dir, "out", "saga")
        if not self.avail["saga"]:
            res.status = "skipped: not installed"
            return res
        if case.geographic:
            res.status = "n/a"
            res.note = "no geodesic metric"
            return res

        def parse(out, err):
            m = re.search(r"total execution time: (\d+) millisecond", out + err)
            return int(m.group(1)) / 1e3 if m else None

        self.repeat(case, res, lambda: ["saga_cmd", "grid_tools", "26", "-FEATURES", case.raster,
                                        "-DISTANCE", os.path.join(res.outdir, "distance.tif"),
                                        "-ALLOCATION", os.path.join(res.outdir, "labels.tif")], parse)
        if res.status == "ok":
            res.distance = os.path.join(res.outdir, "distance.tif")
            res.labels = os.path.join(res.outdir, "labels.tif")
            res.dist_scale = 1.0 / case.cell_m()
            res.dist_f32 = True
            res.note = "writes Float32, LZW; compute = SAGA's own timer (whole seconds)"
        return res


# --------------------------------------------------------------------------------------------
# accuracy


def labels_of(r, r0, r1):
    lab = read_rows(r.labels, r0, r1, np.int64)
    if r.lut is not None:
        lab = r.lut[np.clip(lab, 0, len(r.lut) - 1)]
    return lab - 1


def evaluate_points(case, ref, results):
    """Point cases: true distances in float64 from the reference's nearest seed."""
    W, H = case.width, case.height
    chunk = max(1, 4_000_000 // W)
    acc = {id(r): [0, 0.0, 0, 0.0] for r in results}
    cx = np.arange(W, dtype=np.float64) + 0.5
    for r0 in range(0, H, chunk):
        r1 = min(H, r0 + chunk)
        cy = (np.arange(r0, r1, dtype=np.float64) + 0.5)[:, None]
        ref_i = labels_of(ref, r0, r1)
        if (ref_i < 0).any():
            raise SystemExit(f"peers: the reference leaves cells without a seed on {case.name}")
        dtrue = np.hypot(cx[None, :] - case.sx[ref_i], cy - case.sy[ref_i])
        for r in results:
            a = acc[id(r)]
            if r.labels:
                lab = labels_of(r, r0, r1)
                bad = (lab < 0) | (lab >= case.nseeds)
                lab = np.where(bad, 0, lab)
                dd = np.hypot(cx[None, :] - case.sx[lab], cy - case.sy[lab]) - dtrue
                dd = np.where(bad, np.inf, dd)
                w = dd > 1e-6
                a[0] += int(np.count_nonzero(w))
                if w.any():
                    a[1] = max(a[1], float(dd[w].max()))
            if r.distance:
                d = read_rows(r.distance, r0, r1, np.float64) * r.dist_scale
                err = np.abs(d - dtrue)
                tol = 1e-6 + (dtrue * OFFSETS_F32 * 2 if r.dist_f32 else 0)
                w = err > tol
                a[2] += int(np.count_nonzero(w))
                if w.any():
                    a[3] = max(a[3], float(err[w].max()))
    for r in results:
        a = acc[id(r)]
        if r.labels:
            r.wrong, r.max_dd = a[0], a[1]
        if r.distance:
            r.dwrong, r.max_derr = a[2], a[3]


def evaluate_owners(case, owner_dist, results):
    """Owner cases: per-owner reference distances (Float32 rasters, CRS units)."""
    W, H = case.width, case.height
    chunk = max(1, 2_000_000 // W)
    acc = {id(r): [0, 0.0, 0, 0.0] for r in results}
    scale = 1.0 / case.cell_m()
    for r0 in range(0, H, chunk):
        r1 = min(H, r0 + chunk)
        D = np.stack([read_rows(p, r0, r1, np.float64) * scale for p in owner_dist])  # owners x rows x cols
        dtrue = D.min(axis=0)
        # Both sides of a comparison are Float32-rounded: allow twice the rounding of each.
        tol_ref = 1e-6 + 4 * OFFSETS_F32 * dtrue
        for r in results:
            a = acc[id(r)]
            if r.labels:
                lab = labels_of(r, r0, r1)
                bad = (lab < 0) | (lab >= len(owner_dist))
                lab = np.where(bad, 0, lab)
                dd = np.take_along_axis(D, lab[None], 0)[0] - dtrue
                dd = np.where(bad, np.inf, dd)
                w = dd > tol_ref
                a[0] += int(np.count_nonzero(w))
                if w.any():
                    a[1] = max(a[1], float(dd[w].max()))
            if r.distance:
                d = read_rows(r.distance, r0, r1, np.float64) * r.dist_scale
                err = np.abs(d - dtrue)
                tol = tol_ref + (dtrue * OFFSETS_F32 * 2 if r.dist_f32 else 0)
                w = err > tol
                a[2] += int(np.count_nonzero(w))
                if w.any():
                    a[3] = max(a[3], float(err[w].max()))
    for r in results:
        a = acc[id(r)]
        if r.labels:
            r.wrong, r.max_dd = a[0], a[1]
        if r.distance:
            r.dwrong, r.max_derr = a[2], a[3]


# --------------------------------------------------------------------------------------------
# reporting


def machine():
    # The model name of a VM's CPU is often just the vendor's brand ("AMD EPYC"); family, model
    # and the widest vector set tell generations apart, and the last one picks the version of
    # rvoronoi's row kernels that runs (x86-64-v4 with AVX-512, else AVX2), which changes the
    # engine's speed more than the peers'.
    fields = {}
    with open("/proc/cpuinfo") as f:
        for ln in f:
            if not ln.strip():
                break  # the first processor is enough
            k, _, v = ln.partition(":")
            fields[k.strip()] = v.strip()
    flags = set(fields.get("flags", "").split())
    isa = "AVX-512" if "avx512f" in flags else ("AVX2, no AVX-512" if "avx2" in flags else "no AVX2")
    model = (f"{fields.get('model name', 'unknown')} (family {fields.get('cpu family', '?')}, "
             f"model {fields.get('model', '?')}, {isa})")
    with open("/proc/meminfo") as f:
        mem_kb = int(f.readline().split()[1])
    return model, os.cpu_count(), mem_kb / 1024 / 1024


def versions(avail):
    v = {}

    def cap(cmd):
        try:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
            return (r.stdout.strip() or r.stderr.strip())
        except Exception:  # a missing or broken tool just has no version line
            return ""

    v["rvoronoi"] = cap([ARGS.rvoronoi, "--version"]).splitlines()[0] if cap([ARGS.rvoronoi, "--version"]) else "?"
    v["GDAL"] = cap(["gdal-config", "--version"]) or cap([PY, "-c", "from osgeo import gdal; print(gdal.__version__)"])
    v["NumPy"] = np.__version__
    if avail["scipy"]:
        v["SciPy"] = cap([PY, "-c", "import scipy; print(scipy.__version__)"])
    if avail["cv2"]:
        v["OpenCV"] = cap([PY, "-c", "import cv2; print(cv2.__version__)"])
    if avail["grass"]:
        v["GRASS"] = (cap(["grass", "--version"]).splitlines() or ["?"])[0]
    if avail["saga"]:
        m = re.search(r"SAGA Version: (\S+)", cap(["saga_cmd", "--version"]))
        v["SAGA"] = m.group(1) if m else "?"
    return v


def fmt_s(x):
    if x is None:
        return "—"
    return f"{x:.3g}" if x < 100 else f"{x:.0f}"


def fmt_n(x):
    return "—" if x is None else (f"{x:,}" if isinstance(x, int) else f"{x:.3g}")


def table(case, results, exact):
    lines = []
    hdr = ("| tool | seeds as | threads | compute s | command s | × exact (compute / command) | peak RSS MiB "
           "| wrong owner cells | max Δd (cells) | distance cells off | max distance error (cells) | notes |")
    lines.append(hdr)
    lines.append("|" + "---|" * 12)
    for r in results:
        if r.status != "ok":
            st = r.status + (f" ({r.note})" if r.note else "")
            lines.append(f"| {r.tool} | {r.seeds_as} | {r.threads} | — | {fmt_s(r.command_s) if r.status.startswith('timeout') else '—'} "
                         f"| — | — | — | — | — | — | {st} |")
            continue
        ratio = "—"
        if exact is not None and exact.status == "ok":
            rc = f"{r.compute_s / exact.compute_s:.3g}" if r.compute_s and exact.compute_s else "—"
            ratio = f"{rc} / {r.command_s / exact.command_s:.3g}"
        if getattr(r, "acc_pending", False):
            acc = ["pending"] * 4
        else:
            acc = [fmt_n(r.wrong) if r.labels else "n/a (no labels)",
                   (f"{r.max_dd:.3g}" if r.wrong else "0") if r.labels else "—",
                   fmt_n(r.dwrong) if r.distance else "—",
                   (f"{r.max_derr:.3g}" if r.dwrong else "0") if r.distance else "—"]
        lines.append("| " + " | ".join([
            r.tool, r.seeds_as, r.threads, fmt_s(r.compute_s), fmt_s(r.command_s), ratio,
            f"{r.rss / 2**20:.0f}" if r.rss else "—", *acc, r.note]) + " |")
    return "\n".join(lines)


def streamed_phases(t):
    """How a streamed run's compute and write overlapped (empty for the whole-field path)."""
    st = t.get("streamed")
    if not st:
        return ""
    return (f" (streamed: {st['strips']} strips of {st['rows_per_strip']} rows, compute and write overlapped in "
            f"{st['wall']:.3g} s of wall time; the engine waited {st['compute_waited_for_writer']:.3g} s for the "
            f"writers, the writers (one thread per file, the longest wait) {st['writer_waited_for_compute']:.3g} s "
            f"for the engine)")


def goals(case, results, engine=(None, None)):
    """The issue's goals, checked against this run's numbers on its largest point case. `engine`:
    the engine alone in process (fresh, warm seconds), from engine_alone()."""
    by = {r.tool: r for r in results}
    ex, sp = by.get("rvoronoi exact"), by.get("SciPy distance_transform_edt (indices)")
    out = [f"\n## The goals, on the largest point case of this run ({case.title})\n"]
    if ex is None or ex.status != "ok":
        out.append("rvoronoi exact did not run.\n")
        return "\n".join(out)
    t = ex.report["timings_s"]
    writes = t["write"]["ownership"] + t["write"]["distance"]
    out.append(f"- rvoronoi exact: {ex.wrong:,} wrong cells; compute {ex.compute_s:.3g} s = "
               f"{ex.compute_s / case.cells * 1e9:.2f} ns per cell (goal: about 0.4 ns per cell at 1e8 cells "
               f"with 50 000 seeds on 2 cores).")
    st = t.get("streamed")
    if st:
        # The writers run side by side (one thread per file), so their times overlap each other
        # as well as the engine's: what encoding adds to the command is the overlapped phase's
        # wall time beyond the engine's own.
        extra = max(st["wall"] - ex.compute_s, 0.0)
        out.append(f"- The whole command: {ex.command_s:.3g} s, streamed in {st['strips']} strips of "
                   f"{st['rows_per_strip']} rows: the engine computed for {ex.compute_s:.3g} s "
                   f"({100 * ex.compute_s / ex.command_s:.0f} % of the command) while one writer thread per file "
                   f"encoded the GeoTIFFs side by side (ownership {t['write']['ownership']:.3g} s, distance "
                   f"{t['write']['distance']:.3g} s); the two overlapped in {st['wall']:.3g} s of wall time, so "
                   f"encoding kept the command going {extra:.3g} s beyond the computation "
                   f"({100 * extra / ex.command_s:.0f} % of the command); reading the seeds took {t['read']:.3g} s "
                   f"(goal: not dominated by encoding).")
    else:
        out.append(f"- The whole command: {ex.command_s:.3g} s, of which GeoTIFF writing (ownership + distance) "
                   f"{writes:.3g} s = {100 * writes / ex.command_s:.0f} % and the computation "
                   f"{100 * ex.compute_s / ex.command_s:.0f} % (goal: not dominated by encoding).")
    if sp is not None and sp.status == "ok":
        out.append(f"- SciPy's exact transform: compute {sp.compute_s:.3g} s, command {sp.command_s:.3g} s; "
                   f"rvoronoi exact is {sp.compute_s / ex.compute_s:.0f}× faster in computation and "
                   f"{sp.command_s / ex.command_s:.2g}× in the whole command (goal: at least 100×, and exact). "
                   f"SciPy's answer, measured to cell centres, has {sp.wrong:,} wrong cells (max Δd "
                   f"{sp.max_dd or 0:.3g} cells).")
        fresh, warm = engine
        if warm:
            out.append(f"- The engine alone, in process with nothing else running (as SciPy's transform is timed): "
                       f"{warm:.3g} s into reused buffers, {sp.compute_s / warm:.0f}× SciPy's compute; "
                       f"{fresh:.3g} s into fresh ones (the first touch of {case.cells * 8 / 1e6:.0f} MB of "
                       f"result pages included), {sp.compute_s / fresh:.0f}×. In the command the engine "
                       f"shares the 2 cores with the GeoTIFF encoders, hence the slower compute above.")
    elif sp is not None:
        out.append(f"- SciPy: {sp.status} {sp.note}")
    out.append("- The paper's horizontal + vertical scan took 199.7 s for 10000×10000 with 50 000 seeds on an "
               "i5-3337U (2013, one thread); see the hv-scan row above for this machine.\n")
    return "\n".join(out)


# --------------------------------------------------------------------------------------------
# profile of the engine on the largest case


def owner_of(frames):
    """Which part of the program a sample belongs to: the first user frame that is not libc's,
    the loader's or libstdc++'s (so memset/memcpy and kernel page faults are charged to the code
    that called them; the kernel's frames only say how)."""
    for ip, sym, dso in frames:
        if dso.startswith("[kernel") or dso == "[unknown]":
            continue
        base = os.path.basename(dso)
        if base.startswith("ld-linux"):
            return "process start-up (dynamic loader: GDAL and its libraries)"
        if base.startswith(("libc.so", "libc-", "libstdc++", "libm.so", "libgcc", "libpthread")):
            continue
        if "zstd" in base or base.startswith(("libz.", "libdeflate", "liblzma", "libjpeg", "liblerc")):
            return "GeoTIFF compression (" + base.split(".so")[0] + ")"
        if base.startswith(("libtiff", "libgdal", "libgeotiff")):
            return "GDAL / libtiff (encoding, I/O)"
        if base.startswith("libproj"):
            return "PROJ (reprojection)"
        if base.startswith(("libsqlite", "libgeos", "libspatialite", "libexpat", "libjson")):
            return "GDAL/OGR reading the seeds"
        if base == "rvoronoi" or base.startswith("librv"):
            if re.search(r"Exact|argmin|solve|Solver|brute|scan|Scan|cull|bound", sym):
                return "engine: exact computation"
            if re.search(r"write|Write|tile|Tile|raster_io|GeoTiff", sym):
                return "rvoronoi: handing tiles to GDAL"
            if re.search(r"read|Read|load|Load|seed|Seed|ogr|OGR", sym):
                return "rvoronoi: reading the seeds"
            return "rvoronoi: other (" + sym[:40] + ")"
        return "other (" + base + ")"
    return "unattributed (no user caller in the call chain)"


def profile(runner, case, md):
    """perf record of one rvoronoi exact command on `case`; charges the samples to who asked."""
    if shutil.which("perf") is None:
        md.append("perf is not installed: no profile.\n")
        return
    outdir = os.path.join(case.dir, "out", "perf")
    os.makedirs(outdir, exist_ok=True)
    data = os.path.join(outdir, "perf.data")
    cmd = ["perf", "record", "-g", "-o", data, "--"] + rvoronoi_cmd(runner.exe, case, "exact", outdir)
    rc, wall, rss, out, err = run_child(cmd, runner.args.timeout, cwd=outdir)
    if rc != 0:
        md.append(f"perf record failed (exit {rc}): {err.strip()[-300:]}\n")
        return
    with open(os.path.join(outdir, "report.json")) as f:
        rep = json.load(f)
    script = subprocess.run(["perf", "script", "-i", data, "-F", "comm,tid,ip,sym,dso"], capture_output=True,
                            text=True, errors="replace").stdout
    # Samples are blank-line separated: a header line, then frames "ip sym (dso)", leaf first.
    table_ = {}
    leaves = {}
    total = 0
    for block in script.split("\n\n"):
        lines = [ln for ln in block.splitlines() if ln.strip()]
        if len(lines) < 2:
            continue
        frames = []
        for ln in lines[1:]:
            m = re.match(r"\s*([0-9a-f]+)\s+(.*)\s+\((.*)\)\s*$", ln)
            if m:
                frames.append((m.group(1), m.group(2), m.group(3)))
        if not frames:
            continue
        total += 1
        who = owner_of(frames)
        leaf_sym, leaf_dso = frames[0][1], frames[0][2]
        if leaf_dso.startswith("[kernel"):
            syms = " ".join(f[1] for f in frames if f[2].startswith("[kernel"))
            if re.search(r"clear_page|folio_zero|clear_huge", syms):
                how = "kernel: zeroing fresh pages"
            elif "page_fault" in syms:
                how = "kernel: other page-fault work"
            else:
                how = "kernel: other (syscalls, I/O)"
        else:
            how = "user"
        row = table_.setdefault(who, {})
        row[how] = row.get(how, 0) + 1
        key = (leaf_sym if leaf_sym != "[unknown]" else "[unknown]", os.path.basename(leaf_dso))
        leaves[key] = leaves.get(key, 0) + 1
    hows = ["user", "kernel: zeroing fresh pages", "kernel: other page-fault work", "kernel: other (syscalls, I/O)"]
    t = rep["timings_s"]
    md.append(f"Command: `{' '.join(shlex.quote(str(a)) for a in cmd)}` — wall {wall:.2f} s under perf "
              f"(both threads' samples: {total:,}), peak RSS {rss / 2**20:.0f} MiB.\n")
    md.append(f"rvoronoi's own phase timings in that run: read {t['read']:.3f} s, compute {t['compute']:.3f} s "
              f"({t['compute'] / case.cells * 1e9:.2f} ns/cell), write ownership {t['write']['ownership']:.3f} s, "
              f"write distance {t['write']['distance']:.3f} s{streamed_phases(t)}, total {t['total']:.3f} s.\n")
    md.append("Samples charged to the code that caused them (its first frame outside libc; kernel samples to the "
              "user code whose page fault or system call they serve), % of all samples:\n")
    md.append("| part of the command | " + " | ".join(hows) + " | total |\n|---|" + "---|" * (len(hows) + 1))
    for who, row in sorted(table_.items(), key=lambda kv: -sum(kv[1].values())):
        tot = sum(row.values())
        if tot / max(total, 1) < 0.002:
            continue
        md.append(f"| {who} | " + " | ".join(f"{100 * row.get(h, 0) / total:.1f}" for h in hows)
                  + f" | {100 * tot / total:.1f} |")
    sums = [sum(r.get(h, 0) for r in table_.values()) for h in hows]
    md.append("| **all** | " + " | ".join(f"**{100 * v / max(total, 1):.1f}**" for v in sums) + " | 100 |\n")
    md.append("Top leaf functions (self time; libzstd has no symbols in Debian's package):\n")
    md.append("| % | function | library |\n|---|---|---|")
    for (sym, dso), n in sorted(leaves.items(), key=lambda kv: -kv[1])[:12]:
        md.append(f"| {100 * n / total:.1f} | `{sym[:80]}` | {dso} |")
    md.append("")
    encoding_options(case, outdir, md)


def engine_alone(args, case):
    """The engine alone, in process: fresh result buffers versus buffers reused (compute_into).
    Returns (markdown lines, fresh seconds, warm seconds); the seconds are None when it did not run."""
    exe = args.engine_bench
    if not os.access(exe, os.X_OK):
        return [f"engine_bench not found at {exe}: no in-process measurement.\n"], None, None
    repeats = "1" if args.quick else "5"
    cmd = [exe, "--methods", "exact", "--warm", "--repeats", repeats, "--min-cells", str(case.cells), "--max-cells",
           str(case.cells)]
    rc, wall, rss, out, err = run_child(cmd, args.timeout, cwd=os.path.join(case.dir))
    lines = ["The engine alone, in process (`" + " ".join(cmd[1:]) + "`; its own random seeds of the same "
             "count and grid, nothing else running in the process): fresh result rasters, then "
             "`compute_into()` into the same buffers again; medians of the repeats.\n",
             out.strip() if rc == 0 else f"engine_bench failed (exit {rc}): {err.strip()[-300:]}", ""]
    fresh = warm = None
    for row in out.splitlines():
        cols = [c.strip() for c in row.split("|")]
        if rc == 0 and len(cols) > 7 and cols[3] == "exact":
            try:
                fresh, warm = float(cols[4]) / 1e3, float(cols[6]) / 1e3
            except ValueError:
                pass
    return lines, fresh, warm


def encoding_options(case, outdir, md):
    """How much of the write is the codec: the same distance raster re-encoded with GDAL under
    other creation options (all threads, 256 x 256 tiles like rvoronoi's writer)."""
    from osgeo import gdal

    src = os.path.join(outdir, "dist.tif")
    if not os.path.exists(src):
        return
    mem = gdal.Translate("", src, format="MEM")  # decode once, outside the timings
    variants = [
        ("ZSTD, PREDICTOR=3, ZSTD_LEVEL=9 (GDAL's default level)", ["COMPRESS=ZSTD", "PREDICTOR=3", "ZSTD_LEVEL=9"]),
        ("ZSTD, PREDICTOR=3, ZSTD_LEVEL=1", ["COMPRESS=ZSTD", "PREDICTOR=3", "ZSTD_LEVEL=1"]),
        ("ZSTD, no predictor, ZSTD_LEVEL=1 (rvoronoi's default before the sixteenth session)",
         ["COMPRESS=ZSTD", "ZSTD_LEVEL=1"]),
        ("DEFLATE, PREDICTOR=3, ZLEVEL=1", ["COMPRESS=DEFLATE", "PREDICTOR=3", "ZLEVEL=1"]),
        ("LZW, PREDICTOR=3", ["COMPRESS=LZW", "PREDICTOR=3"]),
        ("uncompressed (rvoronoi's default, --compression fast)", ["COMPRESS=NONE"]),
    ]
    md.append("Re-encoding rvoronoi's Float32 distance raster of this case with GDAL (CreateCopy from memory, "
              "TILED=YES, 256×256, NUM_THREADS=ALL_CPUS), to see what the codec costs:\n")
    md.append("| creation options | seconds | MiB on disk |\n|---|---|---|")
    for name, co in variants:
        dst = os.path.join(outdir, "reencode.tif")
        t0 = time.perf_counter()
        ds = gdal.GetDriverByName("GTiff").CreateCopy(
            dst, mem, options=co + ["TILED=YES", "BLOCKXSIZE=256", "BLOCKYSIZE=256", "NUM_THREADS=ALL_CPUS",
                                    "BIGTIFF=IF_SAFER"])
        ds = None
        dt = time.perf_counter() - t0
        md.append(f"| {name} | {dt:.2f} | {os.path.getsize(dst) / 2**20:.1f} |")
        os.remove(dst)
    md.append("")


# --------------------------------------------------------------------------------------------


def main():
    global ARGS
    # The distance by sea has its own cases, tools and measures (bench/peers_sea.py).
    if "--sea" in sys.argv[1:]:
        import peers_sea
        return peers_sea.main([a for a in sys.argv[1:] if a != "--sea"])
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="small sizes (about a minute): the CI smoke test")
    ap.add_argument("--out", default=None, help="work folder (default: build/bench-peers[-quick])")
    ap.add_argument("--results", default=None, help="markdown file (default: bench/RESULTS.md, quick: OUT/RESULTS.md)")
    ap.add_argument("--rvoronoi", default=os.path.join(ROOT, "build", "service", "rvoronoi"))
    ap.add_argument("--timeout", type=float, default=600, help="per command, seconds")
    ap.add_argument("--repeats", type=int, default=None, help="repeats per command on grids up to 1e6 cells")
    ap.add_argument("--max-cells", type=float, default=1e8, help="skip point cases above this many cells")
    ap.add_argument("--cases", default=None, help="comma-separated case names to run (default: all)")
    ap.add_argument("--tools", default=None,
                    help="comma-separated rows besides rvoronoi exact (default: all): rvoronoi-whole, "
                         "rvoronoi-1thread, hv-scan, scipy, opencv, gdal, grass, saga")
    ap.add_argument("--geodesic-reference", default=os.path.join(ROOT, "build", "bench", "geodesic_reference"),
                    help="tool giving geodesic reference distances while the CLI refuses the metric")
    ap.add_argument("--engine-bench", default=os.path.join(ROOT, "build", "bench", "engine_bench"),
                    help="in-process engine benchmark (for --profile: fresh versus reused buffers)")
    ap.add_argument("--profile", action="store_true", help="perf profile of rvoronoi exact on the largest case")
    ap.add_argument("--keep", action="store_true", help="keep the rasters written (default: delete per case)")
    ap.add_argument("--worker", nargs=3, metavar=("KIND", "SEEDS_TIF", "OUTDIR"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    ARGS = args
    if args.worker:
        worker(*args.worker)
        return 0
    if args.repeats is None:
        args.repeats = 1 if args.quick else 3
    work = os.path.abspath(args.out or os.path.join(ROOT, "build", "bench-peers-quick" if args.quick else "bench-peers"))
    os.makedirs(work, exist_ok=True)
    results_md = args.results or (os.path.join(work, "RESULTS.md") if args.quick else os.path.join(HERE, "RESULTS.md"))
    if not os.access(args.rvoronoi, os.X_OK):
        log(f"peers: rvoronoi not found at {args.rvoronoi} (build it, or pass --rvoronoi)")
        return 2
    runner = Runner(args)
    started = datetime.datetime.now(datetime.timezone.utc)
    oresund = os.path.join(ROOT, "fixtures", "oresund.gpkg")

    # Case list: the paper's Table 1 rows, the Øresund coastline projected, and the same on a
    # geographic grid.
    sizes = TABLE1[:2] if args.quick else TABLE1
    specs = [("points", s, n) for s, n in sizes if s * s <= args.max_cells]
    if not os.path.exists(oresund):
        log(f"peers: {oresund} not found (the repository's fixtures/ is incomplete)")
        return 2
    coast_src = (oresund, "states", "iso2", "Øresund coastline (DK/SE MultiPolygons)")
    specs.append(("coast", 500.0 if args.quick else 100.0))
    specs.append(("geo", 0.01 if args.quick else 0.002))
    wanted = set(args.cases.split(",")) if args.cases else None

    md = []
    model, ncpu, mem_gib = machine()
    md.append("# rvoronoi and its peers, side by side\n")
    md.append(f"Generated by `bench/peers.py` on {started:%Y-%m-%d %H:%M} UTC. Machine: {model}, {ncpu} cores, "
              f"{mem_gib:.1f} GiB memory ({platform.platform()}).\n")
    md.append("Command line: `" + " ".join(shlex.quote(a) for a in [sys.argv[0]] + sys.argv[1:]) + "`\n")
    # Which source the measured binary was built from (the tree at run time; the binary may be older).
    rev = subprocess.run(["git", "-C", ROOT, "describe", "--always", "--dirty"], capture_output=True, text=True)
    md.append(f"Source tree at run time: `{rev.stdout.strip() or 'unknown'}`; rvoronoi binary "
              f"`{args.rvoronoi}` built {datetime.datetime.fromtimestamp(os.path.getmtime(args.rvoronoi), datetime.timezone.utc):%Y-%m-%d %H:%M} UTC.\n")
    md.append("Versions: " + ", ".join(f"{k} {v}" for k, v in versions(runner.avail).items()) + ".\n")
    md.append(open(os.path.join(HERE, "peers_legend.md")).read())
    exact_failed = []
    largest = None
    largest_results = []
    for spec in specs:
        if spec[0] == "points":
            name = f"pts{spec[1]}x{spec[2]}"
        else:
            name = spec[0]
        if wanted and name not in wanted:
            continue
        t_case = time.perf_counter()
        load_start = os.getloadavg()[0]
        if spec[0] == "points":
            case = make_points_case(spec[1], spec[2], work)
        elif spec[0] == "coast":
            case = make_owner_case("coast", f"{coast_src[3]}, EPSG:{UTM}, {spec[1]:g} m cells",
                                   coast_src[0], coast_src[1], coast_src[2], UTM, spec[1], work)
        else:
            case = make_owner_case("geo", f"Øresund on a geographic grid (EPSG:4326), {spec[1]:g}° cells, geodesic",
                                   oresund, "states", "iso2", 4326, spec[1], work)
        log(f"peers: case {case.name}: {case.width}x{case.height} cells, {case.nseeds} seeds")
        results = []
        # Brute force is the reference where it is affordable: cells x seeds up to 2e9 on planar
        # grids. Geodesic brute force costs ~100x the exact method per cell (GeographicLib inverse
        # problems against every segment), so geographic grids always use exact.
        small = case.cells * max(case.nseeds, 1) <= 2e9 and not case.geographic
        if case.kind == "points":
            # Reference: brute force where affordable, else exact (exact == brute force is a test).
            ref = runner.rvoronoi(case, "brute-force" if small else "exact",
                                  label="rvoronoi brute-force (reference)" if small else "rvoronoi exact (reference run)")
            if ref.status != "ok":
                raise SystemExit(f"peers: the reference run failed on {case.name}: {ref.status} {ref.note}")
            if small:
                results.append(ref)
        else:
            # Reference: one distance raster per owner. On the geographic grid rvoronoi's default
            # metric is geodesic; while that is not in the build, the case is wired but pending.
            owner_dist = []
            for i, p in enumerate(case.owner_vectors):
                od = os.path.join(case.dir, "out", f"ref_owner{i + 1}")
                os.makedirs(od, exist_ok=True)
                cmd = rvoronoi_cmd(runner.exe, case, "brute-force" if small else "exact", od, owner_vector=p)
                rc, wall, rss, out, err = run_child(cmd, args.timeout, cwd=od)
                if rc != 0:
                    if case.geographic and "geodesic" in (err + out):
                        case.pending = "rvoronoi compute refuses the geodesic metric in this build: " + err.strip().splitlines()[-1]
                        break
                    raise SystemExit(f"peers: reference run failed on {case.name}: {err.strip()}")
                owner_dist.append(os.path.join(od, "dist.tif"))
            if case.pending:
                # The engine has the geodesic metric even where the CLI refuses it: take the
                # reference from it (exact, which the geodesic tests assert equal to brute force)
                # so that the peers' geodesic answers can still be measured.
                owner_dist = []
                tool = args.geodesic_reference
                if os.access(tool, os.X_OK):
                    for i, p in enumerate(case.owner_vectors):
                        od = os.path.join(case.dir, "out", f"ref_owner{i + 1}")
                        os.makedirs(od, exist_ok=True)
                        path = os.path.join(od, "dist_geodesic.tif")
                        rc, wall, rss, out, err = run_child(
                            [tool, p, repr(case.xmin), repr(case.ymax), repr(case.res), str(case.width),
                             str(case.height), "exact", path], args.timeout, cwd=od)
                        if rc != 0:
                            raise SystemExit(f"peers: geodesic_reference failed on {case.name}: {err.strip()}")
                        owner_dist.append(path)
                    case.ref_note = ("reference: one geodesic distance raster per owner from the engine's exact "
                                     "method (equal to brute force, asserted by the geodesic tests) through "
                                     "bench/geodesic_reference, since the CLI refuses the metric")
            if not case.pending:
                if small:
                    results.append(runner.rvoronoi(case, "brute-force", label="rvoronoi brute-force (reference)"))
        exact = runner.rvoronoi(case, "exact")
        results.append(exact)
        # --tools: a subset of the rows (rvoronoi exact always runs: every ratio is to it).
        def want(key):
            return args.tools is None or key in args.tools.split(",")
        if want("rvoronoi-whole"):
            results.append(runner.rvoronoi(case, "exact", label="rvoronoi exact (whole field, not streamed)",
                                           extra=("--strip-rows", "-1")))
        if want("rvoronoi-1thread"):
            results.append(runner.rvoronoi(case, "exact", threads=1, label="rvoronoi exact (1 thread)"))
        if want("hv-scan"):
            results.append(runner.rvoronoi(case, "hv-scan", label="rvoronoi hv-scan (the paper)"))
        if want("scipy"):
            results.append(runner.pyworker(case, "scipy", "SciPy distance_transform_edt (indices)", "scipy"))
        if want("opencv"):
            results.append(runner.pyworker(case, "opencv-labels", "OpenCV distanceTransformWithLabels (L2, 5×5, pixel labels)", "cv2"))
            results.append(runner.pyworker(case, "opencv-precise", "OpenCV distanceTransform (L2, MASK_PRECISE)", "cv2"))
        if want("gdal"):
            results.append(runner.gdal_proximity(case))
        if want("grass"):
            results.append(runner.grass(case))
        if want("saga"):
            results.append(runner.saga(case))
        measured = [r for r in results if r.status == "ok"]
        if case.kind == "points":
            evaluate_points(case, ref, measured)
        elif owner_dist:
            evaluate_owners(case, owner_dist, measured)
        else:
            for r in measured:
                r.note = (r.note + "; " if r.note else "") + "accuracy pending: no geodesic reference yet"
                r.labels = r.distance = None
                r.acc_pending = True
        if exact.status == "ok" and exact.wrong:
            exact_failed.append(case.name)
        for r in results:
            if r.status == "failed":
                runner.failed.append(f"{case.name}: {r.tool}: {r.note}")
        # Per-case section.
        sec = [f"\n## {case.title}\n",
               f"Grid {case.width} × {case.height} = {case.cells:,} cells, cell {case.res:g} "
               f"{'degrees' if case.geographic else 'm'}; extent {' '.join(f'{v:.10g}' for v in case.extent)}."]
        if case.kind == "points":
            sec.append(f" {case.nseeds:,} seeds; rasterised, {case.burnt:,} distinct cells hold a seed. Reference: "
                       f"rvoronoi {'brute-force' if small else 'exact'}.")
        else:
            sec.append(f" Owners {', '.join(case.owners)}; "
                       + (getattr(case, "ref_note", "") or f"reference: one rvoronoi {'brute-force' if small else 'exact'}"
                          " distance raster per owner") + "."
                       + (" Δd and distance errors in cells of " + f"{case.cell_m():.1f} m (the north-south size of a cell)."
                          if case.geographic else ""))
        sec.append("\n")
        sec.append(table(case, results, exact))
        if exact.status == "ok" and getattr(exact, "cmdline", None):
            sec.append(f"\nrvoronoi exact command: `{exact.cmdline}`")
            rep = exact.report
            t = rep["timings_s"]
            sec.append(f"; phases: read {t['read']:.3g} s, compute {t['compute']:.3g} s "
                       f"({t['compute'] / case.cells * 1e9:.2f} ns/cell), write ownership {t['write']['ownership']:.3g} s, "
                       f"distance {t['write']['distance']:.3g} s{streamed_phases(t)}, total {t['total']:.3g} s.\n")
        sec.append(f"\nCase wall time, everything included: {time.perf_counter() - t_case:.0f} s. Load average "
                   f"(1 min) at the start and end of the case: {load_start:.2f}, {os.getloadavg()[0]:.2f} "
                   f"(the machine's {os.cpu_count()} cores are shared; other work inflates the timings).\n")
        text = "\n".join(sec)
        print(text, flush=True)
        md.append(text)
        if case.kind == "points" and (largest is None or case.cells > largest.cells):
            largest = case
            largest_results = results
        if not args.keep and not (args.profile and case is largest):
            shutil.rmtree(os.path.join(case.dir, "out"), ignore_errors=True)
            for f in ("seeds.tif",):
                p = os.path.join(case.dir, f)
                if os.path.exists(p) and case.kind == "points":
                    os.remove(p)
    engine_md, engine_fresh, engine_warm = [], None, None
    if largest is not None:
        engine_md, engine_fresh, engine_warm = engine_alone(args, largest)
        md.append(goals(largest, largest_results, (engine_fresh, engine_warm)))
    if args.profile and largest is not None:
        md.append(f"\n## Where the time goes: rvoronoi exact on the largest case ({largest.title})\n")
        profile(runner, largest, md)
        if not args.keep:
            shutil.rmtree(os.path.join(largest.dir, "out"), ignore_errors=True)
    md.extend(engine_md)
    md.append(f"\nTotal run: {(datetime.datetime.now(datetime.timezone.utc) - started).total_seconds():.0f} s.\n")
    with open(results_md, "w") as f:
        f.write("\n".join(md))
    log(f"peers: wrote {results_md}")
    status = 0
    if exact_failed:
        log("peers: FAIL: rvoronoi exact has wrong cells on " + ", ".join(exact_failed))
        status = 1
    if runner.failed:
        for f in runner.failed:
            log("peers: tool failed: " + f)
        if args.quick:
            status = 1
    return status


ARGS = None

if __name__ == "__main__":
    sys.exit(main())
