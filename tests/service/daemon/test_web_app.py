"""The map page /app (issue 34) in a real browser: headless Chromium driven by Selenium.

    /usr/bin/python3 tests/service/daemon/test_web_app.py RVORONOI FIXTURES ARTEFACT_DIR

Against daemons this test starts (without and with a bearer token):
  1. the page and its bundle are served with the map page's Content-Security-Policy (no inline
     script); the process describe-seeds lists fields, values, CRS and box of a GeoPackage, a
     zipped Shapefile and a FlatGeobuf;
  2. the Øresund GeoPackage through the file picker: the owner field is offered (and guessed),
     a job with a 12 nmi limit runs with its progress, the owner raster is drawn from the
     daemon's ZSTD/predictor COG in the owners' colours (screenshot pixels), the boundary is
     drawn, the legend lists DK and SE with the report's areas, clicks on the map report the
     owner and distance of exactly the cell the rasters hold there (read back with GDAL), the
     downloads are offered for every result and one is fetched; no JavaScript errors;
  3. the western Baltic (four states, a border tolerance set under "More options"): the legend
     lists the four, the tripoints are drawn; a grid too large for the server: the daemon's
     problem shown in plain words;
  4. hostile data: a GeoJSON whose owner label is <script>alert(1)</script> and whose file name
     and field name are markup: shown as text, nothing runs, nothing is injected;
  5. with authentication on: the page asks for the token (its header says "Not signed in"), then
     says who signed in ("Signed in as alice (user)") and the whole run works (the COG reads
     carry the header) and the token appears in no URL the daemon saw; that daemon allows too
     few vertices for drawing the seeds: the page describes them without and says so; without
     authentication the header says "Open server";
  6. accessibility basics on every state: labelled fields, alt texts.
Screenshots go to ARTEFACT_DIR.
"""
import base64
import gzip
import json
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from daemon_harness import Daemon  # noqa: E402
from test_web_pages import accessibility, check, closed_daemon, HOSTILE, outcome, session  # noqa: E402

import numpy as np  # noqa: E402
from osgeo import gdal  # noqa: E402
from selenium import webdriver  # noqa: E402
from selenium.common.exceptions import NoAlertPresentException  # noqa: E402
from selenium.webdriver import ActionChains  # noqa: E402
from selenium.webdriver.chrome.service import Service  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

RVORONOI, ARTEFACTS = sys.argv[1], sys.argv[3]
# The file picker takes canonical paths only.
FIXTURES = os.path.realpath(sys.argv[2])
gdal.UseExceptions()


def browser(downloads):
    o = webdriver.ChromeOptions()
    # WebGL (the owner raster's layer) on the software renderer: the test machines have no GPU.
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
              "--disable-dev-shm-usage", "--window-size=1400,1000", "--disable-background-networking",
              "--disable-component-update"):
        o.add_argument(a)
    o.binary_location = "/usr/bin/chromium"
    o.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    o.add_experimental_option("prefs", {"download.default_directory": downloads, "download.prompt_for_download": False})
    return webdriver.Chrome(service=Service(executable_path="/usr/bin/chromedriver"), options=o)


def shot(drv, name):
    drv.save_screenshot(os.path.join(ARTEFACTS, "app-" + name + ".png"))


def page_state(drv):
    return drv.find_element(By.TAG_NAME, "body").get_attribute("data-state")


def wait_state(drv, states, seconds=60):
    WebDriverWait(drv, seconds).until(lambda d: page_state(d) in states)
    return page_state(drv)


def errors(drv):
    return [e for e in drv.get_log("browser") if e["level"] == "SEVERE"]


def open_app(drv, base):
    drv.get(base + "/app")
    return wait_state(drv, ("ready", "token", "failed"), 30)


def load(drv, path):
    drv.find_element(By.ID, "seed-file").send_keys(path)
    return wait_state(drv, ("described", "failed"), 30)


def run(drv, limits=None, resolution=None):
    if limits:
        drv.find_element(By.ID, "in-limitDistances").send_keys(limits)
    if resolution:
        field = drv.find_element(By.ID, "in-resolution")
        field.clear()
        field.send_keys(resolution)
    drv.find_element(By.CSS_SELECTOR, "button.run").click()
    return wait_state(drv, ("done", "failed"), 120)


def job_id(drv):
    link = drv.find_element(By.CSS_SELECTOR, "section[aria-labelledby=h-result] a[href^='/jobs/']")
    return link.get_attribute("href").split("/jobs/")[1].split("?")[0]


