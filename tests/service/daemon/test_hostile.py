#!/usr/bin/python3
"""Hostile uploads and clients against the real daemon (issue 28). Each defect of the issue has a
section here; each section fails on the build before the fix.

1. Text that is not UTF-8 (GeoPackage schema SQL, a column name, owner values, FlatGeobuf strings
   and mutants), sync and async, with a valid token: the daemon answers each with valid JSON and
   keeps serving; owners differing only in invalid bytes stay two owners.
2. A job store with such text written by an older build (raw bytes in the message, inputs and
   report columns) opens after a restart, and every endpoint answers.
3. Compressed uploads: a 311 KB zipped Shapefile holding one MultiPoint of 20 million points is
   refused with 422 in under a second, resident memory growing by at most 64 MiB; a zip that
   inflates past limits.max_input_bytes is refused; a GeoPackage view is refused.
4. Out of file descriptors: no accept() spin, /health keeps answering.
5. Bad input is 400, not 404 (a truncated or random zip, an ownerField the data lacks).
6. The small ones: Prefer in any case, the next link's filter, tokens in query strings redacted
   in the log, Retry-After on 503, the job's own peak memory, a 700 KB crs not echoed, seeds at
   +-1e308, points at both poles.

usage: test_hostile.py RVORONOI SOURCE_DIR [--sanitized]
--sanitized (ASan/UBSan builds): the descriptor section runs with the automatic cap only. With the
cap above the descriptors the daemon does run out of them, and then the sanitizer runtime itself
cannot open what it needs to check an address (UBSan's vptr check reports "invalid vptr,
memory cannot be printed" for Boost's error categories); the plain build covers that case.
"""
import base64
import json
import os
import resource
import socket
import sqlite3
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hostile_inputs as hi  # noqa: E402
from daemon_harness import Daemon  # noqa: E402

RVORONOI, SOURCE = sys.argv[1], sys.argv[2]
SANITIZED = "--sanitized" in sys.argv[3:]
FAILURES = []
TOKEN = "hostile-test-token-0123456789abcdef"
AUTH = {"Authorization": f"Bearer {TOKEN}"}
MIB = 1 << 20


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL:", what, flush=True)
    return condition


def strict_json(payload, what):
    """The body as JSON, decoded as strict UTF-8: what a careful client does."""
    try:
        return json.loads(payload.decode("utf-8", errors="strict"))
    except (UnicodeDecodeError, ValueError) as e:
        check(False, f"{what}: not valid UTF-8 JSON ({e}): {payload[:200]!r}")
        return None


def upload(data, media):
    return {"value": base64.b64encode(data).decode(), "mediaType": media, "encoding": "base64"}


def body(seeds, owner="state", resolution=100, **inputs):
    i = {"seeds": seeds, "resolution": resolution}
    if owner:
        i["ownerField"] = owner
    i.update(inputs)
    return {"inputs": i}


def post(d, b, headers=None, timeout=120):
    h = dict(AUTH)
    h.update(headers or {})
    status, hdrs, payload = d.request("POST", "/processes/voronoi/execution", b, h, timeout)
    return status, hdrs, payload


def get(d, path, headers=None):
    h = dict(AUTH)
    h.update(headers or {})
    return d.request("GET", path, None, h)


def alive(d, what):
    check(d.alive(), f"daemon alive after {what}")
    if d.alive():
        status, _, _ = get(d, "/health")
        check(status == 200, f"/health after {what}: {status}")


def wait_job(d, job, seconds=60):
    end = time.time() + seconds
    doc = None
    while time.time() < end:
        status, _, payload = get(d, f"/jobs/{job}")
        doc = strict_json(payload, f"GET /jobs/{job}")
        if doc and doc.get("status") in ("successful", "failed", "dismissed"):
            return doc
        time.sleep(0.02)
    check(False, f"job {job} did not end: {doc}")
    return doc


