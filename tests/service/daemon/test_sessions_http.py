"""Live what-if sessions through the daemon (issue 54): /sessions and everything under it.

Against daemons this test starts:
  1. A session of points of three owners, a coast line and an island (planar, UTM 33N), created
     synchronously: 201 with Location; its id names this daemon; its features carry string ids;
     every deliverable it keeps equals, byte for byte, a fresh job's file on the same inputs.
  2. Edits (a point moved, a coast vertex moved, a weight set): each answer says what changed (cells,
     moved areas, areas, lines); after each, the deliverables equal a fresh job's on the session's
     features (uploaded as they are served), and a job made from the session (POST .../jobs)
     writes rasters and lines equal to that fresh job's, byte for byte. Undo and redo come back to
     the earlier deliverables exactly.
  3. Bad edits (an unknown feature id, a path that is not there, a coordinate outside the CRS's
     bounds, a weight of the wrong type, a polygon that crosses itself, an empty list): 400 with
     one line, and the session unchanged (features, steps).
  4. Scheduling: three edits sent at once to one session are made one at a time (steps 1..3 with
     the answers' counts); with one job worker busy on a large job and another job queued, an edit
     is answered while both still wait or run.
  5. Owners: another principal's session answers exactly as one that does not exist; an admin
     sees it. Limits: sessions.max_sessions (503 with Retry-After), sessions.max_per_principal
     (429), one session's memory (422), every session's memory together (503).
  6. Endings: DELETE (then 404 "was deleted"), idle expiry (404 "expired"), a restart (404 "lost
     when this daemon restarted", while a job saved from the session survives), an id naming
     another daemon (404 naming it); asynchronous creation (202, a status to poll); a session's
     grid counted in its principal's cells of the hour (429 with Retry-After).
Only the standard library and the harness (files compare as bytes).
usage: test_sessions_http.py RVORONOI
"""
import hashlib
import json
import os
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from daemon_harness import Daemon  # noqa: E402

RVORONOI = sys.argv[1]
FAILURES = []
TOKENS = {"alice": "alice-token-0123456789", "bob": "bob-token-0123456789", "root": "root-token-0123456789"}
DELIVERABLES = ["boundaries", "tripoints", "limits", "regions"]


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL:", what, flush=True)
    return condition


def sha(token):
    return hashlib.sha256(token.encode()).hexdigest()


def auth(who):
    return {"Authorization": "Bearer " + TOKENS[who]}


def seed_collection():
    def feature(owner, kind, coordinates):
        return {"type": "Feature", "properties": {"state": owner, "weight": 1.0},
                "geometry": {"type": kind, "coordinates": coordinates}}
    x0, y0 = 400000, 6100000
    points = [("A", 2000, 2000), ("B", 12000, 3000), ("C", 7000, 11000), ("A", 4000, 8000),
              ("B", 13000, 10000), ("C", 9000, 5000)]
    features = [feature(s, "Point", [x0 + x, y0 + y]) for s, x, y in points]
    features.append(feature("A", "LineString", [[x0 + 500, y0 + 12000], [x0 + 2500, y0 + 13000],
                                                [x0 + 4000, y0 + 12500]]))
    features.append(feature("B", "Polygon", [[[x0 + 10000, y0 + 6500], [x0 + 11500, y0 + 6600],
                                              [x0 + 11000, y0 + 7800], [x0 + 10000, y0 + 6500]]]))
    return {"type": "FeatureCollection",
            "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
            "features": features}


def inputs(fc):
    return {"seeds": {"value": fc, "mediaType": "application/geo+json"}, "ownerField": "state",
            "weightField": "weight", "resolution": 50, "extent": [400000, 6100000, 415000, 6114000],
            "limitDistances": ["2000"]}


def session_body(fc):
    return {"inputs": inputs(fc), "outputs": {o: {} for o in DELIVERABLES}}


def href_path(href):
    return "/" + href.split("://", 1)[1].split("/", 1)[1]


def job_files(d, doc, outputs, headers):
    return {o: d.request("GET", href_path(doc[o]["href"]), None, headers)[2] for o in outputs}


