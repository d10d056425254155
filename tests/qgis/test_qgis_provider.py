"""The QGIS Processing provider (issue 53), headless on Debian's QGIS 3.22.

Against a daemon this test starts (authentication on: a principal whose token sits in a QGIS
authentication database the test makes, with its master password in a file):
  1. the plugin installed from the zip of tools/package-qgis.sh, `qgis_process.bin plugins enable
     rvoronoi`, the algorithm listed, its parameters named in
     upper snake case;
  2. rvoronoi:voronoi on the Øresund and on the western Baltic (onConflict lower-code) through
     qgis_process, against the daemon and locally (the Python module in QGIS's process, mode
     local): every file equals the CLI's for the same options (rasters by content, lines and
     regions feature for feature); a Shapefile destination is converted;
  3. a bad input's message, a missing token, an unreachable server (the cached descriptions still
     give the algorithm), a URL that is not the API: one clear message each, never a traceback;
     the token never in what qgis_process prints;
  4. cancelling a run (PyQGIS, a feedback that cancels once the job is submitted) dismisses the
     job on the server;
  5. the styled results rendered offscreen: the ownership raster in each owner's colour from the
     report, cell for cell; the whole map (an artefact) with its boundaries and red tripoints;
  6. the Processing model of qgis/tests (reproject the seeds, rvoronoi, clip the regions) through
     qgis_process, and batch mode (one process running a row of parameters after another);
  7. the dialog's owner-field widget lists the fields of the first seed layer chosen;
  8. a result downloaded as it arrives: 256 MiB through the plugin's client grow QGIS's memory by
     a buffer, not by the file, and equal the bytes sent; an answer cut short and a refusal leave
     no file (nor its .part);
  9. a description with an extra input of every kind (and one of a kind unknown to the plugin)
     becomes the parameters it should, the unknown one as text with a warning.
QGIS's /usr/bin/qgis_process wrapper may add options (QGIS_OPTS) that 3.22's qgis_process refuses;
the test calls /usr/bin/qgis_process.bin, with QT_QPA_PLATFORM=offscreen.

usage: test_qgis_provider.py RVORONOI SOURCE_DIR PYTHON_MODULE_DIR [ARTEFACT_DIR]
"""
import hashlib
import http.server
import json
import os
import socketserver
import subprocess
import sys
import tempfile
import threading
import time
import zipfile

from osgeo import gdal, ogr

SOURCE = sys.argv[2]
RVORONOI = sys.argv[1]
MODULE_DIR = sys.argv[3]
ARTEFACTS = sys.argv[4] if len(sys.argv) > 4 else tempfile.gettempdir()
sys.path.insert(0, os.path.join(SOURCE, "tests", "service", "daemon"))
from daemon_harness import Daemon, DocumentServer  # noqa: E402

QGIS_PROCESS = "/usr/bin/qgis_process.bin"
TOKEN = "qgis-analyst-token-" + os.urandom(12).hex()
FAILURES = []
gdal.UseExceptions()


def check(condition, what):
    if not condition:
        FAILURES.append(what)
        print("FAIL:", what, flush=True)


class Qgis:
    """qgis_process (and PyQGIS scripts) in a profile of their own, the plugin installed from the zip
    tools/package-qgis.sh makes (what QGIS's "Install from ZIP" takes)."""

    def __init__(self, tmp):
        self.home = os.path.join(tmp, "home")
        os.makedirs(self.home)
        made = subprocess.run(["bash", os.path.join(SOURCE, "tools", "package-qgis.sh"), os.path.join(tmp, "dist")],
                              check=True, capture_output=True, text=True).stdout.strip().splitlines()[-1]
        self.plugins = os.path.join(tmp, "plugins")
        with zipfile.ZipFile(made) as z:
            names = z.namelist()
            check(all(n.startswith("rvoronoi/") for n in names) and "rvoronoi/metadata.txt" in names,
                  f"the zip holds one folder rvoronoi/ with its metadata: {names}")
            z.extractall(self.plugins)
        self.auth_dir = os.path.join(tmp, "auth")
        os.makedirs(self.auth_dir)
        self.master = os.path.join(tmp, "master-password")
        with open(self.master, "w") as f:
            f.write("master-" + os.urandom(8).hex())
        self.env = dict(os.environ, HOME=self.home, QT_QPA_PLATFORM="offscreen", XDG_RUNTIME_DIR=tmp,
                        QGIS_PLUGINPATH=self.plugins, QGIS_AUTH_DB_DIR_PATH=self.auth_dir,
                        QGIS_AUTH_PASSWORD_FILE=self.master)
        self.authcfg = self.script(AUTH_SCRIPT, open(self.master).read(), TOKEN).strip().splitlines()[-1]

    def script(self, code, *args, env=None):
        proc = subprocess.run(["/usr/bin/python3", "-c", code] + list(args), capture_output=True, text=True,
                              env=dict(self.env, **(env or {})), timeout=300)
        if proc.returncode != 0:
            raise RuntimeError(f"PyQGIS script failed: {proc.stderr[-2000:]}")
        return proc.stdout

    def run(self, *args, env=None):
        proc = subprocess.run([QGIS_PROCESS] + list(args), capture_output=True, text=True,
                              env=dict(self.env, **(env or {})), timeout=600)
        return proc.returncode, proc.stdout + proc.stderr


