// The distance by sea as the deliverables measure it: a SiteMetric (rv/engine/site_metric.hpp)
// whose distance from a position to a site runs by sea, so that an OwnerIndex over it, and the
// boundaries and tripoints placed with that index (rv/lines/boundaries.hpp), follow the distance
// by sea of rv/sea/sea_field.hpp.
//
// Lines need each owner's own distance, d_X(p), not only the nearest seed's: the bend nodes are
// settled again once per owner over that owner's sites alone (the exact engine's Dijkstra), so
// that every node v knows D_X(v) and the site its path starts from. For a site s of owner X,
// distance(p, s) is the least of
//   - the straight distance to s, where p sees the site's nearest point, and
//   - D_X(v) + |v - p|, over the nodes v whose path starts at s, that p sees, with the path
//     taut at v;
// so the least over X's sites is d_X(p), exactly as compute_sea's statement has it (the same
// visibility, the same nodes). One site's value is never below its own distance by sea, and is
// equal to it where the site is its owner's nearest (exact ties of two sites aside); the straight
// distance bounds it from below, which is what the index's searches need, so the straight
// metric's embedding and bounds serve unchanged.
//
// Positions are grid-CRS coordinates as the straight metrics'; distances metric units (planar:
// CRS units; geodesic: metres, on a projected grid the positions located by the geolocator). On
// land (Visibility::on_land) every geometric site is at +infinity. Area sites are measured as by
// the straight metric (0 inside the polygon; its rings carry the distance outside).
// Gradients: planar a unit vector, geodesic metres per degree, none (NaN) on a projected geodesic
// grid. nearest_point(): the point of the site the path starts from. open_between(a, b): a and b
// are sea, the straight way between them crosses no barrier, and neither (a != b) lies on a
// barrier with sea on more than one side (a line barrier, or where two islands meet at a corner:
// such a point takes the shortest of its sides' paths, so the distances jump on leaving it).
//
// Thread safety: const functions from any number of threads (the lazy settling is synchronised).
#pragma once

#include <limits>
#include <memory>

#include "rv/engine/site_metric.hpp"
#include "rv/sea/sea_field.hpp"

namespace rv {

// What settling the owners measured: the owners settled, the straight paths tested while
// settling them, the wall time, and the distance by sea they were settled to (settle_within).
struct SeaMetricStats {
  int32_t owners = 0;
  int64_t bend_tests = 0;
  double seconds = 0.0;
  double within = std::numeric_limits<double>::infinity();
};

// The metric of the distance by sea for `seeds`, `barriers` and `grid` with `options` (metric,
// geolocator and grid polygons, threads for the owners' settling, cancel; options.prepared, when
// given, must be prepare_sea()'s of the same seeds, barriers and grid: its frame and nodes are
// shared). Keeps references to `seeds`, which must outlive it. Throws as prepare_sea.
// The owners' bend nodes are settled at the first distance asked of it (once, on options.threads
// threads; the other askers wait), so a metric asked nothing (a margin alone, which runs the
// engine per owner) costs no settling; that first call may throw rv::Error(cancelled) when
// *options.cancel becomes true (the next call tries again). `stats`, when given, is filled then:
// it and options.cancel must outlive the metric.
//
// `settle_within` (metric units, >= 0): each owner's bend nodes are settled only up to that
// distance by sea from the owner's seeds. Distances are then exact wherever they are at most
// `settle_within`; a larger one comes out as some path's length above `settle_within`, or
// +infinity (a path bending at a node farther than that from its owner is not sought). So the
// nearest owner at a position, and every comparison of an owner within `settle_within` with any
// other, are exactly as with every node settled; two owners both farther than it are not compared
// exactly. The lines ask for owners at their own positions (between two owners' cells, at three
// owners' meeting, on a limit's level): a bound of the field's largest distance, with a margin,
// and of the largest limit level, leaves them unchanged, and spares the settling of the nodes an
// owner reaches only round many headlands, which is most of it. +infinity: every node settled;
// 0: none beyond the seeds until settle_sea_metric_within raises it (a streamed job raises it
// strip by strip, as the field's largest distance grows).
std::unique_ptr<SiteMetric> make_sea_site_metric(const SeedSet& seeds, const Barriers& barriers, const GridSpec& grid,
                                                 const SeaOptions& options = {}, SeaMetricStats* stats = nullptr,
                                                 double settle_within = std::numeric_limits<double>::infinity());

// Raises the distance a metric of make_sea_site_metric settles its owners within to `within`
// (metric units, >= 0; nothing when not above the present one). Where the owners were settled
// already the settling goes on from where it stopped (what one settling to `within` would have
// settled, to the bit), on the metric's threads, into its stats (bend_tests and seconds add up).
// Not to be called while any other call on the metric runs (a streamed job calls it between
// strips). Throws rv::Error(invalid_argument) for within < 0 or NaN, rv::Error(internal) for a metric
// of another kind, rv::Error(cancelled) as the settling.
void settle_sea_metric_within(SiteMetric& metric, double within);

}  // namespace rv
