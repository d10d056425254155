#!/usr/bin/python3
"""The real `rvoronoi serve` against its own openapi.yaml, and against GDAL's /vsicurl/.

Every response this script receives is validated with python3-jsonschema against the schema
that openapi.yaml gives for that path, method, status and media type, and every status must be
documented there: the document and the server cannot drift apart. Request bodies are validated
against the document too. GDAL (a client nobody here wrote) reads a result through /vsicurl/.
Also: SIGKILL in the middle of a job and a restart; SIGTERM shuts down cleanly. A second server
with principals (issue 52): /me, the 401s with their WWW-Authenticate, a job's principal, the
principal filter of /jobs, and the 429s of the allowances, each validated the same way.

usage: test_openapi.py RVORONOI_BINARY SOURCE_DIR
"""
import base64
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request

import jsonschema
import yaml
from osgeo import gdal

gdal.UseExceptions()

BINARY, SOURCE = sys.argv[1], sys.argv[2]
DOC = yaml.safe_load(open(os.path.join(SOURCE, "openapi.yaml"), encoding="utf-8"))
RESOLVER = jsonschema.RefResolver.from_schema(DOC)
FAILURES = []
CHECKED = {"responses": 0}


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL:", what, flush=True)


def deref(node):
    while isinstance(node, dict) and "$ref" in node:
        _, node = RESOLVER.resolve(node["$ref"])
    return node


SCHEMA_KEYS = ("type", "enum", "default", "minimum", "maximum", "exclusiveMinimum", "minLength", "minItems",
               "maxItems", "required")


def schema_core(node):
    """What a schema says about values (references resolved, descriptions and titles dropped)."""
    node = deref(node)
    if isinstance(node, list):
        return [schema_core(n) for n in node]
    if not isinstance(node, dict):
        return node
    out = {k: node[k] for k in SCHEMA_KEYS if k in node}
    for k in ("items", "oneOf"):
        if k in node:
            out[k] = schema_core(node[k])
    if "properties" in node:
        out["properties"] = {name: schema_core(v) for name, v in node["properties"].items()}
    return out


def validate(instance, schema, what):
    try:
        # OpenAPI 3.0 schemas are JSON Schema draft 4 with extensions (exclusiveMinimum: true).
        jsonschema.Draft4Validator(schema, resolver=RESOLVER).validate(instance)
    except jsonschema.ValidationError as e:
        check(False, f"{what}: {e.message} at {list(e.absolute_path)}")


def operation(path, method):
    """The openapi.yaml operation for a concrete path (templates matched segment-wise)."""
    parts = path.split("?")[0].strip("/").split("/") if path.strip("/") else []
    for template, item in DOC["paths"].items():
        tparts = template.strip("/").split("/") if template.strip("/") else []
        if len(tparts) != len(parts):
            continue
        if all(t.startswith("{") or t == p for t, p in zip(tparts, parts)):
            if method.lower() in item:
                return template, item[method.lower()]
    return None, None


class Server:
    def __init__(self, data_dir, config):
        self.config_path = data_dir.rstrip("/") + ".json"
        with open(self.config_path, "w") as f:
            json.dump(config, f)
        self.proc = subprocess.Popen(
            [BINARY, "serve", "--listen", "127.0.0.1:0", "--data-dir", data_dir, "--config", self.config_path],
            stderr=subprocess.PIPE, text=True)
        first = json.loads(self.proc.stderr.readline())
        self.port = int(first["address"].rsplit(":", 1)[1])
        self.startup = first
        self.log = []
        self.reader = threading.Thread(target=self._drain, daemon=True)
        self.reader.start()
        self.base = f"http://127.0.0.1:{self.port}"

    def _drain(self):
        for line in self.proc.stderr:
            self.log.append(line)

    def stop(self, sig=signal.SIGTERM, timeout=30):
        self.proc.send_signal(sig)
        return self.proc.wait(timeout=timeout)


