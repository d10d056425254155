// A seed set as bytes, and back: what a finished run keeps of its seeds so that a later edit of
// the same job (rv/edit/edit.hpp) can tell which features changed after the user edited the files in
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
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "rv/field/seeds.hpp"

namespace rv {

// The largest feature number (LoadedSeeds::input_position) an archive may hold: the
// nearest-feature raster codes them as Int32.
inline constexpr int64_t kMaxFeatureCode = std::numeric_limits<int32_t>::max() - 1;

struct SeedArchive {
  SeedSet seeds;
  std::vector<int64_t> numbering;  // per feature, its 1-based code in the nearest-feature raster; may be empty
};

std::string encode_seed_archive(const SeedSet& seeds, const std::vector<int64_t>& numbering);

// Throws rv::Error(invalid_input) for bytes that are not an archive of this format (wrong magic
// or version, truncated, trailing bytes, counts beyond the bytes), whose parts do not fit
// together (SeedSet::from_parts) or whose numbering is not one distinct number in
// [1, kMaxFeatureCode] per feature. The bytes may come from anyone: every count and index is
// checked before it is used.
SeedArchive decode_seed_archive(std::string_view bytes);

// An edit's site codes (the site raster's code -> site index, kNoSite for 0 and for sites the
// edits removed; rv::detail's EditBaseWriter::set_site_codes) as bytes: codes 1.. as Int32
// little endian, code 0 left out.
std::string encode_site_codes(const std::vector<int32_t>& site_of_code);
// Back: `codes` codes of `sites` sites. Throws rv::Error(invalid_input) unless the bytes hold
// exactly `codes` values, each kNoSite (-1) or a site index in [0, sites) named once.
std::vector<int32_t> decode_site_codes(std::string_view bytes, size_t codes, int32_t sites);

}  // namespace rv
