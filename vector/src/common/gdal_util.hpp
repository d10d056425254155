// Internal helpers shared by the GDAL-facing sources of rv_vector: owning pointers for GDAL
// objects, a scoped capture of GDAL's error messages, and the path rules (plain .zip ->
// /vsizip/). Not part of the public API.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <cpl_error.h>
#include <cpl_http.h>
#include <gdal_priv.h>
#include <ogr_geometry.h>
#include <ogr_spatialref.h>

#include "rv/gdal/seed_reader.hpp"

namespace rv::gdal {

struct DatasetCloser {
  void operator()(GDALDataset* ds) const { GDALClose(GDALDataset::ToHandle(ds)); }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetCloser>;

struct SrsReleaser {
  void operator()(OGRSpatialReference* s) const { s->Release(); }
};
using SrsPtr = std::unique_ptr<OGRSpatialReference, SrsReleaser>;

struct CtDeleter {
  void operator()(OGRCoordinateTransformation* ct) const { OGRCoordinateTransformation::DestroyCT(ct); }
};
using CtPtr = std::unique_ptr<OGRCoordinateTransformation, CtDeleter>;

// Captures GDAL's messages on the calling thread while alive (GDAL's handler stack is
// per-thread), so that they end up in rv::Error messages and report warnings instead of on
// stderr. Nests: the previous handler is restored on destruction.
class ErrorCapture {
 public:
  ErrorCapture();
  ~ErrorCapture();
  ErrorCapture(const ErrorCapture&) = delete;
  ErrorCapture& operator=(const ErrorCapture&) = delete;

  // The most recent CE_Failure/CE_Fatal message, or "" when none.
  const std::string& last_error() const { return last_error_; }
  // ": <last error>" or "" - for appending to a message.
  std::string suffix() const { return last_error_.empty() ? std::string() : ": " + last_error_; }
  // Forgets the last error (to tell whether the next GDAL call failed).
  void clear_error() { last_error_.clear(); }
  // CE_Warning messages, in order (capped: a driver may warn once per feature).
  std::vector<std::string> take_warnings();

 private:
  static void CPL_STDCALL handler(CPLErr cls, CPLErrorNum num, const char* msg);
  std::string last_error_;
  std::vector<std::string> warnings_;
  int64_t dropped_warnings_ = 0;
};

// Sets a GDAL configuration option for the calling thread while alive, then restores the
// thread's previous value.
class ThreadConfigOption {
 public:
  ThreadConfigOption(const char* key, const char* value);
  ~ThreadConfigOption();
  ThreadConfigOption(const ThreadConfigOption&) = delete;
  ThreadConfigOption& operator=(const ThreadConfigOption&) = delete;

 private:
  std::string key_;
  std::string previous_;
  bool had_previous_ = false;
};

// Shuts GDAL off from the network and from stdin on the calling thread while alive, for reading
// untrusted uploads (SeedReadOptions::confined; the reasons are in rv/gdal/seed_reader.hpp):
//  - every CPLHTTPFetch() is refused and its URL recorded (a thread-local fetch callback), which
//    is how drivers fetch what a file links to (GeoJSON "crs" of type "link"/"url");
//  - CPL_VSIL_CURL_ALLOWED_FILENAME names no real file, so /vsicurl/ and the cloud handlers built
//    on it (/vsis3/, /vsigs/, /vsiaz/, ...) refuse every name before any request;
//  - GDAL_HTTP_PROXY points at 127.0.0.1:1 (a privileged port nothing listens on), so curl-based
//    handlers that skip the filename check (/vsicurl_streaming/ and its cloud siblings) connect
//    nowhere;
//  - CPL_ALLOW_VSISTDIN=NO, OGR_SQLITE_LOAD_EXTENSIONS empty (no SQLite extension loading),
//    OGR_SQLITE_STATIC_VIRTUAL_OGR=NO (no VirtualOGR module, which opens any datasource a table
//    definition names, on SQLite connections).
// All options are set thread-locally (CPLSetThreadLocalConfigOption) and the previous
// thread-local values are restored on destruction, so other threads and the CLI are unaffected.
// Nests. Not copyable; must be destroyed on the thread that created it.
class ConfinedScope {
 public:
  ConfinedScope();
  ~ConfinedScope();
  ConfinedScope(const ConfinedScope&) = delete;
  ConfinedScope& operator=(const ConfinedScope&) = delete;

  // URLs GDAL tried to fetch (and was refused), in order.
  const std::vector<std::string>& refused_urls() const { return refused_urls_; }

 private:
  static CPLHTTPResult* refuse(const char* url, CSLConstList options, GDALProgressFunc progress, void* progress_arg,
                               CPLHTTPFetchWriteFunc write, void* write_arg, void* self);
  std::vector<std::unique_ptr<ThreadConfigOption>> options_;
  std::vector<std::string> refused_urls_;
};

// Sets a line's or ring's vertices to `points`, each mapped to a position by `xy` (returning
// something with .x and .y). The array is sized once: OGR's addPoint grows it by one vertex per
// call, a copy of the whole line each time the allocator cannot grow it in place (always under
// AddressSanitizer), which makes writing a long line quadratic in its vertices.
template <class Points, class Xy>
void set_points(OGRSimpleCurve& curve, const Points& points, Xy xy) {
  curve.setNumPoints(static_cast<int>(points.size()), FALSE);
  int i = 0;
  for (const auto& p : points) {
    const auto v = xy(p);
    curve.setPoint(i++, v.x, v.y);
  }
}
template <class Points>
void set_points(OGRSimpleCurve& curve, const Points& points) {
  set_points(curve, points, [](const auto& p) { return p; });
}

// The name GDAL should open: a plain "x.zip" (or ".ZIP") becomes "/vsizip/x.zip"; anything
// already under /vsi... is left alone.
std::string open_name(const std::string& path);

// True when `path` (as given by the user, before open_name) exists; /vsi paths are checked
// through VSIStatL.
bool path_exists(const std::string& path);

// A CRS from any definition OSR understands, with the traditional GIS axis order
// (x = easting/longitude). Returns null when it cannot be parsed.
SrsPtr parse_srs(const std::string& definition);

// WKT2 (2019) of a CRS, "" on failure.
std::string to_wkt2(const OGRSpatialReference& srs);

// The public description of a parsed CRS.
CrsInfo crs_info(const OGRSpatialReference& srs);

}  // namespace rv::gdal
