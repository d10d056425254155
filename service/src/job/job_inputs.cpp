// The job's inputs besides the seeds: the layers read beside them (the relevant area and coasts,
// the barriers' options), and the deliverables' lengths in metric units. See job_run.hpp.
#include <algorithm>

#include "job/job_run.hpp"
#include "rv/field/error.hpp"

namespace rv::detail {

SeedReadOptions other_layers(SeedReadOptions read, std::vector<std::string> paths, const PreparedJob& job) {
  read.paths = std::move(paths);
  read.layers.clear();
  read.owner_field.reset();
  read.weight_field.reset();
  read.reach_field.reset();
  read.effect_field.reset();
  read.on_conflict = ConflictPolicy::lower_code;
  read.target_crs = job.loaded.crs.wkt;
  read.geographic_seeds = false;
  return read;
}

// The limit lines' distances in metric units (metres on geodesic grids, CRS units on planar).
std::vector<double> limit_distances_in_metric_units(const JobSpec& spec, const PreparedJob& job) {
  const OutputRequest& out = spec.outputs;
  if (!out.limits.empty() && out.limit_distances.empty())
    throw Error(ErrorKind::invalid_argument, "limit lines need limit distances (e.g. --limit-distances 12nmi,24nmi)");
  const bool geodesic = job.metric.kind == MetricSpec::geodesic;
  std::vector<double> metric;
  for (const std::string& text : out.limit_distances) {
    const LimitDistance d = parse_limit_distance(text);
    if (d.unit.empty()) {
      metric.push_back(d.value / job.to_output);
      continue;
    }
    if (!geodesic && job.loaded.crs.wkt.empty())
      throw Error(ErrorKind::invalid_argument, "limit distance '" + text + "' has a unit, but the seeds have no CRS");
    metric.push_back(d.value * metres_per_unit(parse_distance_unit(d.unit)) /
                     (geodesic ? 1.0 : job.loaded.crs.linear_unit));
  }
  for (double d : metric)
    if (d > job.compute.max_distance)
      throw Error(ErrorKind::invalid_argument,
                  "a limit distance exceeds the max distance: cells beyond it have no distance to draw the line in");
  return metric;
}

// The line tolerance in metric units: a length with a unit in metres (CRS units where the seeds
// have no CRS: the default 1 mm is then 0.001 of them), a plain number in the distance units.
double line_tolerance_in_metric_units(const JobSpec& spec, const PreparedJob& job) {
  const Length l = parse_length(spec.outputs.line_tolerance);
  if (l.unit.empty()) return l.value / job.to_output;
  const bool geodesic = job.metric.kind == MetricSpec::geodesic;
  if (geodesic) return l.value * l.metres_per_unit;
  if (job.loaded.crs.wkt.empty()) return l.value * l.metres_per_unit;  // CRS units taken as metres
  return l.value * l.metres_per_unit / job.loaded.crs.linear_unit;
}

// The relevant area (its polygons, in the grid's CRS) and the relevant coasts (in the seeds'
// CRS, owned as the seeds are), read with the seeds' confinement and limits; refused when the
// area holds no polygon, the coasts no line, or a coast's owner has no seeds.
void read_relevant(const JobSpec& spec, const JobLimits& limits, PreparedJob& job) {
  const OutputRequest& out = spec.outputs;
  if (out.relevant_area.empty()) {
    if (!out.relevant_coasts.empty())
      throw Error(ErrorKind::invalid_argument, "relevant coasts need a relevant area (--relevant-area)");
    return;
  }
  const SeedReadOptions area = other_layers(with_limits(spec.seeds, limits), {out.relevant_area}, job);
  job.relevant_area = load_seeds(area);
  if (job.relevant_area->seeds.polygons().empty())
    throw Error(ErrorKind::invalid_input, "the relevant area (" + out.relevant_area + ") holds no polygon");
  if (out.relevant_coasts.empty()) return;
  // The uploads' limits too (the daemon reads them as it reads the seeds).
  const SeedReadOptions seeds = with_limits(seed_options_for_metric(spec.seeds, spec.metric), limits);
  SeedReadOptions coasts = other_layers(seeds, {out.relevant_coasts}, job);
  coasts.owner_field = seeds.owner_field;  // owned as the seeds are, in their CRS
  coasts.geographic_seeds = seeds.geographic_seeds;
  job.relevant_coasts = load_seeds(coasts);
  const SeedSet& cs = job.relevant_coasts->seeds;
  if (cs.geometric_site_count() == 0)
    throw Error(ErrorKind::invalid_input, "the relevant coasts (" + out.relevant_coasts + ") hold no line");
  const std::vector<std::string>& owners = job.loaded.seeds.owner_labels();
  for (const std::string& label : cs.owner_labels())
    if (std::find(owners.begin(), owners.end(), label) == owners.end())
      throw Error(ErrorKind::invalid_input, "the relevant coasts name owner '" + label +
                                                "', which has no seeds (owners are matched by the " +
                                                "owner field's values)");
}

}  // namespace rv::detail
