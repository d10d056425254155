#!/usr/bin/python3
"""Load test of the daemon (issue 8): `rvoronoi serve` driven from this second process over
loopback for a fixed time with a mix of GETs and small synchronous jobs, while slow clients
(slowloris: connections sending their headers a byte at a time) stay connected.

Asserts: no 5xx and no failed request; the daemon is alive afterwards; a probe (a fresh
connection doing GET /health every 100 ms) is always answered within PROBE_BOUND_S while the
slow clients are connected, and the slow clients are cut off by the request timeout; the
resident memory (VmRSS) after the load and a settle period is back near its value after a
warm-up: at most max(32 MiB, 25 %) above it.

Why that bound: after the warm-up every allocator arena, thread stack, GDAL driver and SQLite
page cache exists; what may still grow is bounded by configuration, not by the number of
requests (SQLite's cache is at most 2 MiB, glibc keeps at most a few MiB per arena, and the
daemon trims the heap whenever no job runs). What the bound catches: the run makes some 20 000
requests and 2 000 jobs (on a loaded 2-core machine; more on a faster one), so a leak of 2 KiB
per request, or of one job's grid buffers (about 25 KiB at this job's 41 x 50 cells), exceeds
it. The baseline is taken after the warm-up because the first requests initialise all of that
once; 25 % allows for a larger baseline on machines with more cores (more arenas and threads).

Prints requests per second, p50/p99 latency per kind and overall, and the RSS figures.
usage: test_load.py RVORONOI SOURCE_DIR [--sanitized]
  --sanitized: the binary is an ASan build, whose allocator keeps freed memory in quarantine;
               the memory bound is reported but not asserted.
Environment: RV_LOAD_SECONDS (default 20), RV_LOAD_CLIENTS (default 6), RV_SLOW_CLIENTS (default 64).
"""
import http.client
import json
import os
import random
import shutil
import socket
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from daemon_harness import Daemon  # noqa: E402

RVORONOI, SOURCE = sys.argv[1], sys.argv[2]
SANITIZED = "--sanitized" in sys.argv[3:]
SECONDS = float(os.environ.get("RV_LOAD_SECONDS", "20"))
CLIENTS = int(os.environ.get("RV_LOAD_CLIENTS", "6"))
SLOW_CLIENTS = int(os.environ.get("RV_SLOW_CLIENTS", "64"))
PROBE_BOUND_S = 2.0
REQUEST_TIMEOUT_S = 4  # the daemon's whole-request deadline: slow clients are cut after it
MIB = 1 << 20

DEMO = json.load(open(os.path.join(SOURCE, "fixtures", "demo_basepoints.geojson")))
SMALL_JOB = json.dumps({"inputs": {"seeds": DEMO, "ownerField": "state", "resolution": 1000},
                        "outputs": {"ownership": {}, "report": {}}}).encode()


def percentile(values, p):
    if not values:
        return float("nan")
    s = sorted(values)
    return s[min(len(s) - 1, int(round(p / 100.0 * (len(s) - 1))))]


class Stats:
    def __init__(self):
        self.lock = threading.Lock()
        self.latency = {}  # kind -> [seconds]
        self.statuses = {}  # status -> count
        self.errors = []

    def add(self, kind, status, seconds):
        with self.lock:
            self.latency.setdefault(kind, []).append(seconds)
            self.statuses[status] = self.statuses.get(status, 0) + 1

    def error(self, what):
        with self.lock:
            if len(self.errors) < 20:
                self.errors.append(what)
            self.statuses["error"] = self.statuses.get("error", 0) + 1


