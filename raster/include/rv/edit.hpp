// Edits of a finished field: which features an edit kept, and which cells it can change (seed
// paper 004: removing a site changes only the cells it owned; adding one, only the cells where it
// is nearer than the owner they had).
//
// An edit is a new seed set for the same grid and options. A cell can change only where
//   - its base nearest feature is not kept (removed, or changed: a changed feature is removed
//     and added again), or
//   - an added feature counts there at a cost no higher than the base winner's (ties included:
//     the lower site index wins them, and indices move), the base's Float32 distance widened by
//     its rounding; on unowned cells, wherever an added feature counts at all.
// Every other cell keeps its base nearest feature, at the same distance: its site is the same
// site of the kept feature, renumbered. Recomputing the cells of the mask (ComputeOptions::mask)
// over the renumbered base field gives the fresh field of the edited seeds, cell for cell.
//
// Units: metric units (the field's). Pure functions over value types; thread-safe.
#pragma once

#include <cstdint>
#include <vector>

#include "rv/cell_mask.hpp"
#include "rv/engine.hpp"
#include "rv/seeds.hpp"

namespace rv {

// Which features of the base are in the edited set unchanged: the same owner label, geometry
// (every site's kind and coordinates, and for polygons every ring, bit for bit) and adjustments
// (weight, reach, effect). Equal features pair in order of appearance. A kept feature whose
// place among the kept ones changed (the file's features reordered) counts as changed: the tie
// rule follows indices.
struct FeatureMatch {
  std::vector<int32_t> edited_of_base;  // per base feature: its index in the edited set, or -1
  std::vector<int32_t> base_of_edited;  // per edited feature: its base feature, or -1 (added)
  // The owners' codes (first appearance) order their labels differently: the lower code decides
  // cells inside polygons of two owners, so every polygon's interior may change.
  bool owners_reordered = false;
  int64_t kept() const;
};
FeatureMatch match_features(const SeedSet& base, const SeedSet& edited);

// Per base site, the same site of its kept feature in the edited set; kNoSite for the sites of
// features not kept.
std::vector<int32_t> edited_sites(const SeedSet& base, const SeedSet& edited, const FeatureMatch& match);

struct EditPlan {
  FeatureMatch match;
  CellMask mask;                // window-relative, the base field's window
  int64_t cells = 0;            // cells in the mask
  int64_t removed_cells = 0;    // of them, cells whose base feature is not kept
  int64_t blocks_measured = 0;  // blocks of cells an added feature could not be ruled out of
};

// The plan of an edit of `base` (the field of `base_seeds` over `grid`, its window, computed with
// `options`) to `edited`. Throws rv::Error(invalid_argument) where the field does not fit the
// seeds (a site index out of range). Threads: options.threads.
EditPlan plan_edit(const NearestField& base, const SeedSet& base_seeds, const SeedSet& edited, const GridSpec& grid,
                   const ComputeOptions& options);

// The edited field: the base's cells renumbered to the edited sites, the plan's cells computed
// again (the exact method with a mask). Equal to compute(edited, grid, options) over the base's
// window, cell for cell. Needs options.method exact (else rv::Error(invalid_argument)).
NearestField apply_edit(const NearestField& base, const SeedSet& base_seeds, const SeedSet& edited,
                        const GridSpec& grid, const ComputeOptions& options, const EditPlan& plan);

}  // namespace rv
