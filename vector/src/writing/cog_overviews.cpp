// Overview levels of a COG from streamed rows. See cog_overviews.hpp for the contract.
//
// The windows, weights and order of the sums are GDAL's overview builder's (gcore/overview.cpp,
// its nearest and average resamplers, each level from the one before): the overviews are meant to
// be the ones the COG driver made before the COGs were assembled here, to the bit, and a
// different order of the same sums would round differently. For the same reason this file is
// compiled without floating-point contraction (vector/CMakeLists.txt): a fused multiply-add
// rounds once where GDAL's build rounds twice.
#include "writing/cog_overviews.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

#include "rv/field/error.hpp"

namespace rv::detail {

std::vector<LevelSize> overview_sizes(int64_t width, int64_t height, int64_t tile) {
  std::vector<LevelSize> out;
  while (width > tile || height > tile) {
    width = std::max<int64_t>(1, width / 2);
    height = std::max<int64_t>(1, height / 2);
    out.push_back({width, height});
  }
  return out;
}

namespace {

// The source cells one overview cell reads along one axis: [first, end), the first's and the
// last's weights (average; nearest reads `first` alone).
// The most source rows one overview row reads: a scale is at most 3 (an odd source of 3 rows),
// so a window spans at most 4 rows.
constexpr int64_t kMaxWindow = 4;

struct Span {
  int64_t first = 0;
  int64_t end = 0;
  double first_weight = 1.0;
  double last_weight = 1.0;
};

Span nearest_span(int64_t i, double scale) {
  const auto first = static_cast<int64_t>(0.5 + static_cast<double>(i) * scale);
  return {first, first + 1, 1.0, 1.0};
}

// GDAL's average window (cog_overviews.hpp): the epsilons keep a boundary that lands on a whole
// cell in floating point from reaching into the next one.
Span average_span(int64_t i, double scale, int64_t source_size) {
  const double from = static_cast<double>(i) * scale;
  const double to = static_cast<double>(i + 1) * scale;
  Span s;
  s.first = static_cast<int64_t>(from + 1e-8);
  s.end = static_cast<int64_t>(std::ceil(to - 1e-8));
  if (s.end == s.first) ++s.end;
  s.end = std::min(s.end, source_size);
  s.first_weight = s.end == s.first + 1 ? 1.0 : 1.0 - (from - static_cast<double>(s.first));
  s.last_weight = 1.0 - (static_cast<double>(s.end) - to);
  return s;
}

}  // namespace

template <class T>
struct OverviewPyramid<T>::Level {
  Resampling resampling;
  int64_t source_width, source_height, width, height;
  double scale_x, scale_y;
  std::vector<Span> columns;  // per cell of a row
  // The source rows a row reads (average): row r in slot r % ring_rows.
  std::vector<T> ring;
  int64_t ring_rows = 1;
  int64_t next_row = 0;  // the next row of this level to make
  std::vector<T> band;   // rows [band_first, band_first + band_count) of this level
  int64_t band_first = 0, band_count = 0;
  // Average's nodata test and the value an average equal to nodata becomes (GDAL's).
  T nodata{};
  bool nodata_is_nan = false;
  T replacement{};

  Span row_span(int64_t j) const {
    return resampling == Resampling::nearest ? nearest_span(j, scale_y) : average_span(j, scale_y, source_height);
  }

  // GDAL's nodata mask: NaN for a NaN nodata, else equal within its tolerance (ARE_REAL_EQUAL).
  bool valid(T v) const {
    if constexpr (std::is_floating_point_v<T>) {
      if (nodata_is_nan) return !std::isnan(v);
      return !(v == nodata || std::abs(v - nodata) < std::numeric_limits<float>::epsilon() * std::abs(v + nodata) * 2);
    } else {
      return v != nodata;
    }
  }

  void make_nearest_row(const T* source, T* out) const {
    for (int64_t i = 0; i < width; ++i) out[i] = source[columns[static_cast<size_t>(i)].first];
  }

  // Row j from the source rows of `rows` (in the ring).
  void make_average_row(const Span& rows, T* out) const {
    const T* src[kMaxWindow];
    for (int64_t y = rows.first; y < rows.end; ++y) src[y - rows.first] = ring.data() + (y % ring_rows) * source_width;
    // Two whole rows (an even source height): the 2 x 2 blocks take the shorter path below.
    const bool two_rows = rows.end == rows.first + 2 && rows.first_weight == 1.0 && rows.last_weight == 1.0;
    for (int64_t i = 0; i < width; ++i) {
      const Span& c = columns[static_cast<size_t>(i)];
      out[i] = two_rows && c.end == c.first + 2 && c.first_weight == 1.0 && c.last_weight == 1.0
                   ? average_block(src[0] + c.first, src[1] + c.first)
                   : average_window(rows, c, src);
    }
  }

  // One cell from the source cells of rows x c (GDAL's sums, cog_overviews.hpp).
  T average_window(const Span& rows, const Span& c, const T* const* src) const {
    double total = 0.0, total_weight = 0.0;
    bool any = false;
    for (int64_t y = rows.first; y < rows.end; ++y) {
      const T* row = src[y - rows.first];
      double line = 0.0, line_weight = 0.0;
      for (int64_t x = c.first; x < c.end; ++x) {
        const T v = row[x];
        if (!valid(v)) continue;
        any = true;
        const double w = x == c.first ? c.first_weight : x + 1 == c.end ? c.last_weight : 1.0;
        // GDAL adds the middle cells unweighted; times 1.0 is exact, so the sums are the same.
        line += static_cast<double>(v) * w;
        line_weight += w;
      }
      const double wy = y == rows.first ? rows.first_weight : y + 1 == rows.end ? rows.last_weight : 1.0;
      total += line * wy;
      total_weight += line_weight * wy;
    }
    return any ? rounded(total / total_weight) : nodata;
  }

