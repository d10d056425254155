"""rvoronoi for Python: raster Voronoi diagrams of seed layers (points, lines, polygons), exact.

    import rvoronoi
    ds = rvoronoi.compute("coasts.gpkg", owner_field="state", resolution=0.001,
                          metric="geodesic", distance_units="nmi")
    ds.owner            # owner codes; ds.owner.attrs["flag_meanings"] names them
    ds.distance         # distance to the nearest seed, in nautical miles

The same engine, options and messages as `rvoronoi compute` (the CLI) and the daemon: the keyword
options are the CLI's flags with '_' for '-' (`rvoronoi.keywords()` lists them with their help),
checked by the same option table. Errors are `rvoronoi.Error` subclasses named after the kinds of
the project's error table (InvalidArgument, InvalidInput, NotFound, Conflict, TooLarge,
Unsupported, Cancelled, IOFailure, Busy, OverQuota, InternalError), each also a subclass of the built-in
exception a caller would expect (ValueError, LookupError, OSError, ...).
"""
import json
import math
import operator
import os
import tempfile

from . import _rvoronoi
from ._rvoronoi import Error  # noqa: F401  (re-exported)

for _kind, _name in _rvoronoi.error_kinds:
    globals()[_name] = getattr(_rvoronoi, _name)
del _kind, _name

__version__ = _rvoronoi.version
__all__ = ["compute", "describe", "run", "process_description", "keywords", "Session", "Error"] + [name for _, name in _rvoronoi.error_kinds]

_PRODUCTS = ("ownership", "distance", "nearest_feature", "via")
_DELIVERABLES = {"boundaries": ".geojson", "tripoints": ".geojson", "limits": ".geojson", "regions": ".geojson",
                 "turning_points": ".json"}
_RUN_KEYWORDS = {k["keyword"]: k for k in _rvoronoi.keywords()}
_KEYWORDS = {name: k for name, k in _RUN_KEYWORDS.items() if not k["run_only"]}

from ._session import Session  # noqa: E402  (after the tables it reads)


def keywords():
    """The keyword options of compute(), from the option table: a list of dicts (keyword, type,
    section, title, help, default, choices)."""
    return [dict(k) for k in _rvoronoi.keywords()]


def _json_default(value):
    # NumPy scalars and arrays, tuples of them, paths.
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError("%s is not a value an option takes" % type(value).__name__)


def _check_finite(name, value):
    # JSON has no NaN or infinity, so such a number would reach the option table as text it cannot
    # parse (an internal error); it is the caller's argument that is wrong, so say which one.
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        value = value.tolist()  # NumPy scalars and arrays, as json.dumps will see them
    if isinstance(value, float):
        if not math.isfinite(value):
            raise InvalidArgument("%s: not a finite number (%r)" % (name, value))  # noqa: F821
    elif isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            _check_finite("%s[%d]" % (name, i), item)
    elif isinstance(value, dict):
        for key, item in value.items():
            _check_finite("%s.%s" % (name, key), item)


def _options_json(options, caller="compute", known=None):
    known = _KEYWORDS if known is None else known
    unknown = sorted(set(options) - set(known))
    if unknown:
        raise TypeError("%s() got unexpected keyword argument%s %s; the options are: %s"
                        % (caller, "s" if len(unknown) > 1 else "", ", ".join(repr(u) for u in unknown),
                           ", ".join(sorted(known))))
    for name, value in options.items():
        _check_finite(name, value)
    return json.dumps(options, default=_json_default, allow_nan=False)


def _read_deliverable(name, path, crs_wkt):
    with open(path, encoding="utf-8") as f:
        doc = json.load(f)
    if name == "turning_points":
        return doc
    try:
        import geopandas
    except ImportError:
        return doc
    crs = None
    member = doc.get("crs", {}).get("properties", {}).get("name") if isinstance(doc.get("crs"), dict) else None
    if member or crs_wkt:
        crs = member or crs_wkt
    features = doc.get("features", [])
    if not features:
        return geopandas.GeoDataFrame({"geometry": []}, geometry="geometry", crs=crs)
    return geopandas.GeoDataFrame.from_features(features, crs=crs)


def _products(nearest_feature, via=False):
    return ["ownership", "distance"] + (["nearest_feature"] if nearest_feature else []) + (["via"] if via else [])


def _max_cells(value):
    # An integer (NumPy's too), not a bool, from one cell to what the engine counts in (int64).
    if isinstance(value, bool) or not hasattr(value, "__index__") or not 1 <= operator.index(value) < 2 ** 63:
        raise InvalidArgument("max_cells: must be a positive number of cells, got %r" % (value,))  # noqa: F821
    return operator.index(value)


