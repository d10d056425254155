"""The Python module (issue 33) against the CLI: the same arrays, owner tables, deliverables, errors.

    PYTHONPATH=build/python /usr/bin/python3 tests/python/test_module.py RVORONOI SOURCE_DIR

For each case the CLI (`rvoronoi compute`) writes its rasters and deliverables, and
rvoronoi.compute() is given the same seeds and options: the arrays equal the rasters cell for cell
and bit for bit (distances compared as their bits), the owner table equals the raster's
categories and the report's owners, the grid's georeferencing equals the file's (read back through
rioxarray's CF convention, and through GDAL from the netCDF and Zarr the dataset writes), and the
deliverables equal the CLI's GeoJSON feature for feature. Cases: points (planar, projected CRS),
polygons of the Øresund (geodesic on a geographic grid, nautical miles, a max distance), polygons
with holes on a projected CRS measured on its ellipsoid (geodesic, located cells), and the same
seeds given as a GeoDataFrame and as a GeoJSON mapping. Then errors (kinds, classes, messages),
the GIL released while the engine works, and arrays that own the engine's buffers.
"""
import inspect
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import numpy as np
from osgeo import gdal

import rvoronoi

RVORONOI, SOURCE = sys.argv[1], sys.argv[2]
FIX = os.path.join(SOURCE, "fixtures")
ORESUND = os.path.join(FIX, "oresund.gpkg")
BALTIC = os.path.join(FIX, "baltic_west.gpkg")
gdal.UseExceptions()


def cli(seeds, options, outdir, deliverables=()):
    """Runs the CLI with the module's keyword options; returns {product: array}, report, deliverables."""
    cmd = [RVORONOI, "compute"] + ([seeds] if isinstance(seeds, str) else list(seeds)) + ["--quiet"]
    for k, v in options.items():
        flag = "--" + k.replace("_", "-")
        if isinstance(v, bool):
            cmd += [flag] if v else []
        elif isinstance(v, (list, tuple)) and k == "extent":
            cmd += [flag] + [repr(float(x)) for x in v]
        elif isinstance(v, (list, tuple)):
            cmd += [flag, ",".join(str(x) for x in v)]
        else:
            cmd += [flag, str(v)]
    files = {p: os.path.join(outdir, p + ".tif") for p in ("ownership", "distance", "nearest_feature")}
    for p, f in files.items():
        cmd += ["--" + p.replace("_", "-"), f]
    lines = {d: os.path.join(outdir, d + ".geojson") for d in deliverables}
    for d, f in lines.items():
        cmd += ["--" + d, f]
    cmd += ["--report", os.path.join(outdir, "report.json"), "--no-edit-base"]
    subprocess.run(cmd, check=True)
    arrays, geo = {}, {}
    for p, f in files.items():
        ds = gdal.Open(f)
        band = ds.GetRasterBand(1)
        arrays[p] = band.ReadAsArray()
        geo[p] = (ds.GetGeoTransform(), ds.GetProjection(), band.GetCategoryNames())
    with open(os.path.join(outdir, "report.json")) as f:
        report = json.load(f)
    read = {}
    for d, f in lines.items():
        with open(f) as fh:
            read[d] = json.load(fh)
    return arrays, geo, report, read


def same_bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape or (a.dtype.kind == "f") != (b.dtype.kind == "f"):
        return False
    if a.dtype.kind == "f":
        return a.dtype == b.dtype and np.array_equal(a.view(np.uint32), b.view(np.uint32))
    # Code rasters: GDAL gives the file's narrowest type (Byte, UInt16), the module Int32.
    return np.array_equal(a.astype(np.int64), b.astype(np.int64))