# A Basic configuration whose password is the token: QGIS 3.22 has no bearer method.
AUTH_SCRIPT = """
import sys
from qgis.core import QgsApplication, QgsAuthMethodConfig
app = QgsApplication([], False)
app.initQgis()
manager = QgsApplication.authManager()
assert manager.setMasterPassword(sys.argv[1], True)
config = QgsAuthMethodConfig("Basic")
config.setName("rvoronoi server")
config.setConfig("username", "token")
config.setConfig("password", sys.argv[2])
assert manager.storeAuthenticationConfig(config)[0]
print(config.id())
app.exitQgis()
"""

# Cancelling: the provider from the repository in a standalone PyQGIS, a feedback that cancels
# once the job is on the server; prints the job id.
# What every PyQGIS script below starts with: QGIS (with its GUI classes when `gui`), Processing,
# and the plugin's provider registered (kept in `provider`: the registry does not own it).
def with_provider(body, gui=False):
    return f"""
import json, os, re, sys
from qgis.core import QgsApplication, QgsProcessingContext, QgsProcessingFeedback, QgsProject, QgsVectorLayer
app = QgsApplication([], {gui})
app.initQgis()
sys.path.insert(0, os.environ["QGIS_PLUGINPATH"])
sys.path.insert(0, "/usr/share/qgis/python/plugins")
from processing.core.Processing import Processing
Processing.initialize()
from rvoronoi.provider import RvoronoiProvider
provider = RvoronoiProvider()
QgsApplication.processingRegistry().addProvider(provider)
""" + body


CANCEL_SCRIPT = with_provider("""
class Cancelling(QgsProcessingFeedback):
    job = None
    def pushInfo(self, text):
        m = re.match(r"job ([0-9a-f]{32})", text)
        if m:
            Cancelling.job = m.group(1)
            self.cancel()
        super().pushInfo(text)

alg = QgsApplication.processingRegistry().createAlgorithmById("rvoronoi:voronoi")
params = {"SEEDS": [sys.argv[1]], "OWNER_FIELD": "iso2", "RESOLUTION": float(sys.argv[2]), "OWNERSHIP": sys.argv[3]}
class Errors(Cancelling):
    errors = []
    def reportError(self, text, fatal=False):
        Errors.errors.append(text)
        super().reportError(text, fatal)

feedback = Errors()
results, ok = alg.run(params, QgsProcessingContext(), feedback)
print("cancelled: " + " / ".join(Errors.errors) if not ok else "not cancelled")
print(Cancelling.job)
""")

# The parameters of a description with an extra input of every kind.
KINDS_SCRIPT = """
import json, os, sys
from qgis.core import QgsApplication, QgsMessageLog
app = QgsApplication([], False)
app.initQgis()
sys.path.insert(0, os.environ["QGIS_PLUGINPATH"])
from rvoronoi.parameters import input_parameter
warnings = []
QgsApplication.messageLog().messageReceived.connect(lambda m, tag, level: warnings.append(m))
entries = json.loads(sys.argv[1])
out = {}
for input_id, entry in entries.items():
    p = input_parameter(input_id, entry)
    out[input_id] = [p.name(), p.type(), int(p.flags()) & int(p.FlagOptional) != 0, getattr(p, "parentLayerParameterName", lambda: "")()]
QgsApplication.processEvents()
print(json.dumps({"params": out, "warnings": warnings}))
"""

