#include "rv/preview.hpp"

#include <cmath>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "atomic_file.hpp"
#include "rv/error.hpp"

namespace rv {

std::array<uint8_t, 3> owner_colour(int32_t owner) {
  if (owner <= 0) return {0, 0, 0};
  // Golden-angle hue steps keep neighbouring codes far apart on the colour wheel; saturation
  // and value alternate so that codes whose hues come close again still differ.
  const double hue = std::fmod(static_cast<double>(owner) * 0.6180339887498949, 1.0) * 180.0;
  const int sat = (owner % 2) ? 200 : 140;
  const int val = (owner / 2 % 2) ? 170 : 240;
  cv::Mat hsv(1, 1, CV_8UC3, cv::Scalar(std::floor(hue), sat, val));
  cv::Mat bgr;
  cv::cvtColor(hsv, bgr, cv::COLOR_HSV2BGR);
  const cv::Vec3b c = bgr.at<cv::Vec3b>(0, 0);
  return {c[0], c[1], c[2]};
}

PreviewInfo write_preview(const std::string& path, const Raster<int32_t>& owners, const BoundaryResult* boundaries,
                          const PreviewOptions& options) {
  if (options.max_side < 16) throw Error(ErrorKind::invalid_argument, "preview size must be at least 16 pixels");
  const int64_t w = owners.width(), h = owners.height();
  PreviewInfo info;
  info.step = std::max<int64_t>(1, (std::max(w, h) + options.max_side - 1) / options.max_side);
  info.width = static_cast<int>((w + info.step - 1) / info.step);
  info.height = static_cast<int>((h + info.step - 1) / info.step);

  std::vector<std::array<uint8_t, 3>> palette;
  auto colour = [&](int32_t o) {
    if (o <= 0) return std::array<uint8_t, 3>{0, 0, 0};
    if (static_cast<size_t>(o) >= palette.size()) {
      const size_t old = palette.size();
      palette.resize(static_cast<size_t>(o) + 1);
      for (size_t k = old; k < palette.size(); ++k) palette[k] = owner_colour(static_cast<int32_t>(k));
    }
    return palette[static_cast<size_t>(o)];
  };
  cv::Mat img(info.height, info.width, CV_8UC3);
  for (int y = 0; y < info.height; ++y) {
    // Nearest sampling: the cell at the centre of the pixel's block of step x step cells.
    const int64_t r = std::min<int64_t>(h - 1, y * info.step + info.step / 2);
    const int32_t* row = owners.row(r);
    auto* out = img.ptr<cv::Vec3b>(y);
    for (int x = 0; x < info.width; ++x) {
      const int64_t c = std::min<int64_t>(w - 1, x * info.step + info.step / 2);
      const auto col = colour(row[c]);
      out[x] = cv::Vec3b(col[0], col[1], col[2]);
    }
  }
  if (boundaries) {
    const GridSpec& g = owners.grid();
    const Window& win = owners.window();
    constexpr int kShift = 4;  // sub-pixel precision of cv::polylines
    const double scale = static_cast<double>(1 << kShift) / static_cast<double>(info.step);
    for (const BoundaryLine& line : boundaries->lines) {
      std::vector<cv::Point> pts;
      pts.reserve(line.vertices.size());
      for (const BoundaryVertex& v : line.vertices) {
        const double px = ((v.p.x - g.xmin) / g.res - static_cast<double>(win.col0)) * scale;
        const double py = ((g.ymax - v.p.y) / g.res - static_cast<double>(win.row0)) * scale;
        pts.emplace_back(static_cast<int>(std::lround(px)), static_cast<int>(std::lround(py)));
      }
      cv::polylines(img, pts, line.closed, cv::Scalar(255, 255, 255), 1, cv::LINE_AA, kShift);
    }
  }
  std::vector<uchar> png;
  if (!cv::imencode(".png", img, png)) throw Error(ErrorKind::io, "cannot encode the preview PNG");
  write_file_atomically(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  return info;
}

}  // namespace rv
