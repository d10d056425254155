#!/usr/bin/python3
"""Crash safety of the daemon (issue 8): SIGKILL while a job runs and while it writes its
results, and a full disk while writing; each time the store opens again, finished results are
served byte for byte, the interrupted job is failed (never left "running"), and no partial file
is ever served or left behind. And below limits.min_free_disk_bytes no job is taken at all.

Two daemons: `rvoronoi serve` itself (full disk), and rv_crash_daemon, the same server with a
test-only hook that holds a job at a chosen stage (tests/service/daemon/crash_daemon.cpp), so that the
SIGKILL lands where it must without racing a timer.

Full disk: the data directory on a 4 MiB tmpfs when this runs as root and may mount one (real
ENOSPC, for the job store too); otherwise (not root, or no CAP_SYS_ADMIN in a container) the
daemon runs with RLIMIT_FSIZE of 4 MiB (EFBIG), which any user may set, so this never skips.
RV_TEST_FULL_DISK=rlimit forces the second.

usage: test_crash.py RVORONOI CRASH_DAEMON SOURCE_DIR [--sanitized]
"""
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from daemon_harness import Daemon, wait_for_file  # noqa: E402

RVORONOI, CRASH_DAEMON, SOURCE = sys.argv[1], sys.argv[2], sys.argv[3]
# ASan/UBSan builds: the sanitizer's allocator takes no mallopt setting, so the daemon sets (and
# reports) none.
SANITIZED = "--sanitized" in sys.argv[4:]
FAILURES = []
DEMO = json.load(open(os.path.join(SOURCE, "fixtures", "demo_basepoints.geojson")))
CONFIG = {"http": {"request_timeout_s": 20},
          "jobs": {"workers": 1, "queue_length": 4, "threads_per_job": 2, "shutdown_grace_s": 1}}
ALL_OUTPUTS = {"ownership": {}, "distance": {}, "report": {"transmissionMode": "reference"}}
# The demo seeds at 15 m: about 2800 x 3400 cells, a distance raster of some 10 MiB compressed,
# written for long enough (hundreds of ms) to be caught in the middle.
BIG_RES = 15


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL:", what, flush=True)
    return condition


def job_body(resolution, outputs=ALL_OUTPUTS):
    return {"inputs": {"seeds": DEMO, "ownerField": "state", "resolution": resolution}, "outputs": outputs}


def submit_async(d, body):
    status, h, doc = d.json("POST", "/processes/voronoi/execution", body, {"Prefer": "respond-async"})
    if not check(status == 201, f"async submit: {status} {doc}"):
        raise SystemExit(1)
    return doc["jobID"]


def fetch_results(d, job):
    """Every output file of a successful job, as bytes."""
    files = {}
    for out in ("ownership", "distance", "report", "ownership.aux.xml"):
        status, _, body = d.request("GET", f"/jobs/{job}/results/{out}")
        check(status == 200, f"GET results/{out} of {job}: {status}")
        files[out] = body
    return files


def leftovers(root):
    """Temporary or partial files anywhere under the data directory (ours and GDAL's)."""
    found = []
    for dirpath, _, names in os.walk(root):
        for n in names:
            if ".tmp" in n or n.endswith(".ovr"):
                found.append(os.path.join(dirpath, n))
    return found


def expect_interrupted(d, job, data):
    st = d.wait_status(job, {"failed", "successful", "dismissed"}, 10)
    check(st["status"] == "failed", f"interrupted job {job} is failed after restart: {st['status']}")
    check("server stopped" in st["message"], f"interrupted job message: {st['message']}")
    status, _, _ = d.request("GET", f"/jobs/{job}/results/ownership")
    check(status >= 400, f"no result of the interrupted job is served: {status}")
    check(not os.path.exists(os.path.join(data, "jobs", job)), f"interrupted job {job}'s files are removed")
    _, _, running = d.json("GET", "/jobs?status=running")
    check(running["jobs"] == [], f"no job is left running: {running['jobs']}")