EXTRA_INPUTS = {
    "coastLayers": {"title": "Coasts", "minOccurs": 1,
                    "schema": {"x-rvoronoi-upload": {"geometry": "line", "multiple": True}, "oneOf": []}},
    "basinArea": {"title": "Basin", "minOccurs": 0,
                  "schema": {"x-rvoronoi-upload": {"geometry": "polygon", "multiple": False}, "oneOf": []}},
    "rankField": {"title": "Rank field", "schema": {"type": "string", "x-rvoronoi-field-of": "coastLayers"}},
    "gridCrs": {"title": "CRS", "schema": {"type": "string", "x-rvoronoi-crs": True}},
    "window": {"title": "Window", "schema": {"oneOf": [{"type": "array", "minItems": 4, "maxItems": 4}, {"type": "object"}]}},
    "friction": {"title": "Friction", "schema": {"type": "number", "minimum": 0, "default": 1.5, "x-rvoronoi-unit": "m"}},
    "passes": {"title": "Passes", "schema": {"type": "integer", "minimum": 1, "maximum": 9}},
    "strict": {"title": "Strict", "schema": {"type": "boolean", "default": True}},
    "mode": {"title": "Mode", "schema": {"type": "string", "enum": ["fast", "exact"], "default": "exact"}},
    "radii": {"title": "Radii", "schema": {"type": "array", "items": {"oneOf": [{"type": "string"}]}}},
    "gap": {"title": "Gap", "schema": {"oneOf": [{"type": "string"}, {"type": "number"}]}},
    "oddity": {"title": "Oddity", "schema": {"type": "object"}},
}
EXPECTED_KINDS = {
    "coastLayers": ("COAST_LAYERS", "multilayer", False), "basinArea": ("BASIN_AREA", "vector", True),
    "rankField": ("RANK_FIELD", "field", True), "gridCrs": ("GRID_CRS", "crs", True),
    "window": ("WINDOW", "extent", True), "friction": ("FRICTION", "number", True),
    "passes": ("PASSES", "number", True), "strict": ("STRICT", "boolean", True), "mode": ("MODE", "enum", True),
    "radii": ("RADII", "string", True), "gap": ("GAP", "string", True), "oddity": ("ODDITY", "string", True),
}


# The styled results rendered offscreen (QgsMapRendererParallelJob, one pixel per cell): the
# ownership raster alone, checked cell by cell against the owners' colours in the report, and
# the whole map (rasters, lines, tripoints, regions) as a test artefact, checked for its marks.
RENDER_SCRIPT = """
import json, os, sys
from qgis.core import (QgsApplication, QgsMapRendererParallelJob, QgsMapSettings, QgsRasterLayer, QgsVectorLayer,
                       QgsProject)
from qgis.PyQt.QtCore import QSize
from qgis.PyQt.QtGui import QColor
app = QgsApplication([], False)
app.initQgis()
sys.path.insert(0, os.environ["QGIS_PLUGINPATH"])
from rvoronoi.styles import style
out, artefact = sys.argv[1], sys.argv[2]
owners = json.load(open(os.path.join(out, "report.json")))["seeds"]["owners"]
raster = QgsRasterLayer(os.path.join(out, "o.tif"), "ownership")
assert raster.isValid()
assert style(raster, "ownership", owners)
layers = {"boundaries": "b.geojson", "limits": "l.geojson", "tripoints": "t.gpkg", "regions": "r.gpkg"}
vectors = []
for output_id, name in layers.items():
    layer = QgsVectorLayer(os.path.join(out, name), output_id, "ogr")
    assert layer.isValid(), name
    assert style(layer, output_id, owners), output_id
    vectors.append(layer)

def render(map_layers, path):
    settings = QgsMapSettings()
    settings.setLayers(map_layers)
    settings.setDestinationCrs(raster.crs())
    settings.setExtent(raster.extent())
    settings.setOutputSize(QSize(raster.width(), raster.height()))
    settings.setBackgroundColor(QColor(255, 255, 255))
    job = QgsMapRendererParallelJob(settings)
    job.start()
    job.waitForFinished()
    image = job.renderedImage()
    image.save(path, "PNG")
    return image

alone = render([raster], os.path.join(artefact, "ownership.png"))
block = raster.dataProvider().block(1, raster.extent(), raster.width(), raster.height())
colour = {int(o["code"]): QColor(o["colour"]).rgb() for o in owners}
checked = wrong = 0
for row in range(0, raster.height(), 7):
    for col in range(0, raster.width(), 7):
        code = int(block.value(row, col))
        if code in colour:
            checked += 1
            wrong += alone.pixel(col, row) != colour[code]
whole = render(vectors + [raster], os.path.join(artefact, "styled.png"))
seen = set()
for row in range(whole.height()):
    for col in range(whole.width()):
        seen.add(whole.pixel(col, row))
marks = {"tripoint": QColor("#e31a1c").rgb() in seen, "boundary": QColor("#1a1a1a").rgb() in seen}
print(json.dumps({"checked": checked, "wrong": wrong, "owners": len(owners), "marks": marks,
                  "size": [whole.width(), whole.height()]}))
"""


