// GeoTIFF writing and reading through GDAL. See rv/gdal/raster_io.hpp for the contract.
//
// Writing path (plain GeoTIFF, GeoTiffStripWriter; write_geotiff feeds it the whole raster as one
// strip): GTiff Create() on a temporary name next to the target with SPARSE_OK, so that GDAL
// writes the header, georeferencing, metadata and compression tags with every tile empty, and
// closes. A thread of the writer's own then reopens it read-only to attach the categories (raster
// attribute table and category names, in the PAM sidecar: GDAL 3.6 does not put a RAT inside a
// GTiff) while the tiles are written.
// Each band of 256 rows is then cut into tiles that are predicted and compressed here, `threads`
// at a time, and appended raw with libtiff (tiff_tiles.hpp). GDAL's own path (WriteBlock with
// NUM_THREADS) gave every tile a fresh in-memory TIFF and codec state in its compression pool;
// on the 1e8-cell case its allocations and copies cost more CPU than ZSTD itself on the owner
// codes (bench/RESULTS-encoding.md).
//
// Writing path (COG, the same writer): the plain GeoTIFF above is written as a staging file beside
// the target, while the overviews are made from the same rows (cog_overviews.hpp) and their
// tiles encoded by the same encoders into a spool; finish() assembles the COG from the staged
// and spooled tiles as they are (cog_assembly.hpp). GDAL's COG driver, which the COGs were copied
// by before, only implements CreateCopy(): it decoded every tile of a complete GeoTIFF and encoded
// it again, and built the overviews in a temporary file of its own.
//
// Both take their compression from encoding_for(), the one place a profile (rv::Compression)
// becomes codec, level and predictor.
#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <memory>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include <unistd.h>

#include <cpl_string.h>
#include <cpl_vsi.h>
#include <gdal_rat.h>

#include "common/gdal_util.hpp"
#include "rv/field/checksum.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/gdal/raster_io.hpp"
#include "writing/cog_assembly.hpp"
#include "writing/cog_overviews.hpp"
#include "writing/raster_open.hpp"
#include "writing/tiff_tiles.hpp"

namespace rv {

using detail::open_raster;
using detail::OpenedRaster;
using detail::PixelType;
namespace {

constexpr int kBlock = 256;
// The strip writer's tiles in flight: at most kChunkTiles encoded tiles (each at most about 257
// KiB, ZSTD's bound on a Float32 tile) and one raw tile per encoding thread, at most
// kMaxEncoders of them: about 10 MiB per file at most (the job planner's kWriterBytes).
constexpr int64_t kChunkTiles = 24;
constexpr int kMaxEncoders = 16;

// Whether this GDAL's libtiff can write ZSTD (libtiff >= 4.0.10 built with libzstd).
bool has_zstd(GDALDriver* gtiff) {
  const char* list = gtiff->GetMetadataItem(GDAL_DMD_CREATIONOPTIONLIST);
  return list != nullptr && std::strstr(list, "ZSTD") != nullptr;
}

// What one file is encoded with.
struct Encoding {
  detail::TileCodec codec;
  int level;      // codec level (unused for none)
  int predictor;  // TIFF predictor: 1 none, 2 horizontal differencing, 3 floating point
};

// The codec as GDAL's COMPRESS value.
const char* gdal_codec(detail::TileCodec c) {
  switch (c) {
    case detail::TileCodec::zstd:
      return "ZSTD";
    case detail::TileCodec::deflate:
      return "DEFLATE";
    case detail::TileCodec::none:
      break;
  }
  return "NONE";
}

// Levels and predictors, from re-encoding the 1e8-cell rasters of bench/RESULTS-encoding.md on one
// thread (Float32 distance, 419 MB raw; CPU seconds, medians of 3):
//   ZSTD 1: 0.9 s, 355 MB; with the floating-point predictor 2.0 s, 267 MB (the predictor costs
//   more than the codec); ZSTD 6 + predictor: 5.2 s, 248 MB; ZSTD 9: 9.2 s, 248 MB (nothing more
//   for 1.8x the time); ZSTD 12: 20 s, 247 MB.
//   DEFLATE 1: 4.0 s without the predictor, 3.4 s with it (355 / 262 MB: DEFLATE is no faster on
//   raw floats, so the predictor comes free there); DEFLATE 6: 7.7 s, 253 MB; DEFLATE 9: 35 s,
//   250 MB.
// Hence small = ZSTD level 6 with predictors (the knee: level 9 and above buy under 1 %), deflate =
// level 1 with predictors (level 6 doubles the time for 4 %). fast writes Float32 uncompressed:
// ZSTD 1 spends 0.6 CPU seconds of Huffman coding per 1e8 distances to save 11 % (ZSTD's
// negative levels code no literals and save nothing), and on the 1e8-cell command that codec was
// what kept it going past the computation (bench/RESULTS-encoding.md, sixteenth session). Codes
// keep ZSTD 1 with predictor 2: 33x smaller for a fraction of that time.
constexpr int kFastZstdLevel = 1;
constexpr int kSmallZstdLevel = 6;
constexpr int kDeflateLevel = 1;
constexpr int kSmallDeflateLevel = 6;  // small without ZSTD

// The one place a compression profile becomes codec, level and predictor (rv/gdal/raster_io.hpp has
// the profiles' contract). Integer codes always get the horizontal-differencing predictor (2).
// Without ZSTD, fast codes get DEFLATE 1.
Encoding encoding_for(Compression c, bool floating, bool zstd) {
  const int predictor = floating ? 3 : 2;
  switch (c) {
    case Compression::fast:
      if (floating) return {detail::TileCodec::none, 0, 1};
      return zstd ? Encoding{detail::TileCodec::zstd, kFastZstdLevel, 2}
                  : Encoding{detail::TileCodec::deflate, kDeflateLevel, 2};
    case Compression::small:
      return zstd ? Encoding{detail::TileCodec::zstd, kSmallZstdLevel, predictor}
                  : Encoding{detail::TileCodec::deflate, kSmallDeflateLevel, predictor};
    case Compression::deflate:
      return {detail::TileCodec::deflate, kDeflateLevel, predictor};
    case Compression::none:
      return {detail::TileCodec::none, 0, 1};
  }
  throw Error(ErrorKind::internal, "unknown compression profile");
}

// The encoding as the GTiff driver's creation options.
void set_gtiff_encoding(CPLStringList& co, const Encoding& e) {
  co.SetNameValue("COMPRESS", gdal_codec(e.codec));
  if (e.codec == detail::TileCodec::zstd) co.SetNameValue("ZSTD_LEVEL", std::to_string(e.level).c_str());
  if (e.codec == detail::TileCodec::deflate) co.SetNameValue("ZLEVEL", std::to_string(e.level).c_str());
  if (e.predictor != 1) co.SetNameValue("PREDICTOR", std::to_string(e.predictor).c_str());
}

// The file's data type: T, or for integer rasters with a stated range the narrowest type that
// holds [0, max_code] (owner codes of up to 255 owners take a quarter of the bytes to encode).
template <class T>
GDALDataType file_type(const GeoTiffOptions& options) {
  if constexpr (PixelType<T>::floating) {
    return PixelType<T>::gdal;
  } else {
    if (options.max_code < 0) return GDT_Int32;
    if (options.max_code <= UINT8_MAX) return GDT_Byte;
    if (options.max_code <= UINT16_MAX) return GDT_UInt16;
    return GDT_Int32;
  }
}

// Copies n codes into the file's type, each checked against [0, max]: false when one lies
// outside (a negative code wraps to a large unsigned one). The check makes a caller's wrong
// max_code an error instead of silently wrapped codes, at no extra pass over the cells. The
// inner loop has a fixed count so that GCC vectorises it at -O2 (its "very cheap" cost model
// only takes loops without a remainder): 0.3 instead of 0.6 ns a cell.
template <class Out>
bool store_codes(const int32_t* __restrict in, Out* __restrict out, int64_t n, uint32_t max) {
  constexpr int64_t kChunk = 32;
  uint32_t over = 0;
  int64_t i = 0;
  for (; i + kChunk <= n; i += kChunk) {
    for (int64_t j = 0; j < kChunk; ++j) {
      const auto v = static_cast<uint32_t>(in[i + j]);
      over |= static_cast<uint32_t>(v > max);
      out[i + j] = static_cast<Out>(v);
    }
  }
  for (; i < n; ++i) {
    const auto v = static_cast<uint32_t>(in[i]);
    over |= static_cast<uint32_t>(v > max);
    out[i] = static_cast<Out>(v);
  }
  return over == 0;
}

std::string directory_of(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? std::string(".") : path.substr(0, slash == 0 ? 1 : slash);
}

std::string file_name_of(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  return slash == std::string::npos ? path : path.substr(slash + 1);
}

// A hidden name in the target's directory, unique per process and call: rename() within one
// directory is atomic, and concurrent writers never share a temporary file.
std::string temp_name(const std::string& path) {
  static std::atomic<uint64_t> counter{0};
  const std::string dir = directory_of(path);
  return (dir == "/" ? "" : dir) + "/." + file_name_of(path) + ".tmp-" + std::to_string(::getpid()) + "-" +
         std::to_string(counter.fetch_add(1)) + ".tif";
}

bool exists(const std::string& path) { return gdal::path_exists(path); }

// Removes the temporary file and its sidecar unless commit() succeeded.
class TempOutput {
 public:
  explicit TempOutput(std::string target) : target_(std::move(target)), temp_(temp_name(target_)) {}
  ~TempOutput() {
    if (!committed_) {
      VSIUnlink(temp_.c_str());
      VSIUnlink((temp_ + ".aux.xml").c_str());
    }
  }
  TempOutput(const TempOutput&) = delete;
  TempOutput& operator=(const TempOutput&) = delete;

