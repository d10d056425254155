#include "rv/preview.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/atomic_file.hpp"
#include "rv/field/error.hpp"

namespace rv {

namespace {

cv::Scalar bgr(const std::array<uint8_t, 3>& c) { return cv::Scalar(c[0], c[1], c[2]); }

// Text with a light halo, so that it reads on any owner colour.
void halo_text(cv::Mat& img, const std::string& text, cv::Point at, double scale, const cv::Scalar& ink) {
  cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(255, 255, 255), 3, cv::LINE_AA);
  cv::putText(img, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, ink, 1, cv::LINE_AA);
}

// A round length (1, 2 or 5 times a power of ten) at most `metres`.
double round_length(double metres) {
  const double p = std::pow(10.0, std::floor(std::log10(metres)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= metres) return m * p;
  return p;
}

std::string length_text(double metres) {
  char buf[32];
  if (metres >= 1000.0)
    std::snprintf(buf, sizeof buf, "%g km", metres / 1000.0);
  else
    std::snprintf(buf, sizeof buf, "%g m", metres);
  return buf;
}

std::string area_text(double area, const std::string& units) {
  char buf[48];
  if (units == "m^2" && area >= 1e6)
    std::snprintf(buf, sizeof buf, "%.6g km2", area / 1e6);
  else
    std::snprintf(buf, sizeof buf, "%.6g %s", area, ascii_label(units == "m^2" ? "m2" : units).c_str());
  return buf;
}

// Map pixel of a point in grid coordinates, in cv::polylines' fixed point (kShift bits).
constexpr int kShift = 4;
cv::Point map_point(const GridSpec& g, const Window& win, int64_t step, Vec2 p) {
  const double scale = static_cast<double>(1 << kShift) / static_cast<double>(step);
  const double px = ((p.x - g.xmin) / g.res - static_cast<double>(win.col0)) * scale;
  const double py = ((g.ymax - p.y) / g.res - static_cast<double>(win.row0)) * scale;
  return {static_cast<int>(std::lround(px)), static_cast<int>(std::lround(py))};
}

// A dashed polyline (OpenCV has none): `on` pixels drawn, `off` skipped, along the path.
void dashed(cv::Mat& img, const std::vector<cv::Point>& pts, bool closed, const cv::Scalar& ink, double on,
            double off) {
  const double unit = 1.0 / (1 << kShift);
  double phase = 0.0;
  const size_t n = pts.size();
  for (size_t i = 0; i + 1 < n + (closed ? 1 : 0); ++i) {
    const cv::Point2d a(pts[i].x * unit, pts[i].y * unit), b(pts[(i + 1) % n].x * unit, pts[(i + 1) % n].y * unit);
    const double len = std::hypot(b.x - a.x, b.y - a.y);
    double t = 0.0;
    while (t < len) {
      const double in_dash = std::fmod(phase + t, on + off);
      const double step = in_dash < on ? on - in_dash : on + off - in_dash;
      const double t1 = std::min(len, t + step);
      if (in_dash < on) {
        const cv::Point2d p = a + (b - a) * (t / len), q = a + (b - a) * (t1 / len);
        cv::line(img, cv::Point(cv::saturate_cast<int>(p.x / unit), cv::saturate_cast<int>(p.y / unit)),
                 cv::Point(cv::saturate_cast<int>(q.x / unit), cv::saturate_cast<int>(q.y / unit)), ink, 1, cv::LINE_AA,
                 kShift);
      }
      t = t1;
    }
    phase = std::fmod(phase + len, on + off);
  }
}

// The image: the map, and the legend panel beside it (each owner's swatch, label and sea area;
// land and no owner when the map shows them).
cv::Mat with_legend(const cv::Mat& map, const PreviewLayers& layers, bool any_land, bool any_unowned) {
  const int mw = map.cols, mh = map.rows;
  const size_t owners = layers.owner_labels.size();
  const int shown = static_cast<int>(std::min<size_t>(owners, 24));
  const int rows = 1 + shown + (owners > 24) + any_land + any_unowned;
  constexpr int kPanel = 260, kRow = 20;
  const int ih = std::max(mh, 12 + rows * kRow);
  cv::Mat img(ih, mw + kPanel, CV_8UC3, cv::Scalar(255, 255, 255));
  map.copyTo(img(cv::Rect(0, 0, mw, mh)));
  int y = 8;
  const int x0 = mw + 12;
  cv::putText(img, "Owners", cv::Point(x0, y + 13), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  y += kRow;
  auto swatch_row = [&](const std::array<uint8_t, 3>& c, const std::string& label) {
    cv::rectangle(img, cv::Rect(x0, y + 2, 14, 14), bgr(c), cv::FILLED);
    cv::rectangle(img, cv::Rect(x0, y + 2, 14, 14), cv::Scalar(90, 90, 90), 1);
    cv::putText(img, label, cv::Point(x0 + 20, y + 14), cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
    y += kRow;
  };
  for (int o = 1; o <= shown; ++o) {
    std::string label = ascii_label(layers.owner_labels[static_cast<size_t>(o - 1)]);
    if (label.size() > 22) label = label.substr(0, 21) + "~";
    if (static_cast<size_t>(o) <= layers.owner_areas.size())
      label += "  " + area_text(layers.owner_areas[static_cast<size_t>(o - 1)], layers.area_units);
    swatch_row(owner_colour(o), label);
  }
  if (owners > 24) {
    cv::putText(img, "+ " + std::to_string(owners - 24) + " more", cv::Point(x0 + 20, y + 14), cv::FONT_HERSHEY_SIMPLEX,
                0.42, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    y += kRow;
  }
  if (any_land) swatch_row(kLandColour, "land (seed polygons)");
  if (any_unowned) swatch_row(kNoOwnerColour, "no owner");
  return img;
}

}  // namespace

std::string ascii_label(const std::string& utf8) {
  // Latin-1 Supplement and Latin Extended-A letters -> their base letter.
  static const char* const kLatin1 =  // U+00C0 .. U+00FF
      "AAAAAAACEEEEIIIIDNOOOOOxOUUUUYTs"
      "aaaaaaaceeeeiiiidnooooo/ouuuuyty";
  std::string out;
  for (size_t i = 0; i < utf8.size();) {
    const auto c = static_cast<unsigned char>(utf8[i]);
    if (c < 0x80) {
      out += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
      ++i;
      continue;
    }
    int len = (c >> 5) == 0x6 ? 2 : (c >> 4) == 0xe ? 3 : (c >> 3) == 0x1e ? 4 : 1;
    if (i + static_cast<size_t>(len) > utf8.size()) len = 1;
    uint32_t cp = 0;
    if (len == 2) cp = ((c & 0x1fu) << 6) | (static_cast<unsigned char>(utf8[i + 1]) & 0x3fu);
    if (cp >= 0xc0 && cp <= 0xff)
      out += kLatin1[cp - 0xc0];
    else if (cp >= 0x100 && cp <= 0x17f)
      out +=
          "AaAaAaCcCcCcCcDdDdEeEeEeEeEeGgGgGgGgHhHhIiIiIiIiIiJjJjKkkLlLlLlLlLlNnNnNnnNnOoOoOoOoRrRrRrSsSsSsSsTtTtTtUuUu"
          "UuUuUuUuWwYyYZzZzZzs"[cp - 0x100];
    else
      out += '?';
    i += static_cast<size_t>(len);
  }
  return out;
}

std::array<uint8_t, 3> owner_colour(int32_t owner) {
  if (owner <= 0) return kNoOwnerColour;
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

std::string colour_hex(const std::array<uint8_t, 3>& bgr) {
  char text[8];
  std::snprintf(text, sizeof text, "#%02x%02x%02x", bgr[2], bgr[1], bgr[0]);
  return text;
}

PreviewSample::PreviewSample(const GridSpec& grid, const Window& window, const PreviewOptions& options)
    : grid_(grid), window_(window) {
  if (options.max_side < 16) throw Error(ErrorKind::invalid_argument, "preview size must be at least 16 pixels");
  const int64_t w = window.width, h = window.height;
  info_.step = std::max<int64_t>(1, (std::max(w, h) + options.max_side - 1) / options.max_side);
  info_.width = static_cast<int>((w + info_.step - 1) / info_.step);
  info_.height = static_cast<int>((h + info_.step - 1) / info_.step);
  codes_.assign(static_cast<size_t>(info_.width) * static_cast<size_t>(info_.height), 0);
  land_.assign(codes_.size(), 0);
}

void PreviewSample::add_rows(const int32_t* values, int64_t row0, int64_t rows, const SiteCodes* codes,
                             const float* distances) {
  const int64_t w = window_.width, h = window_.height, step = info_.step;
  for (int y = 0; y < info_.height; ++y) {
    // Nearest sampling: the cell at the centre of the pixel's block of step x step cells.
    const int64_t r = std::min<int64_t>(h - 1, y * step + step / 2);
    if (r < row0 || r >= row0 + rows) continue;
    const int32_t* row = values + (r - row0) * w;
    const float* drow = distances ? distances + (r - row0) * w : nullptr;
    int32_t* out = codes_.data() + static_cast<size_t>(y) * static_cast<size_t>(info_.width);
    uint8_t* land = land_.data() + static_cast<size_t>(y) * static_cast<size_t>(info_.width);
    for (int x = 0; x < info_.width; ++x) {
      const int64_t c = std::min<int64_t>(w - 1, x * step + step / 2);
      out[x] = codes == nullptr ? row[c] : codes->code(row[c]);
      land[x] = drow != nullptr && drow[c] == 0.0f;
    }
  }
}

PreviewInfo write_preview(const std::string& path, const PreviewSample& sample, const PreviewLayers& layers) {
  PreviewInfo info = sample.info_;
  const int mw = info.width, mh = info.height;
  // The map's cells: sea in owner colours, land in sand, no owner near-white.
  std::vector<std::array<uint8_t, 3>> palette;
  auto colour = [&](int32_t o) {
    if (static_cast<size_t>(o) >= palette.size()) {
      const size_t old = palette.size();
      palette.resize(static_cast<size_t>(o) + 1);
      for (size_t k = old; k < palette.size(); ++k) palette[k] = owner_colour(static_cast<int32_t>(k));
    }
    return palette[static_cast<size_t>(o)];
  };
  const size_t owners = layers.owner_labels.size();
  std::vector<double> sum_x(owners + 1, 0.0), sum_y(owners + 1, 0.0), count(owners + 1, 0.0);
  bool any_land = false, any_unowned = false;
  cv::Mat map(mh, mw, CV_8UC3);
  for (int y = 0; y < mh; ++y) {
    const size_t at = static_cast<size_t>(y) * static_cast<size_t>(mw);
    auto* out = map.ptr<cv::Vec3b>(y);
    for (int x = 0; x < mw; ++x) {
      const int32_t o = std::max<int32_t>(0, sample.codes_[at + static_cast<size_t>(x)]);
      const bool land = sample.land_[at + static_cast<size_t>(x)] != 0;
      const auto c = land ? kLandColour : colour(o);
      out[x] = cv::Vec3b(c[0], c[1], c[2]);
      any_land = any_land || land;
      any_unowned = any_unowned || o == 0;
      if (o > 0 && static_cast<size_t>(o) <= owners) {
        sum_x[static_cast<size_t>(o)] += x;
        sum_y[static_cast<size_t>(o)] += y;
        count[static_cast<size_t>(o)] += 1.0;
      }
    }
  }
  const GridSpec& g = sample.grid_;
  const Window& win = sample.window_;
  auto polyline = [&](const auto& vertices) {
    std::vector<cv::Point> pts;
    pts.reserve(vertices.size());
    for (const auto& v : vertices) pts.push_back(map_point(g, win, info.step, v.p));
    return pts;
  };
  if (layers.boundaries)
    for (const BoundaryLine& line : layers.boundaries->lines)
      cv::polylines(map, polyline(line.vertices), line.closed, cv::Scalar(45, 45, 45), 1, cv::LINE_AA, kShift);
  if (layers.limits)
    for (const LimitLine& line : layers.limits->lines)
      dashed(map, polyline(line.vertices), line.closed, cv::Scalar(110, 40, 20), 6.0, 4.0);
  const double text = std::clamp(std::min(mw, mh) / 900.0, 0.4, 0.8);
  // Each owner's label at the cell of its area nearest to the area's centroid.
  if (mw >= 200 && mh >= 100) {
    for (size_t o = 1; o <= owners; ++o) {
      if (count[o] == 0.0) continue;
      const double cx = sum_x[o] / count[o], cy = sum_y[o] / count[o];
      cv::Point best(-1, -1);
      double best_d = 1e300;
      for (int y = 0; y < mh; y += std::max(1, mh / 200))
        for (int x = 0; x < mw; x += std::max(1, mw / 200)) {
          if (sample.codes_[static_cast<size_t>(y) * static_cast<size_t>(mw) + static_cast<size_t>(x)] !=
              static_cast<int32_t>(o))
            continue;
          const double d = (x - cx) * (x - cx) + (y - cy) * (y - cy);
          if (d < best_d) best_d = d, best = {x, y};
        }
      if (best.x < 0) continue;
      const std::string label = ascii_label(layers.owner_labels[o - 1]);
      int base = 0;
      const cv::Size size = cv::getTextSize(label, cv::FONT_HERSHEY_SIMPLEX, text, 1, &base);
      const cv::Point at(std::clamp(best.x - size.width / 2, 2, std::max(2, mw - size.width - 2)),
                         std::clamp(best.y + size.height / 2, size.height + 2, std::max(size.height + 2, mh - 2)));
      halo_text(map, label, at, text, cv::Scalar(20, 20, 20));
    }
  }
  // The scale bar, bottom left, for the length of the map's centre.
  if (layers.metres_per_unit > 0.0 && mw >= 80 && mh >= 40) {
    const double metres_per_pixel = g.res * static_cast<double>(info.step) * layers.metres_per_unit;
    const double metres = round_length(metres_per_pixel * mw / 5.0);
    const int px = std::max(1, static_cast<int>(std::lround(metres / metres_per_pixel)));
    const cv::Point a(10, mh - 12), b(10 + px, mh - 12);
    cv::rectangle(map, a + cv::Point(-2, -4), b + cv::Point(2, 3), cv::Scalar(255, 255, 255), cv::FILLED);
    cv::rectangle(map, a + cv::Point(0, -2), b + cv::Point(0, 1), cv::Scalar(20, 20, 20), cv::FILLED);
    halo_text(map, length_text(metres), a + cv::Point(0, -8), 0.45, cv::Scalar(20, 20, 20));
  }
  const cv::Mat img = with_legend(map, layers, any_land, any_unowned);
  info.image_width = img.cols;
  info.image_height = img.rows;
  std::vector<uchar> png;
  if (!cv::imencode(".png", img, png)) throw Error(ErrorKind::io, "cannot encode the preview PNG");
  write_file_atomically(path, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  return info;
}

PreviewInfo write_preview(const std::string& path, const Raster<int32_t>& owners, const PreviewLayers& layers,
                          const PreviewOptions& options) {
  PreviewSample sample(owners.grid(), owners.window(), options);
  sample.add_rows(owners.data(), 0, owners.height());
  return write_preview(path, sample, layers);
}

}  // namespace rv
