// A seed set as bytes, and back: what a finished run keeps of its seeds so that a later edit of
// the same job (rv/edit.hpp) can tell which features changed after the user edited the files in
// place.
//
// The bytes hold every part of the set (owner labels in code order, features with their owner,
// kind, source, weight, reach and effect, sites, polygons with their rings) and the features'
// numbering (LoadedSeeds::input_position, the nearest-feature raster's codes), doubles bit for
// bit, in little-endian order behind a magic and a format version. Decoding gives back an equal
// set: the same parts in the same order.
//
// Thread safety: pure functions.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rv/seeds.hpp"

namespace rv {

struct SeedArchive {
  SeedSet seeds;
  std::vector<int64_t> numbering;  // per feature, its 1-based code in the nearest-feature raster; may be empty
};

std::string encode_seed_archive(const SeedSet& seeds, const std::vector<int64_t>& numbering);

// Throws rv::Error(invalid_input) for bytes that are not an archive of this format (wrong magic
// or version, truncated, trailing bytes, counts beyond the bytes) or whose parts do not fit
// together (SeedSet::from_parts).
SeedArchive decode_seed_archive(std::string_view bytes);

}  // namespace rv
