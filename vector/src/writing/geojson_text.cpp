// GeoJSON text as GDAL writes it (writing/geojson_text.hpp). What GDAL 3.6's GeoJSON driver does,
// as observed and checked by the tests: a coordinate goes through OGRFormatDouble with 15
// decimals, fixed notation, which rounds the digits away where they end in a run of zeros or
// nines (taken as the binary value's noise; about one value in 25,000) and then drops trailing
// zeros, keeping one decimal;
// a real property is printed with 17 significant digits ("%.17g") and ".0" added where that has
// neither a point nor an exponent; features are json-c's spaced objects, one per line, joined
// by ",\n".
#include "writing/geojson_text.hpp"

#include <unistd.h>

#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>

#include <ogr_geometry.h>
#include <ogr_p.h>
#include <ogrsf_frmts.h>

#include "common/gdal_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"

namespace rv::writing {
namespace {

// Whether GDAL may round a fixed 15-decimal string further: a run of three or more zeros or
// nines among its last eleven characters. (The strings it changes have runs of four or five
// there, as its rounding looks for; the test checks every run length at every position.)
bool gdal_may_round(const char* s, size_t len) {
  int run = 0;
  char of = 0;
  for (size_t i = len >= 11 ? len - 11 : 0; i < len; ++i) {
    run = (s[i] == '0' || s[i] == '9') && s[i] == of ? run + 1 : 1;
    of = s[i];
    if (run >= 3 && (of == '0' || of == '9')) return true;
  }
  return false;
}

}  // namespace

void append_coordinate(std::string& out, double v) {
  char buf[400];
  if (std::isfinite(v) && std::abs(v) <= 1e50) {
    const std::to_chars_result r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::fixed, 15);
    auto len = static_cast<size_t>(r.ptr - buf);
    if (!gdal_may_round(buf, len)) {
      while (len > 2 && buf[len - 1] == '0' && buf[len - 2] != '.') --len;
      out.append(buf, len);
      return;
    }
  }
  if (std::isfinite(v) && std::abs(v) > 1e50) {
    std::snprintf(buf, sizeof(buf), "%.18g", v);
  } else {
    OGRFormatDouble(buf, static_cast<int>(sizeof(buf)), v, '.', 15, 'f');
  }
  out.append(buf);
}

void append_real(std::string& out, double v) {
  char buf[64];
  const int n = std::snprintf(buf, sizeof(buf), "%.17g", v);
  out.append(buf, static_cast<size_t>(n));
  if (std::strpbrk(buf, ".eEni") == nullptr) out.append(".0");
}

void append_string(std::string& out, const std::string& s) {
  out.push_back('"');
  for (const char c : s) {
    switch (c) {
      case '"':
        out.append("\\\"");
        break;
      case '\\':
        out.append("\\\\");
        break;
      case '\b':
        out.append("\\b");
        break;
      case '\f':
        out.append("\\f");
        break;
      case '\n':
        out.append("\\n");
        break;
      case '\r':
        out.append("\\r");
        break;
      case '\t':
        out.append("\\t");
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char u[8];
          std::snprintf(u, sizeof(u), "\\u%04x", static_cast<unsigned>(static_cast<unsigned char>(c)));
          out.append(u);
        } else {
          out.push_back(c);
        }
    }
  }
  out.push_back('"');
}

