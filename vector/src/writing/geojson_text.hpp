// GeoJSON FeatureCollections as GDAL's GeoJSON driver writes them, byte for byte (Debian's GDAL
// 3.6: checked against it by tests/vector/writing/test_geojson_text.cpp), without OGR features:
// writing a coast's lines through OGR spends most of its time in the C library's decimal
// formatting, one coordinate at a time, through a string stream each. Here a coordinate is
// formatted with std::to_chars (fixed, 15 decimals, trailing zeros dropped) and handed to GDAL's
// own formatter only where that one may round the digits further (a run of three zeros or nines
// near the end: about one value in fifty); lines are formatted on several threads, in blocks of
// vertices.
// The header (the layer's name and CRS member) is GDAL's own: an empty layer written by the
// driver. Internal to rv_vector.
// Thread safety: a GeoJsonText is used by one thread (its line coordinates use `threads`); the
// functions are pure.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "rv/field/seeds.hpp"

class OGRGeometry;

namespace rv::writing {

// A coordinate as GDAL's GeoJSON writer formats it (its default precision), appended to `out`.
void append_coordinate(std::string& out, double v);
// A real (OFTReal) property value as GDAL's GeoJSON writer formats it (17 significant digits,
// ".0" on integers).
void append_real(std::string& out, double v);
// A string as json-c quotes it (GDAL's GeoJSON writer): '"' and '\\' escaped, control
// characters as \b \f \n \r \t or \u00XX, everything else (UTF-8) as it is.
void append_string(std::string& out, const std::string& s);

class GeoJsonText {
 public:
  // The collection's header as GDAL writes it for a layer `layer` in `crs` (WKT or any OSR
  // definition; "" = none). Throws rv::Error(invalid_argument) for a CRS GDAL cannot parse.
  GeoJsonText(const std::string& layer, const std::string& crs, int threads = 1);

  // One feature: its properties in order, then its geometry, then end_feature().
  void begin_feature();
  void property(const char* name, int64_t v);
  void property(const char* name, double v);
  void property(const char* name, const std::string& v);
  void property(const char* name, std::span<const int> list);
  void point(Vec2 p);
  // A LineString (its coordinates formatted on the threads, in blocks).
  void line(std::span<const Vec2> points);
  // A Polygon or MultiPolygon (OGR's, as GDAL writes it; other types are refused with
  // rv::Error(internal)).
  void polygons(const OGRGeometry& g);
  void end_feature();

  // The whole text: the header, the features, the end.
  std::string finish();

 private:
  void key(const char* name);
  void geometry(const char* type);
  void coordinates(std::span<const Vec2> points);
  std::string header_, end_, features_, feature_;
  int threads_;
  int64_t count_ = 0;
  bool first_property_ = true;
};

// A hidden temporary name beside `path` (".<name>.tmp-<pid>-<n>", then ".<extension>" when given),
// unique in this process: where a file is built before it is renamed into place.
std::string hidden_temporary(const std::string& path, const std::string& extension);
// Writes `text` to `path` as VectorFile does (a hidden temporary name in the same directory, then
// renamed into place; /vsimem/ paths too). Throws rv::Error(io).
void write_text_file(const std::string& path, const std::string& text);

}  // namespace rv::writing
