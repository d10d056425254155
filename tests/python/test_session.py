"""rvoronoi.Session (issue 54): a live what-if session in process, over the façade's rv::Session.

    PYTHONPATH=build/python /usr/bin/python3 tests/python/test_session.py SOURCE_DIR

Points of four owners and an island in UTM 33N: after each step (move a point, add one, set a
weight, remove one, undo, redo) the session's dataset equals rvoronoi.compute() on its features
as a seed file (arrays bit for bit, owners by label), its lines equal that call's deliverables,
and its areas follow the answer's moved areas. save() writes an ordinary job whose files are the
session's deliverables. A bad edit raises the error table's class and changes nothing.
"""
import json
import os
import sys
import tempfile
import unittest

import numpy as np

import rvoronoi

SOURCE = sys.argv[1]
X0, Y0, SIZE = 500000.0, 6000000.0, 20000.0
OPTIONS = {"owner_field": "owner", "resolution": 100.0, "extent": [X0, Y0, X0 + SIZE, Y0 + SIZE]}


def seeds():
    rng = np.random.default_rng(54)
    features = []
    for i in range(12):
        x, y = X0 + SIZE * (0.1 + 0.8 * rng.random()), Y0 + SIZE * (0.1 + 0.8 * rng.random())
        features.append({"type": "Feature", "properties": {"owner": "ABCD"[i % 4]},
                         "geometry": {"type": "Point", "coordinates": [x, y]}})
    ring = [[X0 + 9000, Y0 + 9000], [X0 + 11000, Y0 + 9000], [X0 + 11000, Y0 + 10500], [X0 + 9000, Y0 + 9000]]
    features.append({"type": "Feature", "properties": {"owner": "B"},
                     "geometry": {"type": "Polygon", "coordinates": [ring]}})
    return {"type": "FeatureCollection", "features": features,
            "crs": {"type": "name", "properties": {"name": "urn:ogc:def:crs:EPSG::32633"}}}


class SessionTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory(prefix="rv-session-")
        self.path = os.path.join(self.tmp.name, "seeds.geojson")
        with open(self.path, "w") as f:
            json.dump(seeds(), f)
        self.s = rvoronoi.Session(self.path, ("boundaries", "tripoints", "regions"), **OPTIONS)
        self.runs = 0

    def tearDown(self):
        self.tmp.cleanup()

    def features_file(self):
        """The session's features as a seed file, as a user saving them would have it."""
        self.runs += 1
        path = os.path.join(self.tmp.name, "edited_%d.geojson" % self.runs)
        doc = json.loads(self.s._s.features())
        for f in doc["features"]:
            f["properties"].pop("reach")  # none given: a field of nulls reads as text
        with open(path, "w") as f:
            json.dump(doc, f)
        return path

    def check_fresh(self, what):
        """The session against compute() on its features as a file. Owners are compared by label:
        the session keeps its owner codes, a file numbers owners by first appearance."""
        path = self.features_file()
        ds, lines = rvoronoi.compute(path, nearest_feature=True, deliverables=["boundaries", "tripoints", "regions"],
                                     weight_field="weight", **OPTIONS)
        mine = self.s.to_dataset()

        def labels(d):
            table = np.array([""] + json.loads(d.owner.attrs["owner_labels"]), dtype=object)
            return table[d.owner.values]

        np.testing.assert_array_equal(labels(mine), labels(ds), err_msg=what)
        self.assertTrue(np.array_equal(mine.distance.values.view(np.uint32), ds.distance.values.view(np.uint32)),
                        what + ": distances differ")
        np.testing.assert_array_equal(mine.nearest_feature.values, ds.nearest_feature.values, err_msg=what)
        for name in ("boundaries", "tripoints", "regions"):
            ours = sorted(g.wkb_hex for g in self.s.lines(name).geometry)
            theirs = sorted(g.wkb_hex for g in lines[name].geometry)
            self.assertEqual(ours, theirs, "%s: the %s differ" % (what, name))

    def test_steps_equal_fresh_runs(self):
        f = self.s.features
        self.assertEqual(list(f.index), [str(i) for i in range(1, 14)], "ids: input positions, in input order")
        self.assertEqual(set(f.columns) >= {"owner", "weight", "reach", "kind", "geometry"}, True)
        self.check_fresh("created")
        areas0 = self.s.areas
        x, y = f.geometry.iloc[0].x, f.geometry.iloc[0].y
        a = self.s.edit({"op": "move-vertex", "feature": "1", "path": [], "to": [x + 1500.0, y - 800.0]})
        self.assertGreater(a["cells"]["owner_changed"], 0)
        self.assertIsNotNone(a["cells"]["box"])
        moved = {}
        for m in a["moved"]:
            moved[m["from"]] = moved.get(m["from"], 0.0) - m["area"]
            moved[m["to"]] = moved.get(m["to"], 0.0) + m["area"]
        areas1 = self.s.areas
        for label, delta in moved.items():
            self.assertAlmostEqual(areas1.loc[label, "cells_area"] - areas0.loc[label, "cells_area"], delta, delta=1e-6)
        # The lines indexed by the ids the answer names: each changed or added line is there, as
        # the answer draws it.
        from shapely.geometry import shape
        b = self.s.lines("boundaries")
        self.assertEqual(b.index.name, "id")
        entries = a["lines"]["boundaries"]["changed"] + a["lines"]["boundaries"]["added"]
        self.assertGreater(len(entries), 0)
        for e in entries:
            self.assertIn(e["id"], b.index)
            self.assertTrue(shape(e["geometry"]).equals_exact(b.geometry[e["id"]], 1e-6), e["id"])
        for i in a["lines"]["boundaries"]["removed"]:
            self.assertNotIn(i, b.index)
        self.check_fresh("moved")
        a = self.s.edit([{"op": "add", "properties": {"owner": "C"},
                          "geometry": {"type": "Point", "coordinates": [X0 + 3000.0, Y0 + 17000.0]}},
                         {"op": "set", "feature": "2", "properties": {"weight": 1.3}}])
        self.assertIn("n1", self.s.features.index)
        self.check_fresh("added and weighted")
        self.s.edit({"op": "remove", "feature": "3"})
        self.check_fresh("removed")
        self.s.undo()
        self.check_fresh("undone")
        self.s.redo()
        self.check_fresh("redone")
        # save(): an ordinary job on the session's seeds (its owner codes): its files are the
        # session's deliverables, byte for byte, and its raster the dataset's owners.
        out = os.path.join(self.tmp.name, "saved")
        os.makedirs(out)
        names = {"boundaries": "b.geojson", "regions": "r.geojson", "ownership": "own.tif"}
        report = self.s.save({k: os.path.join(out, v) for k, v in names.items()})
        self.assertIn("deliverables", report)
        for name in ("boundaries", "regions"):
            with open(os.path.join(out, names[name]), encoding="utf-8") as f:
                self.assertEqual(f.read(), self.s._s.deliverable(name), name)
        from osgeo import gdal
        raster = gdal.Open(os.path.join(out, "own.tif")).ReadAsArray()
        np.testing.assert_array_equal(raster, self.s.to_dataset().owner.values)

    def test_field_alone(self):
        s = rvoronoi.Session(self.path, (), **OPTIONS)
        self.assertEqual(s._s.deliverables(), [])
        a = s.edit({"op": "set", "feature": "1", "properties": {"owner": "D"}})
        self.assertGreater(a["cells"]["owner_changed"], 0)
        self.assertEqual(a["recompute"]["rows_extracted"], 0)
        self.assertEqual(set(s.areas.index), {"A", "B", "C", "D"})
        self.assertNotIn("area", s.areas.columns)  # no regions: the cells' areas alone
        self.assertEqual(s.features.loc["1", "owner"], "D")

    def test_bad_edits_change_nothing(self):
        before = (self.s._s.features(), self.s._s.deliverable("boundaries"))
        for edit, cls in [({"op": "remove", "feature": "404"}, rvoronoi.InvalidArgument),
                          ({"op": "move-vertex", "feature": "1", "path": [], "to": [float("nan"), 1.0]},
                           rvoronoi.InvalidArgument),
                          ({"op": "set", "feature": "1", "properties": {"weight": "heavy"}}, rvoronoi.InvalidArgument),
                          ({"op": "move-vertex", "feature": "1", "path": [], "to": [X0 + 10500.0, Y0 + 9300.0]},
                           rvoronoi.Conflict)]:
            with self.assertRaises(cls, msg=json.dumps(edit)):
                self.s.edit(edit)
            self.assertEqual((self.s._s.features(), self.s._s.deliverable("boundaries")), before)
        with self.assertRaises(rvoronoi.InvalidArgument):
            self.s.undo()
        with self.assertRaises(rvoronoi.InvalidArgument):
            rvoronoi.Session(self.path, ("ownership",), **OPTIONS)
        with self.assertRaises(TypeError):
            rvoronoi.Session(self.path, colour="red")


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]])
