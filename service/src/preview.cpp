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

PreviewSample::PreviewSample(const GridSpec& grid, const Window& window, const PreviewOptions& options)
    : grid_(grid), window_(window) {
  if (options.max_side < 16) throw Error(ErrorKind::invalid_argument, "preview size must be at least 16 pixels");
  const int64_t w = window.width, h = window.height;
  info_.step = std::max<int64_t>(1, (std::max(w, h) + options.max_side - 1) / options.max_side);
  info_.width = static_cast<int>((w + info_.step - 1) / info_.step);
  info_.height = static_cast<int>((h + info_.step - 1) / info_.step);
  codes_.assign(static_cast<size_t>(info_.width) * static_cast<size_t>(info_.height), 0);
}

void PreviewSample::add_rows(const int32_t* values, int64_t row0, int64_t rows, const SiteCodes* codes) {
  const int64_t w = window_.width, h = window_.height, step = info_.step;
  for (int y = 0; y < info_.height; ++y) {
    // Nearest sampling: the cell at the centre of the pixel's block of step x step cells.
    const int64_t r = std::min<int64_t>(h - 1, y * step + step / 2);
    if (r < row0 || r >= row0 + rows) continue;
    const int32_t* row = values + (r - row0) * w;
    int32_t* out = codes_.data() + static_cast<size_t>(y) * static_cast<size_t>(info_.width);
    for (int x = 0; x < info_.width; ++x) {
      const int32_t v = row[std::min<int64_t>(w - 1, x * step + step / 2)];
      out[x] = codes == nullptr ? v : codes->code(v);
    }
  }
}

PreviewInfo write_preview(const std::string& path, const PreviewSample& sample, const BoundaryResult* boundaries) {
  const PreviewInfo& info = sample.info_;
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
    const int32_t* row = sample.codes_.data() + static_cast<size_t>(y) * static_cast<size_t>(info.width);
    auto* out = img.ptr<cv::Vec3b>(y);
    for (int x = 0; x < info.width; ++x) {
      const auto col = colour(row[x]);
      out[x] = cv::Vec3b(col[0], col[1], col[2]);
    }
  }
  if (boundaries) {
    const GridSpec& g = sample.grid_;
    const Window& win = sample.window_;
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

PreviewInfo write_preview(const std::string& path, const Raster<int32_t>& owners, const BoundaryResult* boundaries,
                          const PreviewOptions& options) {
  PreviewSample sample(owners.grid(), owners.window(), options);
  sample.add_rows(owners.data(), 0, owners.height());
  return write_preview(path, sample, boundaries);
}

}  // namespace rv
