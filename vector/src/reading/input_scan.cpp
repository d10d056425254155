// scan_input(): an input's real size before GDAL reads it. See input_scan.hpp for the contract.
//
// Why inflate every member, also those no driver would open: the byte limit bounds the work an
// upload can cause, and what GDAL inflates later is then known to be bounded. Why stream instead
// of seeking over record contents: seeking in /vsizip/ inflates just the same, and reading in
// chunks keeps one code path for archives and plain files.
#include "reading/input_scan.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstring>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>

#include <cpl_conv.h>
#include <cpl_string.h>
#include <cpl_vsi.h>
#include <sqlite3.h>

#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/gdal/seed_reader.hpp"

namespace rv::detail {
namespace {

constexpr size_t kChunk = 256 * 1024;

bool ends_with_ci(std::string_view s, std::string_view suffix) {
  return s.size() >= suffix.size() &&
         std::equal(suffix.begin(), suffix.end(), s.end() - static_cast<std::ptrdiff_t>(suffix.size()),
                    [](char a, char b) {
                      return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
                    });
}

uint32_t big_endian32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | uint32_t{p[3]};
}
int32_t little_endian32(const unsigned char* p) {
  return static_cast<int32_t>(uint32_t{p[0]} | (uint32_t{p[1]} << 8) | (uint32_t{p[2]} << 16) | (uint32_t{p[3]} << 24));
}

// The record headers of a .shp file, read from its bytes as they stream past (ESRI Shapefile
// Technical Description, 1998: a 100-byte file header, then records of an 8-byte header - record
// number and content length in 16-bit words, big-endian - and a content that starts with the
// little-endian shape type; multipoints give numPoints at content byte 36, polylines, polygons
// and multipatches numParts at 36 and numPoints at 40).
class ShapefileRecords {
 public:
  ShapefileRecords(const std::string& label, const InputLimits& limits, InputTally& tally)
      : label_(label), limits_(limits), tally_(tally) {}

  void feed(const unsigned char* p, size_t n) {
    while (n > 0 && state_ != State::done) {
      if (skip_ > 0) {
        const size_t k = static_cast<size_t>(std::min<uint64_t>(skip_, n));
        skip_ -= k;
        p += k;
        n -= k;
        continue;
      }
      const size_t k = std::min(need_ - have_, n);
      std::memcpy(buffer_.data() + have_, p, k);
      have_ += k;
      p += k;
      n -= k;
      if (have_ == need_) block();
    }
  }

 private:
  enum class State { file_header, record_header, record_content, done };

  void expect(State s, size_t bytes) {
    state_ = s;
    need_ = bytes;
    have_ = 0;
  }

  void block() {
    const unsigned char* b = buffer_.data();
    switch (state_) {
      case State::file_header:
        // Not a Shapefile (file code 9994): the driver will say what is wrong with it.
        if (big_endian32(b) != 9994) return expect(State::done, 0);
        return expect(State::record_header, 8);
      case State::record_header: {
        content_ = uint64_t{big_endian32(b + 4)} * 2;
        const size_t prefix = static_cast<size_t>(std::min<uint64_t>(content_, 44));
        if (prefix == 0) return expect(State::record_header, 8);
        return expect(State::record_content, prefix);
      }
      case State::record_content:
        record(b, have_);
        skip_ = content_ - have_;
        return expect(State::record_header, 8);
      case State::done:
        return;
    }
  }