def run_both(d, b, what):
    """Runs `b` synchronously and asynchronously; returns (sync status, sync doc, async job doc)."""
    status, _, payload = post(d, b)
    doc = strict_json(payload, f"sync {what}")
    alive(d, f"sync {what}")
    astatus, _, apayload = post(d, b, {"Prefer": "respond-async"})
    adoc = strict_json(apayload, f"async {what}")
    check(astatus == 201, f"async {what} accepted: {astatus} {adoc}")
    final = wait_job(d, adoc["jobID"]) if adoc and "jobID" in adoc else None
    alive(d, f"async {what}")
    if final and final["status"] == "failed":
        rstatus, _, rpayload = get(d, f"/jobs/{adoc['jobID']}/results")
        rdoc = strict_json(rpayload, f"results of failed async {what}")
        check(rstatus == status, f"{what}: the failed job's results answer as the sync run did: {rstatus} vs {status}")
        check(rdoc is not None and rdoc.get("detail") == (doc or {}).get("detail"),
              f"{what}: same detail sync and async: {rdoc} / {doc}")
    return status, doc, final


def every_endpoint(d, what):
    """Every endpoint answers with valid JSON (or the file) for every job in the store."""
    for path in ("/", "/conformance", "/processes", "/processes/voronoi", "/health"):
        status, _, payload = get(d, path)
        check(status == 200 and strict_json(payload, f"{what} GET {path}") is not None, f"{what}: GET {path}: {status}")
    status, _, payload = get(d, "/api")
    check(status == 200, f"{what}: GET /api: {status}")
    jobs, offset = [], 0
    while True:
        status, _, payload = get(d, f"/jobs?limit=2&offset={offset}")
        doc = strict_json(payload, f"{what} GET /jobs page {offset}")
        if not check(status == 200 and doc is not None, f"{what}: GET /jobs?limit=2&offset={offset}: {status}"):
            break
        jobs += doc["jobs"]
        if len(doc["jobs"]) < 2:
            break
        offset += 2
    for st in ("failed", "successful", "failed,successful"):
        status, _, payload = get(d, f"/jobs?status={st}")
        check(status == 200 and strict_json(payload, f"{what} /jobs?status={st}") is not None,
              f"{what}: GET /jobs?status={st}: {status}")
    for j in jobs:
        jid = j["jobID"]
        for path in (f"/jobs/{jid}", f"/jobs/{jid}/results"):
            status, _, payload = get(d, path)
            # A failed job's results answer with the job's own error (500 for an internal one).
            server_error_ok = path.endswith("/results") and j["status"] == "failed"
            check((status < 500 or server_error_ok) and strict_json(payload, f"{what} GET {path}") is not None,
                  f"{what}: GET {path}: {status}")
        if j["status"] == "successful":
            for link in j["links"]:
                if link["rel"] == "enclosure":
                    status, _, _ = get(d, link["href"].split(str(d.port), 1)[1])
                    check(status == 200, f"{what}: GET {link['href']}: {status}")
    return jobs