def hex_rgb(h):
    return tuple(int(h[i:i + 2], 16) for i in (1, 3, 5))


def screenshot_array(png):
    """A screenshot as rows x columns x RGB."""
    path = "/vsimem/rv-app-shot.png"
    gdal.FileFromMemBuffer(path, png)
    ds = gdal.Open(path)
    a = np.stack([ds.GetRasterBand(b).ReadAsArray().astype(int) for b in (1, 2, 3)], axis=-1)
    ds = None
    gdal.Unlink(path)
    return a


def pixels_of(png, rgb, tolerance=3):
    """How many screenshot pixels have colour rgb (within tolerance per channel)."""
    return int((np.abs(screenshot_array(png) - np.array(rgb)).max(axis=-1) <= tolerance).sum())


def raster(d, job, name, with_transform=False):
    status, _, body = d.request("GET", "/jobs/%s/results/%s" % (job, name), headers=d_headers(d))
    check(status == 200, "GET %s: %s" % (name, status))
    path = "/vsimem/app-%s-%s.tif" % (job, name)
    gdal.FileFromMemBuffer(path, body)
    ds = gdal.Open(path)
    a, gt = ds.ReadAsArray(), ds.GetGeoTransform()
    ds = None
    gdal.Unlink(path)
    return (a, gt) if with_transform else a


def d_headers(d):
    return {"Authorization": "Bearer " + d.token} if getattr(d, "token", None) else {}


