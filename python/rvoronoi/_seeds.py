"""Seeds as the engine reads them: files GDAL opens.

A call's `seeds` may be a path (any OGR source), a list of paths, a GeoJSON mapping or a
GeoDataFrame. Mappings and frames are written to a temporary GeoJSON file (with their CRS), which
lives as long as the `SeedFiles` that made it.

For a chunked call the files also travel: `bundle()` packs their bytes (a shapefile with its
sidecars, a directory with everything in it) so that a Dask worker on another machine writes them
once into a directory of its own and reads them from there (`unpack()`).
"""
import hashlib
import json
import os
import shutil
import tempfile

# A shapefile's companions, read beside it.
_SIDECARS = (".shx", ".dbf", ".prj", ".cpg", ".qix", ".sbn", ".sbx", ".qmd")


def _crs_member(crs):
    """The GeoJSON `crs` member GDAL reads for a pyproj CRS (EPSG code when it has one, else WKT)."""
    if crs is None:
        return None
    epsg = crs.to_epsg()
    name = "urn:ogc:def:crs:EPSG::%d" % epsg if epsg else crs.to_wkt()
    return {"type": "name", "properties": {"name": name}}


def _frame_geojson(frame):
    """A GeoDataFrame as GeoJSON text with its CRS (GeoPandas' own GeoJSON drops it)."""
    doc = json.loads(frame.to_json(drop_id=False))
    member = _crs_member(frame.crs)
    if member:
        doc["crs"] = member
    return json.dumps(doc)


class SeedFiles:
    """The seed sources of one call as paths, and the temporary files that back them."""

    def __init__(self, seeds, what="seeds"):
        self._tmp = None
        self._what = what
        self.paths = []
        items = seeds if isinstance(seeds, (list, tuple)) else [seeds]
        if not items:
            raise TypeError("%s: at least one source is needed" % what)
        self._temporary = []
        for i, item in enumerate(items):
            self.paths.append(self._path_of(item, i))
            self._temporary.append(not isinstance(item, (str, os.PathLike)))

    def is_temporary(self, index):
        """Whether source `index` is a temporary file made from a mapping or a frame."""
        return self._temporary[index]

    def _temp(self, text, index):
        if self._tmp is None:
            self._tmp = tempfile.mkdtemp(prefix="rvoronoi-%s-" % self._what)
        path = os.path.join(self._tmp, "%s%d.geojson" % (self._what, index))
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)
        return path

    def _path_of(self, item, index):
        if isinstance(item, (str, os.PathLike)):
            return os.fspath(item)
        if hasattr(item, "to_json") and hasattr(item, "crs") and hasattr(item, "geometry"):
            return self._temp(_frame_geojson(item), index)
        if isinstance(item, dict) or hasattr(item, "__geo_interface__"):
            mapping = item if isinstance(item, dict) else item.__geo_interface__
            if mapping.get("type") not in ("FeatureCollection", "Feature"):
                raise TypeError("%s: a mapping must be a GeoJSON FeatureCollection or Feature" % self._what)
            return self._temp(json.dumps(mapping), index)
        raise TypeError("%s: a path, a list of paths, a GeoJSON mapping or a GeoDataFrame, got %s"
                        % (self._what, type(item).__name__))

    def close(self):
        if self._tmp:
            shutil.rmtree(self._tmp, ignore_errors=True)
            self._tmp = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        self.close()


class LayerOptions:
    """Keyword options whose value is a vector layer (the barriers), given as the seeds may be:
    mappings and frames written to temporary GeoJSON files (with their CRS) for as long as the
    `with` block lasts; the block sees the options with paths in their place."""

    NAMES = ("barriers",)

    def __init__(self, options):
        self.options = dict(options)
        self._files = []
        for name in self.NAMES:
            value = self.options.get(name)
            if value is None:
                continue
            items = value if isinstance(value, (list, tuple)) else [value]
            if all(isinstance(v, (str, os.PathLike)) for v in items):
                continue
            files = SeedFiles(value, what=name)
            self._files.append(files)
            self.options[name] = list(files.paths) if isinstance(value, (list, tuple)) else files.paths[0]

    def __enter__(self):
        return self.options

    def __exit__(self, *exc):
        for f in self._files:
            f.close()


def _files_of(path):
    """The files a source consists of: (path inside the bundle, path on disk)."""
    if path.startswith("/vsi"):
        raise ValueError("seeds: %s is a GDAL virtual path; a chunked call ships files, give the file itself" % path)
    if os.path.isdir(path):
        out = []
        for root, _, names in os.walk(path):
            for n in sorted(names):
                full = os.path.join(root, n)
                out.append((os.path.relpath(full, os.path.dirname(path.rstrip("/"))), full))
        return out
    if not os.path.exists(path):
        return [(os.path.basename(path), path)]  # the engine names it (not found) on the client
    stem, _ = os.path.splitext(path)
    out = [(os.path.basename(path), path)]
    for ext in _SIDECARS:
        for e in (ext, ext.upper()):
            if os.path.exists(stem + e):
                out.append((os.path.basename(stem + e), stem + e))
    return out


def bundle(paths, file_options):
    """The bytes a worker needs: every seed source and every file an option names.

    `file_options`: keyword -> path of the options whose value is a file (e.g. `like`), or a list
    of paths (`barriers`).
    Returns (bundle, token): the bundle maps each source to its files' bytes; the token is a digest
    of all of it (the worker's cache key, the Dask graph's name).
    """
    sources = []
    digest = hashlib.sha256()
    roles = [("seeds", p) for p in paths]
    for k, v in sorted(file_options.items()):
        roles += [("options:" + k, p) for p in v] if isinstance(v, list) else [("option:" + k, v)]
    for role, path in roles:
        files = []
        main = None
        for rel, full in _files_of(path):
            with open(full, "rb") as f:
                data = f.read()
            files.append((rel, data))
            digest.update(rel.encode() + b"\0" + hashlib.sha256(data).digest())
            if main is None:
                main = rel if not os.path.isdir(path) else os.path.basename(path.rstrip("/"))
        sources.append({"role": role, "main": main, "files": files})
    return {"sources": sources}, digest.hexdigest()[:32]


def unpack(bundle_value, directory):
    """Writes a bundle under `directory`; returns (seed paths, option keyword -> path or list)."""
    seeds, options = [], {}
    for i, src in enumerate(bundle_value["sources"]):
        base = os.path.join(directory, str(i))
        for rel, data in src["files"]:
            full = os.path.join(base, rel)
            os.makedirs(os.path.dirname(full), exist_ok=True)
            with open(full, "wb") as f:
                f.write(data)
        main = os.path.join(base, src["main"])
        if src["role"] == "seeds":
            seeds.append(main)
        elif src["role"].startswith("options:"):
            options.setdefault(src["role"][len("options:"):], []).append(main)
        else:
            options[src["role"][len("option:"):]] = main
    return seeds, options