def compute(seeds, *, chunks=None, nearest_feature=False, via=False, deliverables=None,
            max_cells=_rvoronoi.default_max_cells, **options):
    """Computes the raster Voronoi diagram of `seeds` on a grid.

    seeds: a path (any source GDAL/OGR reads: GeoPackage, Shapefile, GeoJSON, FlatGeobuf, a .zip of
        them), a list of paths, a GeoJSON mapping (FeatureCollection) or a GeoDataFrame.
    chunks: (rows, cols): the result is backed by Dask arrays, one engine window per chunk,
        computed wherever Dask runs them (threads, processes, a distributed cluster); identical to
        the unchunked result, bit for bit. The exact and brute-force methods only. Each chunk uses
        one engine thread unless `threads` says otherwise (Dask runs chunks side by side).
    nearest_feature: also return `nearest_feature` (the 1-based position of the nearest seed
        feature in the input).
    via: with `barriers` (the distance by sea: land polygons and barrier lines, given as the seeds
        are: a path, a GeoJSON mapping, a GeoDataFrame, or a list of them), also return `via`: the last barrier vertex on each cell's path, 0 where the
        seed is seen directly (the report's sea.via_vertices gives each number's position).
    deliverables: names among "boundaries", "tripoints", "limits" (needs limit_distances),
        "regions", "turning_points": computed from the same field (once), returned beside the
        dataset as GeoDataFrames (GeoJSON mappings without GeoPandas; turning points as the
        treaty table's JSON). Not with chunks.
    max_cells: the most cells the whole grid may have, chunked or not (default: the daemon's,
        2^34); over it, TooLarge before anything is computed. Raise it on purpose for a bigger grid.
    **options: the CLI's options (see below and rvoronoi.keywords()).

    Returns an xarray.Dataset (owner, distance[, nearest_feature][, via] on x/y cell centres, CRS in the
    CF `spatial_ref` variable, the owner table as CF flags, the report as JSON text in
    attrs["rvoronoi_report"]); with deliverables, (dataset, {name: deliverable}).
    Raises rvoronoi.Error subclasses; TypeError for an unknown keyword.
    """
    from . import _seeds

    with _seeds.LayerOptions(options) as options:
        return _compute(seeds, chunks, nearest_feature, via, deliverables, max_cells, options)


def _compute(seeds, chunks, nearest_feature, via, deliverables, max_cells, options):
    from . import _dataset, _seeds

    if chunks is not None and "threads" not in options:
        # Dask gives the parallelism (a chunk per worker thread): one engine thread per chunk.
        options = dict(options, threads=1)
    options_json = _options_json(options)
    max_cells = _max_cells(max_cells)
    products = _products(nearest_feature, via)
    wanted = list(deliverables or [])
    for name in wanted:
        if name not in _DELIVERABLES:
            raise InvalidArgument("deliverables: %r is not one of %s" % (name, ", ".join(_DELIVERABLES)))  # noqa: F821
    if chunks is not None:
        if wanted:
            raise InvalidArgument("deliverables: not with chunks; compute them without chunks")  # noqa: F821
        return _compute_chunked(seeds, chunks, products, options, options_json, max_cells)
    with _seeds.SeedFiles(seeds) as files:
        job = _rvoronoi.Job(files.paths, options_json, None, max_cells)
        with tempfile.TemporaryDirectory(prefix="rvoronoi-out-") as out:
            paths = {n: os.path.join(out, n + _DELIVERABLES[n]) for n in wanted}
            result = job.run(None, products, paths)
            lines = {n: _read_deliverable(n, p, job.grid["crs_wkt"]) for n, p in paths.items()}
    ds = _dataset.dataset({p: result[p] for p in products}, job.grid, job.owners, job.unit, job.metric,
                          result["report"])
    return (ds, lines) if wanted else ds


def run(seeds, outputs, *, progress=None, cancelled=None, max_cells=_rvoronoi.default_max_cells, **options):
    """Runs a whole job and writes its files as `rvoronoi compute` does: the same engine, options,
    writers and report, for callers that want files, not arrays (the QGIS provider's local mode).

    seeds: as compute() takes them.
    outputs: {process output id: path}, the ids of process_description()["outputs"]: ownership,
        distance, nearestFeature (GeoTIFF), boundaries, tripoints, limits, regions (.geojson,
        .json or .gpkg), margin (GeoTIFF), preview (.png), turningPoints (.json or .csv), report
        (.json). The file's extension chooses its format, as on the CLI.
    progress: called as progress(stage, fraction) while the job runs (stage: read, compute,
        validate, write, deliver; fraction in [0, 1] of that stage), from the job's threads.
    cancelled: called with each progress report; True stops the job (rvoronoi.Cancelled), and
        nothing partial is left.
    **options: the CLI's options, as compute() takes them, and how the rasters are written:
        compression (fast, small, deflate, none) and cog (Cloud Optimized GeoTIFFs).

    Returns the report (a dict). Raises rvoronoi.Error subclasses; an exception raised by
    progress or cancelled stops the job and is raised again here.
    """
    from . import _seeds

    with _seeds.LayerOptions(options) as options:
        options_json = _options_json(options, "run", _RUN_KEYWORDS)
        max_cells = _max_cells(max_cells)
        files_out = {}
        for name, path in dict(outputs).items():
            if not isinstance(name, str) or not isinstance(path, (str, os.PathLike)):
                raise InvalidArgument("outputs: a mapping of output ids to paths")  # noqa: F821
            files_out[name] = os.fspath(path)
        with _seeds.SeedFiles(seeds) as files:
            report = _rvoronoi.run_files(files.paths, options_json, files_out, progress, cancelled, max_cells)
    return json.loads(report)