# ---------------------------------------------------------------------------------------------
# 1 and 2: text that is not UTF-8.
def invalid_utf8(tmp):
    t0 = time.time()
    data = os.path.join(tmp, "utf8")
    config = {"auth": {"tokens": [TOKEN]}, "jobs": {"workers": 1, "queue_length": 64}}
    d = Daemon([RVORONOI, "serve"], data, config)
    gpkg = "application/geopackage+sqlite3"

    # (a) schema SQL with 0x80: GDAL's message quotes it.
    status, doc, _ = run_both(d, body(upload(hi.gpkg_broken_schema(), gpkg)), "broken schema")
    check(status == 400, f"(a) broken schema: 400, got {status} {doc}")
    check(doc is not None and "\\x80" in doc.get("detail", ""), f"(a) the byte is shown escaped: {doc}")

    # (b) a column named "o\x80" and an ownerField the data lacks: the message lists the fields.
    status, doc, _ = run_both(d, body(upload(hi.gpkg_column_named(b"o\x80"), gpkg), owner="nope"), "column o\\x80")
    check(status == 400, f"(b) missing ownerField is 400 (not 404): {status} {doc}")
    check(doc is not None and "o\\x80" in doc.get("detail", ""), f"(b) field name escaped: {doc}")

    # (d) owner values A\x80, A, B: three owners, the first shown escaped.
    status, doc, final = run_both(d, body(upload(hi.gpkg_owner_values((b"A\x80", b"A", b"B")), gpkg)), "owner A\\x80")
    check(status == 200, f"(d) owner values with invalid bytes compute: {status} {doc}")
    if status == 200:
        job = doc["ownership"]["href"].split("/jobs/")[1].split("/")[0]
        rstatus, _, rpayload = get(d, f"/jobs/{job}/results/report")
        report = strict_json(rpayload, "(d) report")
        labels = [o["label"] for o in report["seeds"]["owners"]] if report else []
        check(labels == ["A\\x80", "A", "B"], f"(d) owners keep their identity, escaped: {labels}")
        _, _, aux = get(d, f"/jobs/{job}/results/ownership.aux.xml")
        check(b"A\\x80" in aux and aux.decode("utf-8", "strict") is not None, "(d) the attribute table shows A\\x80")
    check(final is not None and final["status"] == "successful", f"(d) async too: {final}")

    # FlatGeobuf whose layer name, field name and values are raw bytes.
    raw = b"s\x80\xfft"
    status, doc, _ = run_both(d, body(upload(hi.fgb_with_raw_text(raw + b"e"), "application/flatgeobuf"), owner=None),
                              "FlatGeobuf raw names")
    check(status in (200, 400), f"FlatGeobuf raw names: {status} {doc}")
    status, doc, _ = run_both(d, body(upload(hi.fgb_with_raw_text(raw + b"e"), "application/flatgeobuf"),
                                      owner="nope"), "FlatGeobuf raw names, missing owner")
    check(status == 400 and "\\x80" in (doc or {}).get("detail", ""), f"FlatGeobuf field list escaped: {status} {doc}")

    # (c) mutated FlatGeobuf files: every answer valid JSON, the daemon alive throughout.
    mutants = hi.fgb_mutants(120)
    codes = {}
    for i, m in enumerate(mutants):
        status, _, payload = post(d, body(upload(m, "application/flatgeobuf"), owner="state"))
        strict_json(payload, f"(c) mutant {i}")
        codes[status] = codes.get(status, 0) + 1
        if not d.alive():
            check(False, f"(c) mutant {i} stopped the daemon")
            break
    check(all(c < 500 for c in codes), f"(c) mutants answer 2xx/4xx: {codes}")
    for i, m in enumerate(mutants[:10]):
        status, _, payload = post(d, body(upload(m, "application/flatgeobuf")), {"Prefer": "respond-async"})
        doc = strict_json(payload, f"(c) async mutant {i}")
        if doc and "jobID" in doc:
            wait_job(d, doc["jobID"])
    alive(d, "(c) mutants")
    print(f"(c) {len(mutants)} FlatGeobuf mutants: {codes}", flush=True)

    jobs = every_endpoint(d, "live store")
    check(len(jobs) >= 10, f"jobs listed: {len(jobs)}")
    check(d.stop() == 0, "daemon stops cleanly")

    # 2. The same store written as an older build would have: raw bytes in the text columns.
    db = sqlite3.connect(os.path.join(data, "jobs.sqlite"))
    db.text_factory = bytes
    ids = [r[0].decode() for r in db.execute("SELECT id FROM jobs WHERE status = 'failed' LIMIT 2")]
    ok = [r[0].decode() for r in db.execute("SELECT id FROM jobs WHERE status = 'successful' LIMIT 1")]
    check(len(ids) == 2 and len(ok) == 1, f"store has failed and successful jobs: {ids} {ok}")
    db.execute("UPDATE jobs SET message = CAST(? AS TEXT) WHERE id = ?",
               (b"input 'seeds': malformed schema near \"\x80\xff\": syntax error", ids[0]))
    db.execute("UPDATE jobs SET inputs = CAST(? AS TEXT), message = CAST(? AS TEXT) WHERE id = ?",
               (b'{"ownerField": "o\x80", "resolution": 100}', b"owner field 'o\x80' not found", ids[1]))
    report = db.execute("SELECT report FROM jobs WHERE id = ?", (ok[0],)).fetchone()[0]
    db.execute("UPDATE jobs SET report = CAST(? AS TEXT) WHERE id = ?", (report.replace(b'"A\\\\x80"', b'"A\x80"'), ok[0]))
    db.execute("UPDATE jobs SET error_kind = 'no-such-kind', progress = 400 WHERE id = ?", (ids[1],))
    db.commit()
    db.close()
    d = Daemon([RVORONOI, "serve"], data, config)
    jobs = every_endpoint(d, "older store")
    by_id = {j["jobID"]: j for j in jobs}
    check(ids[0] in by_id and "\\x80\\xFF" in by_id[ids[0]]["message"],
          f"older store: message shown escaped: {by_id.get(ids[0], {}).get('message')}")
    status, _, payload = get(d, f"/jobs/{ids[0]}/results")
    doc = strict_json(payload, "older store failed results")
    check(status == 400 and doc and "\\x80" in doc["detail"], f"older store: failed job's results: {status} {doc}")
    status, _, payload = get(d, f"/jobs/{ids[1]}/results")
    check(status == 500 and strict_json(payload, "unknown kind") is not None, f"unknown stored kind answers: {status}")
    status, _, payload = get(d, f"/jobs/{ok[0]}/results")
    check(status == 200 and strict_json(payload, "older store results") is not None, f"older successful job: {status}")
    for jid in ids + ok:
        status, _, payload = d.request("DELETE", f"/jobs/{jid}", None, AUTH)
        check(status == 200 and strict_json(payload, "DELETE") is not None, f"DELETE {jid}: {status}")
    alive(d, "older store")
    check(d.stop() == 0, "daemon on the older store stops cleanly")
    print(f"invalid UTF-8: ok ({time.time() - t0:.1f} s)", flush=True)


