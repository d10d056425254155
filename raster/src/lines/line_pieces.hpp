// What LinePieces (rv/lines/strip_lines.hpp) holds: the cell-level stages' pieces of one StripLines
// extraction, each with the grid row it belongs to, in the order the stages appended them (so
// every row list is non-decreasing), and per row the boundary stages' statistics.
// Internal to rv_raster. Thread safety: immutable once made.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "lines/boundary_stages.hpp"
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
