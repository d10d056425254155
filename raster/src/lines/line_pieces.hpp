// What LinePieces (rv/lines/strip_lines.hpp) holds: the cell-level stages' pieces of one StripLines
// extraction, each with the grid row it belongs to, in the order the stages appended them (so
// every row list is non-decreasing), and per row the boundary stages' statistics. And what
// RefinedSegments holds: the refinement of every segment of an extraction's lines.
// Internal to rv_raster. Thread safety: immutable once made.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "lines/boundary_stages.hpp"
#include "lines/limit_stages.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"
#include "rv/lines/strip_lines.hpp"

namespace rv {

struct LinePieces::Data {
  std::string key;  // StripLines' key: the grid and the request's parts that shape the pieces
  // Made by StripLines::pieces() in this process, not decoded: every vertex was measured by the
  // metric of the seeds it names, so take_rows need not measure it again (decoded bytes are).
  bool measured_here = false;
  int64_t width = 0, height = 0;
  struct Boundary {
    std::vector<boundary_stages::Crossing> crossings;  // row: the edge's
    std::vector<std::pair<int64_t, int32_t>> slivers;  // (edge, owner passing between), by edge
    std::vector<Tripoint> tripoints;
    std::vector<int32_t> tripoint_row;  // the row of the square each was sought from
    std::vector<std::array<int32_t, 2>> links;
    std::vector<int64_t> link_pair;
    std::vector<int32_t> link_row;                 // the top row of each link's square
    std::vector<std::array<int64_t, 2>> unplaced;  // squares (c, r)
    std::vector<std::array<int64_t, boundary_stages::RowCounts::kCounters>> counts;  // per row
  };
  std::vector<Boundary> boundary;  // none or one
  struct Limit {
    std::vector<int64_t> edges;  // row: the edge's
    std::vector<LimitVertex> verts;
    std::vector<std::array<int32_t, 2>> links;  // crossing indices
    std::vector<int32_t> link_row;              // the top row of each link's square
  };
  std::vector<Limit> limits;  // in StripLines' order of limit runs

  int64_t edge_row(int64_t edge) const { return edge / 2 / width; }
};

}  // namespace rv

namespace rv {

// What a refinement did to one segment of a line (the points it added and the segment's end, and
// their bows), kept so that the next state of an edited field takes it where nothing it measured
// changed (RefinedSegments, rv/lines/strip_lines.hpp). `Stat`: what the refiner counted for it.
// Vertices carry the sites of the seeds they were refined with.
template <class V, class Stat>
struct SegmentMemo {
  struct Entry {
    // Its points in `out`: the added ones and its end, [out0, out1); its start at u_at (the end
    // of the segment before, or a line's first vertex); its bows in `bows`.
    uint32_t u_at = 0, out0 = 0, out1 = 0, bow0 = 0, bow1 = 0;
    int32_t a = 0, b = 0;  // its owners (boundaries; 0 for limit lines)
    Stat stat;
  };
  std::vector<Entry> entries;
  std::vector<V> out;
  std::vector<Bow> bows;
  int64_t taken = 0;  // entries taken from an earlier state's memo, not refined again

