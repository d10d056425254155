// The geodesic reference distances for bench/peers.py while `rvoronoi compute` still refuses
// the geodesic metric: the engine's geodesic brute force (or exact) on a lon/lat grid, written
// as a Float32 distance GeoTIFF in metres. Uses the same seed reader and writer as the CLI.
//
//   geodesic_reference SEEDS XMIN YMAX RES WIDTH HEIGHT brute-force|exact OUT.tif
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "rv/engine/engine.hpp"
#include "rv/gdal/raster_io.hpp"
#include "rv/gdal/seed_reader.hpp"

int main(int argc, char** argv) {
  if (argc != 9) {
    std::fprintf(stderr, "usage: geodesic_reference SEEDS XMIN YMAX RES WIDTH HEIGHT brute-force|exact OUT.tif\n");
    return 2;
  }
  try {
    rv::SeedReadOptions read;
    read.paths = {argv[1]};
    const rv::LoadedSeeds loaded = rv::load_seeds(read);
    if (!loaded.crs.geographic) throw std::runtime_error("the seeds' CRS is not geographic");
    rv::GridSpec grid;
    grid.xmin = std::atof(argv[2]);
    grid.ymax = std::atof(argv[3]);
    grid.res = std::atof(argv[4]);
    grid.width = std::atoll(argv[5]);
    grid.height = std::atoll(argv[6]);
    grid.crs = loaded.crs.wkt;
    rv::ComputeOptions options;
    options.method = rv::parse_method(argv[7]);
    options.metric =
        rv::resolve_metric(rv::MetricRequest::geodesic, true, loaded.crs.semi_major, loaded.crs.flattening);
    const rv::NearestField field = rv::compute(loaded.seeds, grid, options);
    rv::GeoTiffOptions out;
    out.units = "m";
    rv::write_geotiff(argv[8], field.distance, rv::kNoDistance, out);
    std::printf("{\"compute_s\": %.6f}\n", field.seconds);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "geodesic_reference: %s\n", e.what());
    return 1;
  }
  return 0;
}