def fresh(d, fc, outputs, headers):
    body = {"inputs": inputs(fc), "outputs": {o: {} for o in outputs}}
    if "limits" not in outputs:
        del body["inputs"]["limitDistances"]
    status, _, doc = d.json("POST", "/processes/voronoi/execution", body, headers)
    check(status == 200, f"fresh job: {status} {doc}")
    return job_files(d, doc, outputs, headers) if status == 200 else {}


def served_features(d, sid, headers):
    status, h, fc = d.json("GET", f"/sessions/{sid}/features", None, headers)
    check(status == 200 and h.get("content-type") == "application/geo+json", f"features: {status} {h}")
    # As a seed file: the session's ids and kind are not seed properties the job reads.
    for f in fc["features"]:
        f["properties"] = {"state": f["properties"]["owner"], "weight": f["properties"].get("weight", 1.0)}
    fc["crs"] = {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}}
    return fc


def deliverables(d, sid, headers):
    out = {}
    for name in DELIVERABLES:
        status, h, payload = d.request("GET", f"/sessions/{sid}/deliverables/{name}", None, headers)
        check(status == 200 and h.get("content-type") == "application/geo+json", f"deliverable {name}: {status}")
        out[name] = payload
    return out


def equal_to_fresh(d, sid, headers, what):
    fc = served_features(d, sid, headers)
    mine = deliverables(d, sid, headers)
    theirs = fresh(d, fc, DELIVERABLES, headers)
    for name in DELIVERABLES:
        check(mine[name] == theirs.get(name), f"{what}: deliverable {name} differs from a fresh job's")
    return mine, fc


def drawing(d, sid, headers):
    """What a client draws of the session's lines: per kind, line id (GET .../lines, in the
    deliverable's order) -> its coordinates (rounded to 1e-6, as the deliverable's text and the
    answer's JSON write the same doubles with different digits)."""
    status, _, ids = d.json("GET", f"/sessions/{sid}/lines", None, headers)
    check(status == 200, f"line ids: {status} {ids}")
    out = {}
    for kind in ("boundaries", "limits", "tripoints"):
        _, _, fc = d.json("GET", f"/sessions/{sid}/deliverables/{kind}", None, headers)
        check(len(ids[kind]) == len(fc["features"]) and len(set(ids[kind])) == len(ids[kind]),
              f"{kind}: {len(ids[kind])} ids for {len(fc['features'])} features")
        out[kind] = {i: rounded(f["geometry"]["coordinates"]) for i, f in zip(ids[kind], fc["features"])}
    return out


def rounded(coordinates):
    if isinstance(coordinates[0], list):
        return [rounded(c) for c in coordinates]
    return [round(float(c), 6) for c in coordinates]


def patched(drawn, answer):
    """`drawn` (drawing()) changed by a step's answer as a client redraws it."""
    out = {kind: dict(lines) for kind, lines in drawn.items()}
    for kind, changes in (("boundaries", answer["lines"]["boundaries"]), ("limits", answer["lines"]["limits"]),
                          ("tripoints", answer["tripoints"])):
        for i in changes["removed"]:
            check(i in out[kind], f"{kind}: the answer removes {i}, which was not drawn")
            out[kind].pop(i, None)
        for e in changes["changed"]:
            check(e["id"] in out[kind], f"{kind}: the answer changes {e['id']}, which was not drawn")
        for e in changes["added"]:
            check(e["id"] not in out[kind], f"{kind}: the answer adds {e['id']}, which was drawn")
        for e in changes["changed"] + changes["added"]:
            out[kind][e["id"]] = rounded(e["geometry"]["coordinates"])
    return out


def redrawn_from_answer(d, sid, headers, drawn, answer, what):
    """The drawing patched by the answer equals the session's lines read again, and the answer's
    changed features are the session's."""
    now = drawing(d, sid, headers)
    check(patched(drawn, answer) == now, f"{what}: the lines patched by the answer are not the session's")
    served = {f["id"]: f for f in d.json("GET", f"/sessions/{sid}/features", None, headers)[2]["features"]}
    for f in answer["features"]["changed"] + answer["features"]["added"]:
        check(served.get(f["id"]) == f, f"{what}: the answer's feature {f['id']} is not the session's")
    for i in answer["features"]["removed"]:
        check(i not in served, f"{what}: the answer removes feature {i}, which the session still has")
    return now