  void shrink_to_fit() {
    entries.shrink_to_fit();
    out.shrink_to_fit();
    bows.shrink_to_fit();
  }
  const V& start(const Entry& e) const { return out[e.u_at]; }
  const V& end(const Entry& e) const { return out[e.out1 - 1]; }
  int64_t memory_bytes() const {
    return static_cast<int64_t>(entries.capacity() * sizeof(Entry) + out.capacity() * sizeof(V) +
                                bows.capacity() * sizeof(Bow));
  }
  // Appends a block of one line's segments, in order: `block` their entries with out and bow
  // ranges into `block_out` and `block_bows` (copied); `first`: the line's first vertex when the
  // block starts the line, else null (the block goes on from the last one appended).
  void append(std::vector<Entry>&& block, const V* first, const std::vector<V>& block_out,
              const std::vector<Bow>& block_bows) {
    if (first != nullptr) out.push_back(*first);
    auto u = static_cast<uint32_t>(out.size() - 1);
    const auto o = static_cast<uint32_t>(out.size()), w = static_cast<uint32_t>(bows.size());
    out.insert(out.end(), block_out.begin(), block_out.end());
    bows.insert(bows.end(), block_bows.begin(), block_bows.end());
    for (Entry& e : block) {
      e.u_at = u;
      e.out0 += o;
      e.out1 += o;
      e.bow0 += w;
      e.bow1 += w;
      u = e.out1 - 1;
      entries.push_back(std::move(e));
    }
  }
};

// A boundary vertex or a limit vertex equal to an earlier state's (`old`, its sites in that
// state's numbering, `site_map` to this one's; empty: the same), bit for bit; and an earlier
// state's vertex in this state's numbering (false where a site is gone).
bool same_vertex(const BoundaryVertex& now, const BoundaryVertex& old, std::span<const int32_t> site_map);
bool same_vertex(const LimitVertex& now, const LimitVertex& old, std::span<const int32_t> site_map);
bool renumber(BoundaryVertex& v, std::span<const int32_t> site_map);
bool renumber(LimitVertex& v, std::span<const int32_t> site_map);
uint64_t segment_hash(int32_t a, int32_t b, Vec2 u, Vec2 v);

// Whether every tile of `changed` over cells [c0, c1] x [r0, r1] of a grid `width` x `height`
// (inclusive; clamped to the grid) is flagged 0: neither the field nor a measurement by the metric
// changed there (rv::Edit::line_tiles).
inline bool tiles_unchanged(const ChangedTiles& changed, int64_t width, int64_t height, int64_t c0, int64_t r0,
                            int64_t c1, int64_t r1) {
  const int64_t T = changed.size, cols = (width + T - 1) / T, rows = (height + T - 1) / T;
  c0 = std::clamp<int64_t>(c0, 0, width - 1);
  c1 = std::clamp<int64_t>(c1, 0, width - 1);
  r0 = std::clamp<int64_t>(r0, 0, height - 1);
  r1 = std::clamp<int64_t>(r1, 0, height - 1);
  for (int64_t tr = r0 / T; tr <= r1 / T && tr < rows; ++tr)
    for (int64_t tc = c0 / T; tc <= c1 / T && tc < cols; ++tc)
      if (changed.flags[static_cast<size_t>(tr * cols + tc)] != 0) return false;
  return true;
}

// The segments of an earlier state's SegmentMemo an edit leaves valid, found by their ends: those
// whose cells, widened by kMargin at each side, lie in tiles of `changed` flagged 0 (where neither
// the field nor a measurement by the metric changed: rv::Edit::line_tiles). A refinement measures
// on and across its segment only (within a cell of it), so a valid segment with the same ends is
// refined as it was.
// Thread safety: const functions from any thread.
template <class V, class Stat>
class SegmentReuse {
 public:
  static constexpr int64_t kMargin = 2;
  using Entry = typename SegmentMemo<V, Stat>::Entry;

  SegmentReuse(const SegmentMemo<V, Stat>& memo, const GridSpec& grid, const ChangedTiles& changed,
               std::span<const int32_t> site_map)
      : memo_(memo), map_(site_map) {
    auto col_of = [&](double x) { return static_cast<int64_t>(std::floor((x - grid.xmin) / grid.res)); };
    auto row_of = [&](double y) { return static_cast<int64_t>(std::floor((grid.ymax - y) / grid.res)); };
    auto valid = [&](const Entry& e) {
      const Vec2 u = memo.start(e).p, v = memo.end(e).p;
      if (!(std::isfinite(u.x) && std::isfinite(u.y) && std::isfinite(v.x) && std::isfinite(v.y))) return false;
      return tiles_unchanged(changed, grid.width, grid.height, std::min(col_of(u.x), col_of(v.x)) - kMargin,
                             std::min(row_of(u.y), row_of(v.y)) - kMargin, std::max(col_of(u.x), col_of(v.x)) + kMargin,
                             std::max(row_of(u.y), row_of(v.y)) + kMargin);
    };
    valid_.resize(memo.entries.size());
    size_t n = 0;
    for (size_t i = 0; i < memo.entries.size(); ++i) {
      valid_[i] = valid(memo.entries[i]) ? 1 : 0;
      n += valid_[i];
    }
    size_t size = 16;
    while (size < 2 * n) size *= 2;
    slots_.assign(size, 0);
    for (size_t i = 0; i < memo.entries.size(); ++i) {
      const Entry& e = memo.entries[i];
      if (valid_[i] == 0) continue;
      size_t s = segment_hash(e.a, e.b, memo.start(e).p, memo.end(e).p) & (size - 1);
      while (slots_[s] != 0) s = (s + 1) & (size - 1);
      slots_[s] = static_cast<uint32_t>(i + 1);
    }
  }