  const std::string& temp() const { return temp_; }

  void commit() {
    const std::string temp_aux = temp_ + ".aux.xml";
    const std::string target_aux = target_ + ".aux.xml";
    // The sidecar first: once the new file is visible under its name, its sidecar already is.
    const bool has_aux = exists(temp_aux);
    if (has_aux) {
      if (VSIRename(temp_aux.c_str(), target_aux.c_str()) != 0)
        throw Error(ErrorKind::io, "cannot rename " + temp_aux + " to " + target_aux + ": " + std::strerror(errno));
    } else if (exists(target_aux)) {
      // A sidecar left by an earlier file of this name would describe the wrong raster.
      VSIUnlink(target_aux.c_str());
    }
    if (VSIRename(temp_.c_str(), target_.c_str()) != 0) {
      const int err = errno;
      // The new sidecar must not stay next to a file it does not describe.
      if (has_aux) VSIUnlink(target_aux.c_str());
      throw Error(ErrorKind::io, "cannot rename " + temp_ + " to " + target_ + ": " + std::strerror(err));
    }
    committed_ = true;
  }

 private:
  std::string target_;
  std::string temp_;
  bool committed_ = false;
};

void fail(const std::string& path, const std::string& what, const gdal::ErrorCapture& capture) {
  throw Error(ErrorKind::io, "writing " + path + ": " + what + capture.suffix());
}

// Grid of the raster's window: the GeoTIFF covers the window, not the whole grid.
void window_geotransform(const GridSpec& g, const Window& w, double gt[6]) {
  gt[0] = g.xmin + static_cast<double>(w.col0) * g.res;
  gt[1] = g.res;
  gt[2] = 0.0;
  gt[3] = g.ymax - static_cast<double>(w.row0) * g.res;
  gt[4] = 0.0;
  gt[5] = -g.res;
}

// Georeferencing, nodata, units and metadata.
void describe_dataset(GDALDataset& ds, const GridSpec& grid, const Window& window, double nodata,
                      const GeoTiffOptions& options, const std::string& path, const gdal::ErrorCapture& capture) {
  double gt[6];
  window_geotransform(grid, window, gt);
  if (ds.SetGeoTransform(gt) != CE_None) fail(path, "cannot set the geotransform", capture);
  if (!grid.crs.empty()) {
    gdal::SrsPtr srs = gdal::parse_srs(grid.crs);
    if (!srs) throw Error(ErrorKind::invalid_argument, "writing " + path + ": the grid's CRS cannot be parsed");
    if (ds.SetSpatialRef(srs.get()) != CE_None) fail(path, "cannot set the CRS", capture);
  }
  GDALRasterBand* band = ds.GetRasterBand(1);
  if (band->SetNoDataValue(nodata) != CE_None) fail(path, "cannot set the nodata value", capture);
  if (!options.units.empty()) band->SetUnitType(options.units.c_str());
  for (const auto& [key, value] : options.metadata) band->SetMetadataItem(key.c_str(), value.c_str());
}

// Category labels: a RAT (Value, Owner) and the band's category names (index = value).
void write_categories(GDALRasterBand& band, const std::vector<std::string>& labels, const std::string& path,
                      const gdal::ErrorCapture& capture) {
  if (labels.empty()) return;
  GDALDefaultRasterAttributeTable rat;
  rat.CreateColumn("Value", GFT_Integer, GFU_MinMax);
  rat.CreateColumn("Owner", GFT_String, GFU_Name);
  rat.SetTableType(GRTT_THEMATIC);
  rat.SetRowCount(static_cast<int>(labels.size()));
  CPLStringList names;
  names.AddString("");  // value 0: nodata, no owner
  for (size_t i = 0; i < labels.size(); ++i) {
    rat.SetValue(static_cast<int>(i), 0, static_cast<int>(i + 1));
    rat.SetValue(static_cast<int>(i), 1, labels[i].c_str());
    names.AddString(labels[i].c_str());
  }
  if (band.SetDefaultRAT(&rat) != CE_None) fail(path, "cannot attach the raster attribute table", capture);
  if (band.SetCategoryNames(names.List()) != CE_None) fail(path, "cannot set the category names", capture);
}

// The categories of the written file `temp` (`path` for messages): it is opened read-only, so
// that PAM writes the sidecar and the TIFF stays as it is.
void attach_categories(const std::string& temp, const std::vector<std::string>& labels, const std::string& path,
                       const gdal::ErrorCapture& capture) {
  gdal::DatasetPtr done(
      GDALDataset::FromHandle(GDALOpenEx(temp.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
  if (!done) fail(path, "cannot reopen the file to attach its categories", capture);
  write_categories(*done->GetRasterBand(1), labels, path, capture);
  done.reset();
  if (!capture.last_error().empty()) fail(path, "writing the sidecar failed", capture);
  if (!exists(temp + ".aux.xml")) fail(path, "the category sidecar was not written", capture);
}

// Checks shared by every writer, before anything is created: a usable size, labels and a code
// range only on integer rasters, nodata inside the range, an existing target directory.
template <class T>
void check_target(const std::string& path, const Window& window, double nodata, const GeoTiffOptions& options) {
  if (window.width <= 0 || window.height <= 0)
    throw Error(ErrorKind::invalid_argument, "writing " + path + ": the raster is empty or inconsistent");
  if (window.width > INT32_MAX || window.height > INT32_MAX)
    throw Error(ErrorKind::too_large, "writing " + path + ": more than 2^31 columns or rows");
  if (!options.category_labels.empty() && PixelType<T>::floating)
    throw Error(ErrorKind::invalid_argument, "writing " + path + ": category labels need an integer raster");
  if (options.max_code >= 0) {
    if (PixelType<T>::floating)
      throw Error(ErrorKind::invalid_argument, "writing " + path + ": a code range needs an integer raster");
    if (options.max_code > INT32_MAX)
      throw Error(ErrorKind::invalid_argument, "writing " + path + ": max_code above 2^31-1");
    if (!(nodata >= 0.0 && nodata <= static_cast<double>(options.max_code) && nodata == std::floor(nodata)))
      throw Error(ErrorKind::invalid_argument,
                  "writing " + path + ": the nodata value is not a code in 0.." + std::to_string(options.max_code));
  }
  const std::string dir = directory_of(path);
  if (path.rfind("/vsi", 0) != 0 && !exists(dir))
    throw Error(ErrorKind::io, "writing " + path + ": the directory " + dir + " does not exist");
}

template <class T>
void check_raster(const std::string& path, const Raster<T>& raster, double nodata, const GeoTiffOptions& options) {
  if (raster.size() != static_cast<size_t>(raster.width() * raster.height()))
    throw Error(ErrorKind::invalid_argument, "writing " + path + ": the raster is empty or inconsistent");
  check_target<T>(path, raster.window(), nodata, options);
}

[[noreturn]] void out_of_range(const std::string& path, int64_t max_code) {
  throw Error(ErrorKind::invalid_argument,
              "writing " + path + ": a value outside the stated code range 0.." + std::to_string(max_code));
}

}  // namespace

// Everything one GeoTIFF being written needs. Member order matters: the files close (the dataset
// writing the TIFF directory and the PAM sidecar, the tile index, the spool) before the temporary
// files' guards may remove them.
template <class T>
struct GeoTiffStripWriter<T>::State {
  State(const std::string& p, const Window& w, double nd, const GeoTiffOptions& o)
      : path(p), window(w), nodata(nd), options(o), type(file_type<T>(o)), out(p) {}
  std::string path;
  Window window;
  double nodata;
  GeoTiffOptions options;
  GDALDataType type;  // the file's data type (T, or narrower codes)
  TempOutput out;
  // A COG (options.cloud_optimized): GDAL creates, and the full-resolution tiles go to, `staged`,
  // a plain tiled GeoTIFF beside the target; the overviews are made from the same rows
  // (cog_overviews.hpp), their tiles encoded like the others into `spool`, and finish() assembles
  // the COG into out.temp() from both by copying the encoded bytes (cog_assembly.hpp). Both
  // temporary files are removed whatever happens. Null for a plain GeoTIFF, written at out.temp().
  struct Cog {
    explicit Cog(const std::string& target) : staged(target), spool_file(target) {}
    TempOutput staged;  // never committed: guards, and names, temporary files
    TempOutput spool_file;
    std::unique_ptr<detail::OverviewPyramid<T>> pyramid;
    std::unique_ptr<detail::TileSpool> spool;
  };
  std::unique_ptr<Cog> cog;
  int64_t rows_written = 0;
  // Rows of the current band of tiles (kBlock rows) that arrived in strips not ending on a tile
  // boundary; allocated on first use, so strips of whole tile rows never copy.
  std::vector<T> pending;
  int64_t pending_rows = 0;
  // The tiles' encoding (tiff_tiles.hpp): GDAL made the file with every tile empty, the tiles are
  // encoded here, `threads` at a time, and appended raw.
  std::unique_ptr<detail::RawTileFile> file;
  detail::TileFormat format;
  GridSpec grid;
  // An earlier file whose tiles write_band() copies where told (take_tiles_from), and the bytes
  // of the tile being copied.
  std::unique_ptr<detail::RawTileFile> earlier;
  std::vector<uint8_t> earlier_tile;
  std::vector<uint64_t> earlier_checksums;  // empty: copied tiles are not checked
  std::string earlier_display;
  // The earlier file opened by GDAL, to decode tiles whose cells are needed: remapped tiles, and a
  // COG's copied tiles (its overviews are made from every cell).
  gdal::DatasetPtr earlier_ds;
  // Where the earlier file's tiles are of a layout TileDecompressor undoes (tiff_tiles.hpp): they
  // are decoded here instead, `threads` at a time (GDAL's reads decode one tile after another on
  // the writer's thread: the whole cost of recoding a file whose codes all moved).
  std::vector<detail::TileDecompressor> decoders;  // one per thread; empty: GDAL decodes
  std::vector<std::vector<uint8_t>> copied_bytes;  // the band's copied tiles, as stored
  std::vector<int32_t> remap;  // integer files: earlier value v -> remap[v] (copied tiles re-encoded)
  std::vector<T> band;         // a band of rows completed from the earlier file
  // checksum64 of each full-resolution tile appended (tile_checksums()).
  std::vector<uint64_t> checksums;
  int threads = 1;
  std::vector<detail::TileCompressor> compressors;  // one per thread
  std::vector<std::vector<uint8_t>> scratch;        // one raw tile per thread
  std::vector<std::vector<uint8_t>> encoded;        // the chunk's encoded tiles (several threads)
  std::vector<size_t> sizes;                        // ... and their sizes
  std::vector<uint8_t> encoded_single;              // the encoded tile (one thread)
  // The categories' sidecar, built on a thread of its own (0.28 s of GDAL's PAM serialisation
  // for 50 000 owners, otherwise in the way of the first strip or of the tiles): GDAL opens the
  // file read-only and reads only its directory, which the tiles appended at the end never
  // touch until close(). finish() joins it; the destructor too, before `out` removes the files.
  //
  // It starts with the first rows (start_sidecar()), not in the constructor, so that it is
  // created by the thread that writes the rows and inherits that thread's scheduling priority:
  // a streamed job lowers its writers' priority so that the engine keeps the cores, and a
  // sidecar created by the job's main thread ran at the engine's priority instead. On 1e8 cells
  // with 50 000 owners (2 cores) it took a core from the engine for 0.27 s. Medians of 7
  // alternated runs: the engine's time in the command fell from 0.239 to 0.209 s, and the rest
  // of the command (reading excluded) from 0.575 to 0.557 s (bench/RESULTS-encoding.md).
  struct Sidecar {
    std::thread thread;  // joinable from its start until finish() or the destructor joins it
    std::exception_ptr error;
    Sidecar() = default;
    Sidecar(const Sidecar&) = delete;
    Sidecar& operator=(const Sidecar&) = delete;
    ~Sidecar() { join(); }
    void join() {
      if (thread.joinable()) thread.join();
    }
  } sidecar;
  bool failed = false;
  bool finished = false;

  // Starts the categories' sidecar (Sidecar above) unless it has started or there are none.
  // (Nothing calls it after the join: finish() comes after every write_rows().) A file in one of
  // GDAL's virtual file systems (/vsimem/...) is not safe to read on one thread while another
  // appends to it (an in-memory file's buffer moves when it grows: ASan caught the reader
  // copying from a freed one), so there the sidecar waits for finish(), when nothing is written.
  void start_sidecar(bool finishing = false) {
    if (sidecar.thread.joinable() || options.category_labels.empty()) return;
    if (!finishing && written().rfind("/vsi", 0) == 0) return;
    sidecar.thread = std::thread([this] {
      try {
        Scope own;
        attach_categories(written(), options.category_labels, path, own.capture);
      } catch (...) {
        sidecar.error = std::current_exception();
      }
    });
  }

  // The file GDAL creates and the full-resolution tiles are appended to.
  const std::string& written() const { return cog ? cog->staged.temp() : out.temp(); }

  // Overviews of a COG: made from the rows write_band() encodes, nearest for codes (never an
  // average of two owners) and categorical rasters, average for the rest; encoded like the full
  // resolution into the spool.
  void start_overviews() {
    const auto resampling =
        PixelType<T>::floating && !options.categorical ? detail::Resampling::average : detail::Resampling::nearest;
    cog->pyramid = std::make_unique<detail::OverviewPyramid<T>>(
        window.width, window.height, kBlock, resampling, nodata,
        [this](int level, const T* rows, int64_t, int64_t count, int64_t width) {
          encode_band(rows, count, width, nullptr,
                      [&](int64_t, const detail::EncodedTile* t) { cog->spool->append(level, *t); });
        });
    cog->spool = std::make_unique<detail::TileSpool>(cog->spool_file.temp(), cog->pyramid->levels(), path);
  }

  // The COG into out.temp() from the closed staged file and the spool, and the categories'
  // sidecar (written for the staged file: PAM keeps nothing there that differs) beside it.
  void assemble_cog() {
    if (!cog->pyramid->complete()) throw Error(ErrorKind::internal, "writing " + path + ": overviews incomplete");
    detail::assemble_cog(cog->staged.temp(), *cog->spool, out.temp(), path);
    cog->spool.reset();
    cog->pyramid.reset();
    const std::string aux = cog->staged.temp() + ".aux.xml", target_aux = out.temp() + ".aux.xml";
    if (exists(aux) && VSIRename(aux.c_str(), target_aux.c_str()) != 0)
      throw Error(ErrorKind::io, "cannot rename " + aux + " to " + target_aux + ": " + std::strerror(errno));
  }

  // GDAL's error handlers and thread-local options are per thread: every public call installs
  // its own, so that a writer may be handed from thread to thread.
  struct Scope {
    gdal::ErrorCapture capture;
    // The RAT lives in the PAM sidecar: PAM must be on for this thread whatever the process
    // configuration says, also when the dataset closes.
    gdal::ThreadConfigOption pam{"GDAL_PAM_ENABLED", "YES"};
  };

  // Encodes one band of tiles of an image `width` cells wide (the full resolution or an overview):
  // `h` rows (kBlock, or fewer in its last band) of `width` cells at `rows`, converted to the
  // file's type on the way into each tile, and hands them to put(bx, tile) in order of bx. A tile
  // flagged in `copy` is neither read nor encoded: put(bx, nullptr).
  // One encoder: tile by tile, each handed on as soon as it is encoded (an uncompressed tile
  // straight from the scratch tile). Several: in chunks of a few tiles per thread; each thread
  // fills, predicts and compresses its tiles of the chunk into the chunk's buffers, then the
  // chunk is handed on in order. Either way the bytes do not depend on the thread count.
  template <class Put>
  void encode_band(const T* rows, int64_t h, int64_t width, const std::vector<bool>* copy, Put&& put) {
    const int64_t across = (width + kBlock - 1) / kBlock;
    auto copied = [&](int64_t bx) { return copy != nullptr && (*copy)[static_cast<size_t>(bx)]; };
    if (threads == 1) {
      for (int64_t bx = 0; bx < across; ++bx) {
        if (copied(bx)) {
          put(bx, nullptr);
          continue;
        }
        uint8_t* tile = scratch[0].data();
        fill_tile(rows, h, width, bx * kBlock, tile);
        const detail::EncodedTile t = compressors[0].encode(tile, encoded_single);
        put(bx, &t);
      }
      return;
    }
    const int64_t chunk = std::min<int64_t>(across, kChunkTiles);
    encoded.resize(static_cast<size_t>(chunk));
    sizes.resize(static_cast<size_t>(chunk));
    for (int64_t first = 0; first < across; first += chunk) {
      const int64_t n = std::min(chunk, across - first);
      // Each worker has its own codec and scratch tile; a tile's bytes do not depend on which
      // worker encoded it.
      detail::parallel_for(threads, n, [&](int64_t i, int worker) {
        if (copied(first + i)) return;
        uint8_t* tile = scratch[static_cast<size_t>(worker)].data();
        fill_tile(rows, h, width, (first + i) * kBlock, tile);
        // Compressed (an uncompressed file has one encoder), so the bytes are in the chunk's
        // buffer, not in the scratch tile this worker reuses.
        sizes[static_cast<size_t>(i)] =
            compressors[static_cast<size_t>(worker)].encode(tile, encoded[static_cast<size_t>(i)]).size;
      });
      for (int64_t i = 0; i < n; ++i) {
        const detail::EncodedTile t{encoded[static_cast<size_t>(i)].data(), sizes[static_cast<size_t>(i)]};
        put(first + i, copied(first + i) ? nullptr : &t);
      }
    }
  }

  // Encodes and appends the next band of full-resolution tiles: `h` rows (kBlock, or fewer in the
  // last band) of window.width cells at `rows`. With `copy` (one flag per tile across), the
  // flagged tiles' bytes come from the earlier file instead, unchanged, and their cells are not
  // read -- but by a COG's overviews, which are made from every cell of the band.
  void write_band(const T* rows, int64_t h, const std::vector<bool>* copy = nullptr) {
    const int64_t by = rows_written / kBlock;
    const int64_t across = file->tiles_across();
    // A copied tile's stored bytes, checked against its checksum.
    auto earlier_tile_bytes = [&](int64_t bx) {
      const detail::EncodedTile bytes = earlier->read(bx, by, earlier_tile);
      const uint64_t sum = checksum64(bytes.data, bytes.size);
      const auto k = static_cast<size_t>(by * across + bx);
      if (!earlier_checksums.empty() && (k >= earlier_checksums.size() || earlier_checksums[k] != sum))
        throw detail::modified_tile(earlier_display, bx, by, window.width, window.height);
      return std::make_pair(bytes, sum);
    };
    // Where the copied tiles' cells are needed (remapped, or a COG's overviews), the band is
    // completed from the earlier file; the caller's cells elsewhere.
    const T* cells = rows;
    if (copy != nullptr && (!remap.empty() || cog) && !decoders.empty()) {
      band.assign(rows, rows + h * window.width);
      complete_band(h, by, *copy, earlier_tile_bytes);
      cells = band.data();
      if (!remap.empty()) copy = nullptr;  // every tile encoded from the completed band
    } else if (copy != nullptr && (!remap.empty() || cog)) {
      band.assign(rows, rows + h * window.width);
      for (int64_t bx = 0; bx < across; ++bx) {
        if (!(*copy)[static_cast<size_t>(bx)]) continue;
        if (!remap.empty()) earlier_tile_bytes(bx);  // encoded again below: checked here
        const int64_t x0 = bx * kBlock, w = std::min<int64_t>(kBlock, window.width - x0);
        T* at = band.data() + x0;
        const auto cell = static_cast<GSpacing>(sizeof(T));
        if (earlier_ds->GetRasterBand(1)->RasterIO(GF_Read, static_cast<int>(x0), static_cast<int>(by * kBlock),
                                                   static_cast<int>(w), static_cast<int>(h), at, static_cast<int>(w),
                                                   static_cast<int>(h), PixelType<T>::gdal, cell, cell * window.width,
                                                   nullptr) != CE_None)
          throw Error(ErrorKind::io, "reading " + earlier_display + " failed");
        if constexpr (!PixelType<T>::floating) {
          if (!remap.empty())
            for (int64_t r = 0; r < h; ++r)
              for (T* v = at + r * window.width; v != at + r * window.width + w; ++v) {
                if (*v < 0 || static_cast<size_t>(*v) >= remap.size() || remap[static_cast<size_t>(*v)] < 0)
                  throw Error(ErrorKind::invalid_input,
                              earlier_display + " holds a value its run did not write (" + std::to_string(*v) + ")");
                *v = remap[static_cast<size_t>(*v)];
              }
        }
      }
      cells = band.data();
      if (!remap.empty()) copy = nullptr;  // every tile encoded from the completed band
    }
    encode_band(cells, h, window.width, copy, [&](int64_t bx, const detail::EncodedTile* t) {
      const auto k = static_cast<size_t>(by * across + bx);
      if (t != nullptr) {
        file->append(bx, by, *t);
        checksums[k] = checksum64(t->data, t->size);
        return;
      }
      const auto [bytes, sum] = earlier_tile_bytes(bx);
      file->append(bx, by, bytes);
      checksums[k] = sum;
    });
    if (cog) cog->pyramid->add_rows(cells, h);
    rows_written += h;
  }

  // The copied tiles of band `by` (flagged in `copy`) decoded into `band` (h rows), remapped
  // where the codes moved: their stored bytes read (and, when remapped, checked) on this thread,
  // decoded on `threads`.
  template <class TileBytes>
  void complete_band(int64_t h, int64_t by, const std::vector<bool>& copy, TileBytes&& earlier_tile_bytes) {
    std::vector<int64_t> list;
    for (int64_t bx = 0; bx < static_cast<int64_t>(copy.size()); ++bx)
      if (copy[static_cast<size_t>(bx)]) list.push_back(bx);
    copied_bytes.resize(std::max(copied_bytes.size(), list.size()));
    std::vector<detail::EncodedTile> stored(list.size());
    for (size_t i = 0; i < list.size(); ++i) {
      const detail::EncodedTile t =
          remap.empty() ? earlier->read(list[i], by, earlier_tile) : earlier_tile_bytes(list[i]).first;
      copied_bytes[i].assign(t.data, t.data + t.size);
      stored[i] = {copied_bytes[i].data(), t.size};
    }
    const detail::StoredTiles& layout = earlier->stored();
    const auto tile_bytes = static_cast<size_t>(layout.format.width) * static_cast<size_t>(layout.format.height) *
                            static_cast<size_t>(layout.format.sample_bytes);
    std::vector<std::vector<uint8_t>> raw(decoders.size());
    detail::parallel_for(
        static_cast<int>(decoders.size()), static_cast<int64_t>(list.size()),
        [&](int64_t i, int worker) {
          std::vector<uint8_t>& tile = raw[static_cast<size_t>(worker)];
          tile.resize(tile_bytes);
          decoders[static_cast<size_t>(worker)].decode(stored[static_cast<size_t>(i)], tile.data());
          const int64_t x0 = list[static_cast<size_t>(i)] * kBlock, w = std::min<int64_t>(kBlock, window.width - x0);
          for (int64_t r = 0; r < h; ++r)
            take_row(tile.data() + static_cast<size_t>(r) * static_cast<size_t>(layout.format.width) *
                                       static_cast<size_t>(layout.format.sample_bytes),
                     band.data() + r * window.width + x0, w, layout);
        },
        [](int) {});
  }

  // One row of a decoded tile (`w` samples as stored) into the band, in T, through the remap.
  // Branch-free per cell: an unknown value maps to -1, found once the row is done.
  void take_row(const uint8_t* from, T* to, int64_t w, const detail::StoredTiles& layout) const {
    if constexpr (PixelType<T>::floating) {
      std::memcpy(to, from, static_cast<size_t>(w) * sizeof(T));
    } else {
      const int32_t* map = remap.data();
      const auto n = static_cast<int64_t>(remap.size());
      int32_t any_bad = 0;
      auto row = [&](auto sample) {
        using S = decltype(sample);
        for (int64_t c = 0; c < w; ++c) {
          S u;
          std::memcpy(&u, from + c * static_cast<int64_t>(sizeof(S)), sizeof(S));
          const auto v = static_cast<int64_t>(u);
          const int32_t out = map == nullptr ? static_cast<int32_t>(v) : (v >= 0 && v < n ? map[v] : -1);
          any_bad |= out;
          to[c] = static_cast<T>(out);
        }
      };
      const int bytes = layout.format.sample_bytes;
      if (bytes == 1) {
        layout.is_signed ? row(int8_t{}) : row(uint8_t{});
      } else if (bytes == 2) {
        layout.is_signed ? row(int16_t{}) : row(uint16_t{});
      } else {
        layout.is_signed ? row(int32_t{}) : row(uint32_t{});
      }
      if (map != nullptr && any_bad < 0)
        throw Error(ErrorKind::invalid_input, earlier_display + " holds a value its run did not write");
    }
  }

  // The tile whose left column is x0 of rows `width` cells wide, in the file's type. Edge tiles:
  // the part outside the image is padding, filled with nodata so that it compresses to nothing
  // and never shows real-looking values.
  void fill_tile(const T* rows, int64_t h, int64_t width, int64_t x0, uint8_t* tile) const {
    if constexpr (PixelType<T>::floating) {
      fill_tile_as(rows, h, width, x0, reinterpret_cast<T*>(tile));
    } else {
      switch (type) {
        case GDT_Byte:
          fill_tile_as(rows, h, width, x0, tile);
          break;
        case GDT_UInt16:
          fill_tile_as(rows, h, width, x0, reinterpret_cast<uint16_t*>(tile));
          break;
        default:
          fill_tile_as(rows, h, width, x0, reinterpret_cast<T*>(tile));
          break;
      }
    }
  }

  template <class Out>
  void fill_tile_as(const T* rows, int64_t h, int64_t width, int64_t x0, Out* tile) const {
    const int64_t w = std::min<int64_t>(kBlock, width - x0);
    if (w < kBlock || h < kBlock) std::fill(tile, tile + kBlock * kBlock, static_cast<Out>(nodata));
    for (int64_t r = 0; r < h; ++r) store(rows + r * width + x0, tile + r * kBlock, w);
  }

  // n cells into the file's type; codes are checked against the stated range.
  template <class Out>
  void store(const T* in, Out* out, int64_t n) const {
    if constexpr (std::is_same_v<Out, T>) {
      if (PixelType<T>::floating || options.max_code < 0) {
        std::memcpy(out, in, static_cast<size_t>(n) * sizeof(T));
        return;
      }
    }
    if constexpr (!PixelType<T>::floating) {
      if (!store_codes(in, out, n, static_cast<uint32_t>(options.max_code))) out_of_range(path, options.max_code);
    }
  }
};

template <class T>
GeoTiffStripWriter<T>::GeoTiffStripWriter(const std::string& path, const GridSpec& grid, const Window& window,
                                          double nodata, const GeoTiffOptions& options) {
  gdal_init();
  check_target<T>(path, window, nodata, options);
  typename State::Scope scope;
  auto state = std::make_unique<State>(path, window, nodata, options);
  if (options.cloud_optimized) state->cog = std::make_unique<typename State::Cog>(path);
  GDALDriver* gtiff = GetGDALDriverManager()->GetDriverByName("GTiff");
  if (gtiff == nullptr) throw Error(ErrorKind::unsupported, "GDAL has no GTiff driver");
  CPLStringList co;
  co.SetNameValue("TILED", "YES");
  co.SetNameValue("BLOCKXSIZE", std::to_string(kBlock).c_str());
  co.SetNameValue("BLOCKYSIZE", std::to_string(kBlock).c_str());
  const Encoding encoding = encoding_for(options.compression, PixelType<T>::floating, has_zstd(gtiff));
  set_gtiff_encoding(co, encoding);
  co.SetNameValue("BIGTIFF", "IF_SAFER");
  co.SetNameValue("SPARSE_OK", "TRUE");  // every tile stays empty until appended below
  {
    gdal::DatasetPtr ds(gtiff->Create(state->written().c_str(), static_cast<int>(window.width),
                                      static_cast<int>(window.height), 1, state->type, co.List()));
    if (!ds) fail(path, "cannot create the file", scope.capture);
    describe_dataset(*ds, grid, window, nodata, options, path, scope.capture);
    ds.reset();  // closing writes the directory, no tile yet
    if (!scope.capture.last_error().empty()) fail(path, "closing failed", scope.capture);
  }
  detail::TileFormat f;
  f.codec = encoding.codec;
  f.level = encoding.level;
  f.predictor = encoding.predictor;
  f.sample_bytes = GDALGetDataTypeSizeBytes(state->type);
  f.floating = PixelType<T>::floating;
  f.width = f.height = kBlock;
  state->file = std::make_unique<detail::RawTileFile>(state->written(), f, path);
  state->checksums.assign(static_cast<size_t>(state->file->tiles_across() * ((window.height + kBlock - 1) / kBlock)),
                          0);
  state->format = f;
  state->grid = grid;
  // No more encoders than hardware threads, whatever was asked (each holds a codec and a tile).
  state->threads = std::min({resolve_threads(options.threads), resolve_threads(0), kMaxEncoders});
  // Uncompressed tiles are only copied: helpers would add copies, not speed.
  if (f.codec == detail::TileCodec::none) state->threads = 1;
  for (int t = 0; t < state->threads; ++t) {
    state->compressors.emplace_back(f);
    state->scratch.emplace_back(static_cast<size_t>(kBlock) * kBlock * static_cast<size_t>(f.sample_bytes));
  }
  if (state->cog) state->start_overviews();
  state_ = std::move(state);
}

template <class T>
GeoTiffStripWriter<T>::~GeoTiffStripWriter() {
  abort();
}

template <class T>
GeoTiffStripWriter<T>::GeoTiffStripWriter(GeoTiffStripWriter&&) noexcept = default;

template <class T>
GeoTiffStripWriter<T>& GeoTiffStripWriter<T>::operator=(GeoTiffStripWriter&& other) noexcept {
  if (this != &other) {
    abort();
    state_ = std::move(other.state_);
  }
  return *this;
}

template <class T>
int64_t GeoTiffStripWriter<T>::rows_written() const {
  return state_ ? state_->rows_written + state_->pending_rows : 0;
}

template <class T>
void GeoTiffStripWriter<T>::write_rows(const T* cells, int64_t rows) {
  if (!state_ || state_->finished) throw Error(ErrorKind::invalid_argument, "GeoTIFF writer: already finished");
  State& s = *state_;
  if (s.failed) throw Error(ErrorKind::io, "writing " + s.path + ": an earlier write failed");
  if (rows < 0 || rows > s.window.height - rows_written())
    throw Error(ErrorKind::invalid_argument, "writing " + s.path + ": more rows than the raster has");
  typename State::Scope scope;
  s.failed = true;  // until this call returns normally
  s.start_sidecar();
  const int64_t width = s.window.width;
  while (rows > 0) {
    // Rows the current band of tiles holds: kBlock, or what is left of the raster.
    const int64_t band_rows = std::min<int64_t>(kBlock, s.window.height - s.rows_written);
    if (s.pending_rows == 0 && rows >= band_rows) {
      s.write_band(cells, band_rows);
      cells += band_rows * width;
      rows -= band_rows;
      continue;
    }
    const int64_t take = std::min(rows, band_rows - s.pending_rows);
    s.pending.resize(static_cast<size_t>(kBlock * width));
    std::memcpy(s.pending.data() + s.pending_rows * width, cells, static_cast<size_t>(take * width) * sizeof(T));
    s.pending_rows += take;
    cells += take * width;
    rows -= take;
    if (s.pending_rows == band_rows) {
      s.pending_rows = 0;
      s.write_band(s.pending.data(), band_rows);
    }
  }
  s.failed = false;
}

template <class T>
const std::vector<uint64_t>& GeoTiffStripWriter<T>::tile_checksums() const {
  static const std::vector<uint64_t> none;
  return state_ ? state_->checksums : none;
}

template <class T>
void GeoTiffStripWriter<T>::take_tiles_from(const std::string& earlier, std::vector<uint64_t> checksums,
                                            const std::string& display, std::vector<int32_t> remap) {
  if (!state_ || state_->finished) throw Error(ErrorKind::invalid_argument, "GeoTIFF writer: already finished");
  State& s = *state_;
  typename State::Scope scope;
  // The same cells: extent and cell size of the window (the layout is RawTileFile's check), which
  // the TIFF holds itself: its sidecar (the categories) is not parsed.
  const GridSpec g = detail::open_raster(earlier, false).grid;
  const GridSpec& grid = s.grid;
  const double xmin = grid.xmin + static_cast<double>(s.window.col0) * grid.res;
  const double ymax = grid.ymax - static_cast<double>(s.window.row0) * grid.res;
  if (g.width != s.window.width || g.height != s.window.height || g.res != grid.res || g.xmin != xmin || g.ymax != ymax)
    throw Error(ErrorKind::invalid_argument,
                "writing " + s.path + ": " + earlier + " covers other cells than this file (extent or cell size)");
  if (PixelType<T>::floating && !remap.empty())
    throw Error(ErrorKind::invalid_argument, "writing " + s.path + ": only codes are remapped");
  try {
    // Remapped tiles are decoded and encoded again: the earlier file's layout may differ.
    s.earlier = std::make_unique<detail::RawTileFile>(
        earlier, s.format, earlier,
        remap.empty() ? detail::RawTileFile::Access::read : detail::RawTileFile::Access::raw);
  } catch (const Error& e) {
    throw Error(ErrorKind::invalid_argument, "writing " + s.path + ": its tiles cannot be copied from " + earlier +
                                                 ", whose layout (data type, compression, predictor, tiles) differs or "
                                                 "cannot be read: " +
                                                 e.what());
  }
  // Decoded here where the earlier file's layout allows (tiles of the same size, samples of
  // the file's kind), else by GDAL.
  const detail::StoredTiles& stored = s.earlier->stored();
  const bool decodes =
      stored.decodable && stored.format.width == kBlock && stored.format.height == kBlock &&
      (PixelType<T>::floating ? stored.format.floating && stored.format.sample_bytes == 4 : !stored.format.floating);
  s.decoders.clear();
  if ((s.cog || !remap.empty()) && decodes) {
    for (int i = 0; i < std::max(1, s.threads); ++i) s.decoders.emplace_back(stored.format);
  } else if (s.cog || !remap.empty()) {
    s.earlier_ds = open_raster(earlier).ds;
  }
  s.remap = std::move(remap);
  s.earlier_checksums = std::move(checksums);
  s.earlier_display = display.empty() ? earlier : display;
}

template <class T>
void GeoTiffStripWriter<T>::write_band(const T* cells, const std::vector<bool>& copy) {
  if (!state_ || state_->finished) throw Error(ErrorKind::invalid_argument, "GeoTIFF writer: already finished");
  State& s = *state_;
  if (s.failed) throw Error(ErrorKind::io, "writing " + s.path + ": an earlier write failed");
  if (!s.earlier) throw Error(ErrorKind::invalid_argument, "writing " + s.path + ": no earlier file to copy from");
  if (s.pending_rows != 0 || s.rows_written >= s.window.height)
    throw Error(ErrorKind::invalid_argument, "writing " + s.path + ": a band must start on a tile row");
  if (copy.size() != static_cast<size_t>(s.file->tiles_across()))
    throw Error(ErrorKind::invalid_argument, "writing " + s.path + ": one copy flag per tile across, " +
                                                 std::to_string(s.file->tiles_across()) + " of them");
  typename State::Scope scope;
  s.failed = true;  // until this call returns normally
  s.start_sidecar();
  s.write_band(cells, std::min<int64_t>(kBlock, s.window.height - s.rows_written), &copy);
  s.failed = false;
}

template <class T>
void GeoTiffStripWriter<T>::finish() {
  if (!state_ || state_->finished) throw Error(ErrorKind::invalid_argument, "GeoTIFF writer: already finished");
  State& s = *state_;
  if (s.failed) throw Error(ErrorKind::io, "writing " + s.path + ": an earlier write failed");
  if (rows_written() != s.window.height)
    throw Error(ErrorKind::invalid_argument, "writing " + s.path + ": " + std::to_string(rows_written()) + " of " +
                                                 std::to_string(s.window.height) + " rows written");
  typename State::Scope scope;
  s.failed = true;
  s.start_sidecar(true);  // a virtual file's, now that nothing is appended (start_sidecar)
  s.sidecar.join();
  if (s.sidecar.error) std::rethrow_exception(s.sidecar.error);
  s.file->close();  // the tile index; the directory was written at creation
  s.file.reset();
  if (s.cog) s.assemble_cog();
  s.out.commit();
  s.cog.reset();  // the staging files go now, not with the writer
  s.failed = false;
  s.finished = true;
}

template <class T>
void GeoTiffStripWriter<T>::abort() noexcept {
  if (!state_) return;
  if (!state_->finished) {
    // Closing flushes what was written; the temporary file and its sidecar are then removed by
    // the guard.
    typename State::Scope scope;
    state_->file.reset();
  }
  state_.reset();
}

template class GeoTiffStripWriter<int32_t>;
template class GeoTiffStripWriter<float>;

namespace {

template <class T>
void write_any(const std::string& path, const Raster<T>& raster, double nodata, const GeoTiffOptions& options) {
  gdal_init();
  check_raster(path, raster, nodata, options);
  // Both layouts are the strip writer's, fed the whole raster as one strip.
  GeoTiffStripWriter<T> writer(path, raster.grid(), raster.window(), nodata, options);
  writer.write_rows(raster.data(), raster.height());
  writer.finish();
}

}  // namespace

void bound_block_cache() {
  gdal_init();
  if (CPLGetConfigOption("GDAL_CACHEMAX", nullptr) != nullptr) return;
  if (GDALGetCacheMax64() > kBlockCacheBytes) GDALSetCacheMax64(kBlockCacheBytes);
}

std::string_view to_string(Compression c) {
  switch (c) {
    case Compression::fast:
      return "fast";
    case Compression::small:
      return "small";
    case Compression::deflate:
      return "deflate";
    case Compression::none:
      return "none";
  }
  return "?";
}

Compression parse_compression(std::string_view name) {
  for (Compression c : {Compression::fast, Compression::small, Compression::deflate, Compression::none})
    if (name == to_string(c)) return c;
  throw Error(ErrorKind::invalid_argument, "unknown compression profile '" + std::string(name.substr(0, 64)) +
                                               "' (expected fast, small, deflate or none)");
}

void write_geotiff(const std::string& path, const Raster<int32_t>& raster, double nodata,
                   const GeoTiffOptions& options) {
  write_any(path, raster, nodata, options);
}

void write_geotiff(const std::string& path, const Raster<float>& raster, double nodata, const GeoTiffOptions& options) {
  write_any(path, raster, nodata, options);
}

}  // namespace rv