class AgainstTheCli(unittest.TestCase):
    def check_case(self, seeds, options, deliverables=()):
        with tempfile.TemporaryDirectory() as out:
            arrays, geo, report, lines = cli(seeds, options, out, deliverables)
        got = rvoronoi.compute(seeds, nearest_feature=True, deliverables=list(deliverables) or None, **options)
        ds, mine = (got if deliverables else (got, {}))
        self.assertTrue(same_bits(ds.owner.values, arrays["ownership"]), "owner codes differ")
        self.assertTrue(same_bits(ds.distance.values, arrays["distance"]), "distances differ")
        self.assertTrue(same_bits(ds.nearest_feature.values, arrays["nearest_feature"]), "feature numbers differ")
        # The owner table: the raster's categories (index = code), the report's owners, the flags.
        labels = json.loads(ds.owner.attrs["owner_labels"])
        self.assertEqual(labels, [o["label"] for o in report["seeds"]["owners"]])
        self.assertEqual(labels, geo["ownership"][2][1:len(labels) + 1])
        self.assertEqual(list(ds.owner.attrs["flag_values"]), list(range(1, len(labels) + 1)))
        self.assertEqual(len(ds.owner.attrs["flag_meanings"].split()), len(labels))
        # Georeferencing: rioxarray reads the CF grid mapping; it equals the file's.
        import rioxarray  # noqa: F401
        transform, wkt = geo["ownership"][0], geo["ownership"][1]
        self.assertEqual(tuple(ds.owner.rio.transform().to_gdal()), tuple(transform))
        from osgeo import osr
        a, b = osr.SpatialReference(), osr.SpatialReference()
        a.ImportFromWkt(ds.owner.rio.crs.to_wkt())
        b.ImportFromWkt(wkt)
        self.assertTrue(a.IsSame(b), "CRS differs")
        self.assertEqual(json.loads(ds.attrs["rvoronoi_report"])["grid"], report["grid"])
        for name in deliverables:
            self.check_lines(name, lines[name], mine[name])
        return ds

    def check_lines(self, name, theirs, mine):
        from shapely.geometry import shape
        features = theirs["features"]
        self.assertGreater(len(features), 0, name)
        self.assertEqual(len(mine), len(features), name)
        for (_, row), f in zip(mine.iterrows(), features):
            # Vertex for vertex, no tolerance.
            self.assertTrue(row.geometry.equals_exact(shape(f["geometry"]), 0.0), name)
            for k, v in f["properties"].items():
                got = row[k]
                self.assertEqual(got.item() if hasattr(got, "item") else got, v, "%s property %s" % (name, k))

    def test_points_planar(self):
        seeds = os.path.join(FIX, "coast_points.geojson")
        self.check_case(seeds, {"owner_field": "owner", "resolution": 50.0}, ("boundaries",))

    def test_baltic_four_states_tripoints_and_regions(self):
        self.check_case(BALTIC, {"owner_field": "iso2", "resolution": 0.02, "metric": "geodesic",
                                 "distance_units": "nmi", "border_tolerance": 10},
                        ("boundaries", "tripoints", "regions"))

    def test_oresund_geodesic(self):
        ds = self.check_case(ORESUND, {"owner_field": "iso2", "resolution": 0.01, "metric": "geodesic",
                                       "distance_units": "nmi", "max_distance": 5}, ("boundaries",))
        self.assertEqual(ds.distance.attrs["units"], "nmi")
        self.assertEqual(ds.attrs["metric"], "geodesic")
        self.assertTrue((ds.owner.values == 0).any(), "the max distance leaves cells unowned")

    def test_oresund_limits(self):
        self.check_case(ORESUND, {"owner_field": "iso2", "resolution": 0.02, "metric": "geodesic",
                                  "distance_units": "nmi", "limit_distances": ["12nmi"]}, ("limits", "regions"))

    def test_polygons_projected_geodesic(self):
        seeds = os.path.join(FIX, "coast_polygons.geojson")
        self.check_case(seeds, {"owner_field": "owner", "resolution": 100.0, "metric": "geodesic"})

    def test_partial_effect_and_weights(self):
        # The adjustments of the analyst's toolkit through the module: a half-effect islet and a
        # weighted basepoint, against the CLI.
        feats = [("A", 401000, 6101000, 1.0, 1.0), ("B", 409000, 6101000, 1.0, 1.5), ("A", 405500, 6103000, 0.5, 1.0)]
        mapping = {"type": "FeatureCollection",
                   "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
                   "features": [{"type": "Feature", "properties": {"owner": o, "effect": e, "weight": w},
                                 "geometry": {"type": "Point", "coordinates": [x, y]}} for o, x, y, e, w in feats]}
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "adjusted.geojson")
            with open(path, "w") as f:
                json.dump(mapping, f)
            self.check_case(path, {"owner_field": "owner", "effect_field": "effect", "resolution": 50.0,
                                   "extent": [400000, 6100000, 410000, 6106000]})
            self.check_case(path, {"owner_field": "owner", "weight_field": "weight", "resolution": 50.0,
                                   "extent": [400000, 6100000, 410000, 6106000]})

    def test_distance_by_sea_equals_the_cli(self):
        # Ports on the Øresund's coasts, the two states' land as barriers: owner, distance and
        # feature as the CLI's (check_case), the vias too; without barriers the vias are refused.
        ports = os.path.join(FIX, "oresund_ports.geojson")
        options = {"owner_field": "owner", "barriers": ORESUND, "crs": "EPSG:32633", "metric": "planar",
                   "resolution": 500.0, "extent": [330000.0, 6150000.0, 370000.0, 6220000.0]}
        self.check_case(ports, options)
        with tempfile.TemporaryDirectory() as out:
            path = os.path.join(out, "via.tif")
            subprocess.run([RVORONOI, "compute", ports, "--quiet", "--owner-field", "owner", "--barriers", ORESUND,
                            "--crs", "EPSG:32633", "--metric", "planar", "--resolution", "500", "--extent", "330000",
                            "6150000", "370000", "6220000", "--via", path], check=True)
            theirs = gdal.Open(path).ReadAsArray()
        ds = rvoronoi.compute(ports, via=True, **options)
        self.assertTrue(same_bits(ds.via.values, theirs), "vias differ")
        self.assertGreater(int((ds.via.values > 0).sum()), 100, "paths bend round the headlands")
        self.assertTrue(((ds.owner.values == 0) == (ds.distance.values == -1)).all(), "land has neither")
        report = json.loads(ds.attrs["rvoronoi_report"])
        self.assertEqual(report["sea"]["barriers"]["features"], 2)
        with self.assertRaises(rvoronoi.InvalidArgument) as caught:
            rvoronoi.compute(ports, via=True, owner_field="owner", crs="EPSG:32633", resolution=500.0)
        self.assertIn("the via raster needs barriers", str(caught.exception))
        with self.assertRaises(rvoronoi.InvalidArgument) as caught:
            rvoronoi.compute(ports, method="hv-scan", **options)
        self.assertIn("barriers: the distance by sea needs the exact", str(caught.exception))
        # The barriers as a GeoDataFrame or a mapping, as the seeds may be: the same field.
        import geopandas
        frame = geopandas.read_file(ORESUND)
        for given in (frame, [json.loads(frame.to_json())], [ORESUND]):
            other = rvoronoi.compute(ports, via=True, **dict(options, barriers=given))
            self.assertTrue(same_bits(other.distance.values, ds.distance.values))
            self.assertTrue(same_bits(other.via.values, ds.via.values))

    def test_frame_and_mapping_equal_the_file(self):
        import geopandas
        path = os.path.join(FIX, "coast_polygons.geojson")
        options = {"owner_field": "owner", "resolution": 100.0}
        base = rvoronoi.compute(path, **options)
        frame = geopandas.read_file(path)
        from_frame = rvoronoi.compute(frame, **options)
        with open(path) as f:
            mapping = json.load(f)
        from_mapping = rvoronoi.compute(mapping, **options)
        for other in (from_frame, from_mapping):
            self.assertTrue(same_bits(other.owner.values, base.owner.values))
            self.assertTrue(same_bits(other.distance.values, base.distance.values))
            self.assertEqual(other.owner.attrs["owner_labels"], base.owner.attrs["owner_labels"])
            self.assertEqual(other.spatial_ref.attrs["GeoTransform"], base.spatial_ref.attrs["GeoTransform"])

    def test_describe_lists_fields_crs_and_features(self):
        d = rvoronoi.describe(BALTIC)
        self.assertEqual(d["commonFields"], ["iso2"])
        self.assertEqual(d["crs"]["code"], "EPSG:4326")
        layer = d["layers"][0]
        self.assertEqual((layer["name"], layer["features"]), ("states", 4))
        self.assertTrue(layer["source"].endswith("baltic_west.gpkg:states"))
        self.assertEqual(layer["fields"][0]["values"], ["DK", "SE", "DE", "PL"])
        self.assertNotIn("features", d)
        # In another CRS, with the features: reprojected, positions as ids.
        utm = rvoronoi.describe(ORESUND, crs="EPSG:32633", features=True)
        self.assertEqual(utm["crs"]["code"], "EPSG:32633")
        self.assertGreater(utm["bbox"][0], 200000)
        self.assertEqual([f["id"] for f in utm["features"]["features"]], [1, 2])
        self.assertEqual([f["properties"]["iso2"] for f in utm["features"]["features"]], ["DK", "SE"])
        # A mapping is named as the caller knows it; overlapping owners are described, not refused.
        with open(os.path.join(FIX, "overlap.geojson")) as f:
            mapping = json.load(f)
        d = rvoronoi.describe([mapping])
        self.assertEqual(d["layers"][0]["source"].split(":")[0], "seeds[0]")
        with self.assertRaises(rvoronoi.Conflict):
            rvoronoi.compute(mapping, resolution=100.0)
        with self.assertRaises(rvoronoi.NotFound):
            rvoronoi.describe("/nonexistent/seeds.gpkg")

    def test_netcdf_and_zarr_keep_the_grid_and_the_owner_table(self):
        import xarray
        ds = rvoronoi.compute(ORESUND, owner_field="iso2", resolution=0.02, metric="geodesic")
        with tempfile.TemporaryDirectory() as d:
            nc, zr = os.path.join(d, "r.nc"), os.path.join(d, "r.zarr")
            ds.to_netcdf(nc)
            ds.to_zarr(zr)
            for back in (xarray.open_dataset(nc, mask_and_scale=False), xarray.open_zarr(zr, mask_and_scale=False)):
                self.assertEqual(list(back.owner.attrs["flag_values"]), list(ds.owner.attrs["flag_values"]))
                self.assertEqual(back.owner.attrs["flag_meanings"], "DK SE")
                self.assertTrue(same_bits(back.owner.values, ds.owner.values))
                self.assertTrue(same_bits(back.distance.values, ds.distance.values))
                back.close()
            # GDAL reads the netCDF's grid mapping: the same georeferencing as the dataset's.
            g = gdal.Open('NETCDF:"%s":owner' % nc)
            want = [float(v) for v in ds.spatial_ref.attrs["GeoTransform"].split()]
            np.testing.assert_allclose(g.GetGeoTransform(), want, rtol=0, atol=1e-9)
            self.assertIn("WGS 84", g.GetProjection())