# ---------------------------------------------------------------------------------------------
def status_field(pid, name):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith(name):
                return int(line.split()[1]) * 1024
    return 0


# 3 and 5: compressed uploads and broken ones.
def compressed_uploads(tmp):
    t0 = time.time()
    bomb = hi.shapefile_multipoint_bomb()
    check(len(bomb) < 400_000, f"the bomb is small: {len(bomb)} bytes")
    config = {"limits": {"max_vertices": 100_000, "max_memory_bytes": 256 * MIB, "max_input_bytes": 64 * MIB},
              "auth": {"tokens": [TOKEN]}}
    d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "bomb"), config)
    hwm_before = status_field(d.pid, "VmHWM:")
    started = time.time()
    status, _, payload = post(d, body(upload(bomb, "application/zip")))
    took = time.time() - started
    doc = strict_json(payload, "bomb")
    grew = status_field(d.pid, "VmHWM:") - hwm_before
    check(status in (413, 422), f"the bomb is refused with 413/422: {status} {doc}")
    check(took < 1.0, f"the bomb is refused in under 1 s: {took:.2f} s")
    check(grew <= 64 * MIB, f"resident memory grew by at most 64 MiB: {grew / MIB:.1f} MiB")
    check(doc is not None and "vertices" in doc.get("detail", ""), f"the refusal names the limit: {doc}")
    print(f"bomb: {status} in {took:.2f} s, high-water mark +{grew / MIB:.1f} MiB", flush=True)
    status, _, payload = post(d, body(upload(bomb, "application/zip")), {"Prefer": "respond-async"})
    job = (strict_json(payload, "bomb async") or {}).get("jobID")
    final = wait_job(d, job, 10) if job else None
    check(final is not None and final["status"] == "failed" and "vertices" in final["message"],
          f"async bomb fails on the vertex limit: {final}")

    # Inflated bytes counted while inflating: 100 MiB of zeros in a 100 KB zip.
    status, _, payload = post(d, body(upload(hi.zip_of_zeros(100 * MIB), "application/zip")))
    doc = strict_json(payload, "zeros")
    check(status == 422 and "inflates to more than" in (doc or {}).get("detail", ""),
          f"a zip inflating past max_input_bytes is refused: {status} {doc}")
    check(status_field(d.pid, "VmHWM:") - hwm_before <= 64 * MIB, "inflating costs no memory")

    # A GeoPackage view without end, and a generated column: refused before GDAL runs them.
    started = time.time()
    status, _, payload = post(d, body(upload(hi.gpkg_view_layer(), "application/geopackage+sqlite3")))
    doc = strict_json(payload, "view")
    check(status == 400 and "view" in (doc or {}).get("detail", "") and time.time() - started < 5,
          f"a GeoPackage with a view is refused at once: {status} {doc}")

    # 5. Broken uploads and a field the data lacks are bad input (400), not "not found".
    for what, data in (("truncated zip", hi.zip_truncated()), ("random zip", hi.zip_random())):
        status, _, payload = post(d, body(upload(data, "application/zip")))
        doc = strict_json(payload, what)
        check(status == 400, f"{what}: 400, got {status} {doc}")
    status, _, payload = post(d, body(upload(hi.zipped_points(), "application/zip"), owner="nope"))
    doc = strict_json(payload, "missing owner field")
    check(status == 400 and "nope" in (doc or {}).get("detail", ""), f"ownerField the data lacks: 400: {status} {doc}")
    status, _, payload = post(d, body(upload(hi.zipped_points(), "application/zip")))
    check(status == 200, f"a sound zipped Shapefile still computes: {status} {payload[:300]}")
    alive(d, "compressed uploads")
    d.stop()
    print(f"compressed and broken uploads: ok ({time.time() - t0:.1f} s)", flush=True)