  // The valid entry of segment u -> v of owners a, b, or null.
  const Entry* find(int32_t a, int32_t b, const V& u, const V& v) const {
    const size_t mask = slots_.size() - 1;
    for (size_t s = segment_hash(a, b, u.p, v.p) & mask; slots_[s] != 0; s = (s + 1) & mask) {
      const Entry& e = memo_.entries[slots_[s] - 1];
      if (e.a == a && e.b == b && same_vertex(u, memo_.start(e), map_) && same_vertex(v, memo_.end(e), map_)) return &e;
    }
    return nullptr;
  }
  // The entry after `e` (one this reuse returned) when it is valid, goes on along e's line (its
  // start is e's end) and is segment u -> v of owners a, b, where u equals e's end; else null.
  // A line unchanged over a stretch is found entry after entry in memory order this way, without
  // the index's scattered reads.
  const Entry* after(const Entry* e, int32_t a, int32_t b, const V& v) const {
    const auto i = static_cast<size_t>(e - memo_.entries.data()) + 1;
    if (i >= memo_.entries.size() || valid_[i] == 0) return nullptr;
    const Entry& n = memo_.entries[i];
    if (n.u_at != e->out1 - 1 || n.a != a || n.b != b || !same_vertex(v, memo_.end(n), map_)) return nullptr;
    return &n;
  }
  // Appends entry e's points (renumbered) to `out` and its bows to `bows`; false, with nothing
  // appended, where one of its points names a site the edit removed.
  bool take(const Entry& e, std::vector<V>& out, std::vector<Bow>& bows) const {
    const size_t at = out.size();
    for (uint32_t k = e.out0; k < e.out1; ++k) {
      V p = memo_.out[k];
      if (!renumber(p, map_)) {
        out.resize(at);
        return false;
      }
      out.push_back(p);
    }
    bows.insert(bows.end(), memo_.bows.begin() + e.bow0, memo_.bows.begin() + e.bow1);
    return true;
  }

 private:
  const SegmentMemo<V, Stat>& memo_;
  std::span<const int32_t> map_;
  std::vector<uint32_t> slots_;  // entry index + 1; 0: empty
  std::vector<uint8_t> valid_;   // per entry: 1 where the edit left it valid
};

}  // namespace rv

namespace rv {

// One segment of a run refine_with_memo's `refine` refined: where its points end in `out` and its
// bows in `bows`, and what the refiner counted for it alone.
template <class Stat>
struct RefinedRun {
  size_t out_end = 0, bows_end = 0;
  Stat stat;
};

// Segments [i0, i1) of a line's vertices `v` (owners a, b) refined into `out` and `bows` as
// refine(i, j, runs) refines [i, j) (appending the points after vertex i, the bows, one RefinedRun
// per segment to `runs`, and adding to `total`), but for those `reuse` holds (valid, with the
// same ends), which are taken (their Stat merged into `total`). With `kept`: one entry per
// segment, in order, its points and bows as offsets into `out` and `bows` (SegmentMemo::append
// sets its start). Returns how many were taken.
template <class V, class Stat, class Refine>
int64_t refine_with_memo(const SegmentReuse<V, Stat>* reuse, std::vector<typename SegmentMemo<V, Stat>::Entry>* kept,
                         int32_t a, int32_t b, const std::vector<V>& v, size_t i0, size_t i1, std::vector<V>& out,
                         std::vector<Bow>& bows, Stat& total, Refine&& refine) {
  using Entry = typename SegmentMemo<V, Stat>::Entry;
  auto entry = [&](size_t out0, size_t out1, size_t bow0, size_t bow1, const Stat& st) {
    if (kept != nullptr)
      kept->push_back(Entry{0, static_cast<uint32_t>(out0), static_cast<uint32_t>(out1), static_cast<uint32_t>(bow0),
                            static_cast<uint32_t>(bow1), a, b, st});
  };
  const Entry* last = nullptr;  // the entry taken for the segment before, if it was
  auto held = [&](size_t i) -> const Entry* {
    if (reuse == nullptr) return nullptr;
    if (last != nullptr)
      if (const Entry* n = reuse->after(last, a, b, v[i + 1])) return n;
    return reuse->find(a, b, v[i], v[i + 1]);
  };
  int64_t taken = 0;
  std::vector<RefinedRun<Stat>> runs;
  for (size_t i = i0; i < i1;) {
    const size_t out0 = out.size(), bow0 = bows.size();
    const Entry* e = held(i);
    if (e != nullptr && reuse->take(*e, out, bows)) {
      total.merge(e->stat);
      entry(out0, out.size(), bow0, bows.size(), e->stat);
      ++taken;
      ++i;
      last = e;
      continue;
    }
    last = nullptr;
    size_t j = i + 1;
    while (j < i1 && held(j) == nullptr) ++j;
    runs.clear();
    refine(i, j, runs);
    size_t o = out0, w = bow0;
    for (const RefinedRun<Stat>& r : runs) {
      entry(o, r.out_end, w, r.bows_end, r.stat);
      o = r.out_end;
      w = r.bows_end;
    }
    i = j;
  }
  return taken;
}

struct RefinedSegments::Data {
  std::string key;                              // StripLines' key and its line tolerances
  boundary_stages::BoundaryMemo boundary;       // the boundaries' (empty without)
  std::vector<limit_stages::LimitMemo> limits;  // per limit run, in StripLines' order
};

}  // namespace rv