  void record(const unsigned char* c, size_t n) {
    ++tally_.declared_features;
    if (limits_.max_features > 0 && tally_.declared_features > limits_.max_features)
      throw Error(ErrorKind::too_large, "the seed data has more than " + std::to_string(limits_.max_features) +
                                            " features, the limit (" + label_ + " holds more records)");
    if (n < 4) return;
    int64_t vertices = 0;
    bool points = false;
    switch (little_endian32(c)) {
      case 1:
      case 11:
      case 21:  // point, pointZ, pointM
        vertices = 1;
        points = true;
        break;
      case 8:
      case 18:
      case 28:  // multipoint
        if (n >= 40) vertices = little_endian32(c + 36);
        points = true;
        break;
      case 3:
      case 5:
      case 13:
      case 15:
      case 23:
      case 25:
      case 31:  // polyline, polygon, multipatch
        if (n >= 44) vertices = little_endian32(c + 40);
        break;
      default:
        break;  // null shapes and unknown types carry no vertices the driver would build
    }
    vertices = std::max<int64_t>(vertices, 0);
    tally_.declared_vertices += vertices;
    if (points) tally_.declared_points += vertices;
    const std::string where = label_ + ": record " + std::to_string(tally_.declared_features) + " declares " +
                              std::to_string(vertices) + " vertices; refused before reading it";
    if (limits_.max_vertices > 0 && tally_.declared_vertices > limits_.max_vertices)
      throw Error(ErrorKind::too_large, "the seed data has more than " + std::to_string(limits_.max_vertices) +
                                            " vertices, the limit (" + where + ")");
    const int64_t need = reading_bytes(tally_.declared_features, tally_.declared_points,
                                       tally_.declared_vertices - tally_.declared_points);
    if (limits_.max_reading_bytes > 0 && need > limits_.max_reading_bytes)
      throw Error(ErrorKind::too_large, "reading the seed data would need about " + std::to_string(need >> 20) +
                                            " MiB, over the memory limit of " +
                                            std::to_string(limits_.max_reading_bytes >> 20) + " MiB (" + where + ")");
  }