class Files(unittest.TestCase):
    """rvoronoi.run writes a whole job's files as the CLI does (issue 53: the QGIS provider's local
    mode); rvoronoi.process_description() is the daemon's description."""

    def test_the_files_equal_the_clis(self):
        from osgeo import gdal
        seeds = os.path.join(SOURCE, "fixtures", "oresund.gpkg")
        options = {"owner_field": "iso2", "resolution": 0.02, "limit_distances": ["12nmi"]}
        stages = []
        with tempfile.TemporaryDirectory() as out:
            mine = {"ownership": "o.tif", "distance": "d.tif", "boundaries": "b.geojson", "limits": "l.geojson",
                    "report": "r.json", "turningPoints": "t.csv"}
            report = rvoronoi.run(seeds, {k: os.path.join(out, "mine_" + v) for k, v in mine.items()},
                                  progress=lambda stage, fraction: stages.append((stage, fraction)), **options)
            subprocess.run([RVORONOI, "compute", seeds, "--owner-field", "iso2", "--resolution", "0.02", "--quiet",
                            "--limit-distances", "12nmi", "--ownership", os.path.join(out, "o.tif"),
                            "--distance", os.path.join(out, "d.tif"), "--boundaries", os.path.join(out, "b.geojson"),
                            "--limits", os.path.join(out, "l.geojson"), "--turning-points",
                            os.path.join(out, "t.csv")], check=True)
            for raster in ("o.tif", "d.tif"):
                a, b = gdal.Open(os.path.join(out, "mine_" + raster)), gdal.Open(os.path.join(out, raster))
                self.assertEqual(a.ReadRaster(), b.ReadRaster(), raster)
                self.assertEqual(a.GetGeoTransform(), b.GetGeoTransform(), raster)
            for text in ("b.geojson", "l.geojson", "t.csv"):
                with open(os.path.join(out, "mine_" + text)) as f, open(os.path.join(out, text)) as g:
                    self.assertEqual(f.read(), g.read(), text)
            with open(os.path.join(out, "mine_r.json")) as f:
                self.assertEqual(json.load(f)["grid"], report["grid"])
        self.assertEqual(stages[0], ("read", 0.0))
        self.assertIn("compute", {s for s, _ in stages})
        self.assertTrue(all(0.0 <= f <= 1.0 for _, f in stages))

    def test_cancelling_and_a_raising_callback_leave_nothing(self):
        seeds = os.path.join(SOURCE, "fixtures", "oresund.gpkg")
        with tempfile.TemporaryDirectory() as out:
            target = {"ownership": os.path.join(out, "o.tif"), "boundaries": os.path.join(out, "b.geojson")}
            with self.assertRaises(rvoronoi.Cancelled):
                rvoronoi.run(seeds, target, cancelled=lambda: True, owner_field="iso2", resolution=0.01)
            self.assertEqual(os.listdir(out), [])

            def progress(stage, fraction):
                if stage == "compute":
                    raise KeyError("the caller's own")
            with self.assertRaises(KeyError):
                rvoronoi.run(seeds, target, progress=progress, owner_field="iso2", resolution=0.01)
            self.assertEqual(os.listdir(out), [])
            with self.assertRaises(rvoronoi.InvalidArgument):
                rvoronoi.run(seeds, {"nosuch": os.path.join(out, "x")}, owner_field="iso2", resolution=0.01)

    def test_the_description_is_the_daemons(self):
        d = rvoronoi.process_description()
        self.assertEqual(d["id"], "voronoi")
        self.assertEqual(d["inputs"]["seeds"]["minOccurs"], 1)
        self.assertEqual(d["inputs"]["ownerField"]["schema"]["x-rvoronoi-field-of"], "seeds")
        self.assertIn("ownership", d["outputs"])
        keyword_inputs = {k["input"] for k in rvoronoi.keywords() if k["input"]}
        self.assertEqual({k["keyword"] for k in rvoronoi.keywords() if k["run_only"]}, {"compression", "cog"})
        with self.assertRaises(TypeError):
            rvoronoi.compute(os.path.join(SOURCE, "fixtures", "oresund.gpkg"), compression="small")
        # Every described input but the seeds (compute's own argument) is a keyword.
        self.assertEqual(keyword_inputs, set(d["inputs"]) - {"seeds", "baseJob"})