# The dialog's owner-field widget under a list of seed layers: QGIS 3.22's own stays empty; the
# plugin's (parameters.layers_field_wrapper) offers the first layer's fields.
GUI_FIELD_SCRIPT = with_provider("""
from qgis.gui import QgsGui, QgsProcessingGui
alg = QgsApplication.processingRegistry().createAlgorithmById("rvoronoi:voronoi")
layer = QgsVectorLayer(sys.argv[1], "oresund", "ogr"); QgsProject.instance().addMapLayer(layer)
context = QgsProcessingContext(); context.setProject(QgsProject.instance())
seeds = QgsGui.processingGuiRegistry().createParameterWidgetWrapper(alg.parameterDefinition("SEEDS"), QgsProcessingGui.Standard)
seeds_widget = seeds.createWrappedWidget(context)
owner = alg.parameterDefinition("OWNER_FIELD")
wrapper_class = owner.metadata()["widget_wrapper"]["class"]
field = wrapper_class(owner, None)
field.postInitialize([seeds, field])
seeds.setParameterValue([layer.id()], context)
app.processEvents()
w = field.widget
print(json.dumps([w.itemText(i) for i in range(w.count())]))
""", gui=True)

# Batch mode: one algorithm run for each row of parameters in one QGIS process, as the batch
# dialog does (processing.run per row); prints each row's ownership raster's size.
BATCH_SCRIPT = with_provider("""
import processing
from osgeo import gdal
rows = json.loads(sys.argv[1])
sizes = []
for row in rows:
    result = processing.run("rvoronoi:voronoi", row)
    ds = gdal.Open(result["OWNERSHIP"])
    sizes.append([ds.RasterXSize, ds.RasterYSize, os.path.exists(row["BOUNDARIES"])])
print(json.dumps(sizes))
""")

AREA = {"type": "FeatureCollection", "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:OGC:1.3:CRS84"}},
        "features": [{"type": "Feature", "properties": {"name": "box"}, "geometry": {
            "type": "Polygon", "coordinates": [[[12.4, 55.5], [12.9, 55.5], [12.9, 56.0], [12.4, 56.0], [12.4, 55.5]]]}}]}


def model_and_batch(q, tmp):
    """The model of qgis/tests (reproject, rvoronoi, clip) through qgis_process, and batch mode."""
    seeds = os.path.join(SOURCE, "fixtures", "oresund.gpkg")
    area = os.path.join(tmp, "area.geojson")
    with open(area, "w") as f:
        json.dump(AREA, f)
    clipped = os.path.join(tmp, "clipped.gpkg")
    code, text = q.run("run", os.path.join(SOURCE, "qgis", "tests", "reproject_voronoi_clip.model3"), "--",
                       f"seeds={seeds}", "owner_field=iso2", "grid_crs=EPSG:3035", "resolution=500", f"area={area}",
                       f"clip:clipped_regions={clipped}", f"voronoi:ownership={os.path.join(tmp, 'model.tif')}")
    check(code == 0 and "Model processed OK" in text, f"the model runs: {code} {text[-800:]}")
    if code == 0:
        ds = ogr.Open(clipped)
        layer = ds.GetLayer(0)
        owners = sorted(f.GetField("owner") for f in layer)
        check(owners == [1, 2], f"the model's clipped regions: one per owner {owners}")
        check(layer.GetSpatialRef().GetAuthorityCode(None) == "3035", "the model's regions are in the grid CRS")
        from osgeo import osr
        box = ogr.CreateGeometryFromJson(json.dumps(AREA["features"][0]["geometry"]))
        wgs, laea = osr.SpatialReference(), osr.SpatialReference()
        wgs.ImportFromEPSG(4326)
        wgs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
        laea.ImportFromEPSG(3035)
        laea.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
        box.Transform(osr.CoordinateTransformation(wgs, laea))
        layer.ResetReading()
        inside = [box.Buffer(1.0).Contains(f.GetGeometryRef()) for f in layer]
        check(len(inside) == 2 and all(inside), f"the regions are clipped to the area: {inside}")
    rows = [{"SEEDS": [seeds], "OWNER_FIELD": "iso2", "RESOLUTION": r, "OWNERSHIP": os.path.join(tmp, f"batch_{i}.tif"),
             "BOUNDARIES": os.path.join(tmp, f"batch_{i}.geojson")} for i, r in enumerate((0.05, 0.02, 0.01))]
    sizes = json.loads(q.script(BATCH_SCRIPT, json.dumps(rows)).strip().splitlines()[-1])
    expected = []
    for i, r in enumerate((0.05, 0.02, 0.01)):
        out = os.path.join(tmp, f"batch_cli_{i}.tif")
        subprocess.run([RVORONOI, "compute", seeds, "--owner-field", "iso2", "--resolution", str(r), "--quiet",
                        "--ownership", out], check=True)
        ds = gdal.Open(out)
        expected.append([ds.RasterXSize, ds.RasterYSize, True])
    check(sizes == expected, f"batch mode: each row its own grid and files: {sizes} / {expected}")


