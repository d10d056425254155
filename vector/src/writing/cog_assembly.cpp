// COG assembly from encoded tiles. See cog_assembly.hpp for the contract.
//
// The TIFF structure is written here, not by libtiff (whose TIFFDeferStrileArrayWriting and
// TIFFForceStrileArrayWriting, libtiff >= 4.1, let a writer put the IFDs before the data):
//  - the layout GDAL recognises as a COG needs bytes libtiff has no notion of: the ghost area
//    between the header and the first IFD, and a leader and trailer around every tile
//    (TIFFWriteRawTile writes a tile's bytes alone, at the end of the file);
//  - the staged IFD's tags are copied as GDAL wrote them, values unchanged: libtiff knows the
//    GeoTIFF and GDAL tags only once registered (GDAL does it through libgeotiff), and would
//    rewrite what it parsed;
//  - the structure is small (sorted entries, their values, two arrays per IFD), and every offset
//    is known before the first byte is written, so the file is written once, front to back.
// Files go through GDAL's virtual file layer, like every file the writers make (/vsimem/ in tests
// and the fuzzers).
#include "writing/cog_assembly.hpp"

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <string>
#include <utility>

#include <cpl_vsi.h>

#include "rv/field/error.hpp"

namespace rv::detail {
namespace {

constexpr uint16_t kNewSubfileType = 254, kImageWidth = 256, kImageLength = 257, kTileWidth = 322, kTileLength = 323,
                   kTileOffsets = 324, kTileByteCounts = 325;
constexpr uint16_t kTypeShort = 3, kTypeLong = 4, kTypeLong8 = 16;
// The staged IFD's tags an overview's IFD repeats: how its tiles are stored and what nodata is.
constexpr uint16_t kOverviewTags[] = {258, 259, 262, 277, 284, 317, kTileWidth, kTileLength, 339, 42113};
// GDAL's structural metadata, as its COG driver writes it (the trailing space included).
constexpr char kGhostBody[] =
    "LAYOUT=IFDS_BEFORE_DATA\nBLOCK_ORDER=ROW_MAJOR\nBLOCK_LEADER=SIZE_AS_UINT4\n"
    "BLOCK_TRAILER=LAST_4_BYTES_REPEATED\nKNOWN_INCOMPATIBLE_EDITION=NO\n ";
// Bounds on what a staged IFD may hold (ours holds about 20 tags and one entry per tile).
constexpr uint64_t kMaxEntries = 4096;
constexpr uint64_t kMaxValueBytes = uint64_t{1} << 31;

// Bytes of one value of a TIFF field type; 0 for a type this reader does not know.
uint64_t type_size(uint16_t type) {
  switch (type) {
    case 1:  // BYTE
    case 2:  // ASCII
    case 6:  // SBYTE
    case 7:  // UNDEFINED
      return 1;
    case 3:  // SHORT
    case 8:  // SSHORT
      return 2;
    case 4:   // LONG
    case 9:   // SLONG
    case 11:  // FLOAT
    case 13:  // IFD
      return 4;
    case 5:   // RATIONAL
    case 10:  // SRATIONAL
    case 12:  // DOUBLE
    case 16:  // LONG8
    case 17:  // SLONG8
    case 18:  // IFD8
      return 8;
    default:
      return 0;
  }
}

uint64_t get_le(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

void put_le(std::vector<uint8_t>& out, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<uint8_t>(v >> (8 * i)));
}

// One IFD entry with its value's bytes (little-endian), wherever the file kept them.
struct Entry {
  uint16_t tag = 0;
  uint16_t type = 0;
  uint64_t count = 0;
  std::vector<uint8_t> value;
};

Entry integer_entry(uint16_t tag, uint16_t type, const std::vector<uint64_t>& values) {
  Entry e{tag, type, values.size(), {}};
  const int bytes = static_cast<int>(type_size(type));
  e.value.reserve(values.size() * static_cast<size_t>(bytes));
  for (uint64_t v : values) put_le(e.value, v, bytes);
  return e;
}

Entry size_entry(uint16_t tag, uint64_t size) {
  return integer_entry(tag, size <= UINT16_MAX ? kTypeShort : kTypeLong, {size});
}

// A file read through GDAL's virtual file layer; errors name the COG being written.
class Input {
 public:
  Input(const std::string& path, const std::string& display) : display_(display) {
    file_ = VSIFOpenL(path.c_str(), "rb");
    if (file_ == nullptr) fail("cannot open the staged tiles " + path);
  }
  ~Input() {
    if (file_ != nullptr) VSIFCloseL(file_);
  }
  Input(const Input&) = delete;
  Input& operator=(const Input&) = delete;

