#!/usr/bin/python3
"""Throughput of the shared service (issue 55): one, two and three daemons on one PostgreSQL queue.

Starts a PostgreSQL 15 (tests/service/shared/postgres_harness.py) and, for each count of daemons,
that many `rvoronoi serve` daemons of one worker and one engine thread each, sharing the queue and a
results folder; submits JOBS asynchronous jobs round the daemons at once and times them from the
first submission to the last job's end (the jobs per second), and the submissions alone. The counts
alternate over ROUNDS rounds (1, 2, 3, 1, 2, 3, ...); medians are printed as a markdown table, with
the CPU. Never run beside a build: the machine's cores are the measure.

The jobs write the ownership raster alone (it compresses well): the measure is the engine's cores
and the queue, not the disk (ownership and distance at 4 m, 132 million cells each, made every
count of daemons equally slow, bound by writing the distance rasters).

STORAGE s3 puts the results on an S3 server the bench starts (s3rver, tests/service/shared/
s3_harness.py) instead of a folder: every job then uploads its files, its kept field for edits
(4 bytes a cell) the largest of them, through s3rver (one Node.js process on the same two cores).

usage: bench/shared_throughput.py RVORONOI SOURCE_DIR [JOBS=30] [ROUNDS=3] [RESOLUTION=6] [STORAGE=folder|s3]
"""
import json
import os
import platform
import shutil
import statistics
import sys
import tempfile
import time

SOURCE = sys.argv[2]
sys.path.insert(0, os.path.join(SOURCE, "tests", "service", "shared"))
sys.path.insert(0, os.path.join(SOURCE, "tests", "service", "daemon"))
from daemon_harness import Daemon  # noqa: E402
from postgres_harness import Postgres  # noqa: E402

RVORONOI = sys.argv[1]
JOBS = int(sys.argv[3]) if len(sys.argv) > 3 else 30
ROUNDS = int(sys.argv[4]) if len(sys.argv) > 4 else 3
RESOLUTION = float(sys.argv[5]) if len(sys.argv) > 5 else 6.0
STORAGE = sys.argv[6] if len(sys.argv) > 6 else "folder"


def cpu():
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor()


def one_round(pg, s3, tmp, count, body):
    results = os.path.join(tmp, f"results-{count}-{time.time_ns()}")
    where = {"results": f"s3://{s3.bucket}/r{count}-{time.time_ns()}"} if s3 else {"results": results,
                                                                                "results_shared": True}
    config = {"store": pg.uri(), "store_password_file": pg.password_file, **where,
              "jobs": {"workers": 1, "threads_per_job": 1, "poll_s": 0.5, "queue_length": 10000}}
    daemons = [Daemon([RVORONOI, "serve"], os.path.join(tmp, f"d{count}-{i}-{time.time_ns()}"),
                      dict(config, daemon_name=f"n{i}"), env=s3.env if s3 else None) for i in range(count)]
    try:
        t0 = time.perf_counter()
        jobs = []
        for i in range(JOBS):
            st, _, doc = daemons[i % count].json("POST", "/processes/voronoi/execution", body,
                                                 {"Prefer": "respond-async"})
            assert st == 201, doc
            jobs.append(doc["jobID"])
        submitted = time.perf_counter() - t0
        pending = set(jobs)
        while pending:  # one query a quarter second: the watcher must not be the load
            rows = pg.psql("SELECT id, status FROM rv_jobs WHERE status NOT IN ('accepted', 'running')")
            done = {r[0] for r in rows}
            failed = [r for r in rows if r[1] != "successful" and r[0] in pending]
            assert not failed, failed
            pending -= done
            time.sleep(0.25)
        total = time.perf_counter() - t0
        # The daemons' CPU time (user and system, every thread): how many cores they kept busy.
        tick = os.sysconf("SC_CLK_TCK")
        cpu_s = 0.0
        for d in daemons:
            fields = open(f"/proc/{d.pid}/stat").read().rsplit(")", 1)[1].split()
            cpu_s += (int(fields[11]) + int(fields[12])) / tick
        return total, submitted, cpu_s
    finally:
        for d in daemons:
            d.stop()
        pg.psql("DELETE FROM rv_jobs")
        shutil.rmtree(results, ignore_errors=True)


def main():
    fc = json.load(open(os.path.join(SOURCE, "fixtures", "demo_basepoints.geojson")))
    body = {"inputs": {"seeds": fc, "ownerField": "state", "resolution": RESOLUTION},
            "outputs": {"ownership": {}, "report": {}}}
    tmp = tempfile.mkdtemp(prefix="rv-throughput-")
    pg = Postgres()
    s3 = None
    if STORAGE == "s3":
        from s3_harness import S3
        s3 = S3()
    times = {1: [], 2: [], 3: []}
    try:
        for r in range(ROUNDS):
            for count in (1, 2, 3):
                total, submitted, cpu_s = one_round(pg, s3, tmp, count, body)
                times[count].append((total, submitted, cpu_s))
                print(f"round {r + 1}, {count} daemon(s): {total:.2f} s ({JOBS / total:.2f} jobs/s), "
                      f"submissions {submitted:.2f} s, daemons' CPU {cpu_s:.1f} s", flush=True)
    finally:
        pg.close()
        if s3:
            s3.close()
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"\nCPU: {cpu()}, {os.cpu_count()} cores; {JOBS} jobs of resolution {RESOLUTION} m "
          f"(demo_basepoints), results on {'s3rver' if s3 else 'a folder'}, {ROUNDS} rounds alternated, medians\n")
    print("| daemons | wall s | jobs/s | vs one daemon | submissions s | daemons' CPU s | cores busy |")
    print("|---|---|---|---|---|---|---|")
    base = statistics.median(t for t, _, _ in times[1])
    for count in (1, 2, 3):
        wall = statistics.median(t for t, _, _ in times[count])
        sub = statistics.median(s for _, s, _ in times[count])
        cpu_s = statistics.median(c for _, _, c in times[count])
        print(f"| {count} | {wall:.2f} | {JOBS / wall:.2f} | {base / wall:.2f}x | {sub:.2f} | {cpu_s:.1f} | "
              f"{cpu_s / wall:.2f} |")


if __name__ == "__main__":
    main()
