"""Chunked computation on a real Dask cluster (issue 33): identical to unchunked, bit for bit.

    PYTHONPATH=build/python /usr/bin/python3 tests/python/test_dask.py SOURCE_DIR

Starts a scheduler and two worker processes on loopback (`dask-scheduler`, `dask-worker`, one
thread each, no nanny: a killed worker stays dead), then:
  1. planar points and the geodesic Øresund, cut into uneven chunks: every array equals the
     unchunked call's, bit for bit; the chunks ran on both workers, and each worker prepared the
     seeds once however many chunks it computed;
  2. a worker killed (SIGKILL) while it computes a chunk: Dask computes that chunk again on the
     other worker, and the result is still identical;
  3. the threaded scheduler (no cluster) and a chunk size larger than the grid give the same arrays.
Every step is bounded in time; the processes are stopped whatever happens.
"""
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import unittest

import numpy as np

import rvoronoi
from rvoronoi import _chunks

SOURCE = sys.argv[1]
FIX = os.path.join(SOURCE, "fixtures")
ORESUND = os.path.join(FIX, "oresund.gpkg")
DEADLINE = 60  # seconds, for each wait on the cluster


def same_bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype.kind == "f":
        return a.shape == b.shape and np.array_equal(a.view(np.uint32), b.view(np.uint32))
    return a.shape == b.shape and np.array_equal(a, b)


def points_file(directory, n, side, seed):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0, side, size=(n, 2))
    path = os.path.join(directory, "points.geojson")
    with open(path, "w") as f:
        json.dump({"type": "FeatureCollection",
                   "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}},
                   "features": [{"type": "Feature", "properties": {"owner": "o%d" % (i % 7)},
                                 "geometry": {"type": "Point", "coordinates": [400000 + x, 6100000 + y]}}
                                for i, (x, y) in enumerate(pts)]}, f)
    return path


def worker_state():
    """On a worker: how many jobs it prepared, and how many it holds."""
    return {"prepared": _chunks.prepared_count(), "held": len(_chunks.directory_of_cache())}


class Cluster:
    def __init__(self, directory):
        self.dir = directory
        self.procs = []
        env = dict(os.environ)
        env["DASK_DISTRIBUTED__WORKER__DAEMON"] = "False"
        self.env = env
        self.scheduler_file = os.path.join(directory, "scheduler.json")
        # This interpreter runs them (python -m), so that the workers import the rvoronoi this test
        # does (a venv's installed package, or the build tree's through PYTHONPATH).
        self.procs.append(self._start(["dask-scheduler", "--host", "127.0.0.1", "--port", "0",
                                       "--dashboard-address", ":0", "--scheduler-file", self.scheduler_file]))
        self.workers = {}
        for name in ("w1", "w2"):
            self.workers[name] = self._start(["dask-worker", "--scheduler-file", self.scheduler_file, "--nworkers", "1",
                                              "--nthreads", "1", "--no-nanny", "--name", name, "--host", "127.0.0.1",
                                              "--dashboard-address", ":0", "--memory-limit", "2GiB"])
            self.procs.append(self.workers[name])
        until = time.time() + DEADLINE
        while not os.path.exists(self.scheduler_file):
            if time.time() > until:
                raise RuntimeError("the scheduler did not start")
            time.sleep(0.1)
        from distributed import Client
        self.client = Client(scheduler_file=self.scheduler_file, timeout=DEADLINE)
        self.client.wait_for_workers(2, timeout=DEADLINE)

    def _start(self, cmd):
        module = "distributed.cli." + cmd[0].replace("-", "_")
        with open(os.path.join(self.dir, cmd[0] + "-%d.log" % len(self.procs)), "w") as log:
            return subprocess.Popen([sys.executable, "-m", module] + cmd[1:], stdout=log, stderr=subprocess.STDOUT,
                                    env=self.env, start_new_session=True)

    def address_of(self, name):
        for addr, w in self.client.scheduler_info()["workers"].items():
            if w["name"] == name:
                return addr
        return None

    def close(self):
        try:
            self.client.close()
        except Exception:
            pass
        for p in self.procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=30)