class Errors(unittest.TestCase):
    def test_kinds_classes_and_messages(self):
        pts = os.path.join(FIX, "coast_points.geojson")
        cases = [
            (lambda: rvoronoi.compute(pts, owner_field="owner", resolution=-1),
             rvoronoi.InvalidArgument, ValueError, "invalid-argument", "resolution: "),
            (lambda: rvoronoi.compute(os.path.join(FIX, "missing.geojson"), resolution=10),
             rvoronoi.NotFound, LookupError, "not-found", "missing.geojson"),
            (lambda: rvoronoi.compute(pts, owner_field="no_such_field", resolution=10),
             rvoronoi.InvalidArgument, ValueError, "invalid-argument", "owner field 'no_such_field' not found"),
            (lambda: rvoronoi.compute(os.path.join(FIX, "overlap.geojson"), owner_field="owner", resolution=10),
             rvoronoi.Conflict, ValueError, "conflict", "overlap"),
            (lambda: rvoronoi.compute(pts, owner_field="owner", resolution=50, method="hv-scan", chunks=(10, 10)),
             rvoronoi.InvalidArgument, ValueError, "invalid-argument", "chunks: the scan methods"),
            (lambda: rvoronoi.compute(pts, owner_field="owner", resolution=50, metric="spherical"),
             rvoronoi.InvalidArgument, ValueError, "invalid-argument", "metric: must be one of"),
            (lambda: rvoronoi.compute(pts, owner_field="owner", resolution=50, deliverables=["coastlines"]),
             rvoronoi.InvalidArgument, ValueError, "invalid-argument", "deliverables: "),
        ]
        for call, cls, builtin, kind, text in cases:
            with self.assertRaises(cls) as caught:
                call()
            self.assertIsInstance(caught.exception, builtin)
            self.assertIsInstance(caught.exception, rvoronoi.Error)
            self.assertEqual(caught.exception.kind, kind)
            self.assertIn(text, str(caught.exception))

    def test_same_message_as_the_cli(self):
        pts = os.path.join(FIX, "coast_points.geojson")
        with self.assertRaises(rvoronoi.InvalidArgument) as caught:
            rvoronoi.compute(pts, owner_field="no_such_field", resolution=10)
        with tempfile.TemporaryDirectory() as d:
            r = subprocess.run([RVORONOI, "compute", pts, "--owner-field", "no_such_field", "--resolution", "10",
                                "--ownership", os.path.join(d, "o.tif")], capture_output=True, text=True)
        self.assertEqual(r.returncode, 2)
        self.assertIn(str(caught.exception), r.stderr)

    def test_unknown_keyword_is_a_type_error(self):
        with self.assertRaises(TypeError) as caught:
            rvoronoi.compute(os.path.join(FIX, "coast_points.geojson"), resolutoin=10)
        self.assertIn("resolutoin", str(caught.exception))
        self.assertIn("resolution", str(caught.exception))

    def test_bad_seed_argument(self):
        with self.assertRaises(TypeError):
            rvoronoi.compute(42, resolution=10)
        with self.assertRaises(TypeError):
            rvoronoi.compute({"type": "Point", "coordinates": [0, 0]}, resolution=10)


