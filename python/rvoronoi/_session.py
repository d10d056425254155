"""rvoronoi.Session: a live what-if session in this process (the façade's rv::Session).

A session computes a job once and keeps it: the field, the line pieces and the deliverables.
Each edit changes the seeds and recomputes only what the edit can change; the answer says what
changed (cells and their box, area moved between owners, the new areas, the lines added, changed
and removed). After every step the session equals a fresh run on the edited seeds.
"""
import json

from . import _dataset


def _frame(doc, crs):
    """A GeoJSON FeatureCollection as a GeoDataFrame (the mapping itself without GeoPandas)."""
    try:
        import geopandas
    except ImportError:
        return doc
    features = doc.get("features", [])
    if not features:
        return geopandas.GeoDataFrame({"geometry": []}, geometry="geometry", crs=crs)
    frame = geopandas.GeoDataFrame.from_features(features, crs=crs)
    ids = [f.get("id") for f in features]
    if all(i is not None for i in ids):
        frame.index = ids
        frame.index.name = "id"
    return frame


class Session:
    """A live what-if session.

    Session(seeds, deliverables=("boundaries", "tripoints", "regions"), *, undo_depth=50,
            max_cells=..., **options)

    seeds: as rvoronoi.compute takes them (read once, at creation).
    deliverables: kept current after every edit, among "boundaries", "tripoints", "limits"
        (needs limit_distances), "regions", "turning_points".
    **options: the CLI's options, as rvoronoi.compute takes them. The grid, the metric, the
        options and the owner codes are frozen at creation.

    Edits (Session.edit), coordinates in the seeds' CRS, reach in the job's distance units:
        {"op": "replace", "feature": ID, "geometry": GEOJSON}
        {"op": "move-vertex", "feature": ID, "path": [...], "to": [x, y]}  (path [] for a point,
            [part, vertex] for a line, [part, ring, vertex] for a polygon)
        {"op": "add", "properties": {"owner": ..., "weight": ..., "reach": ...}, "geometry": GEOJSON}
        {"op": "remove", "feature": ID}
        {"op": "set", "feature": ID, "properties": {"owner"?, "weight"?, "reach"?}}
    Feature ids are strings (Session.features' index): the 1-based input position of the
    features read, "n1", "n2", ... for those added.
    """

    def __init__(self, seeds, deliverables=("boundaries", "tripoints", "regions"), *, undo_depth=50,
                 max_cells=None, **options):
        import rvoronoi
        from . import _rvoronoi, _seeds

        options_json = rvoronoi._options_json(options, "Session")
        max_cells = rvoronoi._max_cells(_rvoronoi.default_max_cells if max_cells is None else max_cells)
        wanted = list(deliverables)
        for name in wanted:
            if name not in rvoronoi._DELIVERABLES:
                raise rvoronoi.InvalidArgument("deliverables: %r is not one of %s"
                                               % (name, ", ".join(rvoronoi._DELIVERABLES)))
        with _seeds.SeedFiles(seeds) as files:
            self._s = _rvoronoi.Session(files.paths, options_json, wanted, int(undo_depth), max_cells)

    def edit(self, *edits):
        """Applies the edits (dicts, or one list of them) in order as one step; returns the answer
        (a dict). A refused edit raises (rvoronoi.InvalidArgument, InvalidInput, Conflict, TooLarge)
        and leaves the session as it was."""
        if len(edits) == 1 and isinstance(edits[0], (list, tuple)):
            edits = edits[0]
        return json.loads(self._s.edit(json.dumps(list(edits), allow_nan=True)))

    def undo(self):
        """Undoes the last step; returns the answer as edit() does."""
        return json.loads(self._s.undo())

    def redo(self):
        """Makes the last undone step again; returns the answer as edit() does."""
        return json.loads(self._s.redo())

    @property
    def info(self):
        """Grid, owners, areas, memory, steps, undo and redo depth (a dict)."""
        return json.loads(self._s.info())

    @property
    def features(self):
        """The seed features, indexed by id (a GeoDataFrame: owner, weight, reach, kind, and the
        effect in a session made with partial effect)."""
        doc = json.loads(self._s.features())
        return _frame(doc, self._crs(doc))

    def lines(self, name):
        """A deliverable as it stands: boundaries, tripoints, limits or regions as a GeoDataFrame
        (boundaries, tripoints and limits indexed by their line ids, those of the edits' answers),
        turning_points as the treaty table (a dict)."""
        doc = json.loads(self._s.deliverable(name))
        if name == "turning_points":
            return doc
        ids = json.loads(self._s.line_ids()).get(name)
        if ids is not None and len(ids) == len(doc.get("features", [])):
            for f, i in zip(doc["features"], ids):
                f["id"] = i
        return _frame(doc, self._crs(doc))

    @property
    def areas(self):
        """Each owner's areas (a pandas DataFrame indexed by label: cells_area, and with regions
        area, sea_area, land_area), in info["area_units"]."""
        import pandas
        table = pandas.DataFrame(self.info["areas"])
        return table.set_index("label")

    def to_dataset(self):
        """The current field as rvoronoi.compute returns it (an xarray.Dataset: owner, distance,
        nearest_feature)."""
        arrays = self._s.arrays()
        return _dataset.dataset(arrays, self._s.grid, self._s.owners, self._s.unit, self._s.metric,
                                json.dumps({"session": self.info}))

    def save(self, outputs):
        """Runs an ordinary job on the current seeds and writes its files ({process output id:
        path}, as rvoronoi.run takes them); its files equal a fresh run's. Returns the report."""
        import os
        return json.loads(self._s.save({k: os.fspath(v) for k, v in dict(outputs).items()}))

    def _crs(self, doc):
        member = doc.get("crs", {}).get("properties", {}).get("name") if isinstance(doc.get("crs"), dict) else None
        return member or self._s.grid["crs_wkt"] or None
