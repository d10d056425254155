"""The shared service (issue 55): three daemons on one PostgreSQL queue and one results storage.

Started here: a PostgreSQL 15 server (postgres_harness.py), an S3 server (s3rver, s3_harness.py)
with --storage s3 or a results folder (results_shared) with --storage folder, three
`rvoronoi serve` daemons with one engine thread each sharing them, and a fourth daemon on its own
SQLite store, the one-daemon reference. The scenario, each step checked as it ends:
  1. 120 asynchronous jobs from three principals, submitted round the daemons: every one
     successful, claimed by every daemon, its rasters and lines byte for byte the reference's,
     read from a daemon other than the one it was submitted to; no principal sees another's job;
     a damaged upload fails where it is claimed, its message naming seeds[0] as the client knows it;
     then one daemon restarted with its disk below limits.min_free_disk_bytes: it claims none of
     the queue's jobs (the other two run them), refuses a job to run on itself with 503, and its
     /health says "degraded";
  2. kill -9 of the daemon running a job: the job's lease expires, another daemon runs it again
     (attempt 2), and its results equal the reference's; the killed daemon comes back with a fresh
     worker id; a daemon stopped by SIGTERM hands its running job back at once (not counted as an
     attempt), and another daemon runs it;
  3. PostgreSQL stopped for 10 s, then started again: every daemon answers /health (the store
     unreachable), requests that need the store get 503 with Retry-After, and jobs submitted
     before finish afterwards;
  4. a dismissal, on one daemon, of a job running on another: the holder cancels within a
     heartbeat, publishes nothing, and its files go;
  5. an edit (baseJob) run on a daemon other than the one that ran its base: equal to the
     reference's edit;
  6. a live session held by one daemon: another answers its requests with a pointer to the holder's
     address (announced in the store), not a redirect; a job saved from it is served by any daemon;
  7. limits per principal across daemons: a third job on a third daemon past two unfinished (429),
     an hour's cells used up by jobs of other daemons (429 with the Retry-After of the hour);
     (the daemons restarted with retention_s 30 and jobs.split_cells 3.6e6)
  8. a split job (the issue's step 5): a job of 59 million cells cut into 17 bands of 512 rows,
     claimed by all three daemons, assembled by one, its rasters and lines byte for byte the
     one-daemon run's, its bands' files gone after, the bands never listed as jobs;
  9. retention: step 1's jobs go, rows and files;
and at the end: every job ended once (none accepted or running, every failure with a reason),
the sweep leaves no folder no job names (a planted one included) and only each job's published
attempt, and the daemons still standing answered /health throughout.

On a bucket, one step more after step 3: the S3 server stopped while a job runs fails that job
with the storage's message (nothing of it is served), a submission meanwhile gets 503 with
Retry-After, /health says the results storage is unreachable (and "ok" again once it is back),
and jobs run again once it is back.

Before them: a store that cannot be reached, a local results folder not said to be shared and a
password in the URI each stop the daemon with one line.

By default the scenario runs twice: whole on a bucket, then on a folder with 12 jobs, an edit, a
split job, retention and the sweep (the steps that test the store or the daemons alone, 2, 3, 4,
6 and 7, run on the bucket only; the daemons are restarted for split jobs and retention instead).

usage: test_shared_service.py RVORONOI SOURCE_DIR [--storage both|s3|folder] [--jobs N] [--split-resolution M]
"""
import hashlib
import json
import os
import shutil
import sys
import tempfile
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "daemon"))
from daemon_harness import Daemon  # noqa: E402
from postgres_harness import Postgres  # noqa: E402

import argparse  # noqa: E402

_args = argparse.ArgumentParser()
_args.add_argument("rvoronoi")
_args.add_argument("source")
_args.add_argument("--storage", choices=["both", "s3", "folder"], default="both")
_args.add_argument("--jobs", type=int, default=120)
_args.add_argument("--split-resolution", type=float, default=6.0)
_args.add_argument("--split-cells", type=int, default=3_600_000)
_args.add_argument("--split-outputs", default="ownership,distance,boundaries")
ARGS = _args.parse_args()
RVORONOI = ARGS.rvoronoi
SOURCE = ARGS.source
FAILURES = []
STARTED = []  # every daemon started, in order: their logs are kept beside the files on a failure
TOKENS = {"alice": "alice-token-shared-1", "bob": "bob-token-shared-2", "carol": "carol-token-shared-3",
          "root": "root-token-shared-4", "dave": "dave-token-shared-5"}
USERS = ["alice", "bob", "carol"]
SPLIT_CELLS = ARGS.split_cells  # jobs.split_cells of the last steps' daemons: bands of 512 rows at 6 m


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL:", what, flush=True)


def started(daemon):
    STARTED.append(daemon)
    return daemon


def keep_logs(tmp):
    """Each daemon's stderr (its event log) as logs/<n>-<data folder>.log under `tmp`."""
    os.makedirs(os.path.join(tmp, "logs"), exist_ok=True)
    for n, d in enumerate(STARTED):
        name = f"{n:02d}-{os.path.basename(d.config_path)[:-len('.config.json')]}.log"
        with open(os.path.join(tmp, "logs", name), "w") as f:
            f.writelines(list(d.log))


