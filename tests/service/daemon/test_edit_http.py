"""Edits through the daemon (issue 32): a job names a successful job as its baseJob.

Against a daemon this test starts (one worker, so that the edit waits in the queue while its base
is deleted):
  1. a base job; an edit of it (one point moved, one removed) queued behind a slow job, its base
     deleted before it runs: the edit succeeds, and every result file equals a fresh job's byte
     for byte (the same COGs, the same GeoJSON);
  2. the edit's status links to its base (rel "via"), its report says what changed and names the
     base; its changes raster marks the cells whose owner changed;
  3. bad bases: an unknown job id (404), a job that failed (400), a different grid (the edit job
     fails with the invalid-parameter problem naming the difference), a base id that is not an id
     (400), the changes output without a base (400); none leaves a file in the data directory.
Only the standard library and the harness; GDAL is not needed (files compare as bytes).
"""
import json
import os
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from daemon_harness import Daemon  # noqa: E402

RVORONOI = sys.argv[1]
FAILURES = []


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL:", what, flush=True)


def seeds(points):
    fc = {"type": "FeatureCollection",
          "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
          "features": [{"type": "Feature", "id": i + 1, "properties": {"state": s},
                        "geometry": {"type": "Point", "coordinates": [x, y]}}
                       for i, (s, x, y) in enumerate(points)]}
    return {"value": fc, "mediaType": "application/geo+json"}


OUTPUTS = ["ownership", "distance", "nearestFeature", "boundaries", "tripoints", "regions"]


def body(points, resolution=50, extra=None, outputs=OUTPUTS):
    inputs = {"seeds": seeds(points), "ownerField": "state", "resolution": resolution,
              "extent": [400000, 6100000, 415000, 6114000]}
    inputs.update(extra or {})
    out = {o: {} for o in outputs}
    out["report"] = {"transmissionMode": "value"}
    return {"inputs": inputs, "outputs": out}


def submit(d, b):
    status, _, doc = d.json("POST", "/processes/voronoi/execution", b, {"Prefer": "respond-async"})
    return status, doc


def finished(d, job, seconds=120):
    return d.wait_status(job, ("successful", "failed", "dismissed"), seconds)


def result(d, job, output):
    status, _, payload = d.request("GET", f"/jobs/{job}/results/{output}")
    check(status == 200, f"GET results/{output} of {job}: {status}")
    return payload


