// The job tests' case by sea: twelve ports on the Øresund's coasts (fixtures/oresund_ports.geojson,
// owners DK and SE) and the two states' land as barriers, in UTM 33N: 160 x 280 cells of 250 m
// over the strait, the planar metric. Outputs are the test's own.
#pragma once

#include <array>

#include "fixtures.hpp"
#include "rv/job.hpp"

namespace rv::test {

inline JobSpec oresund_ports_by_sea() {
  JobSpec s;
  s.seeds.paths = {fixture("oresund_ports.geojson")};
  s.seeds.owner_field = "owner";
  s.seeds.target_crs = "EPSG:32633";
  s.metric = MetricRequest::planar;
  s.barriers = {fixture("oresund.gpkg")};
  s.grid.resolution = 250.0;
  s.grid.extent = std::array<double, 4>{330000.0, 6150000.0, 370000.0, 6220000.0};
  return s;
}

}  // namespace rv::test
