// Boundaries, tripoints and limit lines taken in strip by strip (a streamed job), and the pieces
// a run keeps so that an edit extracts again only the rows near its changes.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "rv/engine/engine.hpp"
#include "rv/engine/owner_index.hpp"
#include "rv/field/grid.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"

namespace rv {

// What StripLines extracts: boundaries and tripoints (extract_boundaries), and limit lines at
// the given distances (extract_limits).
struct LineRequest {
  bool boundaries = false;
  BoundaryOptions boundary;
  std::vector<double> limit_distances;  // metric units, > 0; none: no limit lines
  LimitOptions limit;
  // Also the edge of the owned area where the index's reaches (each feature's, at most its cap)
  // leave cells unowned: one more set of limit lines, owner kOwnedEdge, after the others. Its
  // inside cells are the field's owned ones; its vertices lie where OwnerIndex::deepest is 0.
  bool owned_edge = false;
};

// The pieces a StripLines extraction's cell-level stages made (crossings, tripoints, links and
// their statistics; per limit line set its crossings and links), each with the grid row it
// belongs to: what a run keeps so that an edit of it (rv/edit/edit.hpp) extracts again only the rows
// near its changes and takes the others' pieces from here (StripLines::take_rows). As bytes
// (encode / decode): a flat little-endian layout behind a magic and a format version, doubles bit
// for bit. Cheap to copy (shared, immutable). Thread safety: const functions from any thread.
class LinePieces {
 public:
  LinePieces();
  bool empty() const;  // made by the default constructor
  // StripLines::key() of the extraction that made them.
  const std::string& key() const;
  std::string encode() const;
  // The bytes the pieces hold in memory (their arrays' capacities and the key), without encoding
  // them: a session counts it after every step.
  int64_t memory_bytes() const;
  // Throws rv::Error(invalid_input) for bytes that are not pieces of this format (magic, version,
  // truncated, trailing bytes, a row or a link out of range, rows out of order).
  static LinePieces decode(std::string_view bytes);
  // The rows (ascending, each once) holding a piece that names a site `site_map` (per site of the
  // seeds the pieces were made with, the site in an edited set) maps to kNoSite: rows an edit
  // must extract again.
  std::vector<int64_t> rows_naming_dropped(std::span<const int32_t> site_map) const;

  struct Data;

 private:
  explicit LinePieces(std::shared_ptr<const Data> d);
  std::shared_ptr<const Data> d_;
  friend class StripLines;
};

// What a StripLines extraction's refinement did, segment by segment (the points it added between
// the vertices on cell edges, their bows and what it counted), for its boundaries, its limit
// lines and the owned area's edge: what a session keeps so that the next extraction, of its
// edited field, refines again only the segments near the edit (StripLines::keep_refined). In
// memory only. Cheap to copy (shared, immutable). Thread safety: const functions from any thread.
class RefinedSegments {
 public:
  RefinedSegments();
  bool empty() const;
  int64_t segments() const;        // segments of the lines before refinement
  int64_t segments_taken() const;  // of which taken from the earlier state, not refined again
  int64_t memory_bytes() const;

  struct Data;

 private:
  explicit RefinedSegments(std::shared_ptr<const Data> d);
  std::shared_ptr<const Data> d_;
  friend class StripLines;
};

// Where an edit may have changed the field's cells or a measurement by the metric: a flag per
// square tile of `size` cells, row-major over the grid, 1 where it may (rv::Edit::line_tiles).
struct ChangedTiles {
  int64_t size = 0;
  std::vector<uint8_t> flags;
};

// Boundaries, tripoints and limit lines taken in strip by strip from an exact field that is
// computed in strips (a streamed job: the whole field never exists). The result equals
// extract_boundaries' and extract_limits' on the whole field, vertex for vertex, whatever the
// strips' heights: each stage runs over the rows whose neighbours have arrived, a few rows
// behind the last strip, and the pieces are chained into lines once the last row is in.
// Memory: a few rows of the field (copied from each strip before the next) and the lines'
// pieces, in proportion to the lines' length, not to the grid.
// Keeps references to `index` (and its metric and seeds); `grid` is copied.
// Thread safety: one StripLines per extraction, used from one thread at a time; it runs its
// stages on request.*.threads threads.
class StripLines {
 public:
  // Throws rv::Error(invalid_argument) for a non-positive or non-finite limit distance.
  StripLines(const GridSpec& grid, const OwnerIndex& index, const LineRequest& request);
  ~StripLines();
  StripLines(StripLines&&) noexcept;
  StripLines& operator=(StripLines&&) noexcept;