# ---------------------------------------------------------------------------------------------
# 4: out of file descriptors.
def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def descriptors(tmp):
    t0 = time.time()

    def low_nofile():
        resource.setrlimit(resource.RLIMIT_NOFILE, (64, 64))

    variants = [("connections above the descriptors", {"max_connections": 100000, "request_timeout_s": 30}),
                ("automatic cap", {"request_timeout_s": 30})]
    for label, http in variants[1:] if SANITIZED else variants:
        d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "fd-" + str(len(label))), {"http": http},
                   preexec_fn=low_nofile)
        idle = []
        for _ in range(150):
            s = socket.socket()
            s.settimeout(5)
            try:
                s.connect(("127.0.0.1", d.port))
                s.send(b"GET /health HTTP/1.1\r\nHost: x\r\n")  # an unfinished request
                idle.append(s)
            except OSError:
                s.close()
        time.sleep(0.5)
        cpu0 = cpu_seconds(d.pid)
        time.sleep(2.0)
        spent = cpu_seconds(d.pid) - cpu0
        check(spent < 0.3, f"{label}: no accept() spin: {spent:.2f} CPU s in 2 s")
        ok = 0
        for _ in range(20):
            status, _, _ = d.request("GET", "/health", timeout=10)
            ok += status == 200
        check(ok == 20, f"{label}: /health answers while {len(idle)} slow clients hold connections: {ok}/20")
        check(d.alive(), f"{label}: daemon alive")
        if "above" in label:
            check(d.logged(lambda line: "accept_backoff" in line), f"{label}: the back-off is logged")
        for s in idle:
            s.close()
        d.stop()
        print(f"descriptors, {label}: ok, {spent:.2f} CPU s idle, /health {ok}/20", flush=True)
    print(f"descriptors: ok ({time.time() - t0:.1f} s)", flush=True)