  void read(uint64_t offset, void* out, uint64_t n) {
    if (VSIFSeekL(file_, offset, SEEK_SET) != 0 || VSIFReadL(out, 1, n, file_) != n)
      fail("cannot read the staged tiles (" + std::to_string(n) + " bytes at " + std::to_string(offset) + ")");
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(ErrorKind::io, "writing " + display_ + ": " + what);
  }

 private:
  VSILFILE* file_ = nullptr;
  std::string display_;
};

// The staged file's first IFD: its tags but the tile arrays, and the tiles' places.
struct Staged {
  std::vector<Entry> entries;
  std::vector<uint64_t> offsets, sizes;
  uint64_t tile_width = 0, tile_length = 0;
};

std::vector<uint64_t> integers(const Entry& e, Input& in) {
  const uint64_t size = type_size(e.type);
  if (e.type != kTypeShort && e.type != kTypeLong && e.type != kTypeLong8)
    in.fail("tag " + std::to_string(e.tag) + " of the staged file is not an integer");
  std::vector<uint64_t> out(e.count);
  for (uint64_t i = 0; i < e.count; ++i) out[i] = get_le(e.value.data() + i * size, static_cast<int>(size));
  return out;
}

Staged read_staged(Input& in) {
  uint8_t header[16];
  in.read(0, header, sizeof(header));
  const uint64_t magic = get_le(header + 2, 2);
  if (header[0] != 'I' || header[1] != 'I' || (magic != 42 && magic != 43))
    in.fail("the staged file is not a little-endian TIFF");
  const bool big = magic == 43;
  const int count_bytes = big ? 8 : 2, field_bytes = big ? 8 : 4, entry_bytes = big ? 20 : 12;
  const uint64_t ifd = big ? get_le(header + 8, 8) : get_le(header + 4, 4);
  uint8_t count_field[8];
  in.read(ifd, count_field, static_cast<uint64_t>(count_bytes));
  const uint64_t n = get_le(count_field, count_bytes);
  if (n == 0 || n > kMaxEntries) in.fail("the staged file's directory is not one this writer made");
  std::vector<uint8_t> raw(n * static_cast<uint64_t>(entry_bytes));
  in.read(ifd + static_cast<uint64_t>(count_bytes), raw.data(), raw.size());
  Staged s;
  std::vector<uint64_t> dims(4, 0);  // width, length, tile width, tile length
  for (uint64_t i = 0; i < n; ++i) {
    const uint8_t* p = raw.data() + i * static_cast<uint64_t>(entry_bytes);
    Entry e{
        static_cast<uint16_t>(get_le(p, 2)), static_cast<uint16_t>(get_le(p + 2, 2)), get_le(p + 4, big ? 8 : 4), {}};
    const uint8_t* field = p + (big ? 12 : 8);
    const uint64_t unit = type_size(e.type);
    if (unit == 0 || e.count > kMaxValueBytes / unit)
      in.fail("tag " + std::to_string(e.tag) + " of the staged file has an unknown type or size");
    e.value.resize(e.count * unit);
    if (e.value.size() <= static_cast<size_t>(field_bytes))
      std::memcpy(e.value.data(), field, e.value.size());
    else
      in.read(get_le(field, field_bytes), e.value.data(), e.value.size());
    if (e.tag == kTileOffsets) {
      s.offsets = integers(e, in);
    } else if (e.tag == kTileByteCounts) {
      s.sizes = integers(e, in);
    } else {
      const uint16_t dim_tags[] = {kImageWidth, kImageLength, kTileWidth, kTileLength};
      for (size_t d = 0; d < 4; ++d)
        if (e.tag == dim_tags[d] && e.count == 1) dims[d] = integers(e, in)[0];
      if (e.tag == kNewSubfileType) continue;
      // A staged BigTIFF (GDAL's IF_SAFER) may hold LONG8 values; as LONG they fit a classic COG.
      if (e.type == kTypeLong8) {
        const std::vector<uint64_t> v = integers(e, in);
        if (std::all_of(v.begin(), v.end(), [](uint64_t x) { return x <= UINT32_MAX; }))
          e = integer_entry(e.tag, kTypeLong, v);
      }
      s.entries.push_back(std::move(e));
    }
  }
  if (dims[2] == 0 || dims[3] == 0) in.fail("the staged file is not tiled");
  s.tile_width = dims[2];
  s.tile_length = dims[3];
  const uint64_t tiles = (dims[0] + dims[2] - 1) / dims[2] * ((dims[1] + dims[3] - 1) / dims[3]);
  if (tiles == 0 || s.offsets.size() != tiles || s.sizes.size() != tiles)
    in.fail("the staged file's tile index does not match its size");
  return s;
}

// One IFD of the COG: its tags but the tile arrays, and its tiles' sizes and places.
struct Ifd {
  std::vector<Entry> entries;
  std::vector<uint64_t> sizes;
  std::vector<uint64_t> offsets;  // of each tile's bytes, after its leader
};

std::string ghost_area() {
  char size_line[64];
  std::snprintf(size_line, sizeof(size_line), "GDAL_STRUCTURAL_METADATA_SIZE=%06zu bytes\n", sizeof(kGhostBody) - 1);
  return std::string(size_line) + kGhostBody;
}

uint64_t even(uint64_t n) { return n + (n & 1); }

// Bytes of an IFD and the values it keeps out of line, in either format.
uint64_t ifd_bytes(const Ifd& ifd, bool big) {
  const uint64_t field = big ? 8 : 4;
  const uint64_t array = ifd.sizes.size() * (big ? 8 : 4);
  uint64_t n = (big ? 8 : 2) + (ifd.entries.size() + 2) * (big ? 20 : 12) + (big ? 8 : 4);
  for (const Entry& e : ifd.entries)
    if (e.value.size() > field) n += even(e.value.size());
  if (array > field) n += 2 * even(array);
  return n;
}

// Appends the IFD, placed at out.size() in the file, and its values; `next` is the next IFD's
// offset (0: none).
void write_ifd(std::vector<uint8_t>& out, const Ifd& ifd, bool big, uint64_t next, const std::string& display) {
  std::vector<Entry> entries = ifd.entries;
  entries.push_back(integer_entry(kTileOffsets, big ? kTypeLong8 : kTypeLong, ifd.offsets));
  entries.push_back(integer_entry(kTileByteCounts, big ? kTypeLong8 : kTypeLong, ifd.sizes));
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.tag < b.tag; });
  const int field = big ? 8 : 4;
  const uint64_t start = out.size();
  uint64_t values = start + (big ? 8 : 2) + entries.size() * (big ? 20 : 12) + static_cast<uint64_t>(field);
  std::vector<uint8_t> tail;  // the out-of-line values, from `values` on
  put_le(out, entries.size(), big ? 8 : 2);
  for (const Entry& e : entries) {
    if (!big && e.type >= kTypeLong8)  // LONG8, SLONG8, IFD8
      throw Error(ErrorKind::io, "writing " + display + ": tag " + std::to_string(e.tag) +
                                     " of the staged file has a BigTIFF type, and the COG is a classic TIFF");
    put_le(out, e.tag, 2);
    put_le(out, e.type, 2);
    put_le(out, e.count, big ? 8 : 4);
    if (e.value.size() <= static_cast<size_t>(field)) {
      out.insert(out.end(), e.value.begin(), e.value.end());
      out.resize(out.size() + static_cast<size_t>(field) - e.value.size(), 0);
    } else {
      put_le(out, values + tail.size(), field);
      tail.insert(tail.end(), e.value.begin(), e.value.end());
      if (tail.size() & 1) tail.push_back(0);
    }
  }
  put_le(out, next, field);
  out.insert(out.end(), tail.begin(), tail.end());
  if (out.size() - start != ifd_bytes(ifd, big))
    throw Error(ErrorKind::internal, "writing " + display + ": the COG's directory size was misjudged");
}