class NonFiniteNumbers(unittest.TestCase):
    """NaN and the infinities are invalid arguments (JSON has no such numbers): InvalidArgument naming
    the option, and the item of a list, from plain floats, nested lists and NumPy values alike."""

    def test_every_option_and_item_is_named(self):
        pts = os.path.join(FIX, "coast_points.geojson")
        nan, inf = float("nan"), float("inf")
        cases = [
            (dict(resolution=nan), "resolution: not a finite number (nan)"),
            (dict(resolution=inf), "resolution: not a finite number (inf)"),
            (dict(resolution=50, extent=[401000, nan, 409000, 6201500]), "extent[1]: not a finite number (nan)"),
            (dict(resolution=50, margin=inf), "margin: not a finite number (inf)"),
            (dict(resolution=50, max_distance=nan), "max_distance: not a finite number (nan)"),
            (dict(resolution=50, limit_distances=[nan]), "limit_distances[0]: not a finite number (nan)"),
            (dict(resolution=50, limit_distances=[12, {"value": -inf, "unit": "nmi"}]),
             "limit_distances[1].value: not a finite number (-inf)"),
            (dict(resolution=np.float32("nan")), "resolution: not a finite number (nan)"),
            (dict(resolution=np.float64("-inf")), "resolution: not a finite number (-inf)"),
            (dict(resolution=50, extent=np.array([401000.0, 6201000.0, np.inf, 6201500.0])),
             "extent[2]: not a finite number (inf)"),
            (dict(resolution=50, extent=(401000, 6201000, (np.float32("nan"),), 6201500)),
             "extent[2][0]: not a finite number (nan)"),
        ]
        for options, message in cases:
            for chunks in (None, (10, 10)):
                with self.subTest(options=options, chunks=chunks):
                    with self.assertRaises(rvoronoi.InvalidArgument) as caught:
                        rvoronoi.compute(pts, owner_field="owner", chunks=chunks, **options)
                    self.assertIsInstance(caught.exception, ValueError)
                    self.assertEqual(caught.exception.kind, "invalid-argument")
                    self.assertEqual(str(caught.exception), message)

    def test_finite_numbers_still_pass(self):
        pts = os.path.join(FIX, "coast_points.geojson")
        ds = rvoronoi.compute(pts, owner_field="owner", resolution=np.float32(100.0), margin=np.float64(500),
                              max_distance=1e5)
        self.assertGreater(ds.owner.size, 0)


