// Live what-if sessions (issue 54): a job computed once and kept alive, its seeds edited one
// step at a time, each step answered with what it changed.
//
// A session holds what a job computes, in memory: the seeds, the grid, the exact field (the
// nearest site and its distance per cell), the pieces of its lines, and the deliverables asked
// for (boundaries, tripoints, limits, regions, turning points) as the job would write them.
// An edit (edit()) changes the seeds; the session then recomputes only the cells the edit can
// change (rv::Edit, seed paper 004), extracts again only the line pieces near them, refines
// again only the segments near them, and answers with the change: cells (and their box), area
// moved between owners, the new areas, the lines added, changed and removed. The deliverables'
// files (and the regions) are made from those lines when first read.
//
// What holds after every step, undo and redo included (tested against fresh computations):
// the field equals compute() on the edited seeds cell for cell, the deliverables equal a fresh
// job's files on them byte for byte, the areas a fresh job's.
//
// Frozen at creation: the grid (extent, cell size, CRS), the metric, the options, and the owner
// codes (labels in their order; a new owner takes the next code, and an owner left without
// features keeps its code: the deliverables and saved jobs number owners as the session does,
// where a seed file of the features would number them afresh).
//
// Feature ids: strings, stable for the session's life: the features read get their 1-based
// input position ("1", "2", ...), added ones "n1", "n2", ... (never reused).
//
// Line ids (the answer's "lines"): a line that comes out of an edit vertex for vertex as it was
// keeps its id and is not listed. Every other line of the new state is matched, in its order,
// to the not yet matched old line of the same kind, owners (and distance, for limits) whose box
// overlaps its own the most: it takes that id and is "changed"; a line matched to none is
// "added" with a new id; an old line left unmatched is "removed". So a line that splits keeps
// its id on the piece that overlaps it most, the others are added; lines that merge keep the id
// of the one the merged line overlaps most, the others are removed. Tripoints likewise, by
// owners and nearest position.
//
// Partial effect (features of one owner with an effect below 1): its field follows every
// feature's effect, so each step of such a session computes the whole job again (the fields at
// full and nil effect, the rule's field and lines) and says so in its answer
// (recompute.whole); its features carry their effect, which "set" may change. The same holds
// after every step. Such a session keeps both fields (16 bytes a cell).
//
// Not (yet) taken by sessions, refused at creation with one line: the geodesic metric on a
// projected grid, scan methods and validation.
//
// Thread safety: one call at a time per session (the daemon runs one session's steps in order);
// distinct sessions are independent. The work of a call runs on the spec's threads.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/field/grid.hpp"
#include "rv/field/seeds.hpp"
#include "rv/job.hpp"

namespace rv {

struct SessionLimits {
  int undo_depth = 50;           // steps kept for undo (older ones are dropped)
  int64_t max_memory_bytes = 0;  // > 0: a session over this (memory_bytes()) is too_large, at
                                 // creation or by an edit (which then rolls back)
};

// The deliverables a session keeps, by name: "boundaries", "tripoints", "limits", "regions",
// "turning_points" (the last as the job's JSON, the others GeoJSON).
inline constexpr const char* kSessionDeliverables[] = {"boundaries", "tripoints", "limits", "regions",
                                                       "turning_points"};

// What Session::save() needs, copied at one step: the seeds, grid and options. Later edits of
// the session do not reach it (a job made from a session and queued behind others saves the
// state it was asked for). Immutable; thread-safe.
class SessionSnapshot {
 public:
  // As Session::save().
  JobResult save(const OutputRequest& outputs, const JobHooks& hooks = {}) const;
  // The session's spec (its kept deliverables' outputs) and its prepared job, as copied.
  const JobSpec& spec() const { return spec_; }
  const PreparedJob& job() const { return job_; }

