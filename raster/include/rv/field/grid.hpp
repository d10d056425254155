// Grid geometry: a north-up raster of square cells in some CRS.
//
// Conventions (GDAL's): the grid's outer corner is (xmin, ymax); cell (col, row) covers
// [xmin + col*res, xmin + (col+1)*res] x [ymax - (row+1)*res, ymax - row*res] and its centre is
// (xmin + (col + 0.5)*res, ymax - (row + 0.5)*res). Row 0 is the northern row. The matching GDAL
// geotransform is {xmin, res, 0, ymax, 0, -res}.
//
// All values are plain data; every function here is pure and thread-safe.
#pragma once

#include <cstdint>
#include <string>

namespace rv {

// A rectangle of cells inside a grid: columns [col0, col0 + width), rows [row0, row0 + height).
struct Window {
  int64_t col0 = 0;
  int64_t row0 = 0;
  int64_t width = 0;
  int64_t height = 0;

  int64_t cell_count() const { return width * height; }
  bool operator==(const Window&) const = default;
};

struct GridSpec {
  double xmin = 0.0;   // west edge of column 0, CRS units
  double ymax = 0.0;   // north edge of row 0, CRS units
  double res = 1.0;    // cell size, CRS units, > 0 (square cells)
  int64_t width = 0;   // number of columns, > 0
  int64_t height = 0;  // number of rows, > 0
  std::string crs;     // the CRS as WKT (or empty: unknown). Opaque to the core.

  double xmax() const { return xmin + static_cast<double>(width) * res; }
  double ymin() const { return ymax - static_cast<double>(height) * res; }
  int64_t cell_count() const { return width * height; }
  Window full_window() const { return Window{0, 0, width, height}; }

  // Cell centre in absolute CRS coordinates.
  double centre_x(int64_t col) const { return xmin + (static_cast<double>(col) + 0.5) * res; }
  double centre_y(int64_t row) const { return ymax - (static_cast<double>(row) + 0.5) * res; }

  // Cell centre relative to the grid origin (xmin, ymax): the frame the engines compute in.
  // Computing relative to the origin keeps full double precision for large coordinates
  // (e.g. UTM northings of 6e6 m) and is identical whatever window is being computed.
  double local_x(int64_t col) const { return (static_cast<double>(col) + 0.5) * res; }
  double local_y(int64_t row) const { return -(static_cast<double>(row) + 0.5) * res; }

  bool contains(const Window& w) const {
    return w.col0 >= 0 && w.row0 >= 0 && w.width > 0 && w.height > 0 && w.col0 + w.width <= width &&
           w.row0 + w.height <= height;
  }
  bool operator==(const GridSpec&) const = default;
};

// Builds a grid covering [xmin, xmax] x [ymin, ymax] with cell size res. The extent is kept as
// given at its north-west corner and grown to whole cells towards the east and south (a
// remainder below 1e-9 of a cell is treated as rounding noise, not as an extra cell).
// Throws rv::Error(kind = invalid_argument) for a non-finite or empty extent or res <= 0.
GridSpec make_grid(double xmin, double ymin, double xmax, double ymax, double res, std::string crs);

// Like make_grid, but snaps the extent outward to multiples of res (an aligned grid), used for
// extents derived from the seeds' bounding box.
GridSpec make_aligned_grid(double xmin, double ymin, double xmax, double ymax, double res, std::string crs);

}  // namespace rv