// The IFDs with every tile placed: data after the last IFD, smallest overview first.
uint64_t place_tiles(std::vector<Ifd>& ifds, bool big, uint64_t header) {
  uint64_t at = header;
  for (const Ifd& ifd : ifds) at += ifd_bytes(ifd, big);
  for (size_t k = ifds.size(); k-- > 0;) {  // the overviews from the last, then the full resolution
    Ifd& ifd = ifds[k];
    ifd.offsets.resize(ifd.sizes.size());
    for (size_t t = 0; t < ifd.sizes.size(); ++t) {
      ifd.offsets[t] = at + 4;
      at += ifd.sizes[t] + 8;
    }
  }
  return at;  // the file's size
}

// The COG's file, written front to back; errors name `display`.
class Output {
 public:
  Output(const std::string& path, const std::string& display) : display_(display) {
    file_ = VSIFOpenL(path.c_str(), "wb");
    if (file_ == nullptr) fail("cannot create the file");
  }
  ~Output() {
    if (file_ != nullptr) VSIFCloseL(file_);
  }
  Output(const Output&) = delete;
  Output& operator=(const Output&) = delete;

  void write(const void* data, uint64_t n) {
    errno = 0;
    if (VSIFWriteL(data, 1, n, file_) != n) {
      const int e = errno;  // the system's reason (a full disk) says more
      fail("cannot write the file" + (e != 0 ? std::string(": ") + std::strerror(e) : std::string()));
    }
  }
  // A tile: its leader (size), bytes and trailer (the last 4 bytes of leader and bytes again).
  void tile(EncodedTile t) {
    uint8_t leader[4];
    for (int i = 0; i < 4; ++i) leader[i] = static_cast<uint8_t>(t.size >> (8 * i));
    uint8_t trailer[4];
    for (size_t i = 0; i < 4; ++i) {
      const size_t from_end = 4 - i;  // byte from_end before the end of leader + bytes
      trailer[i] = from_end <= t.size ? t.data[t.size - from_end] : leader[4 - (from_end - t.size)];
    }
    write(leader, 4);
    write(t.data, t.size);
    write(trailer, 4);
  }
  void close() {
    VSILFILE* f = std::exchange(file_, nullptr);
    if (VSIFCloseL(f) != 0) fail("cannot close the file");
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throw Error(ErrorKind::io, "writing " + display_ + ": " + what);
  }
  VSILFILE* file_ = nullptr;
  std::string display_;
};

}  // namespace