  // average_window() of a 2 x 2 block of whole cells, with the same operations in the same
  // order (every weight 1.0: multiplying by it changes no bit, adding to 0.0 is kept as it is).
  T average_block(const T* top, const T* bottom) const {
    double line0 = 0.0, weight0 = 0.0, line1 = 0.0, weight1 = 0.0;
    auto add = [this](T v, double& line, double& weight) {
      if (!valid(v)) return;
      line += static_cast<double>(v);
      weight += 1.0;
    };
    add(top[0], line0, weight0);
    add(top[1], line0, weight0);
    add(bottom[0], line1, weight1);
    add(bottom[1], line1, weight1);
    if (weight0 == 0.0 && weight1 == 0.0) return nodata;
    double total = 0.0, total_weight = 0.0;
    total += line0;
    total += line1;
    total_weight += weight0;
    total_weight += weight1;
    return rounded(total / total_weight);
  }

  // An average as a cell: never the nodata value (GDAL's replacement).
  T rounded(double average) const {
    const auto v = static_cast<T>(average);
    return v == nodata ? replacement : v;
  }
};

template <class T>
OverviewPyramid<T>::OverviewPyramid(int64_t width, int64_t height, int64_t band_rows, Resampling resampling,
                                    double nodata, BandSink sink)
    : width_(width), height_(height), band_rows_(band_rows), sink_(std::move(sink)) {
  if (resampling == Resampling::average && !std::is_floating_point_v<T>)
    throw Error(ErrorKind::invalid_argument, "overviews: average resampling needs a Float32 raster");
  sizes_ = overview_sizes(width, height, band_rows);
  int64_t source_w = width, source_h = height;
  for (const LevelSize& size : sizes_) {
    auto l = std::make_unique<Level>();
    l->resampling = resampling;
    l->source_width = source_w;
    l->source_height = source_h;
    l->width = size.width;
    l->height = size.height;
    l->scale_x = static_cast<double>(source_w) / static_cast<double>(size.width);
    l->scale_y = static_cast<double>(source_h) / static_cast<double>(size.height);
    for (int64_t i = 0; i < size.width; ++i)
      l->columns.push_back(resampling == Resampling::nearest ? nearest_span(i, l->scale_x)
                                                             : average_span(i, l->scale_x, source_w));
    if (resampling == Resampling::average) {
      // Enough slots for the most rows one row reads; every row's window starts after the last
      // one's start, so the rows still needed always fit.
      for (int64_t j = 0; j < size.height; ++j) {
        const Span s = l->row_span(j);
        l->ring_rows = std::max(l->ring_rows, s.end - s.first);
      }
      if (l->ring_rows > kMaxWindow) throw Error(ErrorKind::internal, "overviews: a row reads too many source rows");
      l->ring.resize(static_cast<size_t>(l->ring_rows * source_w));
    }
    l->band.resize(static_cast<size_t>(std::min(band_rows, size.height) * size.width));
    l->nodata = static_cast<T>(nodata);
    if constexpr (std::is_floating_point_v<T>) {
      l->nodata_is_nan = std::isnan(nodata);
      const float nd = static_cast<float>(nodata);
      l->replacement = nd == FLT_MAX ? std::nextafter(nd, 0.0f) : std::nextafter(nd, FLT_MAX);
    }
    levels_.push_back(std::move(l));
    source_w = size.width;
    source_h = size.height;
  }
}

template <class T>
OverviewPyramid<T>::~OverviewPyramid() = default;

template <class T>
void OverviewPyramid<T>::add_rows(const T* rows, int64_t count) {
  if (count < 0 || count > height_ - rows_in_)
    throw Error(ErrorKind::invalid_argument, "overviews: more rows than the raster has");
  for (int64_t r = 0; r < count; ++r, ++rows_in_)
    if (!levels_.empty()) feed(0, rows + r * width_, rows_in_);
}

template <class T>
bool OverviewPyramid<T>::complete() const {
  return rows_in_ == height_ &&
         std::all_of(levels_.begin(), levels_.end(), [](const auto& l) { return l->next_row == l->height; });
}

// Source row `index` of level `level`: makes the level's rows that it completes, hands each to
// the next level, and the level's bands to the sink.
template <class T>
void OverviewPyramid<T>::feed(size_t level, const T* row, int64_t index) {
  Level& l = *levels_[level];
  if (l.resampling == Resampling::average)
    std::memcpy(l.ring.data() + (index % l.ring_rows) * l.source_width, row,
                static_cast<size_t>(l.source_width) * sizeof(T));
  while (l.next_row < l.height) {
    const Span rows = l.row_span(l.next_row);
    if (rows.end - 1 != index) break;  // its last row is still to come (or was not this one)
    T* out = l.band.data() + l.band_count * l.width;
    if (l.resampling == Resampling::nearest)
      l.make_nearest_row(row, out);
    else
      l.make_average_row(rows, out);
    ++l.band_count;
    ++l.next_row;
    if (level + 1 < levels_.size()) feed(level + 1, out, l.next_row - 1);
    if (l.band_count == band_rows_ || l.next_row == l.height) {
      sink_(static_cast<int>(level), l.band.data(), l.band_first, l.band_count, l.width);
      l.band_first += l.band_count;
      l.band_count = 0;
    }
  }
}

template class OverviewPyramid<int32_t>;
template class OverviewPyramid<float>;

}  // namespace rv::detail
