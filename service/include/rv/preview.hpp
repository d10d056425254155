// The quicklook: a PNG map of the ownership raster for people, rendered with OpenCV (core,
// imgproc, imgcodecs). Lives in the service layer because the core stays free of imaging
// libraries; OpenCV types stay behind this header.
//
// What it shows, left to right: the map, one pixel per cell (rasters larger than max_side on
// their long side are downscaled by an integer step, nearest-neighbour: categories are never
// blended), and a legend panel beside it.
//   - sea: each owner's cells in owner_colour(k), a deterministic palette (hues stepped by the
//     golden angle, alternating saturation and value), so an owner code has the same colour in
//     every preview; land: the cells inside the seed polygons (distance 0), in one sand colour;
//     cells without owner (beyond a max distance): near-white;
//   - boundary lines dark, limit lines dashed navy, 1 px, antialiased;
//   - each owner's label on the map at the cell of its area nearest to the area's centroid, with a
//     halo (maps of 200 px or more across);
//   - a scale bar (a round length near a fifth of the map's width, at the map's centre: along
//     the parallel on the ellipsoid for geographic grids, CRS units times their length in metres
//     for projected ones); none when the grid has no CRS;
//   - the legend: each owner's colour, label and (when regions were made) sea area, up to 24
//     owners, then how many more; land and no-owner swatches when the map shows them.
// Text is drawn with OpenCV's Hershey font, ASCII only: Latin letters with diacritics lose them
// (Ø -> O), anything else shows as '?'. Labels come from uploads; they are only ever drawn as
// pixels.
//
// Thread safety: reentrant. The file is written atomically (temporary name, then rename).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "rv/engine/outputs.hpp"
#include "rv/field/raster.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"

namespace rv {

struct PreviewOptions {
  int max_side = 2000;  // pixels, >= 16
};

struct PreviewInfo {
  int width = 0;  // pixels of the map (the image is wider by the legend, and may be taller)
  int height = 0;
  int64_t step = 1;                       // cells per pixel along each axis
  int image_width = 0, image_height = 0;  // the whole PNG
};

// What the quicklook draws besides the cells. Pointers may be null (nothing drawn).
struct PreviewLayers {
  const BoundaryResult* boundaries = nullptr;
  const LimitResult* limits = nullptr;
  std::vector<std::string> owner_labels;  // code order (1..K): the legend and the map's labels
  std::vector<double> owner_areas;        // sea area per owner, code order; empty = not known
  std::string area_units;                 // e.g. "m^2", "nmi^2" (areas above 1e6 m^2 shown in km^2)
  // Ground metres per CRS unit along x at the map's centre (the scale bar); 0 = no scale bar.
  double metres_per_unit = 0.0;
};

// Blue, green, red of the land (cells inside seed polygons) and of cells without owner.
inline constexpr std::array<uint8_t, 3> kLandColour{170, 205, 222};
inline constexpr std::array<uint8_t, 3> kNoOwnerColour{248, 248, 248};

// Blue, green, red of owner `owner` (> 0); kNoOwnerColour for 0. The report lists it per owner
// (seeds.owners[].colour) so that every picture of a job (this quicklook, the map page) shows an
// owner in the same colour.
std::array<uint8_t, 3> owner_colour(int32_t owner);

// "#rrggbb" of a blue, green, red colour.
std::string colour_hex(const std::array<uint8_t, 3>& bgr);

// The cells a preview shows, collected as rows of owner codes go by (a streamed job never holds
// the whole raster): per pixel, the cell at the centre of its block of step x step cells.
// Throws rv::Error(invalid_argument) for max_side < 16.
class PreviewSample {
 public:
  PreviewSample(const GridSpec& grid, const Window& window, const PreviewOptions& options = {});
  // Rows [row0, row0 + rows) of the window (window-relative, in order, whole rows): values[i]
  // is the owner code, or with `codes` a site index (kNoSite: no owner) that codes turns into one;
  // `distances` (may be null): the cells' distances, 0 marking land (inside a seed polygon).
  void add_rows(const int32_t* values, int64_t row0, int64_t rows, const SiteCodes* codes = nullptr,
                const float* distances = nullptr);
  const PreviewInfo& info() const { return info_; }

 private:
  friend PreviewInfo write_preview(const std::string&, const PreviewSample&, const PreviewLayers&);
  GridSpec grid_;
  Window window_;
  PreviewInfo info_;
  std::vector<int32_t> codes_;  // info_.height x info_.width
  std::vector<uint8_t> land_;   // the same, 1 where the sampled cell is land
};

// Writes the PNG. Throws rv::Error(io) when the file cannot be written.
PreviewInfo write_preview(const std::string& path, const PreviewSample& sample, const PreviewLayers& layers);
// The same from a whole owner raster (no land). Throws rv::Error(invalid_argument) for max_side < 16.
PreviewInfo write_preview(const std::string& path, const Raster<int32_t>& owners, const PreviewLayers& layers,
                          const PreviewOptions& options = {});

// The text the Hershey font can draw: ASCII, Latin letters with diacritics without them, '?' for
// the rest (UTF-8 in).
std::string ascii_label(const std::string& utf8);

}  // namespace rv
