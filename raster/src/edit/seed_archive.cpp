// Seed sets as bytes (rv/edit/seed_archive.hpp).
//
// A plain tagged layout rather than a general serialisation library: the core depends on the
// standard library alone, and the set has five flat parts. Every count is checked against the
// bytes left before anything is allocated, so a damaged archive fails with a message instead of
// a huge allocation.
#include "rv/edit/seed_archive.hpp"

#include <algorithm>
#include <limits>

#include "field/byte_codec.hpp"
#include "rv/engine/engine.hpp"
#include "rv/field/error.hpp"

namespace rv {
namespace {

constexpr std::string_view kMagic = "rvoronoi-seeds";
constexpr uint32_t kVersion = 1;

}  // namespace

std::string encode_seed_archive(const SeedSet& seeds, const std::vector<int64_t>& numbering) {
  detail::ByteWriter o;
  for (const char c : kMagic) o.put(c);
  o.put(kVersion);
  o.put<uint64_t>(seeds.owner_labels().size());
  for (const std::string& l : seeds.owner_labels()) o.text(l);
  o.put<uint64_t>(seeds.features().size());
  for (const Feature& f : seeds.features()) {
    o.put(f.owner);
    o.put(static_cast<uint8_t>(f.kind));
    o.text(f.source);
    o.put(f.weight);
    o.put(f.reach);
    o.put(f.effect);
  }
  o.put<uint64_t>(seeds.sites().size());
  for (const Site& s : seeds.sites()) {
    o.vec(s.a);
    o.vec(s.b);
    o.put(s.feature);
    o.put(static_cast<uint8_t>(s.kind));
  }
  o.put<uint64_t>(seeds.polygons().size());
  for (const Polygon& p : seeds.polygons()) {
    o.put(p.feature);
    o.put(p.area_site);
    o.put<uint64_t>(p.rings.size());
    for (const Ring& r : p.rings) {
      o.put<uint64_t>(r.size());
      for (const Vec2 v : r) o.vec(v);
    }
  }
  o.put<uint64_t>(numbering.size());
  for (const int64_t n : numbering) o.put(n);
  return o.take();
}

SeedArchive decode_seed_archive(std::string_view bytes) {
  detail::ByteReader in(bytes, "seed archive");
  for (const char c : kMagic)
    if (in.get<char>() != c) throw Error(ErrorKind::invalid_input, "seed archive: not an rvoronoi seed archive");
  if (in.get<uint32_t>() != kVersion)
    throw Error(ErrorKind::invalid_input, "seed archive: written by another format version");
  std::vector<std::string> labels(in.count(8));
  for (std::string& l : labels) l = in.text();
  std::vector<Feature> features(in.count(4 + 1 + 8 + 24));
  for (Feature& f : features) {
    f.owner = in.get<int32_t>();
    const auto kind = in.get<uint8_t>();
    if (kind > static_cast<uint8_t>(GeometryKind::mixed)) in.fail();
    f.kind = static_cast<GeometryKind>(kind);
    f.source = in.text();
    f.weight = in.get<double>();
    f.reach = in.get<double>();
    f.effect = in.get<double>();
  }
  std::vector<Site> sites(in.count(37));
  for (Site& s : sites) {
    s.a = in.vec();
    s.b = in.vec();
    s.feature = in.get<int32_t>();
    const auto kind = in.get<uint8_t>();
    if (kind > static_cast<uint8_t>(SiteKind::area)) in.fail();
    s.kind = static_cast<SiteKind>(kind);
  }
  std::vector<Polygon> polygons(in.count(16));
  for (Polygon& p : polygons) {
    p.feature = in.get<int32_t>();
    p.area_site = in.get<int32_t>();
    p.rings.resize(in.count(8));
    for (Ring& r : p.rings) {
      r.resize(in.count(16));
      for (Vec2& v : r) v = in.vec();
    }
  }
  SeedArchive out;
  out.numbering.resize(in.count(8));
  for (int64_t& n : out.numbering) n = in.get<int64_t>();
  if (!in.done()) in.fail();
  if (!out.numbering.empty() && out.numbering.size() != features.size()) in.fail();
  // The numbering indexes tables (an edit's code maps, a raster's codes): each a distinct code
  // of the nearest-feature raster's range.
  std::vector<int64_t> sorted = out.numbering;
  std::sort(sorted.begin(), sorted.end());
  if (!sorted.empty() && (sorted.front() < 1 || sorted.back() > kMaxFeatureCode ||
                          std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()))
    throw Error(ErrorKind::invalid_input, "seed archive: a feature's number out of range or repeated");
  out.seeds = SeedSet::from_parts(std::move(sites), std::move(polygons), std::move(features), std::move(labels));
  return out;
}

std::string encode_site_codes(const std::vector<int32_t>& site_of_code) {
  detail::ByteWriter o;
  for (size_t k = 1; k < site_of_code.size(); ++k) o.put(site_of_code[k]);
  return o.take();
}

std::vector<int32_t> decode_site_codes(std::string_view bytes, size_t codes, int32_t sites) {
  if (bytes.size() != 4 * codes || codes >= static_cast<size_t>(std::numeric_limits<int32_t>::max()))
    throw Error(ErrorKind::invalid_input,
                "site codes: " + std::to_string(bytes.size()) + " bytes for " + std::to_string(codes) + " codes");
  detail::ByteReader in(bytes, "site codes");
  std::vector<int32_t> out(1, kNoSite);
  out.reserve(codes + 1);
  std::vector<bool> seen(static_cast<size_t>(std::max(sites, 0)), false);
  for (size_t k = 0; k < codes; ++k) {
    const auto site = in.get<int32_t>();
    if (site < -1 || site >= sites || (site >= 0 && seen[static_cast<size_t>(site)]))
      throw Error(ErrorKind::invalid_input, "site codes: code " + std::to_string(k + 1) + " names site " +
                                                std::to_string(site) + ", out of range or named twice");
    if (site >= 0) seen[static_cast<size_t>(site)] = true;
    out.push_back(site < 0 ? kNoSite : site);
  }
  return out;
}

}  // namespace rv