  std::string label_;
  const InputLimits& limits_;
  InputTally& tally_;
  State state_ = State::file_header;
  std::array<unsigned char, 100> buffer_{};
  size_t need_ = 100;
  size_t have_ = 0;
  uint64_t content_ = 0;  // bytes of the current record's content
  uint64_t skip_ = 0;     // bytes of it still to pass over
};

struct FileCloser {
  void operator()(VSILFILE* f) const { VSIFCloseL(f); }
};

// Streams one file from start to end; `archive` counts its bytes against the byte limit.
void stream_file(const std::string& path, const std::string& label, bool archive, const InputLimits& limits,
                 InputTally& tally) {
  std::unique_ptr<VSILFILE, FileCloser> file(VSIFOpenL(path.c_str(), "rb"));
  if (!file) throw Error(ErrorKind::invalid_input, label + ": cannot be read (a damaged archive?)");
  std::optional<ShapefileRecords> shp;
  if (ends_with_ci(path, ".shp")) shp.emplace(label, limits, tally);
  if (!archive && !shp) return;
  std::vector<unsigned char> chunk(kChunk);
  for (;;) {
    const size_t n = VSIFReadL(chunk.data(), 1, chunk.size(), file.get());
    if (archive) {
      tally.inflated_bytes += static_cast<int64_t>(n);
      if (limits.max_bytes > 0 && tally.inflated_bytes > limits.max_bytes)
        throw Error(ErrorKind::too_large, "the seed archive inflates to more than " + std::to_string(limits.max_bytes) +
                                              " bytes, the limit (reached in " + label + ")");
    }
    if (shp) shp->feed(chunk.data(), n);
    // A short read is the end of what the reader delivers, which is what a driver would get:
    // a damaged stream ends early for both, and the driver says what it lacks.
    if (n < chunk.size()) return;
  }
}

struct SqliteCloser {
  void operator()(sqlite3* db) const { sqlite3_close(db); }
};

// An untrusted SQLite database held in memory (/vsimem/): refused when it has a view or a table
// with a generated column. The bytes are inspected in place, read-only (sqlite3_deserialize).
void check_sqlite_schema(const std::string& path, const std::string& label) {
  vsi_l_offset size = 0;
  GByte* bytes = VSIGetMemFileBuffer(path.c_str(), &size, FALSE);
  if (bytes == nullptr || size < 100 || std::memcmp(bytes, "SQLite format 3", 16) != 0) return;
  int steps = 0;  // outlives the connection below
  sqlite3* raw = nullptr;
  if (sqlite3_open_v2(":memory:", &raw, SQLITE_OPEN_READWRITE, nullptr) != SQLITE_OK) {
    sqlite3_close(raw);
    throw Error(ErrorKind::internal, "cannot open an SQLite connection to check " + label);
  }
  std::unique_ptr<sqlite3, SqliteCloser> db(raw);
  // The schema queries below are small; the handler stops them should the file make them not.
  sqlite3_progress_handler(
      db.get(), 1000, [](void* count) { return ++*static_cast<int*>(count) > 10000 ? 1 : 0; }, &steps);
  if (sqlite3_deserialize(db.get(), "main", bytes, static_cast<sqlite3_int64>(size), static_cast<sqlite3_int64>(size),
                          SQLITE_DESERIALIZE_READONLY) != SQLITE_OK)
    return;  // not a database SQLite can read: GDAL will say so
  auto refuse = [&](const std::string& what) {
    throw Error(ErrorKind::invalid_input,
                label + ": " + what +
                    "; uploaded GeoPackages must hold plain tables (SQLite computes views and "
                    "generated columns while reading, without bounds)");
  };
  std::vector<std::string> tables;
  {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db.get(), "SELECT type, name FROM sqlite_master WHERE type IN ('view', 'table')", -1, &stmt,
                           nullptr) != SQLITE_OK) {
      sqlite3_finalize(stmt);
      return;  // a schema SQLite cannot read: GDAL will say so
    }
    while (sqlite3_step(stmt) == SQLITE_ROW) {
      const auto* type = reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0));
      const auto* name = reinterpret_cast<const char*>(sqlite3_column_text(stmt, 1));
      const std::string n = name != nullptr ? name : "";
      if (type != nullptr && std::strcmp(type, "view") == 0) {
        sqlite3_finalize(stmt);
        refuse("it defines the view '" + quote_input(n) + "'");
      }
      tables.push_back(n);
    }
    sqlite3_finalize(stmt);
  }
  for (const std::string& table : tables) {
    sqlite3_stmt* stmt = nullptr;
    if (sqlite3_prepare_v2(db.get(), "SELECT name, hidden FROM pragma_table_xinfo(?1)", -1, &stmt, nullptr) !=
        SQLITE_OK) {
      sqlite3_finalize(stmt);
      continue;
    }
    sqlite3_bind_text(stmt, 1, table.c_str(), static_cast<int>(table.size()), SQLITE_TRANSIENT);
    while (sqlite3_step(stmt) == SQLITE_ROW) {
      // hidden: 2 = generated VIRTUAL, 3 = generated STORED (computed on write, but a database
      // written elsewhere may hold anything in them: only the definition is trusted here).
      if (sqlite3_column_int(stmt, 1) >= 2) {
        const auto* column = reinterpret_cast<const char*>(sqlite3_column_text(stmt, 0));
        const std::string c = column != nullptr ? column : "";
        sqlite3_finalize(stmt);
        refuse("the table '" + quote_input(table) + "' has the generated column '" + quote_input(c) + "'");
      }
    }
    sqlite3_finalize(stmt);
  }
}

}  // namespace

void scan_input(const std::string& name, const std::string& label, const InputLimits& limits, InputTally& tally) {
  if (name.rfind("/vsizip/", 0) != 0) {
    if (ends_with_ci(name, ".shp")) stream_file(name, label, false, limits, tally);
    if (limits.untrusted && name.rfind("/vsimem/", 0) == 0) check_sqlite_schema(name, label);
    return;
  }
  // Every member, in the archive's order; directories end in '/' in GDAL's listing.
  const CPLStringList members(VSIReadDirRecursive(name.c_str()));
  if (members.size() > kMaxArchiveMembers)
    throw Error(ErrorKind::invalid_input,
                label + ": the archive has more than " + std::to_string(kMaxArchiveMembers) + " members");
  for (int i = 0; i < members.size(); ++i) {
    const std::string member = members[i];
    if (member.empty() || member.back() == '/') continue;
    const std::string path = name + "/" + member;
    VSIStatBufL st;
    if (VSIStatL(path.c_str(), &st) != 0 || !VSI_ISREG(st.st_mode)) continue;
    stream_file(path, label + "/" + escape_utf8(member), true, limits, tally);
  }
}

}  // namespace rv::detail
