// Seed sets as bytes (rv/edit/seed_archive.hpp): a set of points, lines, polygons with holes, several
// owners and adjustments comes back equal, part for part and bit for bit; every truncation and
// damaged count is refused with invalid_input, never a crash or a huge allocation.
#include <gtest/gtest.h>

#include <bit>
#include <limits>
#include <string>
#include <vector>

#include "rv/edit/seed_archive.hpp"
#include "rv/field/error.hpp"

namespace rv {
namespace {

SeedSet sample() {
  SeedSet s;
  const int32_t a = s.owner_code("DK"), b = s.owner_code("S\xc3\xa9<&>");
  int32_t f = s.add_feature(a, "coast.gpkg:states:fid 1");
  s.add_point(f, {12.5, 55.75});
  f = s.add_feature(b, "coast.gpkg:states:fid 2");
  s.add_polyline(f, std::vector<Vec2>{{13.0, 55.5}, {13.1, 55.6}, {13.3, 55.61}});
  s.set_adjustment(f, 1.5, 22224.0);
  f = s.add_feature(a, "");
  s.add_polygon(f, {Ring{{0.1, 0.1}, {1.0, 0.1}, {1.0, 1.0}, {0.1, 1.0}}, Ring{{0.4, 0.4}, {0.6, 0.4}, {0.5, 0.6}}});
  s.set_effect(f, 0.5);
  return s;
}

void expect_equal(const SeedSet& x, const SeedSet& y) {
  ASSERT_EQ(x.owner_labels(), y.owner_labels());
  ASSERT_EQ(x.features().size(), y.features().size());
  for (size_t i = 0; i < x.features().size(); ++i) {
    const Feature &p = x.features()[i], &q = y.features()[i];
    EXPECT_EQ(p.owner, q.owner);
    EXPECT_EQ(p.kind, q.kind);
    EXPECT_EQ(p.source, q.source);
    EXPECT_EQ(std::bit_cast<uint64_t>(p.weight), std::bit_cast<uint64_t>(q.weight));
    EXPECT_EQ(std::bit_cast<uint64_t>(p.reach), std::bit_cast<uint64_t>(q.reach));
    EXPECT_EQ(std::bit_cast<uint64_t>(p.effect), std::bit_cast<uint64_t>(q.effect));
  }
  ASSERT_EQ(x.sites().size(), y.sites().size());
  for (size_t i = 0; i < x.sites().size(); ++i) {
    EXPECT_EQ(x.sites()[i].a, y.sites()[i].a);
    EXPECT_EQ(x.sites()[i].b, y.sites()[i].b);
    EXPECT_EQ(x.sites()[i].feature, y.sites()[i].feature);
    EXPECT_EQ(x.sites()[i].kind, y.sites()[i].kind);
  }
  ASSERT_EQ(x.polygons().size(), y.polygons().size());
  for (size_t i = 0; i < x.polygons().size(); ++i) {
    EXPECT_EQ(x.polygons()[i].feature, y.polygons()[i].feature);
    EXPECT_EQ(x.polygons()[i].area_site, y.polygons()[i].area_site);
    EXPECT_EQ(x.polygons()[i].rings, y.polygons()[i].rings);
  }
}

TEST(SeedArchive, RoundTripsEveryPart) {
  const SeedSet s = sample();
  const std::vector<int64_t> numbering{3, 1, 7};
  const SeedArchive back = decode_seed_archive(encode_seed_archive(s, numbering));
  expect_equal(s, back.seeds);
  EXPECT_EQ(back.numbering, numbering);
  // The owner index is rebuilt: a new label gets the next code, a known one its own.
  SeedSet again = back.seeds;
  EXPECT_EQ(again.owner_code("DK"), 1);
  EXPECT_EQ(again.owner_code("NO"), 3);
  EXPECT_TRUE(decode_seed_archive(encode_seed_archive(SeedSet{}, {})).seeds.sites().empty());
}

TEST(SeedArchive, DamagedBytesAreRefused) {
  const std::string bytes = encode_seed_archive(sample(), {3, 1, 7});
  auto refused = [](const std::string& b) {
    try {
      decode_seed_archive(b);
    } catch (const Error& e) {
      return e.kind() == ErrorKind::invalid_input;
    }
    return false;
  };
  for (size_t n = 0; n < bytes.size(); ++n) EXPECT_TRUE(refused(bytes.substr(0, n))) << "truncated at " << n;
  EXPECT_TRUE(refused(bytes + "x"));
  EXPECT_TRUE(refused("not an archive at all"));
  // A count of 2^62 owner labels right after the header: refused before anything is allocated.
  std::string huge = bytes;
  const size_t at = std::string("rvoronoi-seeds").size() + 4;
  const uint64_t big = uint64_t{1} << 62;
  huge.replace(at, 8, reinterpret_cast<const char*>(&big), 8);
  EXPECT_TRUE(refused(huge));
  // Parts that do not fit: a feature's owner code beyond the labels.
  SeedSet bad = sample();
  std::string b = encode_seed_archive(bad, {});
  const size_t owner_at = b.find("coast.gpkg:states:fid 1") - 8 - 1 - 4;  // owner, kind, text length
  const int32_t code = 9;
  b.replace(owner_at, 4, reinterpret_cast<const char*>(&code), 4);
  EXPECT_TRUE(refused(b));
}

}  // namespace
}  // namespace rv
