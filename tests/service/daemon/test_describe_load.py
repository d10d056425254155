#!/usr/bin/python3
"""Descriptions of seed files under load (issue 50, defect 1): uploads at the limits never freeze
the daemon, and what they hold stays within its memory account.

Against a daemon with the default two network threads, two describe threads and a memory
account of 2 GiB, four clients post zipped Shapefiles of one line of 4 million vertices (64 MB
inflated, 60 KB zipped; each description reserves about 1.3 GB by the reading's estimate) to
describe-seeds, over and over, for a bounded time. Meanwhile:
  - /health answers within 100 ms at the 99th percentile (before the fix the descriptions ran on
    the network threads, and /health waited seconds behind them);
  - every answer is 200 (the line described) or 503 with Retry-After and the busy problem type
    (the describe threads taken, or the account without room); both occur;
  - /health's memory account never shows more reserved than its budget, and the daemon's
    resident memory stays under the budget.
Then, with the load gone, a description of the same file is answered 200 and the account is back
to zero.

usage: test_describe_load.py RVORONOI SOURCE_DIR [--sanitized]
--sanitized (ASan/UBSan builds): the resident-memory bound is not checked (the sanitizer's shadow
memory and quarantine are not the daemon's); everything else is.
"""
import base64
import json
import os
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hostile_inputs as hi  # noqa: E402
from daemon_harness import Daemon  # noqa: E402

RVORONOI = sys.argv[1]
SANITIZED = "--sanitized" in sys.argv[3:]
BUDGET = 2 << 30
LOAD_SECONDS = 8.0
FAILURES = []


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL:", what, flush=True)
    return condition


def describe_body(zipped):
    return {"inputs": {"seeds": {"value": base64.b64encode(zipped).decode(), "encoding": "base64",
                                 "mediaType": "application/zip"}}}


def main():
    zipped = hi.shapefile_line_bomb(4_000_000)
    print(f"upload: {len(zipped)} bytes zipped", flush=True)
    body = json.dumps(describe_body(zipped)).encode()
    with tempfile.TemporaryDirectory(prefix="rv-describe-load-") as tmp:
        config = {"http": {"io_threads": 2}, "jobs": {"workers": 1, "describe_workers": 2},
                  "limits": {"total_memory_bytes": BUDGET}}
        d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "data"), config)
        try:
            run_load(d, body)
            # Alone again: described, and the account empty.
            status, _, payload = d.request("POST", "/processes/describe-seeds/execution", body)
            check(status == 200, f"a description after the load: {status} {payload[:300]!r}")
            if status == 200:
                doc = json.loads(payload)
                check(doc["layers"][0]["features"] == 1, f"the line is described: {doc['layers']}")
            status, _, payload = d.request("GET", "/health")
            memory = json.loads(payload)["memory"]
            check(memory["reservedBytes"] == 0 and memory["budgetBytes"] == BUDGET, f"the account at rest: {memory}")
        finally:
            d.stop()
    if FAILURES:
        print(f"{len(FAILURES)} failed")
        sys.exit(1)
    print("all passed")


def run_load(d, body):
    outcomes = []
    lock = threading.Lock()
    stop_at = time.monotonic() + LOAD_SECONDS

    def client():
        sent = 0
        while time.monotonic() < stop_at and sent < 200:
            sent += 1
            status, headers, payload = d.request("POST", "/processes/describe-seeds/execution", body, timeout=120)
            with lock:
                outcomes.append((status, headers, payload[:400]))

    clients = [threading.Thread(target=client) for _ in range(4)]
    for t in clients:
        t.start()
    latencies, reserved, rss = [], [], []
    while any(t.is_alive() for t in clients) and len(latencies) < 5000:
        t0 = time.monotonic()
        status, _, payload = d.request("GET", "/health", timeout=60)
        latencies.append(time.monotonic() - t0)
        check(status == 200, f"/health answered {status}")
        if status == 200:
            reserved.append(json.loads(payload)["memory"]["reservedBytes"])
        rss.append(d.rss_bytes())
        time.sleep(0.02)
    for t in clients:
        t.join()
    latencies.sort()
    p99 = latencies[int(0.99 * (len(latencies) - 1))]
    print(f"/health: {len(latencies)} requests, median {1000 * latencies[len(latencies) // 2]:.1f} ms, "
          f"p99 {1000 * p99:.1f} ms, max {1000 * latencies[-1]:.1f} ms", flush=True)
    print(f"describe: {len(outcomes)} answers, {sum(o[0] == 200 for o in outcomes)} x 200, "
          f"{sum(o[0] == 503 for o in outcomes)} x 503; largest reservation {max(reserved, default=0) >> 20} MiB, "
          f"largest RSS {max(rss) >> 20} MiB (budget {BUDGET >> 20} MiB)", flush=True)
    check(len(latencies) >= 50, f"/health was asked often enough: {len(latencies)}")
    check(p99 < 0.1, f"/health p99 under 100 ms while descriptions run: {1000 * p99:.1f} ms")
    check(max(reserved, default=0) <= BUDGET, f"the account never above its budget: {max(reserved, default=0)}")
    check(SANITIZED or max(rss) < BUDGET, f"resident memory under the budget: {max(rss) >> 20} MiB")
    check(any(o[0] == 200 for o in outcomes), "some descriptions were answered 200")
    check(any(o[0] == 503 for o in outcomes), "some descriptions were refused with 503")
    for status, headers, payload in outcomes:
        if status == 503:
            check(headers.get("retry-after", "").isdigit(), f"503 with Retry-After: {headers}")
            check(b"/busy" in payload, f"503 is the busy problem: {payload!r}")
        elif status != 200:
            check(False, f"a description answered {status}: {payload!r}")


if __name__ == "__main__":
    main()
