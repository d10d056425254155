#!/usr/bin/env python3
"""What GeoTIFF encoding costs in `rvoronoi compute` (issue 7): the whole command per compression
profile, against a baseline binary, and a survey of codec levels on the same rasters.

    /usr/bin/python3 bench/encoding.py --seeds SEEDS.geojson --before OLD/rvoronoi --after build/service/rvoronoi \\
        [--repeats 3] [--out DIR] [--survey] > bench/RESULTS-encoding.md

Command table: each configuration (the baseline binary with its defaults, then the new binary
with every --compression profile) runs --repeats times, round-robin (configuration after
configuration, then again), so that a change in the machine's load hits every row alike. Each
cell is the median over the repeats of the report's timings (seconds; "engine waited" is
timings_s.streamed.compute_waited_for_writer, the computing thread idle because both strip
buffers were still being encoded), the files' sizes and the command's peak RSS (GNU time -f %M). The grid is the 1e8-cell case of bench/RESULTS.md: 10000 x
10000 cells of 1 m, one owner per seed point (--owner-field id).

Debian's /usr/bin/python3: python3-gdal is installed for it (bench/peers.sh says the same).

Survey (--survey): the uncompressed rasters the `none` profile wrote, re-encoded by GDAL on one
thread (NUM_THREADS=1, CPU seconds of this process, so that the load of other processes matters
little) with 256 x 256 tiles like rvoronoi's writer, for codec, level and predictor choices.
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time

GRID = ["--resolution", "1.0", "--extent", "400000.0", "6100000.0", "410000.0", "6110000.0", "--method", "exact",
        "--owner-field", "id", "--quiet"]


def run_once(binary, seeds, extra, outdir):
    os.makedirs(outdir, exist_ok=True)
    own, dist, rep = (os.path.join(outdir, n) for n in ("own.tif", "dist.tif", "r.json"))
    for f in (own, own + ".aux.xml", dist, rep):
        if os.path.exists(f):
            os.remove(f)
    tfile = os.path.join(outdir, "time.txt")
    cmd = ["/usr/bin/time", "-f", "%M", "-o", tfile, binary, "compute", seeds, *GRID, "--ownership", own,
           "--distance", dist, "--report", rep, *extra]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    r = json.load(open(rep))
    t = r["timings_s"]
    return {"wall": wall, "total": t["total"], "read": t["read"], "compute": t["compute"],
            "write_own": t["write"]["ownership"], "write_dist": t["write"]["distance"],
            "waited": t["streamed"]["compute_waited_for_writer"],
            "own_mb": os.path.getsize(own) / 1e6, "dist_mb": os.path.getsize(dist) / 1e6,
            "rss_mib": int(open(tfile).read().split()[-1]) / 1024.0, "own_type": raster_type(own)}


def raster_type(path):
    from osgeo import gdal

    ds = gdal.Open(path)
    return gdal.GetDataTypeName(ds.GetRasterBand(1).DataType)


def command_table(args):
    configs = [("before (main)", args.before, [])]
    configs += [(f"after, --compression {p}", args.after, ["--compression", p]) for p in args.profiles]
    runs = {name: [] for name, _, _ in configs}
    loads = []
    for k in range(args.repeats):
        loads.append(os.getloadavg()[0])
        for i, (name, binary, extra) in enumerate(configs):
            runs[name].append(run_once(binary, args.seeds, extra, os.path.join(args.out, f"cfg{i}")))
            print(f"repeat {k + 1}: {name}: {runs[name][-1]}", file=sys.stderr)
    out = ["| configuration | total s | read s | compute s | engine waited s | write own s | write dist s "
           "| ownership MB (type) | distance MB | peak RSS MiB |", "|---|---|---|---|---|---|---|---|---|---|"]
    for name, _, _ in configs:
        rs = runs[name]
        med = {k: statistics.median(r[k] for r in rs) for k in rs[0] if k != "own_type"}
        out.append(f"| {name} | {med['total']:.2f} | {med['read']:.2f} | {med['compute']:.2f} | {med['waited']:.2f} "
                   f"| {med['write_own']:.2f} "
                   f"| {med['write_dist']:.2f} | {med['own_mb']:.1f} ({rs[0]['own_type']}) | {med['dist_mb']:.1f} "
                   f"| {med['rss_mib']:.0f} |")
    spread = ["| configuration | total s of each repeat |", "|---|---|"]
    for name, _, _ in configs:
        totals = ", ".join(f"{r['total']:.2f}" for r in runs[name])
        spread.append(f"| {name} | {totals} |")
    return out, spread, loads


def cpu_seconds():
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


def survey(args):
    """Re-encodes the rasters of the `none` profile's last run."""
    from osgeo import gdal

    gdal.UseExceptions()
    src_dir = os.path.join(args.out, f"cfg{1 + args.profiles.index('none')}")
    out = []
    for name, variants in (
            ("dist.tif", [("ZSTD", 1, 1), ("ZSTD", 1, 3), ("ZSTD", 3, 3), ("ZSTD", 6, 3), ("ZSTD", 9, 3),
                          ("ZSTD", 12, 3), ("ZSTD", 6, 1), ("DEFLATE", 1, 1), ("DEFLATE", 1, 3), ("DEFLATE", 6, 3),
                          ("DEFLATE", 9, 3), ("NONE", 0, 1)]),
            ("own.tif", [("ZSTD", 1, 2), ("ZSTD", 6, 2), ("ZSTD", 9, 2), ("ZSTD", 1, 1), ("ZSTD", 6, 1),
                         ("DEFLATE", 1, 2), ("DEFLATE", 1, 1), ("DEFLATE", 6, 2), ("NONE", 0, 1)])):
        mem = gdal.Translate("", os.path.join(src_dir, name), format="MEM")  # decoded outside the timings
        dtype = gdal.GetDataTypeName(mem.GetRasterBand(1).DataType)
        out.append(f"\n`{name}` ({dtype}, {mem.RasterXSize} x {mem.RasterYSize}) re-encoded on one thread:\n")
        out.append("| codec | level | predictor | CPU s | MB on disk |\n|---|---|---|---|---|")
        for codec, level, predictor in variants:
            co = ["TILED=YES", "BLOCKXSIZE=256", "BLOCKYSIZE=256", "NUM_THREADS=1", "BIGTIFF=IF_SAFER",
                  f"COMPRESS={codec}"]
            if codec == "ZSTD":
                co.append(f"ZSTD_LEVEL={level}")
            if codec == "DEFLATE":
                co.append(f"ZLEVEL={level}")
            if predictor != 1:
                co.append(f"PREDICTOR={predictor}")
            dst = os.path.join(args.out, "survey.tif")
            times = []
            for _ in range(args.survey_repeats):
                c0 = cpu_seconds()
                ds = gdal.GetDriverByName("GTiff").CreateCopy(dst, mem, options=co)
                ds = None  # closing flushes the last tiles and the directory
                times.append(cpu_seconds() - c0)
            size = os.path.getsize(dst) / 1e6
            os.remove(dst)
            out.append(f"| {codec} | {level if codec != 'NONE' else '-'} | {predictor} | "
                       f"{statistics.median(times):.2f} | {size:.1f} |")
        mem = None
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", required=True)
    ap.add_argument("--before", required=True, help="baseline rvoronoi (no --compression option)")
    ap.add_argument("--after", required=True)
    ap.add_argument("--profiles", default="fast,small,deflate,none")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default="/tmp/rv-encoding")
    ap.add_argument("--survey", action="store_true")
    ap.add_argument("--survey-repeats", type=int, default=3)
    args = ap.parse_args()
    args.profiles = args.profiles.split(",")
    if args.survey and "none" not in args.profiles:
        ap.error("--survey re-encodes the rasters of the 'none' profile: keep it in --profiles")
    table, spread, loads = command_table(args)
    print("\n".join(table))
    print("\nTotals of each repeat (the spread behind the medians):\n")
    print("\n".join(spread))
    print(f"\n1-minute load average before each round: {', '.join(f'{x:.2f}' for x in loads)}; "
          f"{os.cpu_count()} cores.")
    if args.survey:
        print("\n".join(survey(args)))


if __name__ == "__main__":
    main()