def request(server, method, path, body=None, headers=None, expect=None, media=None):
    """Sends a request, validates the response against openapi.yaml, returns (status, headers, bytes)."""
    data = None
    hdrs = dict(headers or {})
    if body is not None:
        data = json.dumps(body).encode() if not isinstance(body, bytes) else body
        hdrs["Content-Type"] = "application/json"
    req = urllib.request.Request(server.base + path, data=data, method=method, headers=hdrs)
    try:
        with urllib.request.urlopen(req, timeout=120) as r:
            status, rh, payload = r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        status, rh, payload = e.code, dict(e.headers), e.read()
    what = f"{method} {path} -> {status}"
    if expect is not None:
        check(status == expect, f"{what}: expected {expect}: {payload[:300]!r}")
    template, op = operation(path, method if method != "HEAD" else "GET")
    check(op is not None, f"{what}: path not in openapi.yaml")
    if op is None:
        return status, rh, payload
    responses = op["responses"]
    check(str(status) in responses, f"{what}: status not documented for {template}")
    if str(status) not in responses:
        return status, rh, payload
    response = deref(responses[str(status)])
    ctype = rh.get("Content-Type", "")
    content = response.get("content", {})
    if method == "HEAD" or not content:
        return status, rh, payload
    check(ctype in content, f"{what}: Content-Type {ctype!r} not documented ({list(content)})")
    if ctype in content and (ctype.endswith("json")):
        validate(json.loads(payload), content[ctype]["schema"], what)
        CHECKED["responses"] += 1
    return status, rh, payload


def execute(server, body, prefer_async=False, expect=None):
    validate(body, DOC["components"]["schemas"]["execute"], "execute request body")
    headers = {"Prefer": "respond-async"} if prefer_async else {}
    return request(server, "POST", "/processes/voronoi/execution", body, headers, expect)


def wait_status(server, job, states, seconds=60, headers=None):
    end = time.time() + seconds
    while time.time() < end:
        _, _, p = request(server, "GET", f"/jobs/{job}", headers=headers, expect=200)
        s = json.loads(p)
        if s["status"] in states:
            return s
        time.sleep(0.05)
    check(False, f"job {job} did not reach {states}")
    return s


def b64(path):
    return base64.b64encode(open(path, "rb").read()).decode()


def principals(tmp):
    """Issue 52 against the document: a server with two principals and small allowances."""
    tokens = {"alice": "alice-" + os.urandom(8).hex(), "root": "root-" + os.urandom(8).hex()}
    roles = {"alice": "user", "root": "admin"}
    config = {"jobs": {"workers": 1, "queue_length": 4, "threads_per_job": 1},
              "limits": {"cells_per_principal_per_hour": 1000},
              "auth": {"principals": [{"name": n, "role": roles[n], "token_sha256": hashlib.sha256(t.encode()).hexdigest()}
                                      for n, t in tokens.items()]}}
    s = Server(os.path.join(tmp, "principals"), config)
    alice = {"Authorization": "Bearer " + tokens["alice"]}
    root = {"Authorization": "Bearer " + tokens["root"]}
    try:
        _, h, _ = request(s, "GET", "/me", expect=401)
        check(h.get("WWW-Authenticate", "").startswith("Bearer"), f"401 without a token: {h.get('WWW-Authenticate')}")
        _, h, _ = request(s, "GET", "/me", headers={"Authorization": "Bearer not-" + tokens["alice"]}, expect=401)
        challenge = h.get("WWW-Authenticate", "")
        check('error="invalid_token"' in challenge and 'error_description="' in challenge,
              f"a refused token is told why: {challenge}")
        _, _, me = request(s, "GET", "/me", headers=alice, expect=200)
        me = json.loads(me)
        check((me["name"], me["role"], me["authentication"]) == ("alice", "user", "token"), f"/me as alice: {me}")
        _, _, me = request(s, "GET", "/me", headers=root, expect=200)
        check(json.loads(me)["role"] == "admin", f"/me as root: {me}")
        demo = json.load(open(os.path.join(SOURCE, "fixtures", "demo_basepoints.geojson")))
        body = {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 2000}, "outputs": {"ownership": {}}}
        validate(body, DOC["components"]["schemas"]["execute"], "execute request body")
        _, _, st = request(s, "POST", "/processes/voronoi/execution", body,
                           dict(alice, Prefer="respond-async"), expect=201)
        st = json.loads(st)
        check(st.get("principal") == "alice", f"the job's principal: {st}")
        job = st["jobID"]
        wait_status(s, job, ("successful", "failed"), headers=alice)
        _, _, jobs = request(s, "GET", "/jobs?principal=alice&limit=1", headers=root, expect=200)
        jobs = json.loads(jobs)
        check([j["principal"] for j in jobs["jobs"]] == ["alice"]
              and any("principal=alice" in l["href"] for l in jobs["links"] if l["rel"] == "next"),
              f"an admin lists alice's jobs, the next link repeats the filter: {jobs}")
        _, _, jobs = request(s, "GET", "/jobs?principal=root", headers=alice, expect=200)
        check(json.loads(jobs)["jobs"] == [], f"a user naming another principal lists nothing: {jobs}")
        request(s, "GET", "/jobs?principal=", headers=root, expect=400)
        request(s, "GET", f"/jobs/{job}", headers=root, expect=200)
        # Over the cells of the hour: a grid known up front is refused at once (429, Retry-After) ...
        known = dict(body, inputs=dict(body["inputs"], extent=[340000, 6140000, 400000, 6200000]))
        _, h, problem = request(s, "POST", "/processes/voronoi/execution", known, alice, expect=429)
        check(json.loads(problem)["type"] == "https://rvoronoi.dev/problems/over-quota"
              and int(h.get("Retry-After", "0")) >= 1, f"429 over-quota with Retry-After: {h} {problem}")
        # ... one known only once planned fails with that problem: its results answer 429.
        _, _, st = request(s, "POST", "/processes/voronoi/execution", body,
                           dict(alice, Prefer="respond-async"), expect=201)
        job = json.loads(st)["jobID"]
        wait_status(s, job, ("successful", "failed"), headers=alice)
        _, h, _ = request(s, "GET", f"/jobs/{job}/results", headers=alice, expect=429)
        check(int(h.get("Retry-After", "0")) >= 1, f"a job failed over its allowance: Retry-After {h}")
    finally:
        if s.proc.poll() is None:
            s.stop()