def bearer(name):
    return {"Authorization": f"Bearer {TOKENS[name]}"}


def auth_config():
    return {"principals": [{"name": n, "role": "admin" if n == "root" else "user",
                            "token_sha256": hashlib.sha256(t.encode()).hexdigest()} for n, t in TOKENS.items()]}


def body(resolution, outputs=("ownership", "distance", "boundaries"), seeds=None, base=None):
    fc = seeds or json.load(open(os.path.join(SOURCE, "fixtures", "demo_basepoints.geojson")))
    inputs = {"seeds": fc, "ownerField": "state", "resolution": resolution}
    if base:
        inputs["baseJob"] = base
    out = {o: {} for o in outputs}
    out["report"] = {}
    return {"inputs": inputs, "outputs": out}


class FolderStorage:
    """Results in a folder every daemon mounts."""

    def __init__(self, tmp):
        self.root = os.path.join(tmp, "results")
        self.env = {}
        self.config = {"results": self.root, "results_shared": True}

    def parts(self):
        """{job id: the names directly below it}, as the storage holds them now."""
        if not os.path.isdir(self.root):
            return {}
        return {n: set(os.listdir(os.path.join(self.root, n))) for n in os.listdir(self.root)}

    def plant(self, name):
        os.makedirs(os.path.join(self.root, name, "1"))

    def close(self):
        pass


class BucketStorage:
    """Results in a bucket of an S3 server, below a prefix."""

    def __init__(self, tmp):
        from s3_harness import S3
        self.s3 = S3()
        self.env = self.s3.env
        self.config = {"results": f"s3://{self.s3.bucket}/jobs"}

    def parts(self):
        out = {}
        for key in self.s3.keys("jobs"):
            job, _, rest = key.partition("/")
            out.setdefault(job, set()).add(rest.split("/")[0])
        return out

    def plant(self, name):
        from osgeo import gdal
        for k, v in self.env.items():
            gdal.SetConfigOption(k, v)
        f = gdal.VSIFOpenL(f"/vsis3/{self.s3.bucket}/jobs/{name}/1/ownership.tif", "wb")
        gdal.VSIFWriteL(b"planted", 1, 7, f)
        gdal.VSIFCloseL(f)

    def close(self):
        self.s3.close()


class Cluster:
    def __init__(self, tmp, pg, storage):
        self.tmp, self.pg, self.storage = tmp, pg, storage
        self.daemons = [self.start(i) for i in range(3)]
        self.down = set()  # indices deliberately stopped

    def start(self, i, limits=None, retention_s=None):
        config = {"limits": limits or {}, "store": self.pg.uri(), "store_password_file": self.pg.password_file,
                  **self.storage.config, "daemon_name": f"d{i}", "auth": auth_config(),
                  "jobs": {"workers": 1, "threads_per_job": 1, "poll_s": 0.5, "lease_s": 3, "retry_backoff_s": 0.5,
                           "queue_length": 1000, "orphan_grace_s": 2, "job_timeout_s": 600,
                           "shutdown_grace_s": 0.5}}
        if retention_s:  # the restart for the last steps: retention, and split jobs
            config["jobs"]["retention_s"] = retention_s
            config["jobs"]["split_cells"] = SPLIT_CELLS
        return started(Daemon([RVORONOI, "serve"], os.path.join(self.tmp, f"d{i}"), config, env=self.storage.env))

    def holder(self, job, seconds=60):
        """The index of the daemon that claimed `job` last (from its log)."""
        end = time.time() + seconds
        while time.time() < end:
            found = None
            for i, d in enumerate(self.daemons):
                for line in list(d.log):
                    if '"event":"claimed"' in line and job in line:
                        found = i
            if found is not None:
                return found
            time.sleep(0.02)
        raise AssertionError(f"no daemon claimed {job}")

    def claims(self, i):
        return sum('"event":"claimed"' in line for line in list(self.daemons[i].log))


def slow(finer=0):
    """The resolution of a job that runs long enough to be caught running. On a bucket the upload of
    its kept field (8 bytes a cell) takes longer than its computation: coarser there."""
    return (5 if ARGS.storage == "s3" else 2) + finer


def submit(d, who, b):
    st, h, doc = d.json("POST", "/processes/voronoi/execution", b, dict(bearer(who), Prefer="respond-async"))
    check(st == 201, f"submission answered {st}: {doc}")
    return doc["jobID"] if st == 201 else None


def wait_done(d, job, who="root", seconds=180):
    end = time.time() + seconds
    doc = None
    while time.time() < end:
        st, _, doc = d.json("GET", f"/jobs/{job}", headers=bearer(who))
        if st == 200 and doc.get("status") not in ("accepted", "running"):
            return doc
        time.sleep(0.1)
    raise AssertionError(f"job {job} did not finish: {doc}")


def files(d, job, outputs, who="root"):
    out = {}
    for o in outputs:
        st, _, data = d.request("GET", f"/jobs/{job}/results/{o}", headers=bearer(who))
        check(st == 200, f"job {job} output {o}: {st}")
        out[o] = data
    return out