def edit(d, sid, edits, headers):
    return d.json("POST", f"/sessions/{sid}/edits", {"edits": edits}, headers)


def problem_detail(doc):
    return doc.get("detail", "") if isinstance(doc, dict) else str(doc)


def part_one_to_four(tmp):
    config = {"auth": {"principals": [
        {"name": "alice", "role": "user", "token_sha256": sha(TOKENS["alice"])},
        {"name": "bob", "role": "user", "token_sha256": sha(TOKENS["bob"])},
        {"name": "root", "role": "admin", "token_sha256": sha(TOKENS["root"])}]},
        "jobs": {"workers": 1, "queue_length": 8}, "daemon_name": "node-a",
        "sessions": {"max_sessions": 3, "max_per_principal": 2}}
    d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "data"), config)
    alice, bob, root = auth("alice"), auth("bob"), auth("root")
    try:
        # 1. Create, synchronously.
        status, h, doc = d.json("POST", "/sessions", session_body(seed_collection()), alice)
        if not check(status == 201, f"create: {status} {doc}"):
            return
        sid = doc["sessionID"]
        check(h.get("location", "").endswith("/sessions/" + sid), f"Location {h.get('location')}")
        check(sid.startswith("node-a.") and len(sid.split(".")) == 3, f"the id names the daemon: {sid}")
        check(doc["status"] == "ready" and doc["principal"] == "alice", f"status {doc}")
        check(sorted(doc["deliverables"]) == sorted(DELIVERABLES), f"kept {doc['deliverables']}")
        check(doc["memory_bytes"] > 0 and doc["grid"]["width"] == 300, f"info {doc}")
        rels = {l["rel"] for l in doc["links"]}
        check({"self", "edit", "up"} <= rels, f"links {rels}")
        status, _, fc = d.json("GET", f"/sessions/{sid}/features", None, alice)
        ids = [f["id"] for f in fc["features"]]
        check(ids == [str(i) for i in range(1, 9)], f"feature ids {ids}")
        start, _ = equal_to_fresh(d, sid, alice, "created")
        drawn = drawing(d, sid, alice)
        status, _, listing = d.json("GET", f"/sessions/{sid}/deliverables", None, alice)
        check(status == 200 and [x["id"] for x in listing["deliverables"]] == DELIVERABLES, f"list {listing}")
        status, _, doc = d.json("GET", f"/sessions/{sid}/deliverables/turningPoints", None, alice)
        check(status == 404 and "keeps no" in problem_detail(doc), f"not kept: {status} {doc}")

        # 2. Edits, each equal to a fresh job; a job from the session equal to a fresh one.
        status, _, answer = edit(d, sid, [{"op": "move-vertex", "feature": "2", "path": [], "to": [410500, 6104200]}],
                                 alice)
        check(status == 200 and answer["step"] == 1, f"edit 1: {status} {answer}")
        check(answer["cells"]["owner_changed"] > 0 and answer["cells"]["box"] is not None, f"cells {answer}")
        check(any(m["area"] > 0 for m in answer["moved"]), f"moved {answer['moved']}")
        check("server_s" in answer["timings"] and "boundaries" in answer["lines"], f"answer {answer}")
        check([f["id"] for f in answer["features"]["changed"]] == ["2"] and not answer["features"]["added"] and
              not answer["features"]["removed"], f"the answer's features {answer['features']}")
        one, fc1 = equal_to_fresh(d, sid, alice, "after a point moved")
        drawn = redrawn_from_answer(d, sid, alice, drawn, answer, "edit 1")
        check(one["boundaries"] != start["boundaries"], "the move changed no boundary")
        status, _, answer = edit(d, sid, [
            {"op": "move-vertex", "feature": "7", "path": [0, 1], "to": [402700, 6113200]},
            {"op": "set", "feature": "5", "properties": {"weight": 1.3}}], alice)
        check(status == 200 and answer["step"] == 2 and answer["edits"] == 2, f"edit 2: {status} {answer}")
        two, fc2 = equal_to_fresh(d, sid, alice, "after a vertex moved and a weight set")
        drawn = redrawn_from_answer(d, sid, alice, drawn, answer, "edit 2")
        rasters = ["ownership", "distance", "nearestFeature", "boundaries", "regions"]
        status, h, doc = d.json("POST", f"/sessions/{sid}/jobs", {"outputs": {o: {} for o in rasters}}, alice)
        if check(status == 200, f"session job: {status} {doc}"):
            saved = job_files(d, doc, rasters, alice)
            theirs = fresh(d, fc2, rasters, alice)
            for o in rasters:
                check(saved[o] == theirs.get(o), f"the session's job: {o} differs from a fresh job's")
            saved_job = h.get("link", "").split("/jobs/")[1].split(">")[0]
        status, _, doc = d.json("POST", f"/sessions/{sid}/jobs", {"outputs": {"ownership": {}}},
                                {**alice, "Prefer": "respond-async"})
        check(status == 201 and doc["status"] in ("accepted", "running", "successful"), f"async job {status} {doc}")
        status, _, answer = d.json("POST", f"/sessions/{sid}/undo", None, alice)
        check(status == 200 and answer["step"] == 1 and answer.get("undone"), f"undo {status} {answer}")
        check(deliverables(d, sid, alice) == one, "undo: the deliverables are not those of step 1")
        check(sorted(f["id"] for f in answer["features"]["changed"]) == ["5", "7"], f"undo: {answer['features']}")
        drawn = redrawn_from_answer(d, sid, alice, drawn, answer, "undo")
        status, _, answer = d.json("POST", f"/sessions/{sid}/redo", None, alice)
        check(status == 200 and answer["step"] == 2, f"redo {status} {answer}")
        check(deliverables(d, sid, alice) == two, "redo: the deliverables are not those of step 2")
        drawn = redrawn_from_answer(d, sid, alice, drawn, answer, "redo")

        # 3. Bad edits: 400, one line, nothing changed.
        before = d.json("GET", f"/sessions/{sid}/features", None, alice)[2]
        bad = [
            ([{"op": "remove", "feature": "99"}], "99"),
            ([{"op": "move-vertex", "feature": "7", "path": [0, 9], "to": [401000, 6101000]}], "path"),
            ([{"op": "move-vertex", "feature": "1", "path": [], "to": [2e12, 6101000]}], "outside"),
            ([{"op": "set", "feature": "1", "properties": {"weight": "heavy"}}], "weight"),
            ([{"op": "replace", "feature": "8", "geometry": {"type": "Polygon", "coordinates": [[
                [410000, 6106500], [411500, 6107800], [411500, 6106500], [410000, 6107800], [410000, 6106500]]]}}],
             "polygon"),
        ]
        for edits, word in bad:
            status, h, doc = edit(d, sid, edits, alice)
            check(status == 400 and h.get("content-type") == "application/problem+json" and
                  "\n" not in problem_detail(doc), f"bad edit ({word}): {status} {doc}")
        status, _, doc = d.json("POST", f"/sessions/{sid}/edits", {"edits": []}, alice)
        check(status == 400, f"no edits: {status}")
        status, _, doc = d.json("POST", f"/sessions/{sid}/edits", {"edit": []}, alice)
        check(status == 400 and "unknown member" in problem_detail(doc), f"a misspelt member: {status} {doc}")
        after = d.json("GET", f"/sessions/{sid}/features", None, alice)[2]
        check(before == after, "a refused edit changed the features")
        status, _, doc = d.json("GET", f"/sessions/{sid}", None, alice)
        check(doc["steps"] == 2, f"a refused edit counted as a step: {doc['steps']}")

        # 4. One session's edits one at a time, in order.
        answers = []
        def send(i):
            x = 404000 + 100 * i
            answers.append(edit(d, sid, [{"op": "move-vertex", "feature": "4", "path": [], "to": [x, 6108000]}], alice))
        threads = [threading.Thread(target=send, args=(i,)) for i in range(3)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        steps = sorted(a[2]["step"] for a in answers if a[0] == 200)
        check(steps == [3, 4, 5], f"concurrent edits' steps {steps} {[a[0] for a in answers]}")
        equal_to_fresh(d, sid, alice, "after concurrent edits")
        # Edits run ahead of queued jobs: one worker busy on a large job, another job queued.
        # The running job is made slow (brute force over 23 million cells) so that it still runs
        # when the edit answers, whatever the machine's load.
        big = {"inputs": {**inputs(seed_collection()), "resolution": 3, "method": "brute-force"},
               "outputs": {"ownership": {}}}
        del big["inputs"]["limitDistances"]
        _, _, slow = d.json("POST", "/processes/voronoi/execution", big, {**root, "Prefer": "respond-async"})
        _, _, queued = d.json("POST", "/processes/voronoi/execution", big, {**root, "Prefer": "respond-async"})
        end = time.time() + 30
        while d.json("GET", f"/jobs/{slow['jobID']}", None, root)[2]["status"] == "accepted" and time.time() < end:
            time.sleep(0.01)
        status, _, answer = edit(d, sid, [{"op": "set", "feature": "3", "properties": {"weight": 1.1}}], alice)
        check(status == 200, f"edit beside jobs: {status} {answer}")
        _, _, q = d.json("GET", f"/jobs/{queued['jobID']}", None, root)
        _, _, r = d.json("GET", f"/jobs/{slow['jobID']}", None, root)
        check(q["status"] == "accepted" and r["status"] == "running",
              f"the edit waited for the jobs (the running job is {r['status']}, the queued one {q['status']})")
        for j in (slow, queued):
            d.json("DELETE", f"/jobs/{j['jobID']}", None, root)

        # 5. Owners and limits.
        status, _, doc = d.json("GET", f"/sessions/{sid}", None, bob)
        nobody = sid.rsplit(".", 1)[0] + "." + "0" * 24
        status2, _, doc2 = d.json("GET", f"/sessions/{nobody}", None, bob)
        check(status == 404 and status2 == 404 and
              problem_detail(doc).replace(sid, "X") == problem_detail(doc2).replace(nobody, "X"),
              f"another's session answers as none: {doc} / {doc2}")
        status, _, doc = edit(d, sid, [{"op": "remove", "feature": "1"}], bob)
        check(status == 404, f"bob edits alice's session: {status}")
        status, _, doc = d.json("GET", "/sessions", None, bob)
        check(status == 200 and doc["sessions"] == [], f"bob's list {doc}")
        status, _, doc = d.json("GET", f"/sessions/{sid}", None, root)
        check(status == 200 and doc["principal"] == "alice", f"the admin sees it: {status}")
        status, _, doc = d.json("POST", "/sessions", session_body(seed_collection()), alice)
        check(status == 201, f"alice's second session: {status} {doc}")
        status, h, doc = d.json("POST", "/sessions", session_body(seed_collection()), alice)
        check(status == 429 and "retry-after" in h, f"alice's third (max_per_principal 2): {status} {doc}")
        status, _, doc = d.json("POST", "/sessions", session_body(seed_collection()), bob)
        check(status == 201, f"bob's session: {status} {doc}")
        status, h, doc = d.json("POST", "/sessions", session_body(seed_collection()), root)
        check(status == 503 and "retry-after" in h and "max_sessions" in problem_detail(doc),
              f"a fourth session (max_sessions 3): {status} {doc}")

        # 6. Delete.
        status, _, doc = d.json("DELETE", f"/sessions/{sid}", None, alice)
        check(status == 200 and doc["status"] == "deleted", f"delete: {status} {doc}")
        status, _, doc = d.json("GET", f"/sessions/{sid}", None, alice)
        check(status == 404 and "was deleted" in problem_detail(doc), f"after delete: {status} {doc}")
        status, _, doc = d.json("GET", f"/sessions/{sid}", None, bob)
        check(status == 404 and "deleted" not in problem_detail(doc), f"bob learns of the deletion: {doc}")
        status, _, health = d.json("GET", "/health")
        check(health["sessions"]["held"] == 2, f"health {health['sessions']}")
    finally:
        check(d.stop() == 0, "daemon exit status")
    # A restart: the session is lost, saying so; the job saved from it survives.
    d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "data"), config)
    try:
        status, _, doc = d.json("GET", f"/sessions/{sid}/features", None, alice)
        check(status == 404 and "restarted" in problem_detail(doc), f"after a restart: {status} {doc}")
        status, _, doc = d.json("GET", f"/jobs/{saved_job}", None, alice)
        check(status == 200 and doc["status"] == "successful", f"the saved job after a restart: {status} {doc}")
        other = "node-b." + sid.split(".", 1)[1]
        status, _, doc = d.json("GET", f"/sessions/{other}", None, alice)
        check(status == 404 and "node-b" in problem_detail(doc), f"another daemon's id: {status} {doc}")
    finally:
        check(d.stop() == 0, "daemon exit status after the restart")