GeoJsonText::GeoJsonText(const std::string& layer, const std::string& crs, int threads) : threads_(threads) {
  // The header is the driver's own for an empty layer of that name and CRS.
  static std::atomic<uint64_t> counter{0};
  const std::string path = "/vsimem/rvoronoi-geojson-header-" + std::to_string(::getpid()) + "-" +
                           std::to_string(counter.fetch_add(1)) + ".geojson";
  gdal::ErrorCapture capture;
  {
    GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GeoJSON");
    if (driver == nullptr) throw Error(ErrorKind::unsupported, "GDAL has no GeoJSON driver");
    gdal::DatasetPtr ds(driver->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
    if (!ds) throw Error(ErrorKind::io, "cannot make a GeoJSON header" + capture.suffix());
    gdal::SrsPtr srs;
    if (!crs.empty()) {
      srs = gdal::parse_srs(crs);
      if (!srs) throw Error(ErrorKind::invalid_argument, "cannot parse the output CRS");
    }
    if (ds->CreateLayer(layer.c_str(), srs.get(), wkbUnknown, nullptr) == nullptr)
      throw Error(ErrorKind::io, "cannot make a GeoJSON header" + capture.suffix());
  }
  vsi_l_offset size = 0;
  GByte* bytes = VSIGetMemFileBuffer(path.c_str(), &size, TRUE);
  const std::string text(reinterpret_cast<const char*>(bytes), static_cast<size_t>(size));
  CPLFree(bytes);
  const std::string open = "\"features\": [\n";
  const size_t at = text.find(open);
  if (at == std::string::npos) throw Error(ErrorKind::internal, "GDAL's GeoJSON header has no feature list");
  header_ = text.substr(0, at + open.size());
  end_ = text.substr(at + open.size());  // an empty layer's end: the list closed, the object closed
}

void GeoJsonText::begin_feature() {
  feature_.assign("{ \"type\": \"Feature\", \"properties\": { ");
  first_property_ = true;
}

void GeoJsonText::key(const char* name) {
  if (!first_property_) feature_.append(", ");
  first_property_ = false;
  append_string(feature_, name);
  feature_.append(": ");
}

void GeoJsonText::property(const char* name, int64_t v) {
  key(name);
  feature_.append(std::to_string(v));
}

void GeoJsonText::property(const char* name, double v) {
  key(name);
  append_real(feature_, v);
}

void GeoJsonText::property(const char* name, const std::string& v) {
  key(name);
  append_string(feature_, v);
}

void GeoJsonText::property(const char* name, std::span<const int> list) {
  key(name);
  if (list.empty()) {
    feature_.append("[ ]");
    return;
  }
  feature_.append("[ ");
  for (size_t i = 0; i < list.size(); ++i) {
    if (i > 0) feature_.append(", ");
    feature_.append(std::to_string(list[i]));
  }
  feature_.append(" ]");
}

void GeoJsonText::geometry(const char* type) {
  // The properties closed (an empty object is "{ }"), the geometry opened up to its coordinates.
  feature_.append(first_property_ ? "}, \"geometry\": { \"type\": \"" : " }, \"geometry\": { \"type\": \"");
  feature_.append(type);
  feature_.append("\", \"coordinates\": ");
}

void GeoJsonText::point(Vec2 p) {
  geometry("Point");
  feature_.append("[ ");
  append_coordinate(feature_, p.x);
  feature_.append(", ");
  append_coordinate(feature_, p.y);
  feature_.append(" ] }");
}

void GeoJsonText::coordinates(std::span<const Vec2> points) {
  if (points.empty()) {
    feature_.append("[ ]");
    return;
  }
  // Blocks of points formatted on the threads, joined in order.
  constexpr size_t kBlock = 4096;
  const size_t blocks = (points.size() + kBlock - 1) / kBlock;
  std::vector<std::string> parts(blocks);
  detail::parallel_for(blocks > 1 ? threads_ : 1, static_cast<int64_t>(blocks), [&](int64_t b, int) {
    std::string& s = parts[static_cast<size_t>(b)];
    const size_t i0 = static_cast<size_t>(b) * kBlock, i1 = std::min(points.size(), i0 + kBlock);
    s.reserve((i1 - i0) * 44);
    for (size_t i = i0; i < i1; ++i) {
      s.append(i == 0 ? "[ " : ", [ ");
      append_coordinate(s, points[i].x);
      s.append(", ");
      append_coordinate(s, points[i].y);
      s.append(" ]");
    }
  });
  feature_.append("[ ");
  for (const std::string& s : parts) feature_.append(s);
  feature_.append(" ]");
}

void GeoJsonText::line(std::span<const Vec2> points) {
  geometry("LineString");
  coordinates(points);
  feature_.append(" }");
}

void GeoJsonText::polygons(const OGRGeometry& g) {
  std::vector<const OGRPolygon*> parts;
  const OGRwkbGeometryType type = wkbFlatten(g.getGeometryType());
  if (type == wkbPolygon) {
    parts.push_back(g.toPolygon());
  } else if (type == wkbMultiPolygon) {
    for (const OGRPolygon* p : *g.toMultiPolygon()) parts.push_back(p);
  } else {
    throw Error(ErrorKind::internal, "GeoJSON text: polygons expected");
  }
  geometry(type == wkbPolygon ? "Polygon" : "MultiPolygon");
  if (type == wkbMultiPolygon) feature_.append(parts.empty() ? "[ ]" : "[ ");
  for (size_t k = 0; k < parts.size(); ++k) {
    if (k > 0) feature_.append(", ");
    const OGRPolygon& poly = *parts[k];
    feature_.append("[ ");
    bool first = true;
    for (const OGRLinearRing* ring : poly) {
      if (!first) feature_.append(", ");
      first = false;
      std::vector<Vec2> pts(static_cast<size_t>(ring->getNumPoints()));
      for (int i = 0; i < ring->getNumPoints(); ++i) pts[static_cast<size_t>(i)] = Vec2{ring->getX(i), ring->getY(i)};
      coordinates(pts);
    }
    feature_.append(" ]");
  }
  if (type == wkbMultiPolygon && !parts.empty()) feature_.append(" ]");
  feature_.append(" }");
}

void GeoJsonText::end_feature() {
  feature_.append(" }");
  if (count_ > 0) features_.append(",\n");
  features_.append(feature_);
  ++count_;
}

std::string GeoJsonText::finish() {
  if (count_ == 0) return header_ + end_;
  std::string out;
  out.reserve(header_.size() + features_.size() + 8);
  out.append(header_);
  out.append(features_);
  out.append("\n]\n}\n");
  return out;
}

std::string hidden_temporary(const std::string& path, const std::string& extension) {
  static std::atomic<uint64_t> counter{0};
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : path.substr(0, slash == 0 ? 1 : slash);
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  return (dir == "/" ? "" : dir) + "/." + name + ".tmp-" + std::to_string(::getpid()) + "-" +
         std::to_string(counter.fetch_add(1)) + (extension.empty() ? "" : "." + extension);
}

void write_text_file(const std::string& path, const std::string& text) {
  const std::string temp = hidden_temporary(path, "");
  VSILFILE* f = VSIFOpenL(temp.c_str(), "wb");
  if (f == nullptr) throw Error(ErrorKind::io, "cannot create " + path + ": " + std::strerror(errno));
  const bool written = VSIFWriteL(text.data(), 1, text.size(), f) == text.size();
  const bool closed = VSIFCloseL(f) == 0;
  if (!written || !closed) {
    VSIUnlink(temp.c_str());
    throw Error(ErrorKind::io, "cannot write " + path + ": " + std::strerror(errno));
  }
  if (VSIRename(temp.c_str(), path.c_str()) != 0) {
    VSIUnlink(temp.c_str());
    throw Error(ErrorKind::io, "cannot rename " + temp + " to " + path + ": " + std::strerror(errno));
  }
}

}  // namespace rv::writing