def api_checks(d):
    status, h, body = d.request("GET", "/app", headers={"Accept": "text/html"})
    csp = h.get("content-security-policy", "")
    check(status == 200 and h["content-type"].startswith("text/html"), "/app is a page")
    script_src = [p for p in csp.split(";") if p.strip().startswith("script-src")]
    check(script_src and "unsafe-inline" not in script_src[0] and "'self'" in script_src[0],
          "/app: CSP forbids inline scripts: %s" % csp)
    check(b"<script>" not in body and b"onload=" not in body, "/app holds no inline script")
    status, h, body = d.request("GET", "/static/app.js")
    check(status == 200 and h["content-type"].startswith("text/javascript") and len(body) > 100000
          and "content-encoding" not in h, "the bundle is served (%s, %d bytes)" % (status, len(body)))
    status, hz, packed = d.request("GET", "/static/app.js", headers={"Accept-Encoding": "br, gzip;q=0.8"})
    check(status == 200 and hz.get("content-encoding") == "gzip" and gzip.decompress(packed) == body
          and len(packed) < len(body) // 2, "gzip where accepted: %d of %d bytes" % (len(packed), len(body)))
    _, hq, plain = d.request("GET", "/static/app.js", headers={"Accept-Encoding": "gzip;q=0, deflate"})
    check("content-encoding" not in hq and plain == body, "no gzip where refused (q=0)")
    etag = h.get("etag", "")
    status, h304, empty = d.request("GET", "/static/app.js", headers={"If-None-Match": etag})
    check(etag and status == 304 and not empty and h304.get("etag") == etag, "304 for the same ETag (%r)" % etag)
    status, _, again = d.request("GET", "/static/app.js", headers={"If-None-Match": '"0-0.0"'})
    check(status == 200 and again == body, "200 for another ETag")
    status, _, doc = d.json("GET", "/processes")
    check([p["id"] for p in doc["processes"]] == ["voronoi", "describe-seeds"], "two processes listed")
    status, _, landing = d.json("GET", "/")
    check(any(l["href"].endswith("/app") and l["type"] == "text/html" for l in landing["links"]),
          "the landing page links the map page")

    def describe(path, media, extra=None):
        with open(path, "rb") as f:
            value = base64.b64encode(f.read()).decode()
        inputs = {"seeds": {"value": value, "mediaType": media, "encoding": "base64"}}
        inputs.update(extra or {})
        return d.json("POST", "/processes/describe-seeds/execution", {"inputs": inputs})

    status, _, doc = describe(os.path.join(FIXTURES, "baltic_west.gpkg"), "application/geopackage+sqlite3",
                              {"features": True})
    check(status == 200, "describe-seeds answers: %s %s" % (status, str(doc)[:200]))
    layer = doc["layers"][0]
    check(layer["name"] == "states" and layer["features"] == 4 and layer["source"] == "seeds[0]:states",
          "the Baltic's layer: %s" % {k: layer[k] for k in ("name", "features", "source")})
    iso = [f for f in layer["fields"] if f["name"] == "iso2"]
    check(iso and iso[0]["values"] == ["DK", "SE", "DE", "PL"] and iso[0]["distinct"] == 4 and iso[0]["type"] == "string",
          "iso2 with its four values in reading order: %s" % iso)
    check(doc["commonFields"] == ["iso2"] and doc["crs"]["code"] == "EPSG:4326" and doc["crs"]["geographic"],
          "common fields and CRS: %s %s" % (doc["commonFields"], doc["crs"]["code"]))
    bbox = doc["bbox"]
    check(abs(bbox[0] - 9.0) < 1e-6 and abs(bbox[3] - 56.2) < 1e-6, "the Baltic's box: %s" % bbox)
    features = doc["features"]["features"]
    check(len(features) == 4 and [f["properties"]["iso2"] for f in features] == ["DK", "SE", "DE", "PL"]
          and [f["id"] for f in features] == [1, 2, 3, 4] and features[0]["geometry"]["type"] == "MultiPolygon",
          "the features, in input order, with their positions as ids")
    # The Øresund in UTM 33N: the features come reprojected, the box too.
    status, _, doc = describe(os.path.join(FIXTURES, "oresund.gpkg"), "application/geopackage+sqlite3",
                              {"crs": "EPSG:32633", "features": True})
    check(status == 200 and doc["crs"]["code"] == "EPSG:32633" and not doc["crs"]["geographic"]
          and doc["crs"]["metresPerUnit"] == 1.0 and 200000 < doc["bbox"][0] < 400000,
          "describe-seeds reprojects to the crs asked: %s %s" % (doc.get("crs", {}).get("code"), doc.get("bbox")))
    for name, media in (("coast_shp.zip", "application/zip"), ("all_types.fgb", "application/flatgeobuf")):
        status, _, doc = describe(os.path.join(FIXTURES, name), media)
        check(status == 200 and doc["layers"] and doc["layers"][0]["fields"] and "features" not in doc,
              "%s described, without features unless asked: %s" % (name, str(doc)[:200]))
    status, _, doc = d.json("POST", "/processes/describe-seeds/execution",
                            {"inputs": {"seeds": {"value": "AAAA", "mediaType": "application/zip", "encoding": "base64"}}})
    check(status == 400 and "seeds" in doc.get("detail", ""), "a damaged upload is a 400 naming the input: %s" % doc)
    status, _, doc = d.json("POST", "/processes/describe-seeds/execution", {"inputs": {"seeds": {}, "owner": "x"}})
    check(status == 400 and "owner" in doc.get("detail", ""), "an unknown input is named: %s" % doc)


def oresund_run(drv, d, base, tag):
    check(open_app(drv, base) == "ready", "%s: the page starts" % tag)
    if tag == "open":
        line = session(drv, "open")
        check(line == "Open server", "the map page's header says the server is open: %r" % line)
    accessibility(drv, tag + " start")
    check(load(drv, os.path.join(FIXTURES, "oresund.gpkg")) == "described", "%s: the GeoPackage is described" % tag)
    owner = drv.find_element(By.ID, "in-ownerField")
    options = [o.get_attribute("value") for o in owner.find_elements(By.TAG_NAME, "option")]
    check("iso2" in options and owner.get_attribute("value") == "iso2",
          "%s: iso2 offered and chosen as the owner field: %s" % (tag, options))
    check("2 values" in owner.text, "%s: the field's values are counted" % tag)
    check(drv.find_element(By.ID, "in-resolution").get_attribute("value") != "", "%s: a cell size is proposed" % tag)
    accessibility(drv, tag + " form")
    shot(drv, tag + "-form")
    check(run(drv, limits="12nmi", resolution="0.004") == "done", "%s: the job ran: %s" % (
        tag, drv.find_element(By.ID, "panel").text[-400:]))
    check(drv.find_element(By.ID, "job-progress").get_attribute("value") == "100", "%s: the progress bar is full" % tag)
    time.sleep(1.5)  # the raster tiles are decoded and drawn
    job = job_id(drv)
    _, _, report = d.json("GET", "/jobs/%s/results" % job, headers=d_headers(d))
    report = report["report"]["value"]
    owners = {o["label"]: o for o in report["seeds"]["owners"]}
    check(set(owners) == {"DK", "SE"} and all(o["colour"].startswith("#") for o in owners.values()),
          "%s: the report gives each owner its colour: %s" % (tag, owners))
    legend = drv.find_element(By.ID, "legend")
    text = legend.text
    areas = {a["label"]: a for a in report["deliverables"]["regions"]["areas"]}
    for label in ("DK", "SE"):
        km2 = "{:,.1f}".format(areas[label]["sea_area"] / 1e6)
        check(label in text and km2 in text, "%s: the legend lists %s with its sea area %s km²: %s" % (tag, label, km2, text))
    png = drv.get_screenshot_as_png()
    shot(drv, tag + "-result")
    for label, o in owners.items():
        n = pixels_of(png, hex_rgb(o["colour"]))
        check(n > 5000, "%s: the owner raster shows %s's sea in its colour (%d pixels)" % (tag, label, n))
    n = pixels_of(png, (0x1b, 0x26, 0x31), 10)
    check(n > 200, "%s: the boundary is drawn (%d pixels)" % (tag, n))
    # Clicks: the read-out names the cell and its values, equal to the rasters'.
    own, gt = raster(d, job, "ownership", True)
    dist = raster(d, job, "distance")
    seen = set()
    cell = drv.find_element(By.ID, "cell")
    shown = screenshot_array(png)
    m = drv.find_element(By.ID, "map")
    centre = (m.location["x"] + m.size["width"] // 2, m.location["y"] + m.size["height"] // 2)
    colours = {o["code"]: hex_rgb(o["colour"]) for o in owners.values()}
    coloured = 0
    for dx, dy in ((-60, 0), (0, -40), (50, 80), (120, -150), (-200, 200), (-150, -100), (200, 50)):
        drv.execute_script("arguments[0].removeAttribute('data-row')", cell)
        ActionChains(drv).move_to_element_with_offset(drv.find_element(By.ID, "map"), dx, dy).click().perform()
        try:
            WebDriverWait(drv, 10).until(lambda x: cell.get_attribute("data-row"))
        except Exception:
            check(False, "%s: the click at %s gave a read-out: %s" % (tag, (dx, dy), cell.text))
            continue
        r, c = int(cell.get_attribute("data-row")), int(cell.get_attribute("data-col"))
        code, distance = int(cell.get_attribute("data-code")), float(cell.get_attribute("data-distance"))
        check(code == int(own[r, c]) and distance == float(dist[r, c]),
              "%s: the cell (%d, %d) reads owner %d, distance %r; the rasters hold %d, %r" % (
                  tag, r, c, code, distance, own[r, c], dist[r, c]))
        # The cell is the one under the click: from the clicked map coordinate and the file's
        # georeferencing (GDAL), not from the page's arithmetic.
        x, y = float(cell.get_attribute("data-x")), float(cell.get_attribute("data-y"))
        want = (int((y - gt[3]) // gt[5]), int((x - gt[0]) // gt[1]))
        check((r, c) == want, "%s: the click at (%r, %r) is cell %s; the page read %s" % (tag, x, y, want, (r, c)))
        # Where the screen shows an owner's colour, it is the colour of the owner of that cell.
        px = shown[centre[1] + dy, centre[0] + dx]
        match = [k for k, rgb in colours.items() if np.abs(px - np.array(rgb)).max() <= 3]
        if match:
            coloured += 1
            check(match == [code], "%s: the screen at the click shows owner %s's colour; the cell is %d's" % (
                tag, match, code))
        label = [k for k, o in owners.items() if o["code"] == code]
        check(not label or ("Owner " + label[0]) in cell.text, "%s: the read-out names the owner: %s" % (tag, cell.text))
        seen.add(code)
    check({1, 2} <= seen, "%s: clicks met both owners: %s" % (tag, seen))
    check(coloured >= 3, "%s: at least 3 clicks on the owners' sea (%d)" % (tag, coloured))
    names = [b.text for b in drv.find_elements(By.CSS_SELECTOR, "#downloads button")]
    for want in ("ownership.tif", "distance.tif", "report.json", "regions.geojson", "boundaries.geojson",
                 "tripoints.geojson", "limits.geojson", "ownership.tif.aux.xml"):
        check(want in names, "%s: a download for %s: %s" % (tag, want, names))
    return job, own


def baltic_run(drv, base):
    """Four owners, tripoints, land borders that overlap by metres (a tolerance under More options)."""
    open_app(drv, base)
    check(load(drv, os.path.join(FIXTURES, "baltic_west.gpkg")) == "described", "the Baltic is described")
    drv.find_element(By.CSS_SELECTOR, "details.more summary").click()
    field = drv.find_element(By.ID, "in-borderTolerance")
    field.clear()
    field.send_keys("10")
    check(run(drv, resolution="0.01") == "done", "the Baltic ran: %s" % drv.find_element(By.ID, "panel").text[-300:])
    time.sleep(1.5)
    legend = drv.find_element(By.ID, "legend").text
    check(all(s in legend for s in ("DK", "SE", "DE", "PL")), "the legend lists the four states: %s" % legend)
    png = drv.get_screenshot_as_png()
    shot(drv, "baltic")
    n = pixels_of(png, (0xc0, 0x39, 0x2b), 6)
    check(n > 30, "the tripoints are drawn (%d pixels)" % n)


def sea_run(drv, d, base):
    """The distance by sea: ports as the seeds, the "By sea" switch and the land as the barrier
    layer, a projected CRS and a max distance of 8 km, the turning points asked for; the owners' sea
    on the map is the CLI's, cell for cell, the regions' areas are their cells', and the turning
    points by sea are made and offered, the CLI's lines and points."""
    open_app(drv, base)
    ports = os.path.join(FIXTURES, "oresund_ports.geojson")
    land = os.path.join(FIXTURES, "oresund.gpkg")
    check(load(drv, ports) == "described", "the ports are described")
    check(drv.find_element(By.ID, "sea-layer").get_attribute("hidden") is not None, "the barrier layer waits for the switch")
    drv.find_element(By.ID, "by-sea").click()
    check(drv.find_element(By.ID, "sea-layer").is_displayed(), "the switch asks for the barrier layer")
    check(drv.find_element(By.ID, "out-boundaries").is_enabled(), "the boundaries stay on by sea")
    check(drv.find_element(By.ID, "in-limitDistances").is_enabled(), "the limits stay on by sea")
    turning = drv.find_element(By.ID, "out-turningPoints")
    check(turning.is_enabled(), "the turning points stay on offer by sea")
    if not turning.is_selected():
        turning.click()
    check(turning.is_selected(), "the turning points are asked for by sea")
    drv.find_element(By.ID, "barrier-file").send_keys(land)
    drv.find_element(By.CSS_SELECTOR, "details.more summary").click()
    drv.find_element(By.ID, "in-crs").send_keys("EPSG:32633")
    drv.find_element(By.ID, "in-maxDistance").send_keys("8000")
    check(run(drv, resolution="500") == "done", "the run by sea: %s" % drv.find_element(By.ID, "panel").text[-400:])
    job = job_id(drv)
    own = raster(d, job, "ownership")
    names = [b.text for b in drv.find_elements(By.CSS_SELECTOR, "#downloads button")]
    check("via.tif" in names and "boundaries.geojson" in names and "regions.geojson" in names
          and "turningPoints.json" in names, "the downloads by sea: %s" % names)
    status, _, turning = d.json("GET", "/jobs/%s/results/turningPoints" % job, headers=d_headers(d))
    check(status == 200 and isinstance(turning, dict), "GET turningPoints by sea: %s" % status)
    turning = turning if isinstance(turning, dict) else {}
    points = sum(len(line["points"]) for line in turning.get("lines", []))
    check(turning.get("by_sea") is True and points > 0,
          "the turning points by sea: %d points, by_sea %r" % (points, turning.get("by_sea")))
    with tempfile.TemporaryDirectory() as tmp:
        path, table = os.path.join(tmp, "o.tif"), os.path.join(tmp, "tp.json")
        subprocess.run([RVORONOI, "compute", ports, "--owner-field", "owner", "--barriers", land, "--crs", "EPSG:32633",
                        "--metric", "planar", "--resolution", "500", "--max-distance", "8000", "--ownership", path,
                        "--turning-points", table, "--quiet"], check=True)
        cli = gdal.Open(path).ReadAsArray()
        with open(table) as f:
            cli_turning = json.load(f)
    check(own.shape == cli.shape and np.array_equal(own, cli), "the page's run by sea equals the CLI's")
    cli_points = sum(len(line["points"]) for line in cli_turning["lines"])
    check(len(turning.get("lines", [])) == len(cli_turning["lines"]) and points == cli_points,
          "the page's turning points by sea are the CLI's: %d lines, %d points; the CLI %d, %d"
          % (len(turning.get("lines", [])), points, len(cli_turning["lines"]), cli_points))
    check(int((own == 0).sum()) > 1000, "land has no owner")
    # The regions by sea: each state's sea area in the legend, as the report gives it.
    _, _, report = d.json("GET", "/jobs/%s/results" % job, headers=d_headers(d))
    areas = {a["label"]: a for a in report["report"]["value"]["deliverables"]["regions"]["areas"]}
    legend = drv.find_element(By.ID, "legend").text
    for code, label in ((1, "DK"), (2, "SE")):
        km2 = "{:,.1f}".format(areas[label]["sea_area"] / 1e6)
        check(label in legend and km2 in legend, "by sea: the legend lists %s with its sea area %s km²: %s"
              % (label, km2, legend))
        # (Cells of 500 m: 0.25 km² each; the regions follow the lines, the cells step round them.)
        cells = int((own == code).sum()) * 0.25
        check(abs(areas[label]["sea_area"] / 1e6 - cells) <= 0.04 * cells,
              "by sea within 8 km: %s's region %.1f km², its cells %.1f km²" % (label, areas[label]["sea_area"] / 1e6, cells))
    shot(drv, "by-sea")


def download(drv, downloads, name, expect):
    [b for b in drv.find_elements(By.CSS_SELECTOR, "#downloads button") if b.text == name][0].click()
    path = os.path.join(downloads, name)
    end = time.time() + 20
    while time.time() < end and not os.path.exists(path):
        time.sleep(0.1)
    check(os.path.exists(path), "the download %s was saved" % name)
    if os.path.exists(path):
        a = gdal.Open(path).ReadAsArray()
        check(np.array_equal(a, expect), "the downloaded %s equals the job's" % name)
        os.unlink(path)


def too_large(drv, base):
    open_app(drv, base)
    load(drv, os.path.join(FIXTURES, "oresund.gpkg"))
    check(run(drv, resolution="0.000001") == "failed", "a grid over the limit fails")
    text = drv.find_element(By.ID, "panel").text
    check("larger cell size" in text and "cells" in text, "the limit is told in plain words: %s" % text[-300:])
    shot(drv, "too-large")


def hostile(drv, base, tmp):
    name = os.path.join(tmp, "<img src=x onerror=alert(2)>.geojson")
    field = '<b onmouseover="alert(3)">state</b>'
    fc = {"type": "FeatureCollection",
          "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
          "features": [{"type": "Feature", "properties": {field: s}, "geometry": {"type": "Point", "coordinates": [x, y]}}
                       for s, x, y in ((HOSTILE, 401000, 6101000), ("B", 409000, 6109000), (HOSTILE, 403000, 6108000))]}
    with open(name, "w") as f:
        json.dump(fc, f)
    open_app(drv, base)
    check(load(drv, name) == "described", "the hostile file is described")
    select = drv.find_element(By.ID, "in-ownerField")
    check(field in select.text, "the hostile field name is shown as text")
    for o in select.find_elements(By.TAG_NAME, "option"):
        if o.get_attribute("value") == field:
            o.click()
    check(run(drv, resolution="100") == "done", "the hostile job ran")
    check(HOSTILE in drv.find_element(By.ID, "legend").text, "the hostile label is shown as text in the legend")
    check(os.path.basename(name) in drv.find_element(By.ID, "panel").text, "the hostile file name is shown as text")
    try:
        drv.switch_to.alert
        check(False, "an alert ran")
    except NoAlertPresentException:
        pass
    injected = drv.execute_script(
        "return [...document.querySelectorAll('#panel script, #panel img, #panel b')].length")
    check(injected == 0, "no element was injected (%d)" % injected)
    shot(drv, "hostile")


def with_token(drv, d, base, downloads):
    check(open_app(drv, base) == "token", "the page asks for a token")
    check(session(drv, "signed-out") == "Not signed in", "the map page's header says nobody is signed in")
    accessibility(drv, "token")
    drv.find_element(By.ID, "token").send_keys(d.token)
    drv.find_element(By.CSS_SELECTOR, "form.token button").click()
    time.sleep(0.5)
    wait_state(drv, ("ready",), 30)
    line = session(drv, "signed-in")
    check(line.startswith("Signed in as alice (user)") and "Forget" in line, "the map page's header says who: %r" % line)
    _, own = oresund_run(drv, d, base, "auth")
    check("too large to draw" in drv.find_element(By.ID, "panel").text,
          "over preview_max_vertices, the page says the seeds are not drawn")
    download(drv, downloads, "ownership.tif", own)
    check(not any(d.token in line for line in d.log), "the token appears in no logged request")


def map_pixel(drv, coordinate):
    return drv.execute_script(
        "return document.getElementById('map').rvoronoiView.map.getPixelFromCoordinate(arguments[0]);", coordinate)


def drag(drv, pixel, by):
    """Presses at `pixel` of the map (from its top left), moves by `by` pixels in steps, releases."""
    m = drv.find_element(By.ID, "map")
    dx, dy = pixel[0] - m.size["width"] / 2, pixel[1] - m.size["height"] / 2
    chain = ActionChains(drv).move_to_element_with_offset(m, int(round(dx)), int(round(dy))).click_and_hold()
    for _ in range(4):
        chain = chain.move_by_offset(by[0] // 4, by[1] // 4).pause(0.05)
    chain.release().perform()


def wait_step(drv, step, seconds=60):
    WebDriverWait(drv, seconds).until(
        lambda x: page_state(x) == "editing" and x.find_element(By.ID, "edit-step").get_attribute("data-step") == str(step))


def line_set(coordinates_list):
    return sorted(json.dumps([[round(float(c), 6) for c in p] for p in line]) for line in coordinates_list)


def edit_run(drv, d, base):
    """Issue 54's map page test: the what-if mode on a live session. Drag a point, check that the
    drawn boundary is the session's and that the areas changed by the session's amounts; undo;
    pick and remove a feature; move a vertex by typed coordinates; save as a job."""
    check(open_app(drv, base) == "ready", "edit: the page starts")
    check(load(drv, os.path.join(FIXTURES, "demo_basepoints.geojson")) == "described", "edit: the points are described")
    check(run(drv, resolution="250") == "done", "edit: the job ran")
    drv.find_element(By.ID, "edit-start").click()
    check(wait_state(drv, ("editing", "edit-failed"), 120) == "editing",
          "edit: the session started: %s" % drv.find_element(By.ID, "panel").text[-400:])
    accessibility(drv, "edit mode")
    sid = drv.find_element(By.ID, "edit-step").get_attribute("data-session")
    _, _, start = d.json("GET", "/sessions/" + sid)
    start_area = {a["label"]: a["area"] for a in start["areas"]}
    _, _, fc = d.json("GET", "/sessions/%s/features" % sid)
    first = fc["features"][0]
    at = first["geometry"]["coordinates"]
    drag(drv, map_pixel(drv, at), (48, 36))
    wait_step(drv, 1)
    shot(drv, "edit-dragged")
    _, _, fc = d.json("GET", "/sessions/%s/features" % sid)
    moved = fc["features"][0]["geometry"]["coordinates"]
    check(moved != at, "edit: the dragged point moved on the server: %s -> %s" % (at, moved))
    pixel = map_pixel(drv, moved)
    start_pixel = map_pixel(drv, at)
    check(abs(pixel[0] - start_pixel[0] - 48) <= 3 and abs(pixel[1] - start_pixel[1] - 36) <= 3,
          "edit: the point went where it was dropped: %s from %s" % (pixel, start_pixel))
    drawn = drv.execute_script(
        "return document.getElementById('map').rvoronoiView.layers.boundaries.getSource().getFeatures()"
        ".map(f => f.getGeometry().getCoordinates());")
    _, _, served = d.json("GET", "/sessions/%s/deliverables/boundaries" % sid)
    check(line_set(drawn) == line_set([f["geometry"]["coordinates"] for f in served["features"]]),
          "edit: the drawn boundaries are the session's (%d drawn, %d served)" % (len(drawn), len(served["features"])))
    # Redrawn from the step's answer: the lines keep the session's ids, and the page read the
    # boundaries once (when the session began), not again after the step.
    drawn_ids = drv.execute_script(
        "return document.getElementById('map').rvoronoiView.layers.boundaries.getSource().getFeatures()"
        ".map(f => f.getId());")
    _, _, ids = d.json("GET", "/sessions/%s/lines" % sid)
    check(sorted(drawn_ids) == sorted(ids["boundaries"]), "edit: the drawn lines' ids %s are not the session's %s"
          % (sorted(drawn_ids), sorted(ids["boundaries"])))
    reads = drv.execute_script(
        "return performance.getEntriesByType('resource').map(e => e.name)"
        ".filter(n => n.includes('/sessions/" + sid + "/deliverables/boundaries')).length;")
    check(reads == 1, "edit: the page read the session's boundaries %d times; once, then the answer" % reads)
    _, _, now = d.json("GET", "/sessions/" + sid)
    rows = {r.get_attribute("data-owner"): r for r in drv.find_elements(By.CSS_SELECTOR, "#edit-areas tr[data-owner]")}
    changed = 0
    for a in now["areas"]:
        r = rows.get(a["label"])
        if not check(r is not None, "edit: the area table lists %s" % a["label"]):
            continue
        page_area, page_change = float(r.get_attribute("data-area")), float(r.get_attribute("data-change"))
        want = a["area"] - start_area[a["label"]]
        check(page_area == a["area"] and abs(page_change - want) <= 1e-9 * max(1.0, abs(a["area"])),
              "edit: %s's area %r, change %r; the session says %r, %r" % (a["label"], page_area, page_change, a["area"], want))
        changed += want != 0
        if want != 0:
            check((a["label"] + " +" if want > 0 else a["label"] + " −") in r.text, "edit: the change is shown signed: %s" % r.text)
    check(changed >= 2, "edit: the drag moved sea between owners (%d owners changed)" % changed)
    # Undo: back to the start.
    drv.find_element(By.ID, "edit-undo").click()
    wait_step(drv, 0)
    changes = [float(r.get_attribute("data-change")) for r in drv.find_elements(By.CSS_SELECTOR, "#edit-areas tr[data-owner]")]
    check(changes and all(c == 0 for c in changes), "edit: undo brings the areas back: %s" % changes)
    # Pick a feature by a click and remove it.
    second = fc["features"][1]
    pixel = map_pixel(drv, second["geometry"]["coordinates"])
    m = drv.find_element(By.ID, "map")
    ActionChains(drv).move_to_element_with_offset(m, int(pixel[0] - m.size["width"] / 2),
                                                  int(pixel[1] - m.size["height"] / 2)).click().perform()
    WebDriverWait(drv, 10).until(lambda x: ("Feature " + second["id"]) in x.find_element(By.ID, "edit-feature").text)
    drv.find_element(By.ID, "pick-remove").click()
    wait_step(drv, 1)
    _, _, fc2 = d.json("GET", "/sessions/%s/features" % sid)
    check(second["id"] not in [f["id"] for f in fc2["features"]], "edit: the picked feature was removed")
    # A vertex moved by typed coordinates.
    third = fc["features"][2]
    x, y = third["geometry"]["coordinates"]
    for fid, value in (("move-feature", third["id"]), ("move-path", ""), ("move-x", str(x + 700)), ("move-y", str(y - 300))):
        field = drv.find_element(By.ID, fid)
        field.clear()
        field.send_keys(value)
    drv.find_element(By.CSS_SELECTOR, "#edit-move button[type=submit]").click()
    wait_step(drv, 2)
    _, _, fc3 = d.json("GET", "/sessions/%s/features" % sid)
    got = [f for f in fc3["features"] if f["id"] == third["id"]][0]["geometry"]["coordinates"]
    check(got == [x + 700, y - 300], "edit: the typed move reached the server: %s" % got)
    # Save as job.
    drv.find_element(By.ID, "edit-save").click()
    WebDriverWait(drv, 30).until(lambda x: x.find_elements(By.ID, "edit-saved"))
    job = drv.find_element(By.ID, "edit-saved").text
    status = d.wait_status(job, ("successful", "failed"), 120)
    check(status["status"] == "successful", "edit: the saved job ran: %s" % status)
    shot(drv, "edit-done")
    check(not errors(drv), "edit: no JavaScript errors: %s" % errors(drv))


def main():
    os.makedirs(ARTEFACTS, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        downloads = os.path.join(tmp, "downloads")
        os.makedirs(downloads)
        drv = browser(downloads)
        try:
            d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "open"), {"limits": {"max_cells": 50_000_000}})
            try:
                api_checks(d)
                oresund_run(drv, d, "http://127.0.0.1:%d" % d.port, "open")
                check(not errors(drv), "no JavaScript errors: %s" % errors(drv))
                edit_run(drv, d, "http://127.0.0.1:%d" % d.port)
                baltic_run(drv, "http://127.0.0.1:%d" % d.port)
                sea_run(drv, d, "http://127.0.0.1:%d" % d.port)
                too_large(drv, "http://127.0.0.1:%d" % d.port)
                drv.get_log("browser")  # the 413 itself is logged by the browser
                hostile(drv, "http://127.0.0.1:%d" % d.port, tmp)
                check(not errors(drv), "no JavaScript errors: %s" % errors(drv))
            finally:
                d.stop()
            # Too few vertices allowed for drawing the Øresund: described without its features.
            d, d.token = closed_daemon(RVORONOI, tmp, {"limits": {"preview_max_vertices": 100}})
            try:
                drv.execute_script("sessionStorage.clear()")
                with_token(drv, d, "http://127.0.0.1:%d" % d.port, downloads)
            finally:
                d.stop()
        finally:
            drv.quit()
    return outcome("map page", ARTEFACTS)


if __name__ == "__main__":
    sys.exit(main())
