#!/usr/bin/python3
"""Live what-if sessions through the daemon (issue 54): the server time of an edit as a client
sees it, from sending the request to its last byte (localhost), median and worst of N random edits.

    bench/edits/session_http.py RVORONOI baltic RES N FIXTURES   the western Baltic, geodesic, boundaries,
                                                        tripoints, 12/24 nmi limits, regions; each
                                                        edit moves one DK coast vertex ~100 m
    bench/edits/session_http.py RVORONOI points SIZE N           SIZE x SIZE planar cells, 50,000 random
                                                        points of 8 owners, the field alone; each
                                                        edit moves one point by 5 cells

After each edit the map page's reads are timed too: the regions (their file, like every
deliverable's, is made by the first read after a step) and the session's status (the regions'
areas); "edit and page" is the edit and those reads together. Each edit is undone (untimed, its
reads made) before the next, so that every edit starts from the session's first state, as
bench/edits/session_bench.cpp does in process. Prints one line per edit and a Markdown row.
"""
import base64
import json
import os
import random
import statistics
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "service", "daemon"))
from daemon_harness import Daemon  # noqa: E402


def main():
    binary, case, size, n = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    rng = random.Random(54)
    if case == "baltic":
        gpkg = base64.b64encode(open(os.path.join(sys.argv[5], "baltic_west.gpkg"), "rb").read()).decode()
        body = {"inputs": {"seeds": {"value": gpkg, "mediaType": "application/geopackage+sqlite3", "encoding": "base64"},
                           "ownerField": "iso2", "borderTolerance": 10, "resolution": float(size),
                           "metric": "geodesic", "distanceUnits": "nmi", "limitDistances": ["12nmi", "24nmi"]},
                "outputs": {"boundaries": {}, "tripoints": {}, "limits": {}, "regions": {}}}
    else:
        s = int(size)
        fc = {"type": "FeatureCollection",
              "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
              "features": [{"type": "Feature", "properties": {"owner": "O%d" % (i % 8)},
                            "geometry": {"type": "Point", "coordinates": [rng.uniform(0, s), rng.uniform(0, s)]}}
                           for i in range(50000)]}
        body = {"inputs": {"seeds": {"value": fc, "mediaType": "application/geo+json"}, "ownerField": "owner",
                           "resolution": 1, "extent": [0, 0, s, s]}}
    with tempfile.TemporaryDirectory() as tmp:
        d = Daemon([binary, "serve"], os.path.join(tmp, "data"),
                   {"http": {"max_body_bytes": 1 << 30}, "limits": {"max_cells": 1 << 34},
                    "sessions": {"max_memory_bytes": 16 << 30}, "jobs": {"job_timeout_s": 3600}})
        try:
            t = time.perf_counter()
            status, _, doc = d.json("POST", "/sessions", body, timeout=3600)
            create = time.perf_counter() - t
            assert status == 201, (status, doc)
            sid = doc["sessionID"]
            _, _, features = d.json("GET", f"/sessions/{sid}/features")
            client, server, page = [], [], []
            kept = body.get("outputs", {}).keys()

            def page_reads():
                if "regions" in kept:
                    status, _, _ = d.request("GET", f"/sessions/{sid}/deliverables/regions")
                    assert status == 200
                d.json("GET", f"/sessions/{sid}")

            for k in range(n):
                if case == "baltic":
                    f = next(f for f in features["features"] if f["properties"]["owner"] == "DK")
                    parts = f["geometry"]["geometries"]
                    part = rng.randrange(len(parts))
                    ring = parts[part]["coordinates"][0]
                    v = rng.randrange(len(ring) - 1)
                    to = [ring[v][0] + 0.0012, ring[v][1] + 0.0005]
                    edit = {"op": "move-vertex", "feature": f["id"], "path": [part, 0, v], "to": to}
                else:
                    f = features["features"][rng.randrange(50000)]
                    x, y = f["geometry"]["coordinates"]
                    edit = {"op": "move-vertex", "feature": f["id"], "path": [], "to": [x + 5, y - 3]}
                t = time.perf_counter()
                status, _, answer = d.json("POST", f"/sessions/{sid}/edits", {"edits": [edit]})
                client.append(time.perf_counter() - t)
                assert status == 200, (status, answer)
                server.append(answer["timings"]["server_s"])
                t = time.perf_counter()
                page_reads()
                page.append(client[-1] + time.perf_counter() - t)
                print(f"edit {k}: {client[-1]:.3f} s (server {server[-1]:.3f} s, of which the step "
                      f"{answer['timings']['total']:.3f} s: {json.dumps(answer['timings'])}; "
                      f"lines: {json.dumps({k: v for k, v in answer['recompute'].items() if k != 'whole'})}; "
                      f"cells {answer['cells']['owner_changed']}; with the page's reads {page[-1]:.3f} s)", flush=True)
                status, _, _ = d.json("POST", f"/sessions/{sid}/undo", {})
                assert status == 200
                page_reads()
            _, _, info = d.json("GET", f"/sessions/{sid}")
        finally:
            d.stop()
    print()
    print("| case | cells | session create s | edit median s | edit worst s | server_s median | "
          "edit and page median s | edit and page worst s | bytes per cell |")
    print("|---|---|---|---|---|---|---|---|---|")
    cells = info["grid"]["width"] * info["grid"]["height"]
    print(f"| {case} {size} | {cells:,} | {create:.2f} | {statistics.median(client):.3f} | {max(client):.3f} | "
          f"{statistics.median(server):.3f} | {statistics.median(page):.3f} | {max(page):.3f} | "
          f"{info['bytes_per_cell']:.2f} |")


if __name__ == "__main__":
    main()