def main():
    base_points = [("A", 402000, 6102000), ("B", 412000, 6103000), ("C", 407000, 6111000),
                   ("A", 404000, 6108000), ("B", 413000, 6110000), ("C", 409000, 6105000)]
    edited = list(base_points)
    edited[1] = ("B", 411000, 6104500)  # moved
    del edited[3]                       # removed
    with tempfile.TemporaryDirectory() as tmp:
        data = os.path.join(tmp, "data")
        d = Daemon([RVORONOI, "serve"], data, {"jobs": {"workers": 1, "queue_length": 16}})
        try:
            status, doc = submit(d, body(base_points))
            check(status == 201, f"base submitted: {status} {doc}")
            base = doc["jobID"]
            doc = finished(d, base)
            check(doc["status"] == "successful", f"base job successful: {doc}")

            # A slow job first (a fine grid), then the edit: the base is deleted while the edit waits.
            _, slow = submit(d, body(base_points, resolution=4, outputs=["ownership"]))
            status, doc = submit(d, body(edited, extra={"baseJob": base}, outputs=OUTPUTS + ["changes"]))
            check(status == 201, f"edit submitted: {status} {doc}")
            edit = doc["jobID"]
            status, _, _ = d.request("DELETE", f"/jobs/{base}")
            check(status == 200, f"base deleted while the edit waits: {status}")
            check(d.json("GET", f"/jobs/{edit}")[2]["status"] in ("accepted", "running"),
                  "the edit had not finished when its base was deleted")
            doc = finished(d, edit)
            check(doc["status"] == "successful", f"edit successful: {doc}")
            finished(d, slow["jobID"], 300)
            via = [link for link in doc.get("links", []) if link.get("rel") == "via"]
            check(len(via) == 1 and via[0]["href"].endswith(f"/jobs/{base}"), f"the edit links to its base: {via}")

            _, fresh_doc = submit(d, body(edited))
            fresh = fresh_doc["jobID"]
            check(finished(d, fresh)["status"] == "successful", "fresh job successful")
            for o in OUTPUTS:
                check(result(d, edit, o) == result(d, fresh, o), f"{o}: the edit's file equals the fresh job's")
            report = json.loads(result(d, edit, "report"))
            e = report.get("edit", {})
            check(e.get("base") == base, f"the report names the base job: {e.get('base')}")
            f = e.get("features", {})
            check((f.get("changed"), f.get("removed"), f.get("added")) == (1, 1, 0),
                  f"one feature changed, one removed: {f}")
            check(e.get("owner_changed_cells", 0) > 0 and e.get("cells_recomputed", 0) < 300 * 280,
                  f"cells changed and recomputed: {e.get('owner_changed_cells')}, {e.get('cells_recomputed')}")
            check(len(result(d, edit, "changes")) > 0, "the changes raster is served")

            # Bad bases.
            status, _, doc = d.json("POST", "/processes/voronoi/execution", body(edited, extra={"baseJob": "f" * 32}))
            check(status == 400 and "input 'baseJob': no job" in doc.get("detail", ""), f"unknown base: {status} {doc}")
            status, _, doc = d.json("POST", "/processes/voronoi/execution", body(edited, extra={"baseJob": "../x"}))
            check(status == 400 and "baseJob" in doc.get("detail", ""), f"not a job id: {status} {doc}")
            _, failed = submit(d, body(base_points, extra={"ownerField": "no_such_field"}))
            finished(d, failed["jobID"])
            status, _, doc = d.json("POST", "/processes/voronoi/execution",
                                    body(edited, extra={"baseJob": failed["jobID"]}))
            check(status == 400 and "only a successful job" in doc.get("detail", ""), f"failed base: {status} {doc}")
            status, _, doc = d.json("POST", "/processes/voronoi/execution",
                                    body(edited, resolution=60, extra={"baseJob": edit}))
            check(status == 400 and "grid resolution 60" in doc.get("detail", ""),
                  f"a different grid is named: {status} {doc}")
            status, _, doc = d.json("POST", "/processes/voronoi/execution",
                                    body(edited, outputs=["ownership", "changes"]))
            check(status == 400 and "needs the input baseJob" in doc.get("detail", ""),
                  f"changes without a base: {status} {doc}")
            jobs_dir = os.path.join(data, "jobs")
            # (Polled for up to 2 s: a job's directory goes as its record is written; a leftover
            # that stays is the failure, and its files are listed.)
            deadline = time.time() + 2
            while True:
                leftovers = [j for j in os.listdir(jobs_dir)
                             if j not in (edit, fresh, slow["jobID"]) and os.listdir(os.path.join(jobs_dir, j))]
                if not leftovers or time.time() > deadline:
                    break
                time.sleep(0.05)
            check(not leftovers, "refused edits left no files: " + str(
                {j: [os.path.relpath(os.path.join(r, f), jobs_dir) for r, _, fs in os.walk(os.path.join(jobs_dir, j))
                     for f in fs] for j in leftovers}))
            check(not os.path.exists(os.path.join(jobs_dir, edit, "base-snapshot")),
                  "the edit's copy of its base is gone once it ended")
        finally:
            d.stop()
    if FAILURES:
        print(f"{len(FAILURES)} failure(s)")
        return 1
    print("edits through the daemon: ok")
    return 0


if __name__ == "__main__":
    t0 = time.time()
    rc = main()
    print(f"{time.time() - t0:.1f} s")
    sys.exit(rc)