def is_partial_distance(jobdir, name):
    if not (name.startswith(".distance.tif.tmp-") and name.endswith(".tif")):
        return False
    try:
        return os.path.getsize(os.path.join(jobdir, name)) > 0
    except FileNotFoundError:
        return False


def pause_env(stage, pause_dir):
    shutil.rmtree(pause_dir, ignore_errors=True)
    os.makedirs(pause_dir)
    return {"RV_TEST_PAUSE_STAGE": stage, "RV_TEST_PAUSE_DIR": pause_dir}


def kill_during_compute_and_write(tmp):
    t0 = time.time()
    data = os.path.join(tmp, "data")
    pause = os.path.join(tmp, "pause")

    # A finished job, then SIGKILL of an idle daemon. Its first line reports what it set in the
    # allocator (limits.retained_free_bytes, default 1 GiB).
    d = Daemon([CRASH_DAEMON], data, CONFIG)
    check(d.startup.get("retained_free_bytes") == (0 if SANITIZED else 1 << 30),
          f"startup reports the allocator's setting: {d.startup}")
    status, _, doc = d.json("POST", "/processes/voronoi/execution", job_body(500))
    check(status == 200, f"first job: {status} {doc}")
    done = doc["ownership"]["href"].split("/jobs/")[1].split("/")[0]
    before = fetch_results(d, done)
    d.kill9()

    # (a) SIGKILL while a job computes.
    d = Daemon([CRASH_DAEMON], data, CONFIG, env=pause_env("compute", pause))
    computing = submit_async(d, job_body(200))
    check(wait_for_file(os.path.join(pause, "paused"), 60, d.proc), "the job reached the compute stage")
    check(d.wait_status(computing, {"running"}, 5)["status"] == "running", "held job is running")
    d.kill9()
    # A malloc tunable in the environment is the operator's: the daemon sets nothing.
    d = Daemon([CRASH_DAEMON], data, CONFIG, env={"GLIBC_TUNABLES": "glibc.malloc.arena_max=4"})
    check(d.startup.get("interrupted_jobs_failed") == 1, f"startup reports one interrupted job: {d.startup}")
    check(d.startup.get("retained_free_bytes") == 0, f"a malloc tunable leaves the allocator alone: {d.startup}")
    expect_interrupted(d, computing, data)
    check(fetch_results(d, done) == before, "finished results are identical after SIGKILL and restart")
    d.kill9()
    print(f"kill -9 while computing: ok ({time.time() - t0:.1f} s)", flush=True)

    # (b) SIGKILL in the write stage, after the ownership raster is complete and renamed into
    # place: a whole file of an unfinished job is not a result either.
    t1 = time.time()
    d = Daemon([CRASH_DAEMON], data, CONFIG, env=pause_env("write", pause))
    writing = submit_async(d, job_body(200))
    check(wait_for_file(os.path.join(pause, "paused"), 60, d.proc), "the job reached the write stage")
    check(os.path.exists(os.path.join(data, "jobs", writing, "ownership.tif")),
          "ownership.tif is in place while the job is still writing")
    status, _, problem = d.json("GET", f"/jobs/{writing}/results/ownership")
    check(status == 404 and "result-not-ready" in problem.get("type", ""),
          f"a running job's complete file is not served: {status} {problem}")
    d.kill9()
    d = Daemon([CRASH_DAEMON], data, CONFIG)
    expect_interrupted(d, writing, data)
    check(leftovers(data) == [], f"no temporary file is left: {leftovers(data)}")
    d.kill9()

    # (b) SIGKILL with the distance raster half written under its temporary name. The job is
    # held before that file is begun, released, and the daemon is frozen (SIGSTOP) the moment
    # the temporary file shows up, then killed: what is on disk then is a partial file.
    caught = None
    for attempt in range(3):
        d = Daemon([CRASH_DAEMON], data, CONFIG, env=pause_env("write", pause))
        job = submit_async(d, job_body(BIG_RES, {"ownership": {}, "distance": {}}))
        if not check(wait_for_file(os.path.join(pause, "paused"), 120, d.proc), "the big job reached the write stage"):
            break
        jobdir = os.path.join(data, "jobs", job)
        open(os.path.join(pause, "resume"), "w").close()
        end = time.time() + 60
        temp = None
        while time.time() < end and temp is None and d.alive():
            try:
                names = os.listdir(jobdir)
            except FileNotFoundError:
                names = []
            # The raster's own temporary file (GDAL's overview scratch file comes and goes
            # first), once it has some bytes.
            temp = next((n for n in names if is_partial_distance(jobdir, n)), None)
            if "distance.tif" in names:
                break
        if temp is not None:
            os.kill(d.pid, signal.SIGSTOP)
            names = os.listdir(jobdir)
            if "distance.tif" not in names and temp in names:
                caught = (job, {n: os.path.getsize(os.path.join(jobdir, n)) for n in names})
        d.kill9()  # SIGKILL ends a stopped process too
        d = Daemon([CRASH_DAEMON], data, CONFIG)
        expect_interrupted(d, job, data)
        check(leftovers(data) == [], f"no temporary file is left: {leftovers(data)}")
        check(fetch_results(d, done) == before, "finished results intact after a kill in the write stage")
        d.kill9()
        if caught:
            break
        print(f"attempt {attempt + 1}: the distance raster was renamed before the daemon could be frozen; again",
              flush=True)
    check(caught is not None, "the daemon was killed with a half-written distance raster on disk")
    if caught:
        print(f"killed with the job directory holding {caught[1]}", flush=True)
    print(f"kill -9 while writing: ok ({time.time() - t1:.1f} s)", flush=True)