# ---- Comparing files ---------------------------------------------------------------------------

def same_raster(a, b, what):
    da, db = gdal.Open(a), gdal.Open(b)
    check((da.RasterXSize, da.RasterYSize, da.RasterCount) == (db.RasterXSize, db.RasterYSize, db.RasterCount),
          f"{what}: raster size")
    check(da.GetGeoTransform() == db.GetGeoTransform(), f"{what}: geotransform")
    for i in range(1, da.RasterCount + 1):
        ba, bb = da.GetRasterBand(i), db.GetRasterBand(i)
        check(ba.DataType == bb.DataType and ba.GetNoDataValue() == bb.GetNoDataValue(), f"{what}: band {i} type")
        check(ba.ReadRaster() == bb.ReadRaster(), f"{what}: band {i} content")


def features(path):
    ds = ogr.Open(path)
    out = []
    for layer in ds:
        for f in layer:
            attrs = {k: v for k, v in f.items().items()}
            out.append((layer.GetName() if layer.GetName() not in ("", None) else "", attrs,
                        f.GetGeometryRef().ExportToIsoWkt() if f.GetGeometryRef() else None))
    return out


def same_vector(a, b, what):
    fa, fb = features(a), features(b)
    check(len(fa) == len(fb), f"{what}: {len(fa)} features, the CLI's {len(fb)}")
    for i, (x, y) in enumerate(zip(fa, fb)):
        if x[1] != y[1] or x[2] != y[2]:
            check(False, f"{what}: feature {i} differs: {x[1]} / {y[1]}")
            break


OUTPUTS = {"OWNERSHIP": ("ownership", "o.tif"), "DISTANCE": ("distance", "d.tif"),
           "BOUNDARIES": ("boundaries", "b.geojson"), "TRIPOINTS": ("tripoints", "t.gpkg"),
           "LIMITS": ("limits", "l.geojson"), "REGIONS": ("regions", "r.gpkg")}


def compare_case(q, tmp, name, fixture, resolution, extra_cli, extra_qgis, env=None):
    out_q, out_c = os.path.join(tmp, name, "qgis"), os.path.join(tmp, name, "cli")
    os.makedirs(out_q)
    os.makedirs(out_c)
    seeds = os.path.join(SOURCE, "fixtures", fixture)
    args = ["run", "rvoronoi:voronoi", "--", f"SEEDS={seeds}", "OWNER_FIELD=iso2", f"RESOLUTION={resolution}",
            "LIMIT_DISTANCES=12nmi"] + extra_qgis
    for param, (_, file) in OUTPUTS.items():
        args.append(f"{param}={os.path.join(out_q, file)}")
    args.append(f"REPORT={os.path.join(out_q, 'report.json')}")
    began = time.time()
    code, text = q.run(*args, env=env)
    took = time.time() - began
    check(code == 0, f"{name}: qgis_process run: exit {code}: {text[-1500:]}")
    check(TOKEN not in text, f"{name}: the token in qgis_process's output")
    cli = [RVORONOI, "compute", seeds, "--owner-field", "iso2", "--resolution", str(resolution), "--quiet",
           "--limit-distances", "12nmi"] + extra_cli
    for param, (flag, file) in OUTPUTS.items():
        cli += [f"--{flag}", os.path.join(out_c, file)]
    subprocess.run(cli, check=True, capture_output=True)
    for param, (_, file) in OUTPUTS.items():
        a, b = os.path.join(out_q, file), os.path.join(out_c, file)
        if not os.path.exists(a):
            check(False, f"{name}: {param} not written")
            continue
        (same_raster if file.endswith(".tif") else same_vector)(a, b, f"{name} {param}")
    check(len(features(os.path.join(out_q, "b.geojson"))) > 0, f"{name}: boundaries were drawn")
    print(f"{name}: qgis_process run {took:.1f} s", flush=True)


