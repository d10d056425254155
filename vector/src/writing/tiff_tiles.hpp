// Tiles of a tiled GeoTIFF encoded here and appended raw (internal to rv_vector).
//
// GDAL creates and describes the file (georeferencing, nodata, metadata, compression and
// predictor tags) with every tile left empty (SPARSE_OK); TileCompressor then applies the TIFF
// predictor and codec to each tile in the caller's threads, and RawTileFile appends the bytes
// with libtiff (TIFFWriteRawTile) and rewrites only the tile offset and byte count arrays at the
// end. Every tile holds what libtiff's own encoder would put there, the same predictor and codec
// over the same bytes; only the ZSTD frames differ in their headers (a one-shot frame records
// the tile's size), and both decode alike. What it saves: GDAL's compression pool gives each
// tile a fresh in-memory TIFF and codec state, whose allocations and copies cost more than ZSTD
// itself on owner codes (bench/RESULTS-encoding.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

struct tiff;
struct ZSTD_CCtx_s;
struct ZSTD_DCtx_s;
struct libdeflate_compressor;
struct libdeflate_decompressor;

namespace rv::detail {

enum class TileCodec { none, zstd, deflate };

// An encoded tile: `size` bytes at `data` (in the tile itself or in the caller's buffer).
struct EncodedTile {
  const uint8_t* data = nullptr;
  size_t size = 0;
};

// How every tile of one file is encoded; must agree with the file's tags (RawTileFile checks).
struct TileFormat {
  TileCodec codec = TileCodec::none;
  int level = 0;                  // codec level (ZSTD 1..22, DEFLATE 1..12); unused for none
  int predictor = 1;              // TIFF predictor: 1 none, 2 horizontal differencing, 3 floating point
  int sample_bytes = 1;           // 1, 2 or 4
  bool floating = false;          // IEEE float samples (predictor 3 only applies to them)
  int width = 256, height = 256;  // tile size in samples
};

// Predictor then codec for one tile. One per thread: it owns the codec's state, reused from tile
// to tile. Not thread-safe; movable.
class TileCompressor {
 public:
  explicit TileCompressor(const TileFormat& format);
  ~TileCompressor();
  TileCompressor(TileCompressor&& other) noexcept;
  TileCompressor& operator=(TileCompressor&&) = delete;
  TileCompressor(const TileCompressor&) = delete;
  TileCompressor& operator=(const TileCompressor&) = delete;

  // `tile`: width * height samples, row-major, native byte order (little-endian files only);
  // the predictor works in place. Returns the bytes to store: the tile itself without a codec
  // (no copy), else the front of `out` (grown as needed, never shrunk; only the returned bytes are
  // meaningful). Valid until the next call with the same tile or buffer. Throws
  // rv::Error(internal) when the codec fails.
  EncodedTile encode(uint8_t* tile, std::vector<uint8_t>& out);

 private:
  TileFormat format_;
  ZSTD_CCtx_s* zstd_ = nullptr;
  libdeflate_compressor* deflate_ = nullptr;
  std::vector<uint8_t> row_;  // predictor 3's row scratch
};

// How an existing file's tiles are stored (RawTileFile::stored()). `decodable`: TileDecompressor
// undoes its codec and predictor (no codec, ZSTD or DEFLATE; predictor 1, 2, or 3 on floats;
// 8, 16 or 32-bit samples in the host's byte order).
struct StoredTiles {
  TileFormat format;
  bool is_signed = false;  // integer samples: SAMPLEFORMAT_INT
  bool decodable = false;
};

// Codec then predictor undone for one stored tile: what TileCompressor (or libtiff) encoded, back
// to width * height samples, row-major, native byte order. One per thread: it owns the codec's
// state. Not thread-safe; movable.
class TileDecompressor {
 public:
  explicit TileDecompressor(const TileFormat& format);
  ~TileDecompressor();
  TileDecompressor(TileDecompressor&& other) noexcept;
  TileDecompressor& operator=(TileDecompressor&&) = delete;
  TileDecompressor(const TileDecompressor&) = delete;
  TileDecompressor& operator=(const TileDecompressor&) = delete;

  // Decodes `bytes` into `tile` (width * height * sample_bytes bytes). Throws rv::Error(io) when
  // they do not decode to exactly one tile.
  void decode(EncodedTile bytes, uint8_t* tile);

 private:
  TileFormat format_;
  ZSTD_DCtx_s* zstd_ = nullptr;
  libdeflate_decompressor* deflate_ = nullptr;
  std::vector<uint8_t> row_;  // predictor 3's row scratch
};

// A tiled TIFF opened through GDAL's virtual file layer (any path GDAL can write, /vsimem/
// included): for update, to which encoded tiles are appended, or read-only, from which a tile's
// encoded bytes are read as they are (an earlier file whose unchanged tiles a new one copies), or
// `raw`: read-only, any tiled layout (its tiles' bytes checksummed, never decoded here).
// Not thread-safe.
class RawTileFile {
 public:
  enum class Access { update, read, raw };
  // Opens `path` (written by GDAL, not open elsewhere for update) and checks that its layout is
  // the one the tiles are encoded for: tiled, one band, `format`'s tile size, sample size and
  // kind, compression and predictor tags, and the host's byte order (Access::raw: tiled, one band,
  // `format` unused). Throws rv::Error(io) naming
  // `display` (the user's name for the file) with libtiff's reason.
  RawTileFile(const std::string& path, const TileFormat& format, const std::string& display,
              Access access = Access::update);
  ~RawTileFile();  // closes without reporting (the caller removes a file it gave up)
  RawTileFile(const RawTileFile&) = delete;
  RawTileFile& operator=(const RawTileFile&) = delete;

  // Tiles across the image.
  int64_t tiles_across() const { return tiles_across_; }
  // How the file's tiles are stored (read from its tags).
  const StoredTiles& stored() const { return stored_; }
  // Appends the encoded bytes of tile (bx, by) (Access::update). Throws rv::Error(io).
  void append(int64_t bx, int64_t by, EncodedTile bytes);
  // The encoded bytes of tile (bx, by) as stored, into `buf` (grown as needed): valid until the
  // next call with it. Throws rv::Error(io) for a tile out of range, empty (sparse) or unreadable.
  EncodedTile read(int64_t bx, int64_t by, std::vector<uint8_t>& buf);
  // Writes the tile arrays and closes. Throws rv::Error(io).
  void close();

 private:
  void open(const std::string& path, const TileFormat& format, Access access);
  void release() noexcept;  // closes whatever is open, without reporting
  [[noreturn]] void fail(const std::string& what);

  tiff* tif_ = nullptr;
  void* file_ = nullptr;  // the VSILFILE under tif_
  std::string display_;
  std::string errors_;  // libtiff's error messages for this handle
  int64_t tiles_across_ = 0;
  int64_t tiles_down_ = 0;
  StoredTiles stored_;
  const char* verb_ = "writing";  // for messages: "reading" an earlier file

  friend struct RawTileFileAccess;
};

}  // namespace rv::detail