TileSpool::TileSpool(const std::string& path, std::vector<LevelSize> levels, const std::string& display)
    : display_(display), levels_(std::move(levels)), tiles_(levels_.size()) {
  file_ = VSIFOpenL(path.c_str(), "w+b");
  if (file_ == nullptr) fail("cannot create the overviews' temporary file " + path);
}

TileSpool::~TileSpool() {
  if (file_ != nullptr) VSIFCloseL(static_cast<VSILFILE*>(file_));
}

void TileSpool::append(int level, EncodedTile tile) {
  auto* f = static_cast<VSILFILE*>(file_);
  if (!at_end_ && VSIFSeekL(f, end_, SEEK_SET) != 0) fail("cannot write an overview tile");
  at_end_ = true;
  errno = 0;
  if (VSIFWriteL(tile.data, 1, tile.size, f) != tile.size) {
    const int e = errno;
    fail("cannot write an overview tile" + (e != 0 ? std::string(": ") + std::strerror(e) : std::string()));
  }
  tiles_[static_cast<size_t>(level)].emplace_back(end_, tile.size);
  end_ += tile.size;
}

EncodedTile TileSpool::read(int level, size_t index, std::vector<uint8_t>& buf) {
  const auto [offset, size] = tiles_[static_cast<size_t>(level)][index];
  auto* f = static_cast<VSILFILE*>(file_);
  if (buf.size() < size) buf.resize(size);
  at_end_ = false;
  if (VSIFSeekL(f, offset, SEEK_SET) != 0 || VSIFReadL(buf.data(), 1, size, f) != size)
    fail("cannot read an overview tile back");
  return {buf.data(), size};
}