class OnACluster(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.cluster = Cluster(cls.tmp.name)
        cls.client = cls.cluster.client

    @classmethod
    def tearDownClass(cls):
        cls.cluster.close()
        cls.tmp.cleanup()

    def check_identical(self, seeds, chunks, **options):
        whole = rvoronoi.compute(seeds, nearest_feature=True, **options)
        chunked = rvoronoi.compute(seeds, nearest_feature=True, chunks=chunks, **options)
        self.assertIsNotNone(chunked.owner.data.chunks)
        got = self.client.compute([chunked.owner.data, chunked.distance.data, chunked.nearest_feature.data],
                                  sync=True)
        self.assertTrue(same_bits(got[0], whole.owner.values), "owner codes differ")
        self.assertTrue(same_bits(got[1], whole.distance.values), "distances differ")
        self.assertTrue(same_bits(got[2], whole.nearest_feature.values), "feature numbers differ")
        self.assertEqual(chunked.owner.attrs["owner_labels"], whole.owner.attrs["owner_labels"])
        np.testing.assert_array_equal(chunked.x.values, whole.x.values)
        np.testing.assert_array_equal(chunked.y.values, whole.y.values)
        self.assertEqual(chunked.spatial_ref.attrs, whole.spatial_ref.attrs)
        return chunked

    def test_1_planar_and_geodesic_identical_and_prepared_once_per_worker(self):
        pts = points_file(self.tmp.name, 400, 3000.0, 1)
        before = self.client.run(worker_state)
        chunked = self.check_identical(pts, (37, 53), owner_field="owner", resolution=10.0)
        after = self.client.run(worker_state)
        tasks = len(chunked.owner.data.__dask_keys__()) * len(chunked.owner.data.__dask_keys__()[0])
        self.assertGreater(tasks, 20)
        used = [a for a in after if after[a]["prepared"] > before[a]["prepared"]]
        self.assertEqual(len(used), 2, "both workers computed chunks: %s" % after)
        for a in used:
            self.assertEqual(after[a]["prepared"] - before[a]["prepared"], 1,
                             "a worker prepared the seeds once for all its chunks: %s" % after)
        self.check_identical(ORESUND, (41, 29), owner_field="iso2", resolution=0.01, metric="geodesic",
                             distance_units="nmi", max_distance=25)

    def test_2_a_worker_killed_mid_chunk(self):
        pts = points_file(self.tmp.name, 6000, 4000.0, 2)
        options = dict(owner_field="owner", resolution=10.0, method="brute-force", threads=1)
        t = time.perf_counter()
        whole = rvoronoi.compute(pts, **options)
        per_chunk = (time.perf_counter() - t) / 4
        self.assertGreater(per_chunk, 0.15, "chunks long enough to be killed inside one")
        chunked = rvoronoi.compute(pts, chunks=(100, 400), **options)
        future = self.client.compute(chunked.owner.data)
        victim = self.cluster.address_of("w1")
        until = time.time() + DEADLINE
        while not self.client.processing().get(victim):
            self.assertLess(time.time(), until, "w1 never got a chunk")
            time.sleep(0.02)
        time.sleep(per_chunk / 3)  # inside the chunk's computation
        busy = list(self.client.processing().get(victim, []))
        self.assertTrue(busy, "w1 was computing when killed")
        self.cluster.workers["w1"].send_signal(signal.SIGKILL)
        got = future.result(timeout=DEADLINE * 3)
        self.assertTrue(same_bits(got, whole.owner.values), "the result after the retry differs")
        self.assertEqual(len(self.client.scheduler_info()["workers"]), 1)


class WithoutACluster(unittest.TestCase):
    def test_threads_and_one_big_chunk(self):
        import dask
        seeds = os.path.join(FIX, "coast_polygons.geojson")
        whole = rvoronoi.compute(seeds, owner_field="owner", resolution=100.0, metric="geodesic")
        for chunks in ((17, 23), (10**6, 10**6)):
            with dask.config.set(scheduler="threads", num_workers=2):
                got = rvoronoi.compute(seeds, owner_field="owner", resolution=100.0, metric="geodesic",
                                       chunks=chunks).compute()
            self.assertTrue(same_bits(got.owner.values, whole.owner.values), chunks)
            self.assertTrue(same_bits(got.distance.values, whole.distance.values), chunks)

    def test_written_from_the_chunks_to_geotiff_and_zarr(self):
        # What the README shows for results bigger than memory: a tiled GeoTIFF written window by
        # window (rioxarray) and a Zarr store, both from the chunks, both equal to the arrays.
        import threading

        import dask
        import rioxarray  # noqa: F401
        import xarray
        from osgeo import gdal
        seeds = os.path.join(FIX, "coast_points.geojson")
        whole = rvoronoi.compute(seeds, owner_field="owner", resolution=20.0)
        ds = rvoronoi.compute(seeds, owner_field="owner", resolution=20.0, chunks=(64, 96))
        with tempfile.TemporaryDirectory() as d, dask.config.set(scheduler="threads"):
            tif, store = os.path.join(d, "owner.tif"), os.path.join(d, "r.zarr")
            ds.owner.rio.to_raster(tif, tiled=True, compress="ZSTD", windowed=True, lock=threading.Lock())
            ds.to_zarr(store)
            g = gdal.Open(tif)
            self.assertTrue(same_bits(g.GetRasterBand(1).ReadAsArray(), whole.owner.values))
            block = g.GetRasterBand(1).GetBlockSize()
            self.assertLess(block[0], g.RasterXSize, "tiled")
            self.assertEqual(block[0], block[1], "tiled")
            want = [float(v) for v in whole.spatial_ref.attrs["GeoTransform"].split()]
            np.testing.assert_allclose(g.GetGeoTransform(), want, rtol=0, atol=1e-6)
            g = None
            back = xarray.open_zarr(store, mask_and_scale=False)  # raw codes, 0 = none
            self.assertTrue(same_bits(back.owner.values, whole.owner.values))
            self.assertTrue(same_bits(back.distance.values, whole.distance.values))
            self.assertEqual(back.owner.attrs["flag_meanings"], whole.owner.attrs["flag_meanings"])

    def test_files_travel_with_the_chunks(self):
        # A zipped shapefile of three layers, and a grid taken from a raster (`like`): both shipped
        # in the bundle, unpacked by the worker (here the threaded scheduler's process).
        import dask
        import rioxarray  # noqa: F401
        zipped = os.path.join(FIX, "coast_shp.zip")
        whole = rvoronoi.compute(zipped, owner_field="owner", resolution=40.0)
        with tempfile.TemporaryDirectory() as d:
            grid = os.path.join(d, "grid.tif")
            whole.owner.rio.to_raster(grid)
            with dask.config.set(scheduler="threads"):
                got = rvoronoi.compute(zipped, owner_field="owner", resolution=40.0, chunks=(50, 70)).compute()
                self.assertTrue(same_bits(got.owner.values, whole.owner.values))
                like = rvoronoi.compute(zipped, owner_field="owner", like=grid)
                got = rvoronoi.compute(zipped, owner_field="owner", like=grid, chunks=(33, 45)).compute()
            self.assertTrue(same_bits(got.distance.values, like.distance.values))
            self.assertEqual(like.owner.shape, whole.owner.shape)

    def test_barriers_travel_with_the_chunks(self):
        # The distance by sea chunked: the barrier layers (a list of files) shipped in the bundle;
        # every chunk settles its worker's bends once, and the arrays, vias included, equal the
        # whole grid's bit for bit.
        import dask
        ports = os.path.join(FIX, "oresund_ports.geojson")
        land = os.path.join(FIX, "oresund.gpkg")
        options = {"owner_field": "owner", "barriers": [land], "crs": "EPSG:32633", "metric": "planar",
                   "resolution": 500.0, "extent": [330000.0, 6150000.0, 370000.0, 6220000.0]}
        whole = rvoronoi.compute(ports, via=True, **options)
        with dask.config.set(scheduler="threads"):
            got = rvoronoi.compute(ports, via=True, chunks=(37, 23), **options).compute()
        for name in ("owner", "distance", "via"):
            self.assertTrue(same_bits(got[name].values, whole[name].values), name)
        self.assertGreater(int((whole.via.values > 0).sum()), 100)

    def test_bad_chunks(self):
        seeds = os.path.join(FIX, "coast_points.geojson")
        for bad in ((0, 10), (10,), "big", (1.5, 3)):
            with self.assertRaises(rvoronoi.InvalidArgument):
                rvoronoi.compute(seeds, owner_field="owner", resolution=50.0, chunks=bad)
        with self.assertRaises(rvoronoi.InvalidArgument) as caught:
            rvoronoi.compute(seeds, owner_field="owner", resolution=50.0, chunks=(10, 10), deliverables=["boundaries"])
        self.assertIn("not with chunks", str(caught.exception))


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0], "-v"])