class GridLimit(unittest.TestCase):
    """max_cells (default: the daemon's JobLimits) bounds the whole grid, chunked or not, and is
    checked before any Dask graph is made."""

    PTS = os.path.join(FIX, "coast_points.geojson")
    # 200,000 x 100,000 cells: over the default limit (2^34), small enough in chunks of 2000 x 5000
    # (a binary resolution: the extent is that many cells exactly).
    RES = 2.0 ** -10
    TOP = 6201000 + 100000 * RES
    HUGE = dict(owner_field="owner", resolution=RES, extent=[401000, 6201000, 401000 + 200000 * RES, TOP])

    def setUp(self):
        from rvoronoi import _chunks
        self.graphs = []
        self.real = _chunks.chunked_arrays

        def spy(*args, **kwargs):
            self.graphs.append(args)
            return self.real(*args, **kwargs)
        _chunks.chunked_arrays = spy

    def tearDown(self):
        from rvoronoi import _chunks
        _chunks.chunked_arrays = self.real

    def test_the_default_is_the_daemons(self):
        self.assertEqual(rvoronoi._rvoronoi.default_max_cells, 2 ** 34)
        import inspect
        self.assertEqual(inspect.signature(rvoronoi.compute).parameters["max_cells"].default, 2 ** 34)

    def test_chunked_over_the_limit_is_too_large_like_unchunked(self):
        with self.assertRaises(rvoronoi.TooLarge) as whole:
            rvoronoi.compute(self.PTS, **self.HUGE)
        with self.assertRaises(rvoronoi.TooLarge) as chunked:
            rvoronoi.compute(self.PTS, chunks=(1000, 1000), **self.HUGE)
        self.assertEqual(str(chunked.exception), "the grid has 20000000000 cells, over the limit of 17179869184")
        self.assertEqual(str(chunked.exception), str(whole.exception))
        self.assertEqual(self.graphs, [], "a graph was made before the limit was checked")

    def test_max_cells_lowers_and_raises_the_limit(self):
        small = dict(owner_field="owner", resolution=100.0, extent=[401000, 6201000, 409000, 6201500])  # 80 x 5
        for chunks in (None, (3, 7)):
            with self.subTest(chunks=chunks):
                with self.assertRaises(rvoronoi.TooLarge) as caught:
                    rvoronoi.compute(self.PTS, chunks=chunks, max_cells=100, **small)
                self.assertEqual(str(caught.exception), "the grid has 400 cells, over the limit of 100")
                at_limit = rvoronoi.compute(self.PTS, chunks=chunks, max_cells=400, **small)
                self.assertEqual(at_limit.owner.shape, (5, 80))
                by_default = rvoronoi.compute(self.PTS, chunks=chunks, **small)
                self.assertTrue(same_bits(by_default.owner.values, at_limit.owner.values))
        self.assertEqual(len(self.graphs), 2, "graphs only for the chunked calls within their limit")
        lazy = rvoronoi.compute(self.PTS, chunks=(2000, 5000), max_cells=2 ** 35, **self.HUGE)
        self.assertEqual(lazy.owner.shape, (100000, 200000))
        self.assertEqual(lazy.owner.data.numblocks, (50, 40))
        # Computed as far as asked (the first chunk, on the threaded scheduler): the same cells.
        corner = rvoronoi.compute(self.PTS, max_cells=400, owner_field="owner", resolution=self.RES,
                                  extent=[401000, self.TOP - 8 * self.RES, 401000 + 16 * self.RES, self.TOP])
        for name in ("owner", "distance"):
            self.assertEqual(corner[name].shape, (8, 16))
            self.assertTrue(same_bits(lazy[name][:8, :16].values, corner[name].values), name)

    def test_bad_values_are_invalid_arguments(self):
        for bad in (0, -1, 2 ** 63, 1.5, "many", True, None):
            with self.subTest(bad=bad):
                with self.assertRaises(rvoronoi.InvalidArgument) as caught:
                    rvoronoi.compute(self.PTS, owner_field="owner", resolution=100.0, max_cells=bad)
                self.assertTrue(str(caught.exception).startswith("max_cells: "), str(caught.exception))