def sea_case(q, tmp, name, env=None):
    """The distance by sea from QGIS: ports as seeds, the land as a barrier layer (BARRIERS, a
    multi-layer parameter made from the description's upload marker), the via raster as a
    destination; the same files as the CLI's."""
    out_q, out_c = os.path.join(tmp, name, "qgis"), os.path.join(tmp, name, "cli")
    os.makedirs(out_q)
    os.makedirs(out_c)
    ports = os.path.join(SOURCE, "fixtures", "oresund_ports.geojson")
    land = os.path.join(SOURCE, "fixtures", "oresund.gpkg")
    files = {"OWNERSHIP": ("ownership", "o.tif"), "DISTANCE": ("distance", "d.tif"), "VIA": ("via", "v.tif")}
    args = ["run", "rvoronoi:voronoi", "--", f"SEEDS={ports}", "OWNER_FIELD=owner", f"BARRIERS={land}",
            "CRS=EPSG:32633", "METRIC=planar", "RESOLUTION=500", "EXTENT=330000,370000,6150000,6220000 [EPSG:32633]"]
    args += [f"{param}={os.path.join(out_q, file)}" for param, (_, file) in files.items()]
    code, text = q.run(*args, env=env)
    check(code == 0, f"{name}: qgis_process run: exit {code}: {text[-1500:]}")
    cli = [RVORONOI, "compute", ports, "--owner-field", "owner", "--barriers", land, "--crs", "EPSG:32633",
           "--metric", "planar", "--resolution", "500", "--extent", "330000", "6150000", "370000", "6220000",
           "--quiet"]
    for _, (flag, file) in files.items():
        cli += [f"--{flag}", os.path.join(out_c, file)]
    subprocess.run(cli, check=True, capture_output=True)
    for param, (_, file) in files.items():
        a, b = os.path.join(out_q, file), os.path.join(out_c, file)
        if not os.path.exists(a):
            check(False, f"{name}: {param} not written")
            continue
        same_raster(a, b, f"{name} {param}")
    via = gdal.Open(os.path.join(out_c, "v.tif")).ReadAsArray()
    check(int((via > 0).sum()) > 100, f"{name}: paths bend round the land")


# A result server for the download: /big streams BIG_CHUNKS chunks of 1 MiB (each a block of
# random bytes after its own index) with their length announced, /cut announces 64 MiB and stops
# after 8, /refused answers a problem. Nothing is held whole on either side.
BIG_CHUNKS = 256
BLOCK = os.urandom(1 << 20)


def chunk(i):
    return i.to_bytes(8, "little") + BLOCK[8:]


class ResultHandler(http.server.BaseHTTPRequestHandler):
    def do_GET(self):
        if self.path == "/refused":
            body = json.dumps({"status": 404, "title": "Not found", "detail": "no such result"}).encode()
            self.send_response(404)
            self.send_header("Content-Type", "application/problem+json")
            self.send_header("Content-Length", str(len(body)))
            self.end_headers()
            self.wfile.write(body)
            return
        count, sent = (BIG_CHUNKS, BIG_CHUNKS) if self.path == "/big" else (64, 8)
        self.send_response(200)
        self.send_header("Content-Type", "image/tiff")
        self.send_header("Content-Length", str(count << 20))
        self.end_headers()
        for i in range(sent):
            self.wfile.write(chunk(i))
        self.wfile.flush()
        self.close_connection = True

    def log_message(self, *args):
        pass


DOWNLOAD_SCRIPT = """
import json, os, resource, sys
from qgis.core import QgsApplication
app = QgsApplication([], False)
app.initQgis()
sys.path.insert(0, os.environ["QGIS_PLUGINPATH"])
from rvoronoi.client import Client, ServerError
url, folder = sys.argv[1], sys.argv[2]
client = Client(url=url, authcfg="")
out = {}
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
out["bytes"] = client.download("/big", os.path.join(folder, "big.tif"))
out["grew_mib"] = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
for name in ("cut", "refused"):
    try:
        client.download("/" + name, os.path.join(folder, name + ".tif"))
        out[name] = "no error"
    except ServerError as e:
        out[name] = str(e)
out["files"] = sorted(os.listdir(folder))
print(json.dumps(out))
"""


