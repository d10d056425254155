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

#include "rv/deliverables.hpp"
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

// Writes the PNG. `boundaries` may be null (no lines drawn). Throws rv::Error(io) when the file
// cannot be written, rv::Error(invalid_argument) for max_side < 16.
PreviewInfo write_preview(const std::string& path, const Raster<int32_t>& owners, const BoundaryResult* boundaries,
                          const PreviewOptions& options = {});

}  // namespace rv