def sessions(s, demo):
    """Issue 54 against the document: every /sessions resource, its answers validated."""
    body = {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 2000, "limitDistances": ["20000"]},
            "outputs": {"boundaries": {}, "tripoints": {}, "limits": {}, "regions": {}}}
    validate(body, DOC["components"]["schemas"]["sessionCreate"], "session create body")
    _, h, doc = request(s, "POST", "/sessions", body, expect=201)
    sid = json.loads(doc)["sessionID"]
    check(re.fullmatch(DOC["components"]["parameters"]["sessionID"]["schema"]["pattern"], sid) is not None,
          f"the session id {sid} has the documented form")
    request(s, "GET", "/sessions", expect=200)
    request(s, "GET", f"/sessions/{sid}", expect=200)
    _, _, fc = request(s, "GET", f"/sessions/{sid}/features", expect=200)
    first = json.loads(fc)["features"][0]
    request(s, "GET", f"/sessions/{sid}/deliverables", expect=200)
    for name in ("boundaries", "tripoints", "limits", "regions"):
        request(s, "GET", f"/sessions/{sid}/deliverables/{name}", expect=200)
    request(s, "GET", f"/sessions/{sid}/deliverables/turningPoints", expect=404)
    x, y = first["geometry"]["coordinates"]
    edit = {"edits": [{"op": "move-vertex", "feature": first["id"], "path": [], "to": [x + 3000, y + 2000]}]}
    for e in edit["edits"]:
        validate(e, DOC["components"]["schemas"]["sessionEditOperation"], "edit operation")
    request(s, "POST", f"/sessions/{sid}/edits", edit, expect=200)
    request(s, "POST", f"/sessions/{sid}/edits", {"edits": [{"op": "remove", "feature": "no-such"}]}, expect=400)
    request(s, "POST", f"/sessions/{sid}/undo", expect=200)
    request(s, "POST", f"/sessions/{sid}/redo", expect=200)
    request(s, "POST", f"/sessions/{sid}/redo", expect=400)
    request(s, "POST", f"/sessions/{sid}/jobs", {"outputs": {"ownership": {}, "boundaries": {}}}, expect=200)
    request(s, "POST", f"/sessions/{sid}/jobs", {"outputs": {"ownership": {}}}, {"Prefer": "respond-async"},
            expect=201)
    request(s, "POST", f"/sessions/{sid}/jobs", {"outputs": {"changes": {}}}, expect=400)
    _, h, doc = request(s, "POST", "/sessions", body, {"Prefer": "respond-async"}, expect=202)
    second = json.loads(doc)["sessionID"]
    request(s, "POST", "/sessions", {"inputs": body["inputs"], "outputs": {"distance": {}}}, expect=400)
    request(s, "DELETE", f"/sessions/{sid}", expect=200)
    request(s, "GET", f"/sessions/{sid}", expect=404)
    request(s, "GET", "/sessions/not-a-session", expect=404)
    end = time.time() + 60
    while time.time() < end:
        _, _, doc = request(s, "GET", f"/sessions/{second}", expect=200)
        if json.loads(doc)["status"] != "creating":
            break
        time.sleep(0.05)
    request(s, "DELETE", f"/sessions/{second}", expect=200)