def download(q, tmp):
    server = socketserver.ThreadingTCPServer(("127.0.0.1", 0), ResultHandler)
    server.daemon_threads = True
    threading.Thread(target=server.serve_forever, daemon=True).start()
    folder = os.path.join(tmp, "downloads")
    os.makedirs(folder)
    try:
        got = json.loads(q.script(DOWNLOAD_SCRIPT, f"http://127.0.0.1:{server.server_address[1]}", folder)
                         .strip().splitlines()[-1])
    finally:
        server.shutdown()
        server.server_close()
    print(f"download: {got}", flush=True)
    check(got["bytes"] == BIG_CHUNKS << 20, f"the whole result downloaded: {got['bytes']}")
    check(got["grew_mib"] < 64, f"a {BIG_CHUNKS} MiB download grew QGIS's peak memory by {got['grew_mib']:.0f} MiB")
    same = os.path.getsize(os.path.join(folder, "big.tif")) == BIG_CHUNKS << 20
    with open(os.path.join(folder, "big.tif"), "rb") as f:
        for i in range(BIG_CHUNKS):
            same = same and f.read(1 << 20) == chunk(i)
    check(same, "the downloaded file is the bytes sent")
    check("broke off" in got["cut"] and str(64 << 20) in got["cut"], f"an answer cut short is an error: {got['cut']}")
    check("no such result" in got["refused"], f"a refusal gives its problem: {got['refused']}")
    check(got["files"] == ["big.tif"], f"nothing else is left, no .part: {got['files']}")


