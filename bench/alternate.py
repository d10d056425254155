#!/usr/bin/python3
"""Alternated runs of `rvoronoi compute` variants on the points case of the paper's largest row
(10 000 x 10 000 cells, 50 000 random points, the case of bench/peers.py), to compare two
binaries or two settings within one sitting: each round runs every variant once, in turn, and
the medians over the rounds are reported (wall time of the command, its CPU time, and the
report's phases: compute, the streamed wall, how long the engine waited for the writers and
the writers for the engine).

usage:
  bench/alternate.py --rounds N [--side S --points P] LABEL=BINARY[:ARGS] ...
e.g.
  bench/alternate.py --rounds 5 old=/tmp/old/rvoronoi new=build/service/rvoronoi
  bench/alternate.py --rounds 5 t1=build/service/rvoronoi:--threads,1 t2=build/service/rvoronoi:--threads,2
Debian's /usr/bin/python3. Run it on an otherwise idle machine (no build beside it).
"""
import json
import os
import random
import resource
import statistics
import subprocess
import sys
import tempfile
import time

X0, Y0, UTM = 400000.0, 6000000.0, 32633


def points_case(directory, side, points, seed=2019):
    path = os.path.join(directory, "seeds.geojson")
    rng = random.Random(seed)
    with open(path, "w") as f:
        f.write('{"type":"FeatureCollection","crs":{"type":"name","properties":{"name":"urn:ogc:def:crs:EPSG::%d"}},'
                '"features":[\n' % UTM)
        f.write(",\n".join('{"type":"Feature","properties":{"id":%d},"geometry":{"type":"Point","coordinates":[%r,%r]}}'
                           % (i + 1, X0 + rng.uniform(0, side), Y0 + rng.uniform(0, side)) for i in range(points)))
        f.write("]}\n")
    return path


def run(binary, args, seeds, side, out):
    cmd = [binary, "compute", seeds, "--owner-field", "id", "--resolution", "1", "--extent", repr(X0), repr(Y0),
           repr(X0 + side), repr(Y0 + side), "--quiet", "--ownership", os.path.join(out, "own.tif"),
           "--distance", os.path.join(out, "dist.tif"), "--report", os.path.join(out, "report.json")] + args
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    rep = json.load(open(os.path.join(out, "report.json")))
    tm = rep["timings_s"]
    st = tm.get("streamed", {})
    return {"wall": wall, "cpu": cpu, "read": tm.get("read", 0.0), "compute": tm.get("compute", 0.0),
            "streamed_wall": st.get("wall", 0.0), "engine_waited": st.get("compute_waited_for_writer", 0.0),
            "writers_waited": st.get("writer_waited_for_compute", 0.0), "threads": rep.get("threads")}


def main():
    args = sys.argv[1:]
    rounds, side, points, variants = 5, 10000, 50000, []
    while args:
        a = args.pop(0)
        if a == "--rounds":
            rounds = int(args.pop(0))
        elif a == "--side":
            side = int(args.pop(0))
        elif a == "--points":
            points = int(args.pop(0))
        else:
            label, spec = a.split("=", 1)
            binary, _, extra = spec.partition(":")
            variants.append((label, binary, extra.split(",") if extra else []))
    with open("/proc/cpuinfo") as f:
        cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), "?")
    print(f"# {side} x {side} cells, {points} points, {rounds} alternated rounds; CPU: {cpu}, {os.cpu_count()} threads")
    with tempfile.TemporaryDirectory() as tmp:
        seeds = points_case(tmp, side, points)
        results = {label: [] for label, _, _ in variants}
        for r in range(rounds):
            for label, binary, extra in variants:
                results[label].append(run(binary, extra, seeds, side, tmp))
            print(f"round {r + 1}: " + ", ".join(f"{l} {results[l][-1]['wall']:.2f} s" for l, _, _ in variants),
                  flush=True)
    keys = ["wall", "cpu", "read", "compute", "streamed_wall", "engine_waited", "writers_waited"]
    print("\n| variant | " + " | ".join(keys) + " |")
    print("|---" * (len(keys) + 1) + "|")
    for label, _, _ in variants:
        med = {k: statistics.median(x[k] for x in results[label]) for k in keys}
        print(f"| {label} | " + " | ".join(f"{med[k]:.3f}" for k in keys) + " |")


if __name__ == "__main__":
    main()