 private:
  friend class Session;
  JobSpec spec_;
  PreparedJob job_;
  JobLimits limits_;
};

class Session {
 public:
  // Reads and plans the seeds as prepare_job does, computes the field whole and the
  // deliverables `spec` asks for: any non-empty one of its outputs boundaries, tripoints,
  // limits, regions and turning_points is kept (the paths themselves are not written; raster
  // outputs, the report and the others are ignored; with none, the session keeps the field
  // alone: its owners' areas are the cells'). Throws rv::Error as run_job does, and
  // invalid_argument for what sessions do not take (above);
  // too_large when the session would exceed limits.max_memory_bytes.
  static std::unique_ptr<Session> create(const JobSpec& spec, const SessionLimits& limits = {},
                                         const JobLimits& job_limits = {}, const JobHooks& hooks = {});
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  // Applies `edits` (a JSON array, in order, as one step) and answers what changed (areas in
  // "area_units", the job's distance units squared; "cells_area" sums the squares of the cells
  // an owner holds, updated by the change; "area" is the regions', given when the step makes the
  // files, see deliverables()):
  //   {"step", "edits", "cells": {"owner_changed", "distance_only", "box": [col0, row0, col1,
  //   row1] | null}, "moved": [{"from", "to", "area"}], "areas": [{"label", "cells_area", and
  //   "area", "sea_area", "land_area"?}], "area_units", "lines": {kind: {"added": [...],
  //   "changed": [...], "removed": [ids]}}, "tripoints": {...}, "features": {"added": [...],
  //   "changed": [...], "removed": [ids]} (features() entries), "turning_points"?,
  //   "relevant_area"?, "recompute": {"cells", "lines_s", "rows_extracted", "rows_taken",
  //   "segments_refined", "segments_taken"}, "timings": {...}}
  // Operations (coordinates in the seeds' CRS; reach in the job's distance units):
  //   {"op": "replace", "feature": ID, "geometry": GEOJSON}
  //   {"op": "move-vertex", "feature": ID, "path": [...], "to": [x, y]}: path [] for a point,
  //       [part] for a part of a multipoint, [part, vertex] for a line, [part, ring, vertex] for a
  //       polygon (a ring's first vertex and its closing one are one vertex)
  //   {"op": "add", "properties": {"owner", "weight"?, "reach"?}, "geometry": GEOJSON}
  //   {"op": "remove", "feature": ID}
  //   {"op": "set", "feature": ID, "properties": {"owner"?, "weight"?, "reach"?}}
  // Bad edits are refused, the session left as it was: rv::Error(invalid_argument) for a
  // malformed operation, an unknown id or path, a non-finite or out-of-CRS coordinate, a
  // property of the wrong type; invalid_input for an invalid polygon or no seed left; conflict
  // for an overlap between owners beyond the border tolerance; too_large over the memory limit.
  nlohmann::json edit(const nlohmann::json& edits);
  // Undoes the last step (redo() makes it again), answered as edit() answers. Throws
  // rv::Error(invalid_argument) when there is none.
  nlohmann::json undo();
  nlohmann::json redo();

  // Grid, owners, areas, memory, edits made, undo and redo depth; with regions, their check
  // against the cells (regions_check: a job report's deliverables.regions.against_cells).
  nlohmann::json info() const;
  // The seed features as a GeoJSON FeatureCollection (ids as above; properties owner, weight,
  // reach, kind), coordinates in the seeds' CRS; a CRS other than longitude/latitude is named
  // by a "crs" member (its WKT), the form GDAL reads.
  nlohmann::json features() const;
  // The names of the deliverables kept (kSessionDeliverables' order), and one's current text.
  // Throws rv::Error(not_found) for a name not kept.
  // The deliverables' files are made when first read after a step (deliverable(), info(),
  // save() does not need them): a step answers once its lines are made. A step whose answer
  // carries what only the files give (turning points, the relevant area's ratios) makes them
  // with it.
  std::vector<std::string> deliverables() const;
  const std::string& deliverable(const std::string& name) const;
  // The current lines' ids (see "Line ids"), {"boundaries": [...], "limits": [...],
  // "tripoints": [...]}, each in the order of its deliverable's features: with them a client
  // keys the lines it drew from the deliverables and patches them from each answer.
  nlohmann::json line_ids() const;
  // Runs an ordinary job on the current seeds: `spec`'s outputs (files, rasters in memory, the
  // report) with the session's seeds, grid and options; its files equal a fresh run's on the
  // edited seeds. Throws as run_job.
  JobResult save(const OutputRequest& outputs, const JobHooks& hooks = {}) const;
  // The current state for saving later (its seeds copied: about the seeds' memory).
  std::shared_ptr<const SessionSnapshot> snapshot() const;
  // The memory limit of later steps (SessionLimits::max_memory_bytes; 0 = none): a daemon
  // lowers it when its sessions together near their limit.
  void set_memory_limit(int64_t bytes);

  const SeedSet& seeds() const;
  const GridSpec& grid() const;
  const PreparedJob& job() const;
  // The field in metric units (NearestField: sites index seeds()).
  const NearestField& field() const;
  int64_t steps() const;  // steps made (undo counts back)
  // Bytes held: the field, its tile summaries, the seeds and features, the line pieces and their
  // refinement (segment by segment), the
  // deliverables' text, the undo and redo steps.
  int64_t memory_bytes() const;

 private:
  Session();
  struct State;
  std::unique_ptr<State> st_;
};

}  // namespace rv