def main():
    tmp = tempfile.mkdtemp(prefix="rv_openapi_")
    data = os.path.join(tmp, "data")
    config = {"http": {"max_body_bytes": 1 << 20, "request_timeout_s": 10},
              "jobs": {"workers": 1, "queue_length": 2, "threads_per_job": 1, "shutdown_grace_s": 2},
              "limits": {"max_cells": 50_000_000, "validate_max_cells": 100_000}}
    s = Server(data, config)
    try:
        # Discovery.
        _, _, landing = request(s, "GET", "/", expect=200)
        rels = {l["rel"] for l in json.loads(landing)["links"]}
        check("service-desc" in rels, "landing page links the API definition")
        # One version everywhere: CMake's project(VERSION), which the binary reports.
        version = subprocess.run([BINARY, "--version"], capture_output=True, text=True, check=True).stdout.split()[-1]
        check(json.loads(landing).get("version") == version, f"the landing document gives version {version}")
        check(str(DOC["info"]["version"]) == version,
              f"openapi.yaml's info.version {DOC['info']['version']} is the project's {version}")
        request(s, "GET", "/conformance", expect=200)
        _, h, api = request(s, "GET", "/api", expect=200)
        check(api == open(os.path.join(SOURCE, "openapi.yaml"), "rb").read(), "/api serves openapi.yaml verbatim")
        check(yaml.safe_load(api)["openapi"].startswith("3.0"), "/api is OpenAPI 3.0")
        request(s, "GET", "/health", expect=200)
        # Without authentication whoever asks is the anonymous admin.
        _, _, me = request(s, "GET", "/me", expect=200)
        me = json.loads(me)
        check((me["name"], me["role"], me["authentication"]) == ("anonymous", "admin", "none") and "expires" not in me,
              f"/me without authentication: {me}")
        request(s, "HEAD", "/me", expect=200)
        request(s, "GET", "/processes", expect=200)
        _, _, desc = request(s, "GET", "/processes/voronoi", expect=200)
        desc = json.loads(desc)
        # The inputs the process description lists are exactly those openapi.yaml accepts.
        check(set(desc["inputs"]) == set(DOC["components"]["schemas"]["voronoiInputs"]["properties"]),
              "process description inputs == openapi.yaml voronoiInputs")
        # ... and each input's schema (made from the option table, rv/options.hpp) says what
        # openapi.yaml says of it: types, allowed values, defaults, bounds.
        documented = DOC["components"]["schemas"]["voronoiInputs"]["properties"]
        for name, entry in desc["inputs"].items():
            # The uploads (seed layers) are option-table entries too; openapi.yaml gives their
            # forms in its own words (the execute request's schema).
            if "x-rvoronoi-upload" in entry["schema"] or name not in documented:
                continue
            mine, theirs = schema_core(entry["schema"]), schema_core(documented[name])
            check(mine == theirs, f"input {name}: process description {mine} != openapi.yaml {theirs}")
        required = set(DOC["components"]["schemas"]["voronoiInputs"]["required"])
        check({n for n, e in desc["inputs"].items() if e["minOccurs"] == 1} == required,
              f"required inputs agree with openapi.yaml: {required}")
        check(set(desc["outputs"]) == set(DOC["components"]["schemas"]["results"]["properties"]),
              "process description outputs == openapi.yaml results")
        request(s, "GET", "/processes/other", expect=404)
        request(s, "GET", "/processes/describe-seeds", expect=200)
        request(s, "GET", "/app", expect=200)
        # describe-seeds: the response validates against seedDescription.
        demo_seeds = json.load(open(os.path.join(SOURCE, "fixtures", "demo_basepoints.geojson")))
        _, _, described = request(s, "POST", "/processes/describe-seeds/execution",
                                  {"inputs": {"seeds": demo_seeds, "features": True}}, expect=200)
        described = json.loads(described)
        check(described["commonFields"] and len(described["features"]["features"]) == described["layers"][0]["features"],
              f"describe-seeds lists fields and features: {str(described)[:300]}")
        request(s, "POST", "/processes/describe-seeds/execution", {"inputs": {"seeds": demo_seeds, "x": 1}}, expect=400)

        exe_path = "/processes/voronoi/execution"
        # Synchronous, GeoJSON by value.
        demo = json.load(open(os.path.join(SOURCE, "fixtures", "demo_basepoints.geojson")))
        body = {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 2000}}
        _, _, doc = execute(s, body, expect=200)
        doc = json.loads(doc)
        own_href = doc["ownership"]["href"]
        job1 = own_href.split("/jobs/")[1].split("/")[0]
        # The disproportionality test: a relevant area uploaded as a seed layer is; its areas and
        # coasts in the report (deliverables.regions.relevant_area).
        area = {"type": "FeatureCollection", "crs": demo["crs"], "features": [{"type": "Feature", "properties": {},
                "geometry": {"type": "Polygon", "coordinates": [[[345000, 6150000], [360000, 6150000],
                                                                 [360000, 6165000], [345000, 6165000],
                                                                 [345000, 6150000]]]}}]}
        body = {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 1000, "relevantArea": area},
                "outputs": {"report": {"transmissionMode": "value"}}}
        _, _, rel = execute(s, body, expect=200)
        rel = json.loads(rel)
        rel = rel.get("report", rel).get("value", rel)
        check("deliverables" in rel, f"report by value: {str(rel)[:300]}")
        rel = rel["deliverables"]["regions"]["relevant_area"]
        check(abs(rel["area"] - 15000.0 * 15000.0) < 1.0 and len(rel["owners"]) >= 2
              and all(o["coast_length"] >= 0 for o in rel["owners"]), f"relevant area in the report: {rel}")
        # The turning points as a treaty table, JSON and CSV, by reference.
        body = {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 1000},
                "outputs": {"turningPoints": {"transmissionMode": "reference"},
                            "report": {"transmissionMode": "value"}}}
        _, _, doc = execute(s, body, expect=200)
        check("turningPoints" in json.loads(doc), f"the results document: {doc[:400]}")
        href = json.loads(doc)["turningPoints"]["href"]
        _, _, tp = request(s, "GET", "/jobs/" + href.split("/jobs/", 1)[1], expect=200)
        tp = json.loads(tp)
        check(tp["datum"] == "WGS 84" and len(tp["lines"]) >= 2 and "lat_dms" in tp["lines"][0]["points"][0],
              f"turning points by reference: {str(tp)[:300]}")
        body["outputs"]["turningPoints"] = {"transmissionMode": "reference", "format": {"mediaType": "text/csv"}}
        _, _, doc = execute(s, body, expect=200)
        href = json.loads(doc)["turningPoints"]["href"]
        _, h, csv = request(s, "GET", "/jobs/" + href.split("/jobs/", 1)[1], expect=200)
        check(csv.startswith(b"line,seq,kind,owner_a,owner_b,lon,lat"), f"turning points as CSV: {csv[:200]}")
        # Partial effect by value: B's island at half effect between two mainland coasts; the
        # report states it and the boundaries' traced stretch; a scan is refused (400).
        island = {"type": "FeatureCollection", "features": [
            {"type": "Feature", "properties": {"state": "A", "e": None},
             "geometry": {"type": "LineString", "coordinates": [[10.0, 55.0], [10.0, 55.6]]}},
            {"type": "Feature", "properties": {"state": "B", "e": None},
             "geometry": {"type": "LineString", "coordinates": [[10.8, 55.0], [10.8, 55.6]]}},
            {"type": "Feature", "properties": {"state": "B", "e": 0.5},
             "geometry": {"type": "Point", "coordinates": [10.3, 55.3]}}]}
        half = {"inputs": {"seeds": island, "ownerField": "state", "effectField": "e", "resolution": 0.01},
                "outputs": {"boundaries": {}, "report": {"transmissionMode": "value"}}}
        _, _, rep = execute(s, half, expect=200)
        rep = json.loads(rep)
        rep = rep.get("report", rep).get("value", rep)
        check(rep.get("partial_effect", {}).get("effect") == 0.5
              and rep["deliverables"]["boundaries"]["partial_effect"]["stretches"] == 1,
              f"partial effect in the report: {str(rep)[:400]}")
        half["inputs"]["method"] = "hv-scan"
        _, _, problem = execute(s, half, expect=400)
        check("partial effect needs the exact or brute-force method" in json.loads(problem)["detail"],
              f"a scan with partial effect: {problem}")
        bad_area = dict(body, inputs=dict(body["inputs"], relevantArea={"type": "FeatureCollection", "crs": demo["crs"], "features": [
            {"type": "Feature", "properties": {}, "geometry": {"type": "Point", "coordinates": [350000, 6155000]}}]}))
        _, _, problem = execute(s, bad_area, expect=400)
        check(json.loads(problem)["detail"].startswith("input 'relevantArea': ")
              and "holds no polygon" in json.loads(problem)["detail"],
              f"a relevant area without polygons: {problem}")

        # Asynchronous: uploads of every accepted binary format, in one job.
        fx = os.path.join(SOURCE, "fixtures")
        upload = {"inputs": {"seeds": [
            {"value": b64(os.path.join(fx, "coast.gpkg")), "mediaType": "application/geopackage+sqlite3", "encoding": "base64"},
        ], "ownerField": "owner", "resolution": 100, "method": "hv-scan", "validate": True},
            "outputs": {"ownership": {}, "report": {"transmissionMode": "reference"}}}
        status, h, st = execute(s, upload, prefer_async=True, expect=201)
        st = json.loads(st)
        check(h.get("Location", "").endswith("/jobs/" + st["jobID"]), "Location header names the job")
        done = wait_status(s, st["jobID"], {"successful", "failed"})
        check(done["status"] == "successful", f"GeoPackage upload job: {done}")
        _, _, res = request(s, "GET", f"/jobs/{st['jobID']}/results", expect=200)
        res = json.loads(res)
        check(set(res) == {"ownership", "report"} and "href" in res["report"], f"requested outputs only: {res}")
        _, _, rep = request(s, "GET", f"/jobs/{st['jobID']}/results/report", expect=200)
        check(json.loads(rep)["validation"]["wrong_cells"] >= 0, "report carries the validation")
        for name, media in (("coast_shp.zip", "application/zip"), ("all_types.fgb", "application/flatgeobuf")):
            one = {"inputs": {"seeds": {"value": b64(os.path.join(fx, name)), "mediaType": media, "encoding": "base64"},
                              "ownerField": "owner", "resolution": 250}}
            _, _, r = execute(s, one, expect=200)
            check("ownership" in json.loads(r), f"{name} upload computed")
        # A geographic grid from an OGC CRS URI, geodesic distances in nautical miles.
        geo = {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 0.02,
                          "crs": "http://www.opengis.net/def/crs/EPSG/0/4326", "metric": "geodesic",
                          "maxDistance": 10, "distanceUnits": "nmi"},
               "outputs": {"report": {}}}
        _, _, g = execute(s, geo, expect=200)
        g = json.loads(g)["report"]["value"]
        check(g["metric"] == "geodesic" and g["grid"]["geographic"], f"geodesic job report: {g.get('grid')}")
        check(g["distance_units"] == "nmi", f"distance units {g.get('distance_units')}")
        # Every deliverable output, each fetched: its Content-Type must be documented, and the
        # results document must validate with all of them in it.
        outs = {k: {} for k in ("ownership", "distance", "nearestFeature", "report", "boundaries", "tripoints",
                                "limits", "regions", "margin", "preview")}
        outs["regions"] = {"format": {"mediaType": "application/geopackage+sqlite3"}}
        deliver = {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 1000,
                              "limitDistances": ["2nmi", {"value": 5, "unit": "km"}], "limitsPerOwner": True},
                   "outputs": outs}
        _, _, st = execute(s, deliver, prefer_async=True, expect=201)
        jd = json.loads(st)["jobID"]
        check(wait_status(s, jd, {"successful", "failed"})["status"] == "successful", "deliverables job")
        _, _, res = request(s, "GET", f"/jobs/{jd}/results", expect=200)
        res = json.loads(res)
        check(set(res) == set(outs), f"every requested output listed: {sorted(res)}")
        expected = {"boundaries": "application/geo+json", "regions": "application/geopackage+sqlite3",
                    "preview": "image/png", "margin": "image/tiff; application=geotiff; profile=cloud-optimized"}
        for name in outs:
            _, h, body = request(s, "GET", f"/jobs/{jd}/results/{name}", expect=200)
            if name in expected:
                check(h.get("Content-Type") == expected[name], f"{name} Content-Type {h.get('Content-Type')}")
                check(res[name]["type"] == expected[name], f"{name} type in the results document")
            check(len(body) > 0, f"{name} has content")
        _, h, png = execute(s, {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 1000},
                                "outputs": {"preview": {}}, "response": "raw"}, expect=200)
        check(h.get("Content-Type") == "image/png" and png[:8] == b"\x89PNG\r\n\x1a\n", "raw preview is a PNG")
        request(s, "POST", exe_path, {"inputs": {"seeds": demo, "resolution": 1000, "limitDistances": ["12 parsecs"]},
                                      "outputs": {"limits": {}}}, expect=400)

        request(s, "GET", "/jobs", expect=200)
        request(s, "GET", "/jobs?limit=1&status=successful", expect=200)
        request(s, "GET", f"/jobs/{job1}", expect=200)
        request(s, "GET", f"/jobs/{job1}/results", expect=200)

        # Errors, each documented.
        # (Invalid bodies are sent with request(): execute() would refuse them on our side.)
        exe = "/processes/voronoi/execution"
        request(s, "POST", exe, {"inputs": {"seeds": demo, "resolution": -1}}, expect=400)
        request(s, "POST", exe, {"inputs": {"seeds": {"href": "http://example.org/x.geojson"}, "resolution": 1}},
                expect=400)
        request(s, "POST", exe, b"{not json", expect=400)
        execute(s, {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 1}}, expect=422)
        request(s, "POST", "/processes/voronoi/execution", b"x" * (2 << 20), expect=413)
        request(s, "GET", "/jobs/0123456789abcdef0123456789abcdef", expect=404)
        request(s, "GET", "/jobs/0123456789abcdef0123456789abcdef/results", expect=404)
        request(s, "DELETE", "/jobs/0123456789abcdef0123456789abcdef", expect=404)

        # Files: range, outside range, HEAD.
        own_path = own_href.split(str(s.port), 1)[1]
        _, _, whole = request(s, "GET", own_path, expect=200)
        _, h, part = request(s, "GET", own_path, headers={"Range": "bytes=0-99"}, expect=206)
        check(part == whole[:100], "206 carries the requested bytes")
        _, h, _ = request(s, "GET", own_path, headers={"Range": f"bytes={len(whole) + 1}-"}, expect=416)
        check(h.get("Content-Range") == f"bytes */{len(whole)}", "416 names the size")
        request(s, "HEAD", own_path, expect=200)

        # GDAL's /vsicurl/ reads the result in place, sidecar (attribute table) included.
        ds = gdal.Open("/vsicurl/" + own_href)
        local = os.path.join(tmp, "own.tif")
        open(local, "wb").write(whole)
        ref = gdal.Open(local)
        check((ds.RasterXSize, ds.RasterYSize) == (ref.RasterXSize, ref.RasterYSize), "vsicurl size")
        check(ds.GetRasterBand(1).ReadRaster() == ref.GetRasterBand(1).ReadRaster(), "vsicurl pixels")
        check(ds.GetGeoTransform() == ref.GetGeoTransform(), "vsicurl geotransform")
        rat = ds.GetRasterBand(1).GetDefaultRAT()
        check(rat is not None and rat.GetRowCount() == 3, "vsicurl finds the attribute table via ownership.aux.xml")
        if rat is not None:
            labels = sorted(rat.GetValueAsString(i, 1) for i in range(rat.GetRowCount()))
            check(labels == ["A", "B", "C"], f"attribute table labels {labels}")
        ds = None

        # The compression input reaches the COGs; the code raster of three owners is Byte.
        info = gdal.Info(ref, format="json")
        check(info["bands"][0]["type"] == "Byte", f"ownership of three owners is Byte: {info['bands'][0]['type']}")
        ref = None
        for profile, codec, predictor in (("deflate", "DEFLATE", "3"), ("none", None, None)):
            _, _, r = execute(s, {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 2000,
                                             "compression": profile},
                                  "outputs": {"distance": {}}, "response": "raw"}, expect=200)
            local = os.path.join(tmp, f"dist_{profile}.tif")
            open(local, "wb").write(r)
            d = gdal.Open(local)
            meta = d.GetMetadata("IMAGE_STRUCTURE")
            check(meta.get("COMPRESSION") == codec and meta.get("PREDICTOR") == predictor
                  and meta.get("LAYOUT") == "COG", f"compression {profile}: {meta}")
            d = None
        request(s, "POST", exe, {"inputs": {"seeds": demo, "resolution": 2000, "compression": "lzw"}}, expect=400)

        sessions(s, demo)

        # Dismiss, then SIGKILL during a running job, then restart.
        slow = {"inputs": {"seeds": demo, "ownerField": "state", "resolution": 10, "method": "brute-force"}}
        _, _, a = execute(s, slow, prefer_async=True, expect=201)
        ja = json.loads(a)["jobID"]
        wait_status(s, ja, {"running"})
        _, _, d = request(s, "DELETE", f"/jobs/{ja}", expect=200)
        check(json.loads(d)["status"] == "dismissed", "DELETE dismisses")
        _, _, b = execute(s, slow, prefer_async=True, expect=201)
        jb = json.loads(b)["jobID"]
        running = wait_status(s, jb, {"running"})
        request(s, "GET", f"/jobs/{jb}/results", expect=404)
        check(0 <= running["progress"] <= 100, "progress in range")
        s.stop(signal.SIGKILL)

        s = Server(data, config)
        check(s.startup.get("interrupted_jobs_failed") == 1, f"startup reports the interrupted job: {s.startup}")
        st = wait_status(s, jb, {"failed"}, 5)
        check("server stopped" in st["message"], f"interrupted job message: {st['message']}")
        request(s, "GET", f"/jobs/{jb}/results", expect=500)
        _, _, again = request(s, "GET", own_path, expect=200)
        check(again == whole, "finished results survive SIGKILL and restart")
        check(not os.path.exists(os.path.join(data, "jobs", jb)), "interrupted job's files removed")

        # Request log: one JSON line per request.
        time.sleep(0.2)
        lines = [json.loads(l) for l in s.log if l.startswith("{")]
        reqs = [l for l in lines if "method" in l]
        check(reqs and all({"method", "path", "status", "ms"} <= set(l) for l in reqs), "structured request log")

        # SIGTERM: graceful, exit status 0.
        code = s.stop(signal.SIGTERM)
        check(code == 0, f"exit status after SIGTERM: {code}")

        principals(tmp)
    finally:
        if s.proc.poll() is None:
            s.proc.kill()
            s.proc.wait()
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{CHECKED['responses']} JSON responses validated against openapi.yaml")
    if FAILURES:
        print(f"{len(FAILURES)} failure(s)")
        sys.exit(1)
    print("ok")


if __name__ == "__main__":
    main()