def part_five_six(tmp):
    # Memory limits, idle expiry and asynchronous creation on an open daemon.
    config = {"sessions": {"session_memory_bytes": 4_500_000, "max_memory_bytes": 6_000_000, "idle_expiry_s": 1.5}}
    d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "data2"), config)
    try:
        large = session_body(seed_collection())
        large["inputs"]["resolution"] = 10  # 2.1 M cells: 17 MB of field
        status, _, doc = d.json("POST", "/sessions", large, None)
        check(status == 422 and "memory limit" in problem_detail(doc), f"one session over its limit: {status} {doc}")
        status, h, doc = d.json("POST", "/sessions", session_body(seed_collection()), {"Prefer": "respond-async"})
        check(status == 202 and h.get("preference-applied") == "respond-async" and "location" in h,
              f"async create: {status} {h} {doc}")
        sid = doc["sessionID"]
        end = time.time() + 60
        while doc.get("status") == "creating" and time.time() < end:
            time.sleep(0.05)
            _, _, doc = d.json("GET", f"/sessions/{sid}")
        check(doc.get("status") == "ready", f"async session: {doc}")
        mem = doc["memory_bytes"]
        # Field, lines, their pieces and refinement: more than half of every session's 6 MB, so a
        # second one would pass them together.
        check(3_000_000 < mem < 4_500_000, f"a session of 210,000 cells holds {mem} bytes")
        status, h, doc = d.json("POST", "/sessions", session_body(seed_collection()), None)
        check(status == 503 and "retry-after" in h, f"sessions' memory together: {status} {doc}")
        status, _, doc = d.json("POST", "/sessions", {"inputs": inputs(seed_collection()),
                                                      "outputs": {"ownership": {}}})
        check(status == 400 and "rasters" in problem_detail(doc), f"a raster output: {status} {doc}")
        body = session_body(seed_collection())
        body["inputs"]["method"] = "scan"
        status, _, doc = d.json("POST", "/sessions", body)
        check(status == 400, f"a scan session: {status} {doc}")
        time.sleep(3.5)
        status, _, doc = d.json("GET", f"/sessions/{sid}")
        check(status == 404 and "expired" in problem_detail(doc), f"idle expiry: {status} {doc}")
        status, _, health = d.json("GET", "/health")
        check(health["sessions"] == {"held": 0, "memoryBytes": 0}, f"health after expiry {health['sessions']}")
    finally:
        check(d.stop() == 0, "daemon exit status")


def hourly_cells(tmp):
    # A session's grid counts in its principal's cells of the hour, as a job's: the second one is
    # over the allowance, 429 with Retry-After.
    d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "data3"), {"limits": {"cells_per_principal_per_hour": 100000}})
    try:
        status, _, doc = d.json("POST", "/sessions", session_body(seed_collection()))
        check(status == 201, f"a session within the hour's cells: {status} {doc}")
        status, h, doc = d.json("POST", "/sessions", session_body(seed_collection()))
        check(status == 429 and int(h.get("retry-after", "0")) >= 1, f"over the hour's cells: {status} {h} {doc}")
    finally:
        check(d.stop() == 0, "daemon exit status")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        part_one_to_four(tmp)
        part_five_six(tmp)
        hourly_cells(tmp)
    if FAILURES:
        print(f"{len(FAILURES)} failure(s)")
        sys.exit(1)
    print("test_sessions_http: ok")


if __name__ == "__main__":
    main()
