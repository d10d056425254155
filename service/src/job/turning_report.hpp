// The turning-point report of a job (--turning-points FILE.json|.csv, output turningPoints):
// each boundary line's turning points (rv::turning_points) as a treaty table states them --
// longitude and latitude in decimal degrees and in degrees-minutes-seconds to 0.001", the datum,
// each side's controlling basepoints (position, feature, owner, distance) -- and for each
// segment to the next point its geodesic length and initial azimuth, the largest separation of
// the rhumb line between the two points from the geodesic, and the largest distance of the true
// line between them from the geodesic segment (rv/report/treaty.hpp); and the arcs of the job's
// distance-limit lines (JSON only). Grids without a CRS get grid coordinates and plane lengths
// only.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "rv/engine/owner_index.hpp"
#include "rv/job.hpp"
#include "rv/lines/boundaries.hpp"
#include "rv/lines/limits.hpp"

namespace rv::detail {

// The report as JSON (distances in the job's units); `index`: the field's. With the job's limit
// lines, each line's arcs too (rv::limit_arcs: from, to, the basepoint or edge drawing it).
nlohmann::json turning_report(const BoundaryResult& boundaries, const LimitResult& limits, const OwnerIndex& index,
                              const PreparedJob& job, int threads);
// Writes it atomically: JSON for a .json path, one row per turning point for .csv.
void write_turning_report(const std::string& path, const nlohmann::json& report);

}  // namespace rv::detail
