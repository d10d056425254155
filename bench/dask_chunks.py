#!/usr/bin/env python3
"""Grids beyond one process: the Python module's chunks on Dask workers against the CLI (issue 33).

    PYTHONPATH=build/python /usr/bin/python3 bench/dask_chunks.py --binary build/service/rvoronoi \
        [--rows 25000 --cols 40000] [--seeds 50000] [--chunk 4096] [--repeats 2] [--work DIR] > table.md

The case: ROWS x COLS cells of 1 m (default 1e9), SEEDS random points, one owner each (the
1e8-cell case of bench/RESULTS.md, ten times the cells). Four measurements, each alternated
--repeats times with the others it is compared with, medians quoted:

1. The CLI's streamed run of the grid (ownership + distance GeoTIFFs, `--no-edit-base`), wall.
2. The same grid through a LocalCluster of two worker processes (one thread each, engine threads 1
   per chunk: the two cores), chunks of CHUNK x CHUNK: (a) computed and reduced on the workers
   (owner and distance summed: the engine's work and Dask's, no file), (b) written to a Zarr store
   straight from the chunks (the result bigger than one worker's memory). Wall, and each worker's
   peak resident memory (ru_maxrss of the worker process).
3. Per-chunk overhead: a 1e8-cell part of the grid reduced on the cluster with chunk sides from
   4096 down to 128: wall against the largest chunk's; the smallest side whose overhead stays under
   10 % is the one to use.
4. What a 1.3e10-cell global grid would take on N such machines, from (2a)'s cells per second.
"""
import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time

X0, Y0, EPSG = 400000.0, 6100000.0, 32633


def write_points(path, n, rows, cols, seed=1):
    import numpy as np
    rng = np.random.default_rng(seed)
    xs = rng.uniform(X0, X0 + cols, n)
    ys = rng.uniform(Y0, Y0 + rows, n)
    with open(path, "w") as f:
        f.write('{"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::%d"}},'
                '"features":[\n' % EPSG)
        f.write(",\n".join('{"type":"Feature","properties":{"id":%d},"geometry":{"type":"Point","coordinates":[%r,%r]}}'
                           % (i, float(x), float(y)) for i, (x, y) in enumerate(zip(xs, ys))))
        f.write("]}\n")


