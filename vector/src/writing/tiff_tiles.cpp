// Tile encoding and raw tile appending. See tiff_tiles.hpp for the contract.
#include "writing/tiff_tiles.hpp"

#include <bit>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>

#include <cpl_vsi.h>
#include <libdeflate.h>
#include <tiffio.h>
#include <zstd.h>

#include "rv/field/error.hpp"

namespace rv::detail {
namespace {

// Horizontal differencing (TIFF predictor 2) of one row of n samples of type U, in place, with
// wraparound: what libtiff's encoder does to each row of a tile before compressing it.
template <class U>
void difference_row(U* row, int n) {
  for (int i = n - 1; i > 0; --i) row[i] = static_cast<U>(row[i] - row[i - 1]);
}

// The floating-point predictor (3) of one row of n samples of `bytes` bytes: the samples' bytes
// regrouped into planes, most significant first, then every byte differenced from the one
// before it across the whole row (TIFF Technical Note 3, as libtiff encodes it).
void float_predict_row(uint8_t* row, int n, int bytes, uint8_t* scratch) {
  for (int i = 0; i < n; ++i)
    for (int b = 0; b < bytes; ++b) scratch[(bytes - 1 - b) * n + i] = row[i * bytes + b];
  const int count = n * bytes;
  row[0] = scratch[0];
  for (int i = 1; i < count; ++i) row[i] = static_cast<uint8_t>(scratch[i] - scratch[i - 1]);
}

// Predictor 2 undone: each sample the sum of the differences before it, with wraparound.
template <class U>
void accumulate_row(U* row, int n) {
  for (int i = 1; i < n; ++i) row[i] = static_cast<U>(row[i] + row[i - 1]);
}

// Predictor 3 undone: the bytes summed back across the row, then the planes put back into samples.
void float_unpredict_row(uint8_t* row, int n, int bytes, uint8_t* scratch) {
  const int count = n * bytes;
  scratch[0] = row[0];
  for (int i = 1; i < count; ++i) scratch[i] = static_cast<uint8_t>(row[i] + scratch[i - 1]);
  for (int i = 0; i < n; ++i)
    for (int b = 0; b < bytes; ++b) row[i * bytes + b] = scratch[(bytes - 1 - b) * n + i];
}

[[noreturn]] void codec_failed(const char* what) {
  throw Error(ErrorKind::internal, std::string("tile encoding: ") + what);
}

}  // namespace

TileCompressor::TileCompressor(const TileFormat& format) : format_(format) {
  if (format_.codec == TileCodec::zstd) {
    zstd_ = ZSTD_createCCtx();
    if (zstd_ == nullptr) throw std::bad_alloc();
  } else if (format_.codec == TileCodec::deflate) {
    deflate_ = libdeflate_alloc_compressor(format_.level);
    if (deflate_ == nullptr) throw std::bad_alloc();
  }
  if (format_.predictor == 3) row_.resize(static_cast<size_t>(format_.width * format_.sample_bytes));
}

TileCompressor::~TileCompressor() {
  ZSTD_freeCCtx(zstd_);
  libdeflate_free_compressor(deflate_);
}

TileCompressor::TileCompressor(TileCompressor&& other) noexcept
    : format_(other.format_),
      zstd_(std::exchange(other.zstd_, nullptr)),
      deflate_(std::exchange(other.deflate_, nullptr)),
      row_(std::move(other.row_)) {}

EncodedTile TileCompressor::encode(uint8_t* tile, std::vector<uint8_t>& out) {
  const int w = format_.width, h = format_.height, bytes = format_.sample_bytes;
  const size_t row_bytes = static_cast<size_t>(w) * static_cast<size_t>(bytes);
  const size_t n = row_bytes * static_cast<size_t>(h);
  if (format_.predictor == 2) {
    for (int r = 0; r < h; ++r) {
      uint8_t* row = tile + static_cast<size_t>(r) * row_bytes;
      switch (bytes) {
        case 1:
          difference_row(row, w);
          break;
        case 2:
          difference_row(reinterpret_cast<uint16_t*>(row), w);
          break;
        default:
          difference_row(reinterpret_cast<uint32_t*>(row), w);
          break;
      }
    }
  } else if (format_.predictor == 3) {
    for (int r = 0; r < h; ++r) float_predict_row(tile + static_cast<size_t>(r) * row_bytes, w, bytes, row_.data());
  }
  // `out` only grows: resizing it down and up again would zero the bytes each time.
  switch (format_.codec) {
    case TileCodec::none:
      return {tile, n};
    case TileCodec::zstd: {
      const size_t bound = ZSTD_compressBound(n);
      if (out.size() < bound) out.resize(bound);
      const size_t got = ZSTD_compressCCtx(zstd_, out.data(), bound, tile, n, format_.level);
      if (ZSTD_isError(got)) codec_failed(ZSTD_getErrorName(got));
      return {out.data(), got};
    }
    case TileCodec::deflate: {
      const size_t bound = libdeflate_zlib_compress_bound(deflate_, n);
      if (out.size() < bound) out.resize(bound);
      const size_t got = libdeflate_zlib_compress(deflate_, tile, n, out.data(), bound);
      if (got == 0) codec_failed("DEFLATE output over its bound");
      return {out.data(), got};
    }
  }
  codec_failed("unknown codec");
}

TileDecompressor::TileDecompressor(const TileFormat& format) : format_(format) {
  if (format_.codec == TileCodec::zstd) {
    zstd_ = ZSTD_createDCtx();
    if (zstd_ == nullptr) throw std::bad_alloc();
  } else if (format_.codec == TileCodec::deflate) {
    deflate_ = libdeflate_alloc_decompressor();
    if (deflate_ == nullptr) throw std::bad_alloc();
  }
  if (format_.predictor == 3) row_.resize(static_cast<size_t>(format_.width * format_.sample_bytes));
}

TileDecompressor::~TileDecompressor() {
  ZSTD_freeDCtx(zstd_);
  libdeflate_free_decompressor(deflate_);
}

TileDecompressor::TileDecompressor(TileDecompressor&& other) noexcept
    : format_(other.format_),
      zstd_(std::exchange(other.zstd_, nullptr)),
      deflate_(std::exchange(other.deflate_, nullptr)),
      row_(std::move(other.row_)) {}

void TileDecompressor::decode(EncodedTile bytes, uint8_t* tile) {
  const int w = format_.width, h = format_.height, sample = format_.sample_bytes;
  const size_t row_bytes = static_cast<size_t>(w) * static_cast<size_t>(sample);
  const size_t n = row_bytes * static_cast<size_t>(h);
  auto bad = [](const std::string& why) { throw Error(ErrorKind::io, "a stored tile does not decode: " + why); };
  switch (format_.codec) {
    case TileCodec::none:
      if (bytes.size != n) bad("its size is not the tile's");
      std::memcpy(tile, bytes.data, n);
      break;
    case TileCodec::zstd: {
      const size_t got = ZSTD_decompressDCtx(zstd_, tile, n, bytes.data, bytes.size);
      if (ZSTD_isError(got)) bad(ZSTD_getErrorName(got));
      if (got != n) bad("ZSTD gave " + std::to_string(got) + " bytes of " + std::to_string(n));
      break;
    }
    case TileCodec::deflate: {
      size_t got = 0;
      if (libdeflate_zlib_decompress(deflate_, bytes.data, bytes.size, tile, n, &got) != LIBDEFLATE_SUCCESS || got != n)
        bad("DEFLATE data damaged or of another size");
      break;
    }
  }
  if (format_.predictor == 2) {
    for (int r = 0; r < h; ++r) {
      uint8_t* row = tile + static_cast<size_t>(r) * row_bytes;
      switch (sample) {
        case 1:
          accumulate_row(row, w);
          break;
        case 2:
          accumulate_row(reinterpret_cast<uint16_t*>(row), w);
          break;
        default:
          accumulate_row(reinterpret_cast<uint32_t*>(row), w);
          break;
      }
    }
  } else if (format_.predictor == 3) {
    for (int r = 0; r < h; ++r) float_unpredict_row(tile + static_cast<size_t>(r) * row_bytes, w, sample, row_.data());
  }
}

// libtiff's I/O goes through GDAL's virtual file layer, so that every path GDAL writes (a
// /vsimem/ file in tests and the fuzzers) takes the same route.
struct RawTileFileAccess {
  static VSILFILE* file(thandle_t h) { return static_cast<VSILFILE*>(h); }
  static tmsize_t read(thandle_t h, void* buf, tmsize_t n) {
    return static_cast<tmsize_t>(VSIFReadL(buf, 1, static_cast<size_t>(n), file(h)));
  }
  static tmsize_t write(thandle_t h, void* buf, tmsize_t n) {
    return static_cast<tmsize_t>(VSIFWriteL(buf, 1, static_cast<size_t>(n), file(h)));
  }
  static toff_t seek(thandle_t h, toff_t off, int whence) {
    VSILFILE* f = file(h);
    vsi_l_offset target = off;
    if (whence == SEEK_CUR) {
      target = VSIFTellL(f) + static_cast<vsi_l_offset>(static_cast<int64_t>(off));
    } else if (whence == SEEK_END) {
      if (VSIFSeekL(f, 0, SEEK_END) != 0) return static_cast<toff_t>(-1);
      target = VSIFTellL(f) + static_cast<vsi_l_offset>(static_cast<int64_t>(off));
    }
    if (VSIFSeekL(f, target, SEEK_SET) != 0) return static_cast<toff_t>(-1);
    return VSIFTellL(f);
  }
  static int close(thandle_t) { return 0; }  // RawTileFile closes the VSILFILE itself
  static toff_t size(thandle_t h) {
    VSILFILE* f = file(h);
    const vsi_l_offset here = VSIFTellL(f);
    VSIFSeekL(f, 0, SEEK_END);
    const vsi_l_offset end = VSIFTellL(f);
    VSIFSeekL(f, here, SEEK_SET);
    return end;
  }
  static int map(thandle_t, void**, toff_t*) { return 0; }
  static void unmap(thandle_t, void*, toff_t) {}
  // Errors are kept for the exception; warnings (the GeoTIFF and GDAL tags libtiff does not
  // know, met when it reads the directory) are dropped.
  static int on_error(TIFF*, void* user, const char* module, const char* fmt, va_list ap) {
    char text[512];
    std::vsnprintf(text, sizeof(text), fmt, ap);
    std::string& errors = static_cast<RawTileFile*>(user)->errors_;
    if (!errors.empty()) errors += "; ";
    errors += (module != nullptr ? std::string(module) + ": " : std::string()) + text;
    return 1;
  }
  static int on_warning(TIFF*, void*, const char*, const char*, va_list) { return 1; }
};

RawTileFile::RawTileFile(const std::string& path, const TileFormat& format, const std::string& display, Access access)
    : display_(display), verb_(access == Access::update ? "writing" : "reading") {
  // A constructor that throws runs no destructor: what open() got is released here.
  try {
    open(path, format, access);
  } catch (...) {
    release();
    throw;
  }
}

void RawTileFile::open(const std::string& path, const TileFormat& format, Access access) {
  using A = RawTileFileAccess;
  const bool update = access == Access::update;
  file_ = VSIFOpenL(path.c_str(), update ? "r+b" : "rb");
  if (file_ == nullptr) fail(update ? "cannot reopen the file to write its tiles" : "cannot open the file");
  TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
  if (opts == nullptr) throw std::bad_alloc();
  TIFFOpenOptionsSetErrorHandlerExtR(opts, &A::on_error, this);
  TIFFOpenOptionsSetWarningHandlerExtR(opts, &A::on_warning, this);
  tif_ = TIFFClientOpenExt(path.c_str(), update ? "r+m" : "rm", static_cast<thandle_t>(file_), &A::read, &A::write,
                           &A::seek, &A::close, &A::size, &A::map, &A::unmap, opts);
  TIFFOpenOptionsFree(opts);
  if (tif_ == nullptr) fail(update ? "libtiff cannot open it for update" : "libtiff cannot open it");
  uint32_t width = 0, height = 0, tile_w = 0, tile_h = 0;
  uint16_t bits = 0, spp = 0, sample_format = 0, compression = 0, predictor = 1;
  TIFFGetField(tif_, TIFFTAG_IMAGEWIDTH, &width);
  TIFFGetField(tif_, TIFFTAG_IMAGELENGTH, &height);
  TIFFGetField(tif_, TIFFTAG_TILEWIDTH, &tile_w);
  TIFFGetField(tif_, TIFFTAG_TILELENGTH, &tile_h);
  TIFFGetFieldDefaulted(tif_, TIFFTAG_BITSPERSAMPLE, &bits);
  TIFFGetFieldDefaulted(tif_, TIFFTAG_SAMPLESPERPIXEL, &spp);
  TIFFGetFieldDefaulted(tif_, TIFFTAG_SAMPLEFORMAT, &sample_format);
  TIFFGetFieldDefaulted(tif_, TIFFTAG_COMPRESSION, &compression);
  if (compression != COMPRESSION_NONE && TIFFGetFieldDefaulted(tif_, TIFFTAG_PREDICTOR, &predictor) != 1) predictor = 1;
  const uint16_t want_compression = format.codec == TileCodec::zstd      ? COMPRESSION_ZSTD
                                    : format.codec == TileCodec::deflate ? COMPRESSION_ADOBE_DEFLATE
                                                                         : COMPRESSION_NONE;
  const uint16_t want_format = format.floating                     ? SAMPLEFORMAT_IEEEFP
                               : sample_format == SAMPLEFORMAT_INT ? SAMPLEFORMAT_INT
                                                                   : SAMPLEFORMAT_UINT;
  constexpr bool little_endian_host = std::endian::native == std::endian::little;
  // How the tiles are stored, for a reader that decodes them itself.
  TileFormat& f = stored_.format;
  f.codec = compression == COMPRESSION_ZSTD                                                  ? TileCodec::zstd
            : compression == COMPRESSION_ADOBE_DEFLATE || compression == COMPRESSION_DEFLATE ? TileCodec::deflate
                                                                                             : TileCodec::none;
  f.predictor = predictor;
  f.sample_bytes = bits / 8;
  f.floating = sample_format == SAMPLEFORMAT_IEEEFP;
  f.width = static_cast<int>(tile_w);
  f.height = static_cast<int>(tile_h);
  stored_.is_signed = sample_format == SAMPLEFORMAT_INT;
  const bool known_codec = compression == COMPRESSION_NONE || compression == COMPRESSION_ZSTD ||
                           compression == COMPRESSION_ADOBE_DEFLATE || compression == COMPRESSION_DEFLATE;
  stored_.decodable = known_codec && (bits == 8 || bits == 16 || bits == 32) && spp == 1 &&
                      (predictor == 1 || predictor == 2 || (predictor == 3 && f.floating)) &&
                      TIFFIsByteSwapped(tif_) == 0 && little_endian_host && TIFFIsTiled(tif_) && tile_w > 0 &&
                      tile_h > 0;
  if (access == Access::raw) {
    if (!TIFFIsTiled(tif_) || spp != 1 || tile_w == 0 || tile_h == 0 || width == 0 || height == 0)
      fail("it is not a tiled raster of one band");
  } else if (!TIFFIsTiled(tif_) || spp != 1 || tile_w != static_cast<uint32_t>(format.width) ||
             tile_h != static_cast<uint32_t>(format.height) || bits != 8 * format.sample_bytes ||
             sample_format != want_format || compression != want_compression || predictor != format.predictor ||
             TIFFIsByteSwapped(tif_) != 0 || !little_endian_host || width == 0 || height == 0)
    fail("its layout is not the one its tiles are encoded for");
  tiles_across_ = (static_cast<int64_t>(width) + tile_w - 1) / tile_w;
  tiles_down_ = (static_cast<int64_t>(height) + tile_h - 1) / tile_h;
}

RawTileFile::~RawTileFile() { release(); }

void RawTileFile::release() noexcept {
  if (tif_ != nullptr) TIFFClose(tif_);
  tif_ = nullptr;
  if (file_ != nullptr) VSIFCloseL(static_cast<VSILFILE*>(file_));
  file_ = nullptr;
}

void RawTileFile::append(int64_t bx, int64_t by, EncodedTile bytes) {
  if (bx < 0 || by < 0 || bx >= tiles_across_ || by >= tiles_down_) fail("tile index out of range");
  const auto index = static_cast<uint32_t>(by * tiles_across_ + bx);
  // TIFFWriteRawTile does not write through the pointer; its signature is not const.
  void* data = const_cast<uint8_t*>(bytes.data);
  errno = 0;
  if (TIFFWriteRawTile(tif_, index, data, static_cast<tmsize_t>(bytes.size)) != static_cast<tmsize_t>(bytes.size)) {
    // The system's reason (a full disk, a file size limit) says more than libtiff's.
    const int e = errno;
    fail("cannot write tile (" + std::to_string(bx) + ", " + std::to_string(by) + ")" +
         (e != 0 ? std::string(": ") + std::strerror(e) : std::string()));
  }
}

EncodedTile RawTileFile::read(int64_t bx, int64_t by, std::vector<uint8_t>& buf) {
  const std::string name = "tile (" + std::to_string(bx) + ", " + std::to_string(by) + ")";
  if (bx < 0 || by < 0 || bx >= tiles_across_ || by >= tiles_down_) fail(name + " is out of range");
  const auto index = static_cast<uint32_t>(by * tiles_across_ + bx);
  const uint64_t size = TIFFGetStrileByteCount(tif_, index);
  if (size == 0) fail(name + " is empty");
  if (buf.size() < size) buf.resize(size);
  if (TIFFReadRawTile(tif_, index, buf.data(), static_cast<tmsize_t>(size)) != static_cast<tmsize_t>(size))
    fail("cannot read " + name);
  return {buf.data(), size};
}

void RawTileFile::close() {
  // TIFFFlush rewrites only the tile offset and byte count arrays when nothing else changed
  // (TIFFForceStrileArrayWriting), else the whole directory.
  const bool flushed = TIFFFlush(tif_) == 1;
  TIFFClose(tif_);
  tif_ = nullptr;
  const bool closed = VSIFCloseL(static_cast<VSILFILE*>(file_)) == 0;
  file_ = nullptr;
  if (!flushed || !errors_.empty()) fail("cannot write the tile index");
  if (!closed) fail("cannot close the file");
}

void RawTileFile::fail(const std::string& what) {
  throw Error(ErrorKind::io,
              std::string(verb_) + " " + display_ + ": " + what + (errors_.empty() ? "" : " (" + errors_ + ")"));
}

}  // namespace rv::detail