class Reference:
    """The one-daemon server of the SQLite store: what every shared result must equal."""

    def __init__(self, tmp):
        self.d = started(Daemon([RVORONOI, "serve"], os.path.join(tmp, "reference"), {"jobs": {"threads_per_job": 1}}))
        self.cache = {}

    def run(self, b, outputs):
        key = json.dumps(b, sort_keys=True)
        if key not in self.cache:
            st, _, doc = self.d.json("POST", "/processes/voronoi/execution", b, {"Prefer": "respond-async"})
            assert st == 201, doc
            done = wait_done(self.d, doc["jobID"])
            assert done["status"] == "successful", done
            self.cache[key] = (doc["jobID"], files(self.d, doc["jobID"], outputs))
        return self.cache[key]


def health_watch(cluster, stop, failures):
    while not stop.is_set():
        for i, d in enumerate(list(cluster.daemons)):
            if i in cluster.down or not d.alive():
                continue
            try:
                st, _, doc = d.json("GET", "/health", timeout=5)
                if st != 200:
                    failures.append((i, st))
            except Exception as e:  # noqa: BLE001 - any failure to answer counts
                if i not in cluster.down:
                    failures.append((i, repr(e)))
        time.sleep(0.25)


def step_refusals(tmp, pg):
    """Bad set-ups get one line and an exit code, before the daemon listens."""
    import subprocess
    from postgres_harness import free_port
    cases = [({"store": f"postgresql://rv@127.0.0.1:{free_port()}/postgres", "results": os.path.join(tmp, "r"),
               "results_shared": True}, 10, "the job store is unavailable"),
             ({"store": pg.uri(), "results": os.path.join(tmp, "r")}, 2, "results_shared"),
             ({"store": "postgresql://rv:hunter2@127.0.0.1/x", "results": "/r", "results_shared": True}, 2,
              "must not contain a password")]
    # A bucket on a server that is not there.
    dead = {"AWS_S3_ENDPOINT": f"127.0.0.1:{free_port()}", "AWS_HTTPS": "NO", "AWS_VIRTUAL_HOSTING": "FALSE",
            "AWS_ACCESS_KEY_ID": "K", "AWS_SECRET_ACCESS_KEY": "hunter3", "AWS_REGION": "us-east-1",
            "GDAL_HTTP_MAX_RETRY": "0"}
    cases.append(({"store": pg.uri(), "store_password_file": pg.password_file, "results": "s3://rv/jobs"}, 10,
                  "the results storage is unavailable"))
    for i, (config, code, words) in enumerate(cases):
        path = os.path.join(tmp, f"refused{i}.json")
        with open(path, "w") as f:
            json.dump(config, f)
        p = subprocess.run([RVORONOI, "serve", "--listen", "127.0.0.1:0", "--data-dir", os.path.join(tmp, f"x{i}"),
                            "--config", path], capture_output=True, text=True, timeout=60,
                           env=dict(os.environ, **dead))
        lines = p.stderr.strip().splitlines()
        check(p.returncode == code and len(lines) == 1 and words in lines[0] and "hunter" not in p.stderr,
              f"refused set-up {i}: exit {p.returncode}, {p.stderr!r}")