def peak_rss():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--binary", required=True)
    ap.add_argument("--rows", type=int, default=25000)
    ap.add_argument("--cols", type=int, default=40000)
    ap.add_argument("--seeds", type=int, default=50000)
    ap.add_argument("--chunk", type=int, default=4096)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--work", default="/tmp/rv_dask_bench")
    a = ap.parse_args()

    import dask
    import numpy as np  # noqa: F401
    from distributed import Client, LocalCluster

    import rvoronoi

    os.makedirs(a.work, exist_ok=True)
    seeds = os.path.join(a.work, "seeds.geojson")
    write_points(seeds, a.seeds, a.rows, a.cols)
    extent = [X0, Y0, X0 + a.cols, Y0 + a.rows]
    options = dict(owner_field="id", resolution=1.0, extent=extent, threads=1)
    cells = a.rows * a.cols

    def cli():
        out = os.path.join(a.work, "cli")
        shutil.rmtree(out, ignore_errors=True)
        os.makedirs(out)
        cmd = [a.binary, "compute", seeds, "--owner-field", "id", "--resolution", "1", "--extent"] + \
              [repr(v) for v in extent] + ["--ownership", os.path.join(out, "o.tif"), "--distance",
                                           os.path.join(out, "d.tif"), "--report", os.path.join(out, "r.json"),
                                           "--no-edit-base", "--quiet"]
        t = time.perf_counter()
        subprocess.run(cmd, check=True)
        wall = time.perf_counter() - t
        with open(os.path.join(out, "r.json")) as f:
            r = json.load(f)
        shutil.rmtree(out, ignore_errors=True)
        return wall, r["peak_memory_bytes"], r["timings_s"]["compute"]

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, memory_limit="10GiB",
                           dashboard_address=None)
    client = Client(cluster)

    def reduced(chunk, part=None):
        opts = dict(options)
        if part:
            opts["extent"] = part
        t = time.perf_counter()
        ds = rvoronoi.compute(seeds, chunks=(chunk, chunk), **opts)
        o, d = dask.compute(ds.owner.sum(dtype="int64"), ds.distance.sum(dtype="float64"))
        return time.perf_counter() - t, int(o)

    def zarr(chunk):
        store = os.path.join(a.work, "out.zarr")
        shutil.rmtree(store, ignore_errors=True)
        t = time.perf_counter()
        ds = rvoronoi.compute(seeds, chunks=(chunk, chunk), **options)
        ds.to_zarr(store, compute=True)
        wall = time.perf_counter() - t
        shutil.rmtree(store, ignore_errors=True)
        return wall

    runs = {"cli": [], "reduce": [], "zarr": []}
    sums = set()
    for _ in range(a.repeats):
        runs["cli"].append(cli())
        w, s = reduced(a.chunk)
        runs["reduce"].append(w)
        sums.add(s)
        runs["zarr"].append(zarr(a.chunk))
    worker_peaks = client.run(peak_rss)
    med = {k: statistics.median([r[0] if isinstance(r, tuple) else r for r in v]) for k, v in runs.items()}

    # Per-chunk overhead on a 1e8-cell part (10000 x 10000 cells, the top left).
    part = [X0, Y0 + a.rows - 10000, X0 + 10000, Y0 + a.rows]
    sides = [4096, 2048, 1024, 512, 256]

    def dask_alone(side):
        # The same graph shape without the engine: two arrays of zeros made per chunk, summed.
        import dask.array as da
        t = time.perf_counter()
        z1 = da.map_blocks(lambda b: b.copy(), da.zeros((10000, 10000), chunks=(side, side), dtype="int32"))
        z2 = da.map_blocks(lambda b: b.copy(), da.zeros((10000, 10000), chunks=(side, side), dtype="float32"))
        dask.compute(z1.sum(dtype="int64"), z2.sum(dtype="float64"))
        return time.perf_counter() - t

    over = {s: [] for s in sides}
    alone = {s: [] for s in sides}
    for _ in range(a.repeats):
        for s in sides:
            over[s].append(reduced(s, part)[0])
            alone[s].append(dask_alone(s))
    over_med = {s: statistics.median(v) for s, v in over.items()}
    alone_med = {s: statistics.median(v) for s, v in alone.items()}
    ref = over_med[sides[0]]

    client.close()
    cluster.close()

    cpu = "unknown"
    try:
        for line in subprocess.run(["lscpu"], capture_output=True, text=True).stdout.splitlines():
            if line.startswith("Model name"):
                cpu = line.split(":", 1)[1].strip()
    except OSError:
        pass
    print("CPU: %s, %d cores; %d x %d = %.2e cells, %d points, one owner each; medians of %d, alternated\n"
          % (cpu, os.cpu_count(), a.rows, a.cols, cells, a.seeds, a.repeats))
    print("| run | wall s | cells/s | memory |")
    print("|---|---|---|---|")
    cli_peak = int(statistics.median([r[1] for r in runs["cli"]]))
    print("| CLI streamed, ownership + distance GeoTIFFs | %.2f | %.3g | %d MiB (job peak) |"
          % (med["cli"], cells / med["cli"], cli_peak >> 20))
    print("| Dask, 2 workers, chunks %d^2, computed and reduced | %.2f | %.3g | %s |"
          % (a.chunk, med["reduce"], cells / med["reduce"],
             ", ".join("%d MiB" % (v >> 20) for v in worker_peaks.values()) + " (worker peaks)"))
    print("| Dask, 2 workers, chunks %d^2, to Zarr | %.2f | %.3g | |" % (a.chunk, med["zarr"], cells / med["zarr"]))
    print("\nThe CLI's engine time alone: %.2f s (median)." % statistics.median([r[2] for r in runs["cli"]]))
    print("Sum of owner codes identical across runs: %s.\n" % (len(sums) == 1))
    print("Per-chunk overhead, 1e8 cells reduced on the two workers:\n")
    print("| chunk side | chunks | wall s | ms per further chunk (vs 2048) | Dask alone, same graph shape, s |"
          " ms per further chunk, Dask alone |")
    print("|---|---|---|---|---|---|")
    n_of = {s: ((10000 + s - 1) // s) ** 2 for s in sides}
    for s in sides:
        slope = slope_alone = float("nan")
        if n_of[s] > n_of[2048]:
            slope = 1e3 * (over_med[s] - over_med[2048]) / (n_of[s] - n_of[2048])
            slope_alone = 1e3 * (alone_med[s] - alone_med[2048]) / (n_of[s] - n_of[2048])
        print("| %d | %d | %.2f | %.1f | %.2f | %.1f |" % (s, n_of[s], over_med[s], slope, alone_med[s], slope_alone))
    slopes = [1e3 * (over_med[s] - over_med[2048]) / (n_of[s] - n_of[2048]) for s in sides if n_of[s] > n_of[2048]]
    per_chunk = statistics.median(slopes) / 1e3
    engine_ns = statistics.median([r[2] for r in runs["cli"]]) * 2 / cells * 1e9  # one thread's ns per cell
    side10 = (per_chunk / (0.1 * engine_ns * 1e-9)) ** 0.5
    print("\nEach further chunk costs %.1f ms (median of the slopes); the engine needs %.2f ns a cell on one"
          " thread here, so a chunk's overhead stays under 10 %% of its work from about %d x %d cells on."
          % (per_chunk * 1e3, engine_ns, side10, side10))
    rate = cells / med["reduce"]
    print("\nA 1.3e10-cell global grid at this rate (%.3g cells/s per 2-core machine, reduced on the workers): " % rate
          + ", ".join("%d machine%s %.0f s" % (n, "s" if n > 1 else "", 1.3e10 / (rate * n)) for n in (1, 4, 16, 64))
          + "; at the Zarr rate (%.3g cells/s, writing included): " % (cells / med["zarr"])
          + ", ".join("%d machine%s %.0f s" % (n, "s" if n > 1 else "", 1.3e10 / (cells / med["zarr"] * n))
                      for n in (1, 4, 16, 64)) + ".")


if __name__ == "__main__":
    sys.exit(main())