class Memory(unittest.TestCase):
    def test_arrays_own_the_engine_buffers(self):
        ds = rvoronoi.compute(os.path.join(FIX, "coast_points.geojson"), owner_field="owner", resolution=50)
        for name in ("owner", "distance"):
            a = ds[name].values
            self.assertFalse(a.flags.owndata)
            self.assertEqual(type(a.base).__name__, "PyCapsule", name)
            self.assertTrue(a.flags.c_contiguous)

    def test_the_gil_is_released_while_computing(self):
        rng = np.random.default_rng(7)
        pts = rng.uniform(0, 4000, size=(3000, 2))
        mapping = {"type": "FeatureCollection",
                   "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
                   "features": [{"type": "Feature", "properties": {"id": i},
                                 "geometry": {"type": "Point", "coordinates": [400000 + x, 6100000 + y]}}
                                for i, (x, y) in enumerate(pts)]}
        done = threading.Event()
        ticks = [0]

        def spin():
            while not done.is_set():
                ticks[0] += 1
        spinner = threading.Thread(target=spin)
        spinner.start()
        try:
            # Brute force: seconds of engine time without Python in between.
            start = time.perf_counter()
            before = ticks[0]
            rvoronoi.compute(mapping, owner_field="id", resolution=4, extent=[400000, 6100000, 404000, 6104000],
                             method="brute-force", threads=1)
            elapsed = time.perf_counter() - start
            spun = ticks[0] - before
        finally:
            done.set()
            spinner.join()
        # Holding the GIL, the spinner would advance only at the interpreter's switch interval
        # around the call; released, it spins through the whole computation.
        self.assertGreater(elapsed, 0.3, "the computation is too short to tell")
        self.assertGreater(spun, 100000, "the spinner stood still: the GIL was held (%d ticks in %.2f s)"
                           % (spun, elapsed))


