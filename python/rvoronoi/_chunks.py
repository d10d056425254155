"""A grid computed in chunks on Dask: one engine window per chunk, wherever Dask runs it.

The graph has one key holding the seeds' bundle (the bytes of every seed file and of every file an
option names, see _seeds.bundle) and, per chunk, one task that computes the chunk's products
together and one `getitem` per product. Every chunk task depends on the bundle's key, so Dask's
distributed scheduler moves the bundle to a worker once, however many of its chunks that worker
computes; there the bundle is written to a directory once and the job read and prepared once per
worker process (the `_jobs` cache, keyed by the bundle's digest), and each chunk is
`Job.run(window)` on that prepared job. Threads of one worker share it (the engine's prepared
job is only read).

A chunk's cells equal the same cells of the whole grid (the exact and brute-force methods compute
any window identically), so the array is the unchunked one bit for bit, however it is cut and
whoever computes it. A lost worker's chunks are computed again elsewhere by Dask, from the same
bundle: the same cells.
"""
import atexit
import operator
import os
import shutil
import tempfile
import threading

import numpy as np

from . import _rvoronoi, _seeds

_DTYPES = {"ownership": np.int32, "distance": np.float32, "nearest_feature": np.int32, "via": np.int32}

_jobs = {}  # digest -> (directory, _rvoronoi.Job), per worker process
_jobs_lock = threading.Lock()
_prepared = [0]  # jobs this process prepared (tests: once per worker, not once per chunk)


def _forget_jobs():
    for directory, _ in _jobs.values():
        shutil.rmtree(directory, ignore_errors=True)
    _jobs.clear()


atexit.register(_forget_jobs)


def _job_for(digest, bundle, options_json, window, max_cells):
    """This process's prepared job of a bundle, made on first use."""
    with _jobs_lock:
        found = _jobs.get(digest)
        if found is None:
            directory = tempfile.mkdtemp(prefix="rvoronoi-chunks-%s-" % digest[:8])
            try:
                seeds, files = _seeds.unpack(bundle, directory)
                job = _rvoronoi.Job(seeds, _with_files(options_json, files), list(window), max_cells)
            except BaseException:
                shutil.rmtree(directory, ignore_errors=True)
                raise
            found = _jobs[digest] = (directory, job)
            _prepared[0] += 1
        return found[1]


def _with_files(options_json, files):
    import json
    options = json.loads(options_json)
    options.update(files)
    return json.dumps(options)


class Shipped:
    """What every chunk of one call needs, one object in the graph (opaque to Dask)."""

    __slots__ = ("digest", "bundle", "options_json", "max_cells")

    def __init__(self, digest, bundle, options_json, max_cells):
        self.digest, self.bundle, self.options_json, self.max_cells = digest, bundle, options_json, max_cells

    def __getstate__(self):
        return (self.digest, self.bundle, self.options_json, self.max_cells)

    def __setstate__(self, state):
        self.digest, self.bundle, self.options_json, self.max_cells = state


def compute_chunk(shipped, window, products):
    """One chunk: {product: array} of the window (row0, col0, rows, cols). Runs on a worker."""
    # The caller's limit: a grid it allowed past the default is allowed on the workers too.
    job = _job_for(shipped.digest, shipped.bundle, shipped.options_json, window, shipped.max_cells)
    result = job.run(list(window), list(products), {}, False)
    return {p: result[p] for p in products}


def _starts(total, size):
    starts = list(range(0, total, size))
    return starts, tuple(min(size, total - s) for s in starts)


def chunked_arrays(grid, chunks, digest, bundle, options_json, products, max_cells):
    """{product: dask.array.Array} of the whole grid in chunks of (rows, cols)."""
    import dask.array as da

    rows, cols = chunks
    if int(rows) != rows or int(cols) != cols or rows < 1 or cols < 1:
        raise _rvoronoi.InvalidArgument("chunks: (rows, cols), two positive integers, got %r" % (chunks,))
    row_starts, row_sizes = _starts(grid["height"], int(rows))
    col_starts, col_sizes = _starts(grid["width"], int(cols))
    seeds_key = "rvoronoi-seeds-" + digest
    field_name = "rvoronoi-field-%s-%s" % (digest, "-".join(products))
    graph = {seeds_key: Shipped(digest, bundle, options_json, max_cells)}
    for i, r0 in enumerate(row_starts):
        for j, c0 in enumerate(col_starts):
            window = (r0, c0, row_sizes[i], col_sizes[j])
            graph[(field_name, i, j)] = (compute_chunk, seeds_key, window, tuple(products))
    arrays = {}
    for p in products:
        name = "rvoronoi-%s-%s" % (p, field_name[len("rvoronoi-field-"):])
        layer = dict(graph)
        for i in range(len(row_starts)):
            for j in range(len(col_starts)):
                layer[(name, i, j)] = (operator.getitem, (field_name, i, j), p)
        arrays[p] = da.Array(layer, name, chunks=(row_sizes, col_sizes), dtype=_DTYPES[p])
    return arrays


def prepared_count():
    """How many jobs this process has prepared from shipped bundles."""
    return _prepared[0]


def directory_of_cache():
    """The directories this process unpacked bundles into (tests)."""
    return [d for d, _ in _jobs.values() if os.path.isdir(d)]