def process_description():
    """The description of the process "voronoi" (OGC API - Processes), exactly as an rvoronoi daemon
    serves it at /processes/voronoi (links relative): every input with its schema and the
    x-rvoronoi-* members clients are made from, every output with its media types."""
    return json.loads(_rvoronoi.process_description())


def describe(seeds, *, crs=None, features=False):
    """What seed sources hold, before computing with them: the same description as the daemon's
    process describe-seeds.

    seeds: as compute() takes them. crs: the CRS to give the box (and features) in; default the
    first layer's. features: also return every feature as GeoJSON (ids: 1-based positions in the
    input, as nearest_feature numbers them).

    Returns a dict: crs {name, wkt, geographic, metresPerUnit, code}, bbox, layers [{source,
    name, features, empty, geometryTypes, fields [{name, type, nonNull, distinct, distinctExact,
    values}]}], commonFields (an owner field must be one), warnings[, features]. No owner field
    is needed and nothing is checked between owners: data a run would refuse until the right
    options are chosen is described all the same. Raises rvoronoi.Error subclasses.
    """
    from . import _seeds

    with _seeds.SeedFiles(seeds) as files:
        d = json.loads(_rvoronoi.describe_seeds(files.paths, crs or "", bool(features)))
        # A mapping or frame went through a temporary file: the caller knows it as seeds[i].
        for i, path in enumerate(files.paths):
            if files.is_temporary(i):
                for layer in d["layers"]:
                    layer["source"] = layer["source"].replace(path, "seeds[%d]" % i)
    return d


def _compute_chunked(seeds, chunks, products, options, options_json, max_cells):
    import hashlib

    from . import _chunks, _dataset, _seeds

    try:
        rows, cols = chunks
    except (TypeError, ValueError):
        raise InvalidArgument("chunks: (rows, cols), two positive integers, got %r" % (chunks,)) from None  # noqa: F821
    with _seeds.SeedFiles(seeds) as files:
        # Read and checked here once, on the caller's side, so that bad input raises now, not in a
        # worker; the first chunk's window stands for all (the plan's memory is a chunk's). The
        # whole grid is held to max_cells here, whatever the window, before any graph is made.
        try:
            first = [0, 0, max(1, int(rows)), max(1, int(cols))]
            job = _rvoronoi.Job(files.paths, options_json, [0, 0, 1, 1], max_cells)  # the grid, of any size
            grid = job.grid
            first[2], first[3] = min(first[2], grid["height"]), min(first[3], grid["width"])
            job = _rvoronoi.Job(files.paths, options_json, first, max_cells)
        except InvalidArgument as e:  # noqa: F821
            text = str(e)
            if text.startswith("window: "):
                raise InvalidArgument("chunks: " + text[len("window: "):]) from None  # noqa: F821
            raise
        # (A repeatable one, the barriers, may name a list of files.)
        file_options = {k: [os.fspath(p) for p in v] if isinstance(v, (list, tuple)) else os.fspath(v)
                        for k, v in options.items() if v is not None and _KEYWORDS[k]["type"] == "path"}
        shipped_options = json.dumps({k: v for k, v in json.loads(options_json).items() if k not in file_options})
        bundle, digest = _seeds.bundle(files.paths, file_options)
    digest = hashlib.sha256((digest + shipped_options + str(max_cells)).encode()).hexdigest()[:32]
    arrays = _chunks.chunked_arrays(grid, (rows, cols), digest, bundle, shipped_options, products, max_cells)
    report = json.dumps({"chunks": [int(rows), int(cols)], "grid": {k: v for k, v in grid.items() if k != "crs_wkt"},
                         "owners": job.owners, "metric": job.metric, "distance_units": job.unit})
    return _dataset.dataset(arrays, grid, job.owners, job.unit, job.metric, report)


def _describe_options():
    lines = ["", "Options (the CLI's, from its option table):", ""]
    for k in _KEYWORDS.values():
        head = "%s (%s)" % (k["keyword"], k["type"])
        if k["choices"]:
            head += ": " + " | ".join(k["choices"])
        if k["default"]:
            head += ", default " + k["default"]
        lines.append("    " + head)
        lines.append("        " + k["help"])
    return "\n".join(lines)


compute.__doc__ += _describe_options()