def full_disk(tmp):
    t0 = time.time()
    mount = os.path.join(tmp, "small")
    os.makedirs(mount)
    mode = None
    # RV_TEST_FULL_DISK=rlimit runs the fallback where a tmpfs could be mounted.
    if os.geteuid() == 0 and os.environ.get("RV_TEST_FULL_DISK") != "rlimit":
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=4m,mode=0700", "tmpfs", mount],
                           capture_output=True, text=True)
        if r.returncode == 0:
            mode = "tmpfs"
        else:
            print(f"cannot mount a tmpfs ({r.stderr.strip()}); using RLIMIT_FSIZE", flush=True)
    limit = None
    if mode is None:
        mode = "rlimit"
        limit = 4 << 20
    data = os.path.join(mount, "data")

    def preexec():
        if limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    try:
        # (No floor of free space: this job must reach the full disk; disk_floor tests the floor.)
        d = Daemon([RVORONOI, "serve"], data, {**CONFIG, "limits": {"min_free_disk_bytes": 0}}, preexec_fn=preexec)
        status, _, small = d.json("POST", "/processes/voronoi/execution", job_body(2000))
        check(status == 200, f"a small job fits: {status} {small}")
        status, h, problem = d.json("POST", "/processes/voronoi/execution",
                                    job_body(BIG_RES, {"ownership": {}, "distance": {}}))
        check(status == 500 and isinstance(problem, dict) and problem.get("status") == 500,
              f"the job that fills the disk fails: {status} {problem}")
        job = h.get("link", "").split("/jobs/")[-1].split(">")[0]
        st = d.wait_status(job, {"failed", "successful"}, 10)
        message = st.get("message", "")
        check(st["status"] == "failed", f"full-disk job status: {st['status']}")
        reason = "No space left on device" if mode == "tmpfs" else "File too large"
        check(reason in message and "results" in message,
              f"the status says why ({reason!r}): {message!r}")
        check(str(data) not in message, f"the message does not reveal server paths: {message!r}")
        check(d.alive(), "the daemon survives a full disk")
        check(not os.path.exists(os.path.join(data, "jobs", job)), "the failed job's directory is removed")
        check(leftovers(data) == [], f"no partial file remains: {leftovers(data)}")
        status, _, _ = d.json("GET", "/health")
        check(status == 200, f"health after a full disk: {status}")
        status, _, again = d.json("POST", "/processes/voronoi/execution", job_body(2000))
        check(status == 200, f"the daemon keeps computing after a full disk: {status} {again}")
        first = small["ownership"]["href"].split("/jobs/")[1].split("/")[0]
        status, _, _ = d.request("GET", f"/jobs/{first}/results/ownership")
        check(status == 200, f"earlier results still served: {status}")
        code = d.stop()
        check(code == 0, f"clean SIGTERM exit after a full disk: {code}")
        print(f"full disk ({mode}): ok ({time.time() - t0:.1f} s); status message: {message}", flush=True)
    finally:
        if mode == "tmpfs":
            subprocess.run(["umount", "-l", mount], check=False)