void TileSpool::fail(const std::string& what) const { throw Error(ErrorKind::io, "writing " + display_ + ": " + what); }

void assemble_cog(const std::string& staged, TileSpool& overviews, const std::string& target,
                  const std::string& display, bool bigtiff) {
  Input in(staged, display);
  Staged s = read_staged(in);
  std::vector<Ifd> ifds(1 + overviews.levels().size());
  ifds[0].entries = s.entries;
  ifds[0].sizes = s.sizes;
  for (size_t k = 0; k < overviews.levels().size(); ++k) {
    const LevelSize& size = overviews.levels()[k];
    Ifd& ifd = ifds[k + 1];
    ifd.entries = {integer_entry(kNewSubfileType, kTypeLong, {1}), size_entry(kImageWidth, size.width),
                   size_entry(kImageLength, size.height)};
    for (const Entry& e : s.entries)
      if (std::find(std::begin(kOverviewTags), std::end(kOverviewTags), e.tag) != std::end(kOverviewTags))
        ifd.entries.push_back(e);
    const auto level = static_cast<int>(k);
    const uint64_t across = (static_cast<uint64_t>(size.width) + s.tile_width - 1) / s.tile_width;
    const uint64_t down = (static_cast<uint64_t>(size.height) + s.tile_length - 1) / s.tile_length;
    if (overviews.tile_count(level) != across * down) in.fail("overview " + std::to_string(k + 1) + " lacks tiles");
    for (size_t t = 0; t < overviews.tile_count(level); ++t) ifd.sizes.push_back(overviews.tile_size(level, t));
  }
  for (const Ifd& ifd : ifds)
    if (std::find(ifd.sizes.begin(), ifd.sizes.end(), 0) != ifd.sizes.end()) in.fail("a tile is missing");
  const std::string ghost = ghost_area();
  auto header_bytes = [&](bool big) { return even((big ? 16 : 8) + ghost.size()); };
  // Classic TIFF holds 32-bit offsets: BigTIFF only when the file reaches 4 GiB.
  if (!bigtiff && place_tiles(ifds, false, header_bytes(false)) > UINT32_MAX) bigtiff = true;
  place_tiles(ifds, bigtiff, header_bytes(bigtiff));

  std::vector<uint8_t> head;
  head.insert(head.end(), {'I', 'I'});
  if (bigtiff) {
    put_le(head, 43, 2);
    put_le(head, 8, 2);
    put_le(head, 0, 2);
    put_le(head, header_bytes(true), 8);
  } else {
    put_le(head, 42, 2);
    put_le(head, header_bytes(false), 4);
  }
  head.insert(head.end(), ghost.begin(), ghost.end());
  head.resize(header_bytes(bigtiff), 0);
  for (size_t k = 0; k < ifds.size(); ++k) {
    const uint64_t next = k + 1 < ifds.size() ? head.size() + ifd_bytes(ifds[k], bigtiff) : 0;
    write_ifd(head, ifds[k], bigtiff, next, display);
  }

  Output out(target, display);
  out.write(head.data(), head.size());
  std::vector<uint8_t> buf;
  for (size_t k = overviews.levels().size(); k-- > 0;)
    for (size_t t = 0; t < ifds[k + 1].sizes.size(); ++t) out.tile(overviews.read(static_cast<int>(k), t, buf));
  for (size_t t = 0; t < s.sizes.size(); ++t) {
    if (buf.size() < s.sizes[t]) buf.resize(s.sizes[t]);
    in.read(s.offsets[t], buf.data(), s.sizes[t]);
    out.tile({buf.data(), s.sizes[t]});
  }
  out.close();
}

}  // namespace rv::detail
