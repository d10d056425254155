// Internal: the exact method with an owner filter (see OtherOwnerSolver in exact.cpp).
#pragma once

#include <vector>

#include "engine/engine_internal.hpp"

namespace rv::detail {

// For every cell of ctx.window: the nearest geometric site whose owner (owner_of_site) differs
// from the owner of own's site at that cell; kNoSite / kNoDistance where own has no site or no
// such site exists. `own` covers ctx.window (window-relative indexing).
void run_exact_other_owner(const EngineContext& ctx, const Raster<int32_t>& own,
                           const std::vector<int32_t>& owner_of_site, Raster<int32_t>& site, Raster<float>& distance);

}  // namespace rv::detail