def client(port, stop, stats, job_id, seed):
    """One keep-alive connection issuing the request mix until `stop` is set."""
    rng = random.Random(seed)
    conn = None
    while not stop.is_set():
        x = rng.random()
        if x < 0.35:
            kind, method, path, body = "GET /", "GET", "/", None
        elif x < 0.55:
            kind, method, path, body = "GET /processes", "GET", "/processes", None
        elif x < 0.70:
            kind, method, path, body = "GET /jobs", "GET", "/jobs?limit=20", None
        elif x < 0.90:
            kind, method, path, body = "GET /jobs/{id}", "GET", "/jobs/" + job_id, None
        else:
            kind, method, path, body = "POST sync job", "POST", "/processes/voronoi/execution", SMALL_JOB
        try:
            if conn is None:
                conn = http.client.HTTPConnection("127.0.0.1", port, timeout=60)
            t = time.perf_counter()
            conn.request(method, path, body=body, headers={"Content-Type": "application/json"} if body else {})
            r = conn.getresponse()
            r.read()
            stats.add(kind, r.status, time.perf_counter() - t)
            if r.status != 200:  # every request of the mix is valid and within the limits
                stats.error(f"{kind}: status {r.status}")
            if r.getheader("Connection", "").lower() == "close":
                conn.close()
                conn = None
        except (OSError, http.client.HTTPException) as e:
            stats.error(f"{kind}: {type(e).__name__}: {e}")
            if conn is not None:
                conn.close()
            conn = None
    if conn is not None:
        conn.close()


def slowloris(port, stop, counters):
    """SLOW_CLIENTS connections, each sending a request header one byte every 100 ms and never
    finishing it. A connection the server cuts (its request deadline) is opened again."""
    header = b"GET /processes HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Slow: " + b"a" * 10000
    socks = {}

    def connect(i):
        s = socket.create_connection(("127.0.0.1", port), timeout=5)
        s.setblocking(False)
        socks[i] = [s, 0]
        counters["opened"] += 1

    for i in range(SLOW_CLIENTS):
        connect(i)
    counters["connected"] = threading.Event()
    counters["connected"].set()
    while not stop.is_set():
        for i in list(socks):
            s, pos = socks[i]
            try:
                s.send(header[pos % len(header):pos % len(header) + 1])
                socks[i][1] = pos + 1
                # The server closes a connection it cut off; recv sees the end of the stream.
                try:
                    if s.recv(4096) == b"":
                        raise ConnectionResetError("closed by the server")
                except BlockingIOError:
                    pass
            except OSError:
                s.close()
                counters["cut"] += 1
                connect(i)
        stop.wait(0.1)
    for s, _ in socks.values():
        s.close()


def probe(port, stop, samples):
    while not stop.is_set():
        t = time.perf_counter()
        try:
            c = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
            c.request("GET", "/health")
            r = c.getresponse()
            r.read()
            c.close()
            samples.append((r.status, time.perf_counter() - t))
        except (OSError, http.client.HTTPException) as e:
            samples.append((str(e), time.perf_counter() - t))
        stop.wait(0.1)


def settle_rss(d, seconds):
    """The lowest VmRSS sampled over `seconds` (a transient page or two is not growth)."""
    end = time.time() + seconds
    low = d.rss_bytes()
    while time.time() < end:
        time.sleep(0.2)
        low = min(low, d.rss_bytes())
    return low