# ---------------------------------------------------------------------------------------------
# 6: the small ones.
def small_ones(tmp):
    t0 = time.time()
    demo = json.load(open(os.path.join(SOURCE, "fixtures", "demo_basepoints.geojson")))
    config = {"jobs": {"workers": 1, "queue_length": 0}, "auth": {"tokens": [TOKEN]}}
    d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "small"), config)

    status, h, payload = post(d, body(demo, resolution=500), {"Prefer": "Respond-Async"})
    doc = strict_json(payload, "Respond-Async")
    check(status == 201 and h.get("preference-applied") == "respond-async", f"Prefer: Respond-Async: {status}")
    if doc and "jobID" in doc:
        wait_job(d, doc["jobID"])
    status, _, _ = post(d, body(demo, resolution=500), {"Prefer": "wait=10, RESPOND-ASYNC ; x=1"})
    check(status == 201, f"respond-async among several preferences: {status}")
    time.sleep(0.5)

    for _ in range(3):
        post(d, body(demo, resolution=500))
    status, _, payload = get(d, "/jobs?limit=1&status=successful")
    doc = strict_json(payload, "next link")
    nxt = [l["href"] for l in doc["links"] if l["rel"] == "next"] if doc else []
    check(len(nxt) == 1 and "status=successful" in nxt[0] and "offset=1" in nxt[0], f"next link keeps the filter: {nxt}")

    d.request("GET", "/jobs?access_token=SECRET-in-url&limit=1", None, AUTH)
    d.request("GET", "/jobs?limit=1&api_key=SECRET2", None, AUTH)
    d.logged(lambda line: "api_key=" in line)  # the second request's line
    logged = [line for line in d.log if "/jobs?" in line]
    check(logged and not any("SECRET" in line for line in d.log), f"tokens in URLs are not logged: {logged[-2:]}")
    check(any("access_token=REDACTED" in line for line in logged), f"the redaction shows: {logged[-2:]}")
    status, _, _ = d.request("GET", "/jobs?access_token=" + TOKEN)
    check(status == 401, f"a token in the URL does not authenticate: {status}")

    # 503 with Retry-After: one worker, no queue, a long job running.
    status, _, payload = post(d, body(demo, resolution=8), {"Prefer": "respond-async"})
    long_job = (strict_json(payload, "long job") or {}).get("jobID")
    status, h, payload = post(d, body(demo, resolution=500))
    check(status == 503 and h.get("retry-after", "").isdigit(), f"503 carries Retry-After: {status} {h}")
    if long_job:
        d.request("DELETE", f"/jobs/{long_job}", None, AUTH)
        wait_job(d, long_job)
    # A dismissed job is "dismissed" at once; its worker is free once the cancellation lands.
    end = time.time() + 30
    while time.time() < end and (strict_json(get(d, "/health")[2], "health") or {}).get("jobs", {}).get("running"):
        time.sleep(0.02)

    # The job's own peak memory: a small job after a large one does not report the large one's.
    big = post(d, body(demo, resolution=20))
    small = post(d, body(demo, resolution=2000))
    peaks = []
    for status, _, payload in (big, small):
        check(status == 200, f"peak job: {status} {payload[:200]}")
        doc = strict_json(payload, "peak job")
        job = doc["ownership"]["href"].split("/jobs/")[1].split("/")[0] if status == 200 else None
        report = strict_json(get(d, f"/jobs/{job}/results/report")[2], "peak report") if job else {}
        peaks.append(report.get("peak_memory_bytes", -1))
    check(peaks[0] > 40 * MIB and 0 <= peaks[1] < 16 * MIB and peaks[1] < peaks[0] / 4,
          f"peak_memory_bytes is the job's: large {peaks[0] / MIB:.1f} MiB, small {peaks[1] / MIB:.1f} MiB")

    # A 700 KB crs is not echoed.
    status, _, payload = post(d, body(demo, crs="PROJCS[" + "W" * 700_000))
    check(status == 400 and len(payload) < 4096, f"a 700 KB crs: 400 with a short answer ({len(payload)} bytes)")

    # Seeds at +-1e308: a clear refusal, not "margin must be a non-negative number".
    huge = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"state": "N"}, "geometry": {"type": "Point", "coordinates": [1e308, 1e308]}},
        {"type": "Feature", "properties": {"state": "S"}, "geometry": {"type": "Point", "coordinates": [-1e308, -1e308]}}]}
    for crs in ("EPSG:3857", None):
        b = body(huge, resolution=1000)
        if crs:
            b["inputs"]["crs"] = crs
        status, _, payload = post(d, b)
        doc = strict_json(payload, "1e308")
        detail = (doc or {}).get("detail", "")
        check(status == 400 and "margin" not in detail and ("beyond" in detail), f"seeds at 1e308 ({crs}): {status} {detail}")

    # Points at both poles, no extent: the default grid stops at +-90.
    poles = {"type": "FeatureCollection", "features": [
        {"type": "Feature", "properties": {"state": "N"}, "geometry": {"type": "Point", "coordinates": [0, 90]}},
        {"type": "Feature", "properties": {"state": "S"}, "geometry": {"type": "Point", "coordinates": [10, -90]}}]}
    status, _, payload = post(d, body(poles, resolution=1))
    doc = strict_json(payload, "poles")
    check(status == 200, f"points at both poles compute: {status} {doc}")
    if status == 200:
        job = doc["ownership"]["href"].split("/jobs/")[1].split("/")[0]
        report = strict_json(get(d, f"/jobs/{job}/results/report")[2], "poles report")
        g = report["grid"]
        check(g["ymin"] >= -90 and g["ymax"] <= 90 and g["ymax"] - g["ymin"] >= 179, f"grid within the poles: {g}")
    alive(d, "small ones")
    d.stop()
    print(f"small ones: ok ({time.time() - t0:.1f} s)", flush=True)


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for section in (invalid_utf8, compressed_uploads, descriptors, small_ones):
            try:
                section(tmp)
            except Exception as e:  # a section that crashes is a failure, the others still run
                check(False, f"{section.__name__} raised {type(e).__name__}: {e}")
    if FAILURES:
        print(f"{len(FAILURES)} failure(s)")
        sys.exit(1)
    print("all hostile checks passed")


if __name__ == "__main__":
    main()