def free_port():
    import socket
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def main():
    with tempfile.TemporaryDirectory(prefix="rv_qgis_") as tmp:
        began = time.time()
        q = Qgis(tmp)
        config = {"auth": {"principals": [{"name": "analyst", "role": "user",
                                           "token_sha256": hashlib.sha256(TOKEN.encode()).hexdigest()}]},
                  "jobs": {"workers": 1, "queue_length": 8}}
        d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "data"), config)
        url = f"http://127.0.0.1:{d.port}"
        q.env.update(RVORONOI_URL=url, RVORONOI_AUTHCFG=q.authcfg)
        try:
            # 1. The plugin, its algorithm and parameters.
            code, text = q.run("plugins", "enable", "rvoronoi")
            check(code == 0, f"plugins enable: {code} {text[-500:]}")
            code, text = q.run("help", "rvoronoi:voronoi")
            check(code == 0, f"help: {code} {text[-800:]}")
            for name in ("SEEDS:", "OWNER_FIELD:", "RESOLUTION:", "EXTENT:", "METRIC:", "MAX_DISTANCE:",
                         "LIMIT_DISTANCES:", "WEIGHT_FIELD:", "ON_CONFLICT:", "RELEVANT_AREA:", "OWNERSHIP:",
                         "NEAREST_FEATURE:", "BOUNDARIES:", "TRIPOINTS:", "TURNING_POINTS:", "PREVIEW:", "REPORT:",
                         "BARRIERS:", "SNAP_TOLERANCE:", "VIA:"):
                check(name in text, f"help names the parameter {name}")
            # 2. The same files as the CLI.
            compare_case(q, tmp, "oresund", "oresund.gpkg", 0.01, [], [])
            compare_case(q, tmp, "baltic", "baltic_west.gpkg", 0.01, ["--on-conflict", "lower-code"],
                         ["ON_CONFLICT=lower-code"])
            sea_case(q, tmp, "sea")
            # The styled result, rendered offscreen.
            artefacts = os.path.join(ARTEFACTS, "qgis")
            os.makedirs(artefacts, exist_ok=True)
            got = json.loads(q.script(RENDER_SCRIPT, os.path.join(tmp, "baltic", "qgis"), artefacts)
                             .strip().splitlines()[-1])
            check(got["checked"] > 100 and got["wrong"] == 0 and got["owners"] == 4,
                  f"the ownership raster renders in the owners' colours: {got}")
            check(all(got["marks"].values()), f"the styled map shows tripoints and boundaries: {got}")
            # The descriptions are fetched once and then validated: 304s, no second full download.
            described = [json.loads(line) for line in d.log if '"path":"/processes/voronoi"' in line]
            check(sum(1 for x in described if x["status"] == 200) == 1 and
                  sum(1 for x in described if x["status"] == 304) >= 2,
                  f"the description is cached by its ETag: {[x['status'] for x in described]}")
            model_and_batch(q, tmp)
            fields = json.loads(q.script(GUI_FIELD_SCRIPT, os.path.join(SOURCE, "fixtures", "oresund.gpkg"))
                                .strip().splitlines()[-1])
            check("iso2" in fields, f"the dialog's owner field lists the seed layer's fields: {fields}")
            local = {"RVORONOI_MODE": "local", "RVORONOI_URL": "", "PYTHONPATH": MODULE_DIR}
            compare_case(q, tmp, "oresund-local", "oresund.gpkg", 0.01, [], [], env=local)
            compare_case(q, tmp, "baltic-local", "baltic_west.gpkg", 0.01, ["--on-conflict", "lower-code"],
                         ["ON_CONFLICT=lower-code"], env=local)
            sea_case(q, tmp, "sea-local", env=local)
            shp = os.path.join(tmp, "boundaries.shp")
            code, text = q.run("run", "rvoronoi:voronoi", "--", f"SEEDS={os.path.join(SOURCE, 'fixtures', 'oresund.gpkg')}",
                               "OWNER_FIELD=iso2", "RESOLUTION=0.01", f"BOUNDARIES={shp}",
                               f"OWNERSHIP={os.path.join(tmp, 'shp.tif')}", env=local)
            check(code == 0 and len(features(shp)) == len(features(os.path.join(tmp, "oresund-local", "cli", "b.geojson"))),
                  f"a Shapefile destination: {code} {text[-400:]}")
            # 3. Failures, each one clear line.
            seeds = os.path.join(SOURCE, "fixtures", "oresund.gpkg")
            base = ["run", "rvoronoi:voronoi", "--", f"SEEDS={seeds}", "RESOLUTION=0.05",
                    f"OWNERSHIP={os.path.join(tmp, 'x.tif')}"]
            code, text = q.run(*(base + ["OWNER_FIELD=nosuch"]))
            check(code != 0 and "owner field 'nosuch'" in text and "Traceback" not in text,
                  f"a bad input: {code} {text[-600:]}")
            code, text = q.run(*(base + ["OWNER_FIELD=iso2"]), env={"RVORONOI_AUTHCFG": ""})
            check(code != 0 and "bearer token" in text and "Traceback" not in text, f"no token: {code} {text[-1600:]!r}")
            dead = f"http://127.0.0.1:{free_port()}"
            code, text = q.run("list", env={"RVORONOI_URL": dead})
            check("rvoronoi:voronoi" not in text, "an unreached server never seen before gives no algorithm")
            # (The cache is per server: the daemon's descriptions, cached above, serve when it is down.)
            d.stop()
            code, text = q.run("list")
            check("rvoronoi:voronoi" in text, f"the daemon down: the cached algorithm is listed: {text[-400:]}")
            code, text = q.run(*(base + ["OWNER_FIELD=iso2"]))
            check(code != 0 and "cannot be reached" in text and "Traceback" not in text,
                  f"the daemon down: a run says so: {code} {text[-600:]}")
            wiki = DocumentServer(b"<html><body>a wiki</body></html>", "text/html")
            code, text = q.run(*(base + ["OWNER_FIELD=iso2"]), env={"RVORONOI_URL": wiki.url})
            check(code != 0 and "not the rvoronoi API" in text and "Traceback" not in text,
                  f"not the API: {code} {text[-600:]}")
            wiki.close()
            # 4. Cancelling dismisses the job (a grid large enough to be running when cancelled).
            d = Daemon([RVORONOI, "serve"], os.path.join(tmp, "data"), config)
            q.env.update(RVORONOI_URL=f"http://127.0.0.1:{d.port}")
            out = q.script(CANCEL_SCRIPT, seeds, "0.0002", os.path.join(tmp, "cancelled.tif"))
            lines = out.strip().splitlines()
            check(lines and lines[0].startswith("cancelled:"), f"the run was cancelled: {out[-400:]}")
            job = lines[-1] if lines else ""
            status, _, doc = d.json("GET", f"/jobs/{job}", headers={"Authorization": f"Bearer {TOKEN}"})
            check(status == 200 and doc.get("status") == "dismissed", f"the job was dismissed: {status} {doc}")
            # 5. A result downloaded as it arrives.
            download(q, tmp)
            # 6. An extra input of every kind.
            got = json.loads(q.script(KINDS_SCRIPT, json.dumps(EXTRA_INPUTS)).strip().splitlines()[-1])
            for input_id, (name, kind, optional) in EXPECTED_KINDS.items():
                p = got["params"].get(input_id)
                check(p and p[0] == name and p[1] == kind and p[2] == optional,
                      f"extra input {input_id}: {p}, expected {(name, kind, optional)}")
            check(got["params"]["rankField"][3] == "COAST_LAYERS", "a field is bound to its layer input")
            check(any("oddity" in w for w in got["warnings"]), f"an unknown kind is warned about: {got['warnings']}")
        finally:
            d.stop()
        print(f"qgis provider: {time.time() - began:.1f} s", flush=True)
    if FAILURES:
        print(f"{len(FAILURES)} failure(s)")
        sys.exit(1)
    print("all QGIS provider checks passed")


if __name__ == "__main__":
    main()