def disk_floor(tmp):
    """Below limits.min_free_disk_bytes the daemon takes no job (503, Retry-After, nothing written)
    and /health says so; with the floor under the free space, the same job runs."""
    t0 = time.time()
    data = os.path.join(tmp, "floor")
    os.makedirs(data)
    fs = os.statvfs(data)
    free = fs.f_bavail * fs.f_frsize
    floor = free + (1 << 30)  # always above what is free, on any disk
    d = Daemon([RVORONOI, "serve"], data, {**CONFIG, "limits": {"min_free_disk_bytes": floor}})
    try:
        status, _, health = d.json("GET", "/health")
        disk = health.get("disk", {}) if isinstance(health, dict) else {}
        check(status == 200 and health.get("status") == "degraded", f"/health with the disk low: {status} {health}")
        check(disk.get("low") is True and disk.get("minFreeBytes") == floor, f"/health's disk: {disk}")
        check(isinstance(disk.get("freeBytes"), int) and abs(disk["freeBytes"] - free) < (1 << 30),
              f"/health's free bytes near statvfs's {free}: {disk}")
        for prefer in ({}, {"Prefer": "respond-async"}):
            status, h, problem = d.json("POST", "/processes/voronoi/execution", job_body(2000), prefer)
            detail = problem.get("detail", "") if isinstance(problem, dict) else ""
            check(status == 503 and h.get("content-type") == "application/problem+json",
                  f"a job with the disk below the floor is refused 503 ({prefer}): {status} {problem}")
            check("min_free_disk_bytes" in detail and "MiB free" in detail, f"the problem says why: {detail!r}")
            check("retry-after" in h, f"the refusal says when to retry: {h}")
            check(data not in detail, f"the problem names no server path: {detail!r}")
        _, _, jobs = d.json("GET", "/jobs")
        check(jobs.get("jobs") == [], f"no job recorded: {jobs}")
        jobs_dir = os.path.join(data, "jobs")
        left = os.listdir(jobs_dir) if os.path.isdir(jobs_dir) else []
        check(left == [], f"nothing written for the refused jobs: {left}")
        check(d.logged(lambda line: '"event":"disk_low"' in line), "the daemon logs that its disk is low")
    finally:
        check(d.stop() == 0, "clean SIGTERM exit with the disk low")
    # The same daemon with the floor at what a small disk still has: it computes again.
    d = Daemon([RVORONOI, "serve"], data, {**CONFIG, "limits": {"min_free_disk_bytes": 1 << 20}})
    try:
        status, _, health = d.json("GET", "/health")
        check(health.get("status") == "ok" and health.get("disk", {}).get("low") is False,
              f"/health with the disk above the floor: {health}")
        status, _, doc = d.json("POST", "/processes/voronoi/execution", job_body(2000))
        check(status == 200, f"a job with the disk above the floor runs: {status} {doc}")
    finally:
        check(d.stop() == 0, "clean SIGTERM exit")
    print(f"disk floor: ok ({time.time() - t0:.1f} s)", flush=True)


def main():
    tmp = tempfile.mkdtemp(prefix="rv_crash_")
    try:
        kill_during_compute_and_write(tmp)
        disk_floor(tmp)
        full_disk(tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if FAILURES:
        print(f"{len(FAILURES)} failure(s)")
        sys.exit(1)
    print("ok")


if __name__ == "__main__":
    main()
