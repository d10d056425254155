// sea_bench --paint 1 (paint_measure.cpp): what drawing the shortest-path map root by root would
// cost and whether a root's region can be bounded while it is drawn. Timing and counts only: no
// engine uses it.
#pragma once

#include "rv/field/grid.hpp"
#include "rv/field/metric.hpp"
#include "rv/field/seeds.hpp"
#include "rv/sea/barriers.hpp"
#include "rv/sea/sea_field.hpp"

// Paints the field by sea of `seeds` round `barriers` over `grid` root by root (see
// paint_measure.cpp) and compares every sea cell with `field` (the exact engine's answer). Prints
// the counts; returns false where a cell the painting claims to have decided differs.
bool measure_paint(const rv::SeedSet& seeds, const rv::Barriers& barriers, const rv::GridSpec& grid,
                   const rv::MetricSpec& metric, const rv::SeaField& field, bool stop_rays);