  // The next strip: whole rows of the grid, the first at row 0, each starting where the last
  // ended; its metric the index's. The strip is read during the call only. Throws
  // rv::Error(invalid_argument) otherwise (nothing taken in). After any other exception (the
  // stages' own) the extraction cannot go on.
  void add(const NearestField& strip);
  // Rows [row0, row1) of `strip` (which holds them; row0 where the last strip ended), as add()
  // of a strip of those rows, without copying them out.
  void add(const NearestField& strip, int64_t row0, int64_t row1);
  // Rows taken in so far.
  int64_t rows() const;

  // The pieces of a row depend on the field's cells and on the metric's measurements within
  // kDependRows rows of it (crossings read the next row, tripoint searches the crossings around
  // their square and the tripoints found from the rows before, links the tripoints filed up to a
  // square away, found from up to two squares farther).
  static constexpr int64_t kDependRows = 8;
  // What shapes the pieces: the grid, the request (but threads and simplification) and whether
  // the index is adjusted. Two extractions with one key make the same pieces from the same field.
  const std::string& key() const;
  // After the last row (before take_*): every piece so far (LinePieces).
  LinePieces pieces() const;
  // After the last row, before take_*: the pieces are kept as the lines are taken, their arrays
  // moved into the kept pieces once the chains no longer read them instead of copied before
  // (a session keeps every step's pieces for the next). Throws rv::Error(invalid_argument) before
  // the last row or after a take_*.
  void keep_pieces();
  // After keep_pieces() and every take_* (taken()): the pieces, equal to what pieces() gave
  // before the lines were taken. Throws rv::Error(invalid_argument) otherwise, and after a take_*
  // that threw.
  LinePieces kept_pieces() const;
  // Rows [rows(), row1) taken from `base` (an earlier run's pieces(), key() equal) instead of
  // strips, as though their strips had been added: for an edit, rows whose pieces are the base's
  // (neither the field's cells nor any measurement by the metric changed within kDependRows rows
  // of them; the strips added around them must hold kDependRows such rows at each side).
  // `site_map`: per site of the base's seeds, the site of this extraction's seeds (empty: the
  // same). The next strip then starts at row1. Throws rv::Error(invalid_argument) for another key,
  // a row1 not after rows() or beyond the grid, or a piece naming a site the map drops;
  // rv::Error(invalid_input) for a piece naming a site or an owner these seeds do not have, and,
  // for decoded pieces (LinePieces::decode: bytes from outside), for a vertex not on its edge or
  // not at the distances the metric measures there now (pieces made by pieces() in this process
  // were measured when made, and are not measured again).
  void take_rows(const LinePieces& base, int64_t row1, std::span<const int32_t> site_map = {});
  // Before the first row: the rows added afterwards take a boundary crossing or a limit vertex
  // from `base` (an earlier run's pieces(), key() equal) instead of placing it again, on an edge
  // whose two cells, widened by two at each side, lie in tiles `changed` flags 0 (since `base`,
  // neither the field's cells nor any measurement by the metric changed there:
  // rv::Edit::line_tiles), its sites renumbered by `site_map` (as take_rows): the same
  // measurements would place it there. A boundary edge is taken where the base placed one
  // crossing on it, of the same owners, with no owner passing between. The pieces are the same,
  // vertex for vertex. Pieces decoded from bytes (LinePieces::decode) are not taken from: their
  // vertices are placed. Keeps a reference-counted copy of `base`. Throws
  // rv::Error(invalid_argument) for another key, tiles that do not cover the grid, or a call
  // after the first row.
  void take_measured(const LinePieces& base, ChangedTiles changed, std::vector<int32_t> site_map = {});
  // The boundary crossings and limit vertices take_measured took so far.
  int64_t vertices_taken() const;
  // Before take_*: the refinement keeps what it does (refined()), and takes from `before` (an
  // earlier state's refined(), of an extraction with the same key and line tolerances; empty:
  // none) the segments whose ends are bit for bit the same (their sites renumbered by `site_map`,
  // as take_rows) and whose cells, widened by two at each side, lie in tiles `changed` flags 0
  // (since `before`, neither the field's cells nor any measurement by the metric changed there)
  // instead of refining them again. The lines are the same, vertex for vertex. Throws
  // rv::Error(invalid_argument) for a `before` of another extraction, or `changed` tiles that do
  // not cover the grid.
  void keep_refined(RefinedSegments before = {}, ChangedTiles changed = {}, std::vector<int32_t> site_map = {});
  // After take_boundaries and take_limits (those requested), with keep_refined: every segment
  // refined or taken.
  RefinedSegments refined() const;
  // Whether every kind of line requested has been taken (refined() may be asked).
  bool taken() const;
  // After the last row: the lines. Throws rv::Error(invalid_argument) when rows are missing.
  // Each may be called once.
  BoundaryResult take_boundaries();
  LimitResult take_limits();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rv
