"""The xarray.Dataset of a computation: arrays on cell-centre coordinates, georeferenced the CF way.

- `x`, `y`: cell centres in the grid's CRS (y descending: row 0 is the north edge).
- `spatial_ref`: the CF grid mapping variable (`crs_wkt`, GDAL's `spatial_ref` and
  `GeoTransform`), which rioxarray and GDAL's netCDF and Zarr drivers read; every data variable
  names it in `grid_mapping`.
- `owner`: owner codes 1..K, 0 where no seed is within reach; the owner table as CF `flag_values`
  / `flag_meanings` (labels with blanks made underscores, as CF requires words) and, exactly as
  read, `owner_labels` (JSON text); `_FillValue` 0 in its encoding.
- `distance`: distance to the nearest seed in the job's units (`units`), -1 where none
  (`_FillValue` -1 in its encoding).
- `nearest_feature`: 1-based position of the nearest seed feature in the input, 0 = none.
- `via` (with barriers): the last barrier vertex on each cell's path by sea, 0 = none.
- Dataset attributes: `rvoronoi_report` (the report as JSON text), `metric`, `distance_units`.
"""
import json
import re

import numpy as np
import xarray as xr


def _flag_meanings(labels):
    words = []
    for label in labels:
        w = re.sub(r"\s+", "_", label.strip()) or "_"
        words.append(w)
    return " ".join(words)


def coordinates(grid, window=None):
    """x and y of the cell centres of `window` (row0, col0, rows, cols) or of the whole grid."""
    row0, col0, rows, cols = window or (0, 0, grid["height"], grid["width"])
    res = grid["resolution"]
    x = grid["xmin"] + (np.arange(col0, col0 + cols, dtype=np.float64) + 0.5) * res
    y = grid["ymax"] - (np.arange(row0, row0 + rows, dtype=np.float64) + 0.5) * res
    return x, y


def spatial_ref(grid, window=None):
    row0, col0, _, _ = window or (0, 0, 0, 0)
    res = grid["resolution"]
    west = grid["xmin"] + col0 * res
    north = grid["ymax"] - row0 * res
    wkt = grid["crs_wkt"]
    attrs = {"GeoTransform": "%r %r 0 %r 0 %r" % (west, res, north, -res)}
    if wkt:
        attrs["crs_wkt"] = wkt
        attrs["spatial_ref"] = wkt
    return xr.DataArray(np.int32(0), attrs=attrs)


def dataset(arrays, grid, owners, unit, metric, report, window=None):
    """`arrays`: product -> 2-D array (NumPy or Dask) over `window` or the whole grid."""
    x, y = coordinates(grid, window)
    coords = {"y": ("y", y), "x": ("x", x), "spatial_ref": spatial_ref(grid, window)}
    data = {}
    if "ownership" in arrays:
        owner = xr.DataArray(arrays["ownership"], dims=("y", "x"), attrs={
            "long_name": "owner of the nearest seed",
            "flag_values": np.arange(1, len(owners) + 1, dtype=np.int32),
            "flag_meanings": _flag_meanings(owners),
            "owner_labels": json.dumps(list(owners), ensure_ascii=False),
            "grid_mapping": "spatial_ref",
        })
        owner.encoding["_FillValue"] = np.int32(0)
        data["owner"] = owner
    if "distance" in arrays:
        distance = xr.DataArray(arrays["distance"], dims=("y", "x"), attrs={
            "long_name": "distance to the nearest seed",
            "units": unit,
            "grid_mapping": "spatial_ref",
        })
        distance.encoding["_FillValue"] = np.float32(-1.0)
        data["distance"] = distance
    if "nearest_feature" in arrays:
        feature = xr.DataArray(arrays["nearest_feature"], dims=("y", "x"), attrs={
            "long_name": "1-based position of the nearest seed feature in the input",
            "grid_mapping": "spatial_ref",
        })
        feature.encoding["_FillValue"] = np.int32(0)
        data["nearest_feature"] = feature
    if "via" in arrays:
        via = xr.DataArray(arrays["via"], dims=("y", "x"), attrs={
            "long_name": "number of the last barrier vertex on the path by sea (0 = the seed seen directly, "
                         "or none reached); the report's sea.via_vertices gives each number's position",
            "grid_mapping": "spatial_ref",
        })
        via.encoding["_FillValue"] = np.int32(0)
        data["via"] = via
    ds = xr.Dataset(data, coords=coords)
    ds.x.attrs.update({"axis": "X", "long_name": "x coordinate of the cell centre"})
    ds.y.attrs.update({"axis": "Y", "long_name": "y coordinate of the cell centre"})
    ds.attrs.update({"rvoronoi_report": report, "metric": metric, "distance_units": unit,
                     "Conventions": "CF-1.8"})
    return ds