class Package(unittest.TestCase):
    """What the package says of itself: one version (CMake's, as the CLI reports it, and the
    installed metadata's where installed), and a typing stub made from the option table."""

    def test_one_version(self):
        cli = subprocess.run([RVORONOI, "--version"], capture_output=True, text=True, check=True).stdout.split()[-1]
        self.assertEqual(rvoronoi.__version__, cli)
        try:
            from importlib import metadata
            self.assertEqual(metadata.version("rvoronoi"), cli)
        except metadata.PackageNotFoundError:
            pass  # imported from the build tree (PYTHONPATH), not installed: no metadata there

    def test_typing_stub_names_every_keyword(self):
        import ast
        here = os.path.dirname(rvoronoi.__file__)
        self.assertTrue(os.path.exists(os.path.join(here, "py.typed")))
        with open(os.path.join(here, "__init__.pyi"), encoding="utf-8") as f:
            tree = ast.parse(f.read())
        computes = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "compute"]
        self.assertEqual(len(computes), 2)  # overloads: without and with deliverables
        real = inspect.signature(rvoronoi.compute).parameters
        wanted = {k["keyword"] for k in rvoronoi.keywords() if not k["run_only"]} | {
            p.name for p in real.values() if p.kind is p.KEYWORD_ONLY}
        for c in computes:
            self.assertEqual({a.arg for a in c.args.kwonlyargs}, wanted)
            self.assertEqual([a.arg for a in c.args.args], ["seeds"])
        # Choices as literals, e.g. the metric's.
        text = ast.unparse(computes[0])
        self.assertIn("metric: Literal['auto', 'planar', 'geodesic'] | None=None", text)
        classes = {n.name for n in tree.body if isinstance(n, ast.ClassDef)}
        self.assertEqual(classes, {"Error", "Session"} | {name for _, name in rvoronoi._rvoronoi.error_kinds})
        # The session takes compute()'s keyword options too.
        session = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "Session")
        init = next(n for n in session.body if isinstance(n, ast.FunctionDef) and n.name == "__init__")
        self.assertEqual({a.arg for a in init.args.kwonlyargs},
                         {k["keyword"] for k in rvoronoi.keywords() if not k["run_only"]} | {"undo_depth", "max_cells"})
        functions = {n.name for n in tree.body if isinstance(n, ast.FunctionDef)}
        self.assertTrue({"compute", "describe", "keywords"} <= functions)


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"])
