// A COG assembled from tiles already encoded (internal to rv_vector): the full resolution's from
// the plain tiled GeoTIFF GeoTiffStripWriter staged, the overviews' from a TileSpool, copied
// byte for byte, never decoded.
//
// The file (what GDAL 3.6's COG driver writes, and what its validator
// validate_cloud_optimized_geotiff.py checks):
//   - the TIFF header, little-endian; classic TIFF unless the file would reach 4 GiB, then
//     BigTIFF (decided on the exact size, which is known: GDAL's BIGTIFF=IF_SAFER estimates it);
//   - GDAL's structural metadata ("ghost area") right after the header: LAYOUT=IFDS_BEFORE_DATA,
//     BLOCK_ORDER=ROW_MAJOR, BLOCK_LEADER=SIZE_AS_UINT4, BLOCK_TRAILER=LAST_4_BYTES_REPEATED,
//     KNOWN_INCOMPATIBLE_EDITION=NO. GDAL reports LAYOUT=COG (IMAGE_STRUCTURE) only for a file
//     that declares all of these, so the tiles carry the leader and trailer they promise;
//   - every IFD, each followed by its values: the full resolution first, with every tag of the
//     staged file's first IFD (size, tiles, compression, predictor, sample format and bits,
//     GeoTIFF tags 33550/33922/34735/34736/34737, GDAL_METADATA 42112, GDAL_NODATA 42113), then
//     the overviews, largest first (NewSubfileType 1, their size, and the staged IFD's image
//     structure tags 258, 259, 262, 277, 284, 317, 322, 323, 339 and 42113: no georeferencing);
//   - the tiles, the smallest overview's first and the full resolution's last, each level's
//     row-major, each as a 4-byte little-endian leader holding its size, its bytes, and its last
//     4 bytes again.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "writing/cog_overviews.hpp"
#include "writing/tiff_tiles.hpp"

namespace rv::detail {

// Encoded overview tiles appended to a temporary file as they are made, and where each went.
// Not thread-safe.
class TileSpool {
 public:
  // Creates `path` (any path GDAL's virtual file layer writes; the caller removes it) for the
  // tiles of `levels` (largest first). `display` names the COG in messages. Throws rv::Error(io).
  TileSpool(const std::string& path, std::vector<LevelSize> levels, const std::string& display);
  ~TileSpool();  // closes without reporting
  TileSpool(const TileSpool&) = delete;
  TileSpool& operator=(const TileSpool&) = delete;

  const std::vector<LevelSize>& levels() const { return levels_; }
  // Appends the next tile of `level` (0 = largest; row-major, one tile row after another).
  // Throws rv::Error(io).
  void append(int level, EncodedTile tile);
  // Tiles appended to `level` so far, and the size of tile `index` of it.
  size_t tile_count(int level) const { return tiles_[static_cast<size_t>(level)].size(); }
  uint64_t tile_size(int level, size_t index) const { return tiles_[static_cast<size_t>(level)][index].second; }
  // Tile `index` of `level`, into `buf` (grown as needed; valid until the next call with it).
  // Throws rv::Error(io).
  EncodedTile read(int level, size_t index, std::vector<uint8_t>& buf);

 private:
  [[noreturn]] void fail(const std::string& what) const;

  void* file_ = nullptr;  // the VSILFILE
  std::string display_;
  std::vector<LevelSize> levels_;
  std::vector<std::vector<std::pair<uint64_t, uint64_t>>> tiles_;  // per level: offset, size
  uint64_t end_ = 0;
  bool at_end_ = true;  // the file position is end_ (no read since the last append)
};

// Writes the COG to `target` (a new file, any path GDAL's virtual file layer writes; on failure
// the caller removes it): the tags and full-resolution tiles of `staged`, a little-endian tiled
// GeoTIFF with one band and no other IFD that RawTileFile closed, and the overview tiles of
// `overviews`, which must hold every tile of each of its levels, encoded like the staged ones.
// `bigtiff` forces BigTIFF (tests). `display` names the COG in messages. Throws rv::Error(io) when
// a file cannot be read or written or `staged` is not such a file, naming `display`.
void assemble_cog(const std::string& staged, TileSpool& overviews, const std::string& target,
                  const std::string& display, bool bigtiff = false);

}  // namespace rv::detail