def main():
    tmp = tempfile.mkdtemp(prefix="rv_load_")
    failures = []
    config = {"http": {"request_timeout_s": REQUEST_TIMEOUT_S, "io_threads": 2},
              "jobs": {"workers": 2, "queue_length": 16, "threads_per_job": 1, "shutdown_grace_s": 2}}
    d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "data"), config)
    try:
        status, _, doc = d.json("POST", "/processes/voronoi/execution", json.loads(SMALL_JOB))
        assert status == 200, (status, doc)
        job_id = doc["ownership"]["href"].split("/jobs/")[1].split("/")[0]

        # Warm-up: the same mix, briefly, so that arenas, stacks, drivers and caches exist.
        warm = Stats()
        stop = threading.Event()
        threads = [threading.Thread(target=client, args=(d.port, stop, warm, job_id, 100 + i)) for i in range(CLIENTS)]
        for t in threads:
            t.start()
        time.sleep(3)
        stop.set()
        for t in threads:
            t.join()
        rss_start = settle_rss(d, 2)

        stats = Stats()
        stop = threading.Event()
        slow = {"opened": 0, "cut": 0}
        probes = []
        slow_thread = threading.Thread(target=slowloris, args=(d.port, stop, slow))
        slow_thread.start()
        probe_thread = threading.Thread(target=probe, args=(d.port, stop, probes))
        probe_thread.start()
        threads = [threading.Thread(target=client, args=(d.port, stop, stats, job_id, i)) for i in range(CLIENTS)]
        rss_peak = rss_start
        t0 = time.perf_counter()
        for t in threads:
            t.start()
        while time.perf_counter() - t0 < SECONDS:
            time.sleep(0.25)
            rss_peak = max(rss_peak, d.rss_bytes())
        stop.set()
        for t in threads:
            t.join()
        elapsed = time.perf_counter() - t0
        slow_thread.join()
        probe_thread.join()
        alive = d.alive()
        rss_end = settle_rss(d, 3) if alive else 0

        total = sum(len(v) for v in stats.latency.values())
        every = [x for v in stats.latency.values() for x in v]
        print(f"load: {elapsed:.1f} s, {CLIENTS} keep-alive clients, {SLOW_CLIENTS} slow clients", flush=True)
        print(f"  {total} requests, {total / elapsed:.0f} requests/s, p50 {percentile(every, 50) * 1e3:.1f} ms, "
              f"p99 {percentile(every, 99) * 1e3:.1f} ms, max {max(every) * 1e3:.1f} ms")
        for kind in sorted(stats.latency):
            v = stats.latency[kind]
            print(f"  {kind:16s} {len(v):6d}  p50 {percentile(v, 50) * 1e3:7.1f} ms  p99 {percentile(v, 99) * 1e3:7.1f} ms")
        print(f"  statuses {stats.statuses}")
        probe_times = [s for _, s in probes]
        print(f"  probe GET /health on a fresh connection: {len(probes)} samples, max {max(probe_times) * 1e3:.1f} ms, "
              f"p50 {percentile(probe_times, 50) * 1e3:.1f} ms")
        print(f"  slow clients: {slow['opened']} connections opened, {slow['cut']} cut off by the server")
        print(f"  VmRSS after warm-up {rss_start / MIB:.1f} MiB, peak {rss_peak / MIB:.1f} MiB, "
              f"after load and settle {rss_end / MIB:.1f} MiB")

        if not alive:
            failures.append("the daemon died under load")
        if stats.errors:
            failures.append(f"failed requests: {stats.errors}")
        if any(isinstance(k, int) and k >= 500 for k in stats.statuses):
            failures.append(f"5xx answers: {stats.statuses}")
        if total < 100:
            failures.append(f"only {total} requests in {elapsed:.0f} s")
        bad_probes = [p for p in probes if p[0] != 200 or p[1] > PROBE_BOUND_S]
        if not probes or bad_probes:
            failures.append(f"probes not answered within {PROBE_BOUND_S} s while slow clients were connected: "
                            f"{bad_probes[:5]}")
        if SECONDS > REQUEST_TIMEOUT_S + 2 and slow["cut"] < SLOW_CLIENTS:
            failures.append(f"slow clients were not cut off by the request timeout: {slow}")
        allowed = max(32 * MIB, rss_start // 4)
        if alive and rss_end > rss_start + allowed:
            what = (f"VmRSS {rss_end / MIB:.1f} MiB after the load, more than {allowed / MIB:.0f} MiB above "
                    f"{rss_start / MIB:.1f} MiB after the warm-up")
            if SANITIZED:
                print(f"  (ASan build, not asserted) {what}")
            else:
                failures.append(what)
        if alive:
            code = d.stop()
            if code != 0:
                failures.append(f"exit status after SIGTERM: {code}")
    finally:
        if d.alive():
            d.proc.kill()
            d.proc.wait()
        shutil.rmtree(tmp, ignore_errors=True)
    for f in failures:
        print("FAIL:", f)
    if failures:
        sys.exit(1)
    print("ok")


if __name__ == "__main__":
    main()
