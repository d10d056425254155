// The quicklook: a PNG of the ownership raster in distinct colours with the boundary lines drawn
// over it, rendered with OpenCV (core, imgproc, imgcodecs). Lives in the service layer because
// the core stays free of imaging libraries; OpenCV types stay behind this header.
//
// Colours: owner k gets owner_colour(k), a deterministic palette (hues stepped by the golden
// angle, alternating saturation and value), so the same owner code has the same colour in
// every preview. Cells without owner (0) are black. Boundary lines are white, 1 px, antialiased.
// Rasters larger than max_side on their long side are downscaled by an integer step with
// nearest-neighbour sampling (categories are never blended).
//
// Thread safety: reentrant. The file is written atomically (temporary name, then rename).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "rv/deliverables.hpp"
#include "rv/outputs.hpp"
#include "rv/raster.hpp"

namespace rv {

struct PreviewOptions {
  int max_side = 2000;  // pixels, >= 16
};

struct PreviewInfo {
  int width = 0;  // pixels
  int height = 0;
  int64_t step = 1;  // cells per pixel along each axis
};

// Blue, green, red of owner `owner` (> 0); {0, 0, 0} for 0.
std::array<uint8_t, 3> owner_colour(int32_t owner);

// The cells a preview shows, collected as rows of owner codes go by (a streamed job never holds
// the whole raster): per pixel, the cell at the centre of its block of step x step cells.
// Throws rv::Error(invalid_argument) for max_side < 16.
class PreviewSample {
 public:
  PreviewSample(const GridSpec& grid, const Window& window, const PreviewOptions& options = {});
  // Rows [row0, row0 + rows) of the window (window-relative, in order, whole rows): values[i]
  // is the owner code, or with `codes` a site index (kNoSite: no owner) that codes turns into one.
  void add_rows(const int32_t* values, int64_t row0, int64_t rows, const SiteCodes* codes = nullptr);
  const PreviewInfo& info() const { return info_; }

 private:
  friend PreviewInfo write_preview(const std::string&, const PreviewSample&, const BoundaryResult*);
  GridSpec grid_;
  Window window_;
  PreviewInfo info_;
  std::vector<int32_t> codes_;  // info_.height x info_.width
};

// Writes the PNG. `boundaries` may be null (no lines drawn). Throws rv::Error(io) when the file
// cannot be written.
PreviewInfo write_preview(const std::string& path, const PreviewSample& sample, const BoundaryResult* boundaries);
// The same from a whole owner raster. Throws rv::Error(invalid_argument) for max_side < 16.
PreviewInfo write_preview(const std::string& path, const Raster<int32_t>& owners, const BoundaryResult* boundaries,
                          const PreviewOptions& options = {});

}  // namespace rv