def step_many_jobs(c, ref):
    outputs = ["ownership", "distance", "boundaries"]
    resolutions = [4000, 3000, 5000, 2500]
    jobs = []
    t0 = time.time()
    for i in range(ARGS.jobs):
        who = USERS[i % 3]
        b = body(resolutions[i % 4])
        jobs.append((submit(c.daemons[i % 3], who, b), who, b, i % 3))
    docs = {job: wait_done(c.daemons[0], job) for job, _, _, _ in jobs}
    print(f"step 1: {ARGS.jobs} jobs done in {time.time() - t0:.1f} s; claims per daemon "
          f"{[c.claims(i) for i in range(3)]}", flush=True)
    check(all(d["status"] == "successful" for d in docs.values()),
          f"every job successful: {[d.get('message') for d in docs.values() if d['status'] != 'successful']}")
    check(all(c.claims(i) > 0 for i in range(3)), "every daemon claimed jobs")
    for job, who, b, at in jobs:
        _, expected = ref.run(b, outputs)
        got = files(c.daemons[(at + 1) % 3], job, outputs, who)
        for o in outputs:
            check(got[o] == expected[o], f"job {job} output {o} equals the one-daemon run's")
    # Ranges, as a COG is read, from a daemon that neither took nor ran the job.
    job, who, b, at = jobs[0]
    _, expected = ref.run(b, outputs)
    whole = expected["ownership"]
    st, h, data = c.daemons[(at + 2) % 3].request("GET", f"/jobs/{job}/results/ownership",
                                                  headers=dict(bearer(who), Range="bytes=100-611"))
    check(st == 206 and data == whole[100:612] and h.get("content-range") == f"bytes 100-611/{len(whole)}",
          f"a range of a result: {st} {h.get('content-range')}")
    st, h, data = c.daemons[(at + 1) % 3].request("GET", f"/jobs/{job}/results/ownership",
                                                  headers=dict(bearer(who), Range=f"bytes=-{len(whole) // 3}"))
    check(st == 206 and data == whole[-(len(whole) // 3):], f"a suffix range of a result: {st}")
    # No principal sees another's job.
    st, _, mine = c.daemons[1].json("GET", "/jobs?limit=1000", headers=bearer("alice"))
    hers = (ARGS.jobs + 2) // 3
    check(st == 200 and len(mine["jobs"]) == hers and all(j.get("principal", "alice") == "alice" for j in mine["jobs"]),
          f"alice lists her {hers} jobs only: {len(mine.get('jobs', []))}")
    # A damaged upload fails on whichever daemon claims it, named as the client knows it.
    import base64
    damaged = body(4000)
    damaged["inputs"]["seeds"] = {"value": base64.b64encode(b"SQLite format 3\0" + b"\x07" * 5000).decode(),
                                  "mediaType": "application/geopackage+sqlite3", "encoding": "base64"}
    bad = submit(c.daemons[0], "carol", damaged)
    doc = wait_done(c.daemons[1], bad, "carol")
    check(doc["status"] == "failed" and doc.get("message", "").startswith("input 'seeds': seeds[0]") and
          "/vsimem" not in doc.get("message", ""), f"a damaged upload's failure names seeds[0]: {doc.get('message')}")
    bobs = next(job for job, who, _, _ in jobs if who == "bob")
    for path in (f"/jobs/{bobs}", f"/jobs/{bobs}/results", f"/jobs/{bobs}/results/ownership"):
        st, _, _ = c.daemons[2].request("GET", path, headers=bearer("alice"))
        check(st == 404, f"alice gets 404 for bob's {path}: {st}")
    return [job for job, _, _, _ in jobs]


def step_disk_floor(c):
    """A daemon whose disk is below limits.min_free_disk_bytes claims nothing from the shared queue
    (the others run every job), refuses a job to run on itself with 503, and says so on /health;
    then it is restarted with the default floor (the split step counts its claims again)."""
    c.down.add(2)
    c.daemons[2].stop()
    fs = os.statvfs(c.tmp)
    floor = fs.f_bavail * fs.f_frsize + (1 << 30)  # above what is free, on any disk
    c.daemons[2] = c.start(2, {"min_free_disk_bytes": floor})
    c.down.discard(2)
    low = c.daemons[2]
    st, _, health = low.json("GET", "/health")
    check(st == 200 and health.get("status") == "degraded" and health.get("disk", {}).get("low") is True,
          f"/health of the daemon short of disk: {st} {health}")
    kind = "s3" if ARGS.storage == "s3" else "folder"
    check(health.get("results") == {"kind": kind, "reachable": True}, f"/health's results storage: {health}")
    jobs = [submit(c.daemons[i % 2], USERS[i % 3], body(4000, outputs=("ownership",))) for i in range(6)]
    # (Its workers keep polling the queue meanwhile: every poll is a chance to claim.)
    docs = [wait_done(c.daemons[0], job) for job in jobs if job]
    check(len(docs) == 6 and all(d["status"] == "successful" for d in docs),
          f"the queue's jobs ran on the other daemons: {[d.get('message') for d in docs]}")
    check(c.claims(2) == 0, f"the daemon short of disk claimed nothing: {c.claims(2)} claims")
    check(low.logged(lambda line: '"event":"disk_low"' in line), "it logged that its disk is low")
    st, h, doc = low.json("POST", "/processes/voronoi/execution", body(4000, outputs=("ownership",)),
                          bearer("root"))
    check(st == 503 and "retry-after" in h and "min_free_disk_bytes" in (doc or {}).get("detail", ""),
          f"a synchronous job on the daemon short of disk: {st} {doc}")
    c.down.add(2)
    low.stop()
    c.daemons[2] = c.start(2)
    c.down.discard(2)
    print(f"disk floor: 6 jobs done by d0 and d1 while d2 was short of disk; claims "
          f"{[c.claims(i) for i in range(3)]}", flush=True)


def step_kill(c, ref):
    b = body(slow(), outputs=("ownership",))
    job = submit(c.daemons[0], "alice", b)
    h = c.holder(job)
    time.sleep(0.3)
    c.down.add(h)
    c.daemons[h].kill9()
    print(f"step 2: killed d{h} running {job}", flush=True)
    survivor = c.daemons[(h + 1) % 3]
    doc = wait_done(survivor, job, "alice")
    check(doc["status"] == "successful", f"the killed daemon's job ran again: {doc}")
    rows = c.pg.psql(f"SELECT attempt, results FROM rv_jobs WHERE id = '{job}'")
    check(rows and rows[0][0] == "2" and rows[0][1] == f"{job}/2", f"attempt 2 published: {rows}")
    _, expected = ref.run(b, ["ownership"])
    check(files(survivor, job, ["ownership"], "alice")["ownership"] == expected["ownership"],
          "the rerun's raster equals the one-daemon run's")
    c.daemons[h] = c.start(h)
    c.down.discard(h)
    # SIGTERM instead: the daemon hands its running job back at once (not counted as an attempt).
    job2 = submit(c.daemons[1], "bob", b)
    h2 = c.holder(job2)
    time.sleep(0.3)
    c.down.add(h2)
    check(c.daemons[h2].stop() == 0, "a daemon stops cleanly on SIGTERM with a job running")
    doc = wait_done(c.daemons[(h2 + 1) % 3], job2, "bob")
    rows = c.pg.psql(f"SELECT attempt, max_attempts, results FROM rv_jobs WHERE id = '{job2}'")
    check(doc["status"] == "successful" and rows and rows[0][0] == "2" and rows[0][1] == "4",
          f"the job handed back on SIGTERM ran again, not counted against its attempts: {doc['status']} {rows}")
    check(files(c.daemons[(h2 + 2) % 3], job2, ["ownership"], "bob")["ownership"] == expected["ownership"],
          "the handed-back job's raster equals the one-daemon run's")
    c.daemons[h2] = c.start(h2)
    c.down.discard(h2)
    return [job, job2]


def step_store_outage(c, ref):
    b = body(1000)
    jobs = [submit(c.daemons[i % 3], USERS[i % 3], b) for i in range(6)]
    slow_job = submit(c.daemons[0], "bob", body(slow(1), outputs=("ownership",)))
    c.pg.stop()
    t0 = time.time()
    time.sleep(1.5)
    for i, d in enumerate(c.daemons):
        st, _, doc = d.json("GET", "/health")
        check(st == 200, f"d{i} answers /health while the store is away: {st}")
    time.sleep(2.0)
    st, _, doc = c.daemons[1].json("GET", "/health")
    check(doc.get("store") == {"kind": "postgresql", "reachable": False}, f"/health says the store is away: {doc}")
    st, h, doc = c.daemons[2].json("GET", f"/jobs/{jobs[0]}", headers=bearer("alice"))
    check(st == 503 and "retry-after" in h, f"a job's status while the store is away: {st} {h.get('retry-after')}")
    st, h, doc = c.daemons[2].json("POST", "/processes/voronoi/execution", b, dict(bearer("alice"), Prefer="respond-async"))
    check(st == 503 and "retry-after" in h, f"a submission while the store is away: {st} {doc}")
    time.sleep(max(0.0, 10 - (time.time() - t0)))
    c.pg.start()
    print("step 3: the store was away for 10 s", flush=True)
    for job, who in zip(jobs + [slow_job], USERS * 2 + ["bob"]):
        doc = wait_done(c.daemons[1], job, who)
        check(doc["status"] == "successful", f"job {job} finished after the outage: {doc}")
    _, expected = ref.run(b, ["ownership", "distance", "boundaries"])
    got = files(c.daemons[2], jobs[0], ["ownership"], "alice")
    check(got["ownership"] == expected["ownership"], "a job of the outage equals the one-daemon run's")
    st, _, doc = c.daemons[0].json("GET", "/health")
    check(doc.get("store", {}).get("reachable") is True, f"/health says the store is back: {doc}")
    return jobs + [slow_job]


def results_health(d, reachable, seconds=20):
    """/health once its results storage's reachability is `reachable` (the sweep probes every
    min(60 s, orphan_grace_s): 2 s here), or the last answer."""
    end = time.time() + seconds
    doc = {}
    while time.time() < end:
        _, _, doc = d.json("GET", "/health", timeout=5)
        if isinstance(doc, dict) and doc.get("results", {}).get("reachable") is reachable:
            return doc
        time.sleep(0.2)
    return doc if isinstance(doc, dict) else {}


def step_storage_outage(c, ref):
    """The S3 server away while a job runs: the job fails with the storage's message."""
    job = submit(c.daemons[1], "bob", body(slow(1), outputs=("ownership",)))
    h = c.holder(job)
    end = time.time() + 60
    while time.time() < end:  # running, its request read: the storage goes away under its computation
        st, _, doc = c.daemons[h].json("GET", f"/jobs/{job}", headers=bearer("bob"))
        if doc.get("progress", 0) > 0 or doc.get("status") not in ("accepted", "running"):
            break
        time.sleep(0.05)
    s3 = c.storage.s3
    s3.stop()
    st, h2, doc = c.daemons[(h + 1) % 3].json("POST", "/processes/voronoi/execution", body(1000),
                                              dict(bearer("alice"), Prefer="respond-async"))
    check(st == 503 and "retry-after" in h2 and "results storage is unavailable" in doc.get("detail", ""),
          f"a submission while the storage is away: {st} {doc}")
    away = results_health(c.daemons[(h + 2) % 3], False)
    check(away.get("results") == {"kind": "s3", "reachable": False} and away.get("status") == "degraded",
          f"/health says the results storage is away: {away}")
    doc = wait_done(c.daemons[h], job, "bob")
    check(doc["status"] == "failed" and "could not be stored" in doc.get("message", ""),
          f"the job whose upload failed says why: {doc['status']} {doc.get('message')}")
    st, _, data = c.daemons[(h + 2) % 3].request("GET", f"/jobs/{job}/results/ownership", headers=bearer("bob"))
    check(st != 200 and b"could not be stored" in data, f"nothing of it is served, the failure instead: {st} {data[:200]}")
    check(not any(p.isdigit() for p in c.storage.parts().get(job, ())), "no attempt of it stays in the bucket")
    s3.start()
    time.sleep(0.5)
    back = results_health(c.daemons[(h + 2) % 3], True)
    check(back.get("results", {}).get("reachable") is True and back.get("status") == "ok",
          f"/health says the results storage is back: {back}")
    check(c.daemons[(h + 2) % 3].logged(lambda line: '"event":"results_unreachable"' in line),
          "the daemon logged the storage away")
    print(f"step 3b: the S3 server was stopped under d{h}'s job; it failed with: {doc.get('message')}", flush=True)
    b = body(1000)
    again = submit(c.daemons[0], "alice", b)
    check(wait_done(c.daemons[2], again, "alice")["status"] == "successful", "jobs run again once the storage is back")
    _, expected = ref.run(b, ["ownership", "distance", "boundaries"])
    check(files(c.daemons[1], again, ["ownership"], "alice")["ownership"] == expected["ownership"],
          "a job after the storage outage equals the one-daemon run's")
    return [job, again]


def step_dismiss(c):
    job = submit(c.daemons[0], "carol", body(1, outputs=("ownership",)))
    h = c.holder(job)
    time.sleep(0.5)
    other = (h + 1) % 3
    t0 = time.time()
    st, _, doc = c.daemons[other].json("DELETE", f"/jobs/{job}", headers=bearer("carol"))
    check(st == 200 and doc.get("status") == "dismissed", f"dismissed on d{other}: {st} {doc}")
    end = time.time() + 5
    ended = False
    while time.time() < end and not ended:
        ended = any('"event":"job"' in line and job in line for line in list(c.daemons[h].log))
        time.sleep(0.05)
    print(f"step 4: d{h} stopped the dismissed job after {time.time() - t0:.2f} s", flush=True)
    check(ended, f"the holder d{h} stopped the job within a heartbeat")
    time.sleep(1)
    doc = wait_done(c.daemons[h], job, "carol")
    check(doc["status"] == "dismissed", f"the job stays dismissed: {doc}")
    check(job not in c.storage.parts(), "the dismissed job's files are gone")
    return [job]


def step_edit(c, ref):
    fc = json.load(open(os.path.join(SOURCE, "fixtures", "demo_basepoints.geojson")))
    b = body(500, outputs=("ownership", "boundaries"), seeds=fc)
    base = submit(c.daemons[0], "alice", b)
    check(wait_done(c.daemons[0], base, "alice")["status"] == "successful", "the base job")
    h = c.holder(base)
    moved = json.loads(json.dumps(fc))
    moved["features"][0]["geometry"]["coordinates"][0] += 700.0
    other = (h + 1) % 3
    eb = body(500, outputs=("ownership", "boundaries"), seeds=moved, base=base)
    # Synchronous: it runs on the daemon that takes it, not the one that ran its base.
    st, _, doc = c.daemons[other].json("POST", "/processes/voronoi/execution", eb, bearer("alice"), timeout=300)
    check(st == 200, f"the edit on d{other} (its base ran on d{h}): {st} {doc}")
    ref_base, _ = ref.run(b, ["ownership", "boundaries"])
    rb = json.loads(json.dumps(eb))
    rb["inputs"]["baseJob"] = ref_base
    _, expected = ref.run(rb, ["ownership", "boundaries"])
    st, _, listing = c.daemons[other].json("GET", "/jobs?limit=1", headers=bearer("alice"))
    edit = listing["jobs"][0]["jobID"]
    got = files(c.daemons[h], edit, ["ownership", "boundaries"], "alice")
    for o in ("ownership", "boundaries"):
        check(got[o] == expected[o], f"the edit's {o} equals the one-daemon edit's")
    return [base, edit]


def step_session_pointer(c):
    """A live session stays on its daemon; another daemon points there (no redirect)."""
    b = body(1000, outputs=("boundaries",))
    del b["outputs"]["report"]
    st, _, doc = c.daemons[0].json("POST", "/sessions", b, bearer("alice"))
    check(st == 201, f"a session on d0: {st} {doc}")
    if st != 201:
        return
    sid = doc["sessionID"]
    check(sid.startswith("d0."), f"the session id names its daemon: {sid}")
    time.sleep(1.2)  # a heartbeat announces d0's address
    st, h, doc = c.daemons[1].json("GET", f"/sessions/{sid}", headers=bearer("alice"))
    url = f"http://127.0.0.1:{c.daemons[0].port}/sessions/{sid}"
    check(st == 404 and "location" not in h and url in doc.get("detail", ""),
          f"d1 points to d0 for its session: {st} {doc}")
    st, _, doc = c.daemons[0].json("GET", f"/sessions/{sid}", headers=bearer("alice"))
    check(st == 200 and doc.get("status") == "ready", f"d0 holds it: {st}")
    # A job saved from the session runs on its daemon, and is any daemon's to serve.
    st, _, doc = c.daemons[0].json("POST", f"/sessions/{sid}/jobs", {"outputs": {"ownership": {}}},
                                   dict(bearer("alice"), Prefer="respond-async"))
    check(st == 201, f"a job saved from the session: {st} {doc}")
    if st == 201:
        job = doc["jobID"]
        check(wait_done(c.daemons[2], job, "alice")["status"] == "successful", "the session's job succeeded")
        st, _, data = c.daemons[2].request("GET", f"/jobs/{job}/results/ownership", headers=bearer("alice"))
        check(st == 200 and data[:2] in (b"II", b"MM"), f"d2 serves the session's job: {st}")
    c.daemons[0].json("DELETE", f"/sessions/{sid}", headers=bearer("alice"))


def step_limits(c):
    """A principal's limits count its jobs on every daemon (the counters are the store's)."""
    c.down.update(range(3))  # restarted on purpose with the limits
    for d in c.daemons:
        d.stop()
    c.daemons = [c.start(i, {"jobs_per_principal": 2, "cells_per_principal_per_hour": 3_000_000}, retention_s=30)
                 for i in range(3)]
    c.down.clear()
    b = body(1, outputs=("ownership",))
    b["inputs"]["extent"] = [340000, 6150000, 341000, 6151000]  # 1e6 cells, known up front
    first = submit(c.daemons[0], "dave", b)
    second = submit(c.daemons[1], "dave", b)
    st, h, doc = c.daemons[2].json("POST", "/processes/voronoi/execution", b, dict(bearer("dave"), Prefer="respond-async"))
    check(st == 429 and "retry-after" in h and "2 jobs queued or running" in doc.get("detail", ""),
          f"dave's third job on a third daemon: {st} {doc}")
    for job in (first, second):
        check(wait_done(c.daemons[2], job, "dave")["status"] == "successful", f"dave's job {job}")
    check(submit(c.daemons[2], "dave", b) is not None, "dave's third million cells fit the hour")
    st, h, doc = c.daemons[0].json("POST", "/processes/voronoi/execution", b, dict(bearer("dave"), Prefer="respond-async"))
    check(st == 429 and int(h.get("retry-after", "0")) > 60 and "cells per hour" in doc.get("detail", ""),
          f"a fourth million over the hour's 3e6, on another daemon: {st} {h.get('retry-after')} {doc}")


def step_split(c, ref):
    """A job above jobs.split_cells: its bands computed on every daemon, assembled byte for byte."""
    outputs = tuple(ARGS.split_outputs.split(","))
    res = ARGS.split_resolution  # 6 m: 7010 x 8410 cells, 17 bands of 512 rows (the last 218)
    b = body(res, outputs=outputs)
    width, height = round(42060 / res), round(50460 / res)  # demo_basepoints' grid
    band_rows = max(1, SPLIT_CELLS // width // 256) * 256
    expected_bands = -(-height // band_rows)
    t0 = time.time()
    job = submit(c.daemons[0], "root", b)
    try:
        doc = wait_done(c.daemons[1], job, "root", seconds=180)
    except AssertionError:
        print("bands:", c.pg.psql(f"SELECT id, status, attempt, message, results FROM rv_jobs WHERE parent = '{job}'"))
        raise
    per = [sum('"event":"claimed"' in line and f'"band_of":"{job}"' in line for line in list(d.log)) for d in c.daemons]
    split_by = [i for i, d in enumerate(c.daemons) if any('"event":"split"' in x and job in x for x in list(d.log))]
    assembled_by = [i for i, d in enumerate(c.daemons)
                    if any('"event":"assembling"' in x and job in x for x in list(d.log))]
    print(f"step 5: a job of {width * height / 1e6:.0f} million cells split by d{split_by} in {sum(per)} bands, claimed per daemon {per}, "
          f"assembled by d{assembled_by}, done in {time.time() - t0:.1f} s", flush=True)
    check(doc["status"] == "successful", f"the split job succeeded: {doc.get('message')}")
    check(all(n > 0 for n in per), f"its bands landed on all three daemons: {per}")
    rows = c.pg.psql(f"SELECT status, count(*) FROM rv_jobs WHERE parent = '{job}' GROUP BY status")
    check(rows == [["successful", str(expected_bands)]],
          f"its {expected_bands} bands ended successful, once each: {rows}")
    _, expected = ref.run(b, list(outputs))
    got = files(c.daemons[2], job, outputs, "root")
    for o in outputs:
        check(got[o] == expected[o], f"the split job's {o} equals the one-daemon run's")
    check(not {n for n in c.storage.parts().get(job, ()) if n == "bands"}, "its bands' files went with the assembly")
    st, _, listing = c.daemons[0].json("GET", "/jobs?limit=1000", headers=bearer("root"))
    check(job in [j["jobID"] for j in listing.get("jobs", [])] and
          not any(j["jobID"] in [r[0] for r in c.pg.psql(f"SELECT id FROM rv_jobs WHERE parent = '{job}'")]
                  for j in listing.get("jobs", [])), "the job is listed, its bands are not")


def step_retention(c, early):
    """Jobs finished more than retention_s ago go, row, request and results."""
    end = time.time() + 60
    while time.time() < end and set(early) & set(c.storage.parts()):
        time.sleep(0.5)
    check(not set(early) & set(c.storage.parts()), "retention removed the early jobs' files")
    st, _, _ = c.daemons[1].json("GET", f"/jobs/{early[0]}", headers=bearer("root"))
    check(st == 404, f"an expired job is gone: {st}")
    rows = c.pg.psql("SELECT count(*) FROM rv_jobs WHERE id IN (" + ",".join(f"'{j}'" for j in early) + ")")
    check(rows == [["0"]], f"their rows are deleted: {rows}")


def final_checks(c, planted):
    # The last step's jobs may still run (a sanitizer build is slow): every job must end, in time.
    end = time.time() + 180
    while time.time() < end and c.pg.psql("SELECT count(*) FROM rv_jobs WHERE status IN ('accepted','running')") != [["0"]]:
        time.sleep(0.5)
    rows = c.pg.psql("SELECT status, count(*) FROM rv_jobs GROUP BY status ORDER BY status")
    print("final statuses:", rows, flush=True)
    check(not any(r[0] in ("accepted", "running") for r in rows), f"every job ended: {rows}")
    failed = c.pg.psql("SELECT id, message FROM rv_jobs WHERE status = 'failed' AND message = ''")
    check(not failed, f"every failure has a reason: {failed}")
    # The sweep: a folder no job names, and attempts a finished job does not name, go once untouched
    # for orphan_grace_s (2 s here); it runs every 2 s. Under a loaded machine (the suite runs two
    # tests at once on two cores) a pass can take longer than two periods: wait until nothing is
    # left for it, at most 60 s, then check.
    def leftovers():
        published = dict(c.pg.psql("SELECT id, results FROM rv_jobs"))
        return [name for name, subs in c.storage.parts().items()
                if name not in published or any(sub != "request.json" and published[name] != f"{name}/{sub}"
                                                 for sub in subs)]
    t0 = time.time()
    time.sleep(6)
    while time.time() < t0 + 60 and leftovers():
        time.sleep(0.5)
    print(f"the sweep left nothing after {time.time() - t0:.1f} s" if not leftovers()
          else "the sweep left files after 60 s", flush=True)
    parts = c.storage.parts()
    check(planted not in parts, "the planted orphan was swept")
    published = dict(c.pg.psql("SELECT id, results FROM rv_jobs"))
    # Retention (30 s in the folder pass) deletes a job's row and then its files, so a job that
    # expires between the two listings shows files without a row for a moment: such a name is gone
    # within the sweep's grace. A stray is a name still there after it (2 s, swept every 2 s).
    strays = [name for name in parts if name not in published]
    end = time.time() + 15
    while strays and time.time() < end:
        time.sleep(0.5)
        now = c.storage.parts()
        strays = [name for name in strays if name in now]
    for name in strays:
        check(False, f"stored files {name} name no job")
    for name, subs in parts.items():
        if name not in published:
            continue
        for sub in subs:
            check(sub == "request.json" or published[name] == f"{name}/{sub}",
                  f"job {name} keeps only its request and published attempt, not {sub}")


def restart_with_retention(c):
    """The daemons restarted with retention_s 30 (the folder pass, which skips step 7)."""
    c.down.update(range(3))
    for d in c.daemons:
        d.stop()
    c.daemons = [c.start(i, retention_s=30) for i in range(3)]
    c.down.clear()


def run_pass(tmp, ref, kind, jobs, full):
    """The scenario on one storage; `full` runs the steps that test the store alone too."""
    global ARGS
    ARGS.storage, ARGS.jobs = kind, jobs
    print(f"-- the scenario on {'an S3 bucket' if kind == 's3' else 'a shared folder'}, {jobs} jobs", flush=True)
    tmp = os.path.join(tmp, kind)
    os.makedirs(tmp)
    pg = Postgres()
    storage = None
    c = None
    stop = threading.Event()
    health_failures = []
    try:
        storage = (BucketStorage if kind == "s3" else FolderStorage)(tmp)
        if full:
            step_refusals(tmp, pg)
        c = Cluster(tmp, pg, storage)
        watcher = threading.Thread(target=health_watch, args=(c, stop, health_failures), daemon=True)
        watcher.start()
        planted = "ab" * 16
        storage.plant(planted)
        early = step_many_jobs(c, ref)
        step_disk_floor(c)
        if full:
            step_kill(c, ref)
            step_store_outage(c, ref)
        if kind == "s3":
            step_storage_outage(c, ref)
        if full:
            step_dismiss(c)
        step_edit(c, ref)
        if full:
            step_session_pointer(c)
            step_limits(c)
        else:
            restart_with_retention(c)
        step_split(c, ref)
        step_retention(c, early)
        final_checks(c, planted)
        stop.set()
        watcher.join()
        check(not health_failures, f"the standing daemons answered /health throughout: {health_failures[:5]}")
    finally:
        stop.set()
        for d in c.daemons if c else []:
            d.stop()
        pg.close()
        if storage:
            storage.close()


def main():
    tmp = tempfile.mkdtemp(prefix="rv-shared-")
    ref = None
    ended = False  # false when an exception ends the run: its files and logs are kept too
    try:
        ref = Reference(tmp)
        if ARGS.storage == "both":
            # The scenario on a bucket; on a folder the steps the storage changes, fewer jobs.
            run_pass(tmp, ref, "s3", ARGS.jobs, True)
            run_pass(tmp, ref, "folder", 12, False)
        else:
            run_pass(tmp, ref, ARGS.storage, ARGS.jobs, True)
        ended = True
    finally:
        if ref:
            ref.d.stop()
        if ended and not FAILURES:
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            keep_logs(tmp)
            print(f"{len(FAILURES)} failure(s); files kept in {tmp}, each daemon's log in {tmp}/logs", flush=True)
    if FAILURES:
        sys.exit(1)
    print("shared service: all checks passed")


if __name__ == "__main__":
    main()
