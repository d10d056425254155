// SeedSet::replaced (rv/field/seeds.hpp): a copy with some features replaced equals the set
// built again feature by feature with the replacements, sites, polygons (their area sites) and
// features alike; what does not fit is refused. SeedSet::adjusted, kept as a count, says what a
// scan of the features says after every way a set is made or changed; copies share their
// features' source names.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "rv/field/error.hpp"
#include "rv/field/seeds.hpp"

namespace rv {
namespace {

// One random feature's geometry: points, a line, polygons with holes, or a mix; sometimes
// degenerate parts the set drops (a repeated point, a ring of two vertices).
struct Shape {
  std::vector<Vec2> points;
  std::vector<std::vector<Vec2>> lines;
  std::vector<std::vector<Ring>> polygons;
};

Shape random_shape(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 100.0);
  auto at = [&] { return Vec2{u(rng), u(rng)}; };
  Shape s;
  const int kind = static_cast<int>(rng() % 5);
  if (kind == 0 || kind == 4)
    for (int i = 0, n = 1 + static_cast<int>(rng() % 3); i < n; ++i) s.points.push_back(at());
  if (kind == 1 || kind == 4) {
    std::vector<Vec2> line;
    for (int i = 0, n = 1 + static_cast<int>(rng() % 5); i < n; ++i) line.push_back(at());
    if (rng() % 4 == 0) line.push_back(line.back());  // a repeated vertex
    s.lines.push_back(line);
  }
  if (kind == 2 || kind == 3 || kind == 4)
    for (int i = 0, n = 1 + static_cast<int>(rng() % 2); i < n; ++i) {
      const Vec2 c = at();
      Ring outer{{c.x, c.y}, {c.x + 3, c.y}, {c.x + 3, c.y + 3}, {c.x, c.y + 3}};
      std::vector<Ring> rings{outer};
      if (rng() % 2 == 0) rings.push_back(Ring{{c.x + 1, c.y + 1}, {c.x + 2, c.y + 1}, {c.x + 2, c.y + 2}});
      if (rng() % 5 == 0) rings = {Ring{c, c}};  // dropped: fewer than three vertices
      s.polygons.push_back(rings);
    }
  return s;
}

struct Made {
  int32_t owner;
  Shape shape;
  double weight, reach, effect;
  std::string source;
};

Made random_made(std::mt19937& rng, int32_t owner, int n) {
  const double weight = rng() % 3 == 0 ? 1.5 : 1.0;
  const double reach = rng() % 4 == 0 ? 30.0 : std::numeric_limits<double>::infinity();
  const double effect = rng() % 5 == 0 ? 0.5 : 1.0;
  return Made{owner, random_shape(rng), weight, reach, effect, "feature " + std::to_string(n)};
}

void add(SeedSet& s, const Made& m) {
  const int32_t f = s.add_feature(m.owner, m.source);
  for (const Vec2& p : m.shape.points) s.add_point(f, p);
  for (const auto& l : m.shape.lines) s.add_polyline(f, l);
  for (const auto& p : m.shape.polygons) s.add_polygon(f, p);
  s.set_adjustment(f, m.weight, m.reach);
  s.set_effect(f, m.effect);
}

SeedSet labelled(int owners) {
  SeedSet s;
  for (int o = 1; o <= owners; ++o) s.owner_code("O" + std::to_string(o));
  return s;
}

// The oracle of SeedSet::adjusted: a scan of the features.
bool scanned_adjusted(const SeedSet& s) {
  return std::any_of(s.features().begin(), s.features().end(),
                     [](const Feature& f) { return f.weight != 1.0 || std::isfinite(f.reach); });
}

void expect_same(const SeedSet& a, const SeedSet& b) {
  ASSERT_EQ(a.owner_labels(), b.owner_labels());
  EXPECT_EQ(a.adjusted(), scanned_adjusted(a));
  EXPECT_EQ(b.adjusted(), scanned_adjusted(b));
  ASSERT_EQ(a.features().size(), b.features().size());
  for (size_t f = 0; f < a.features().size(); ++f) {
    const Feature &x = a.features()[f], &y = b.features()[f];
    EXPECT_TRUE(x.owner == y.owner && x.kind == y.kind && x.source == y.source && x.weight == y.weight &&
                x.reach == y.reach && x.effect == y.effect)
        << "feature " << f;
  }
  ASSERT_EQ(a.sites().size(), b.sites().size());
  for (size_t i = 0; i < a.sites().size(); ++i) {
    const Site &x = a.sites()[i], &y = b.sites()[i];
    EXPECT_TRUE(x.a == y.a && x.b == y.b && x.feature == y.feature && x.kind == y.kind) << "site " << i;
  }
  ASSERT_EQ(a.polygons().size(), b.polygons().size());
  for (size_t i = 0; i < a.polygons().size(); ++i) {
    const Polygon &x = a.polygons()[i], &y = b.polygons()[i];
    EXPECT_TRUE(x.feature == y.feature && x.area_site == y.area_site && x.rings == y.rings) << "polygon " << i;
  }
}

TEST(SeedSet, ReplacedEqualsTheSetBuiltAgain) {
  std::mt19937 rng(20261130);
  for (int round = 0; round < 300; ++round) {
    const int owners = 1 + static_cast<int>(rng() % 4);
    const int n = 1 + static_cast<int>(rng() % 40);
    std::vector<Made> made;
    for (int i = 0; i < n; ++i) made.push_back(random_made(rng, 1 + static_cast<int32_t>(rng() % owners), i));
    // Grouped by owner, as the readers group them.
    std::stable_sort(made.begin(), made.end(), [](const Made& a, const Made& b) { return a.owner < b.owner; });
    SeedSet base = labelled(owners);
    for (const Made& m : made) add(base, m);
    // Some features replaced: the first, the last, runs, or none.
    std::vector<int32_t> which;
    SeedSet by = labelled(owners);
    std::vector<Made> after = made;
    for (int f = 0; f < n; ++f)
      if (rng() % 3 == 0 || (round % 7 == 0 && (f == 0 || f == n - 1))) {
        which.push_back(f);
        after[static_cast<size_t>(f)] = random_made(rng, made[static_cast<size_t>(f)].owner, 1000 + f);
        add(by, after[static_cast<size_t>(f)]);
      }
    SeedSet again = labelled(owners);
    for (const Made& m : after) add(again, m);
    SCOPED_TRACE("round " + std::to_string(round));
    expect_same(base.replaced(which, by), again);
    if (HasFailure()) return;
  }
}

TEST(SeedSet, ReplacedRefusesWhatDoesNotFit) {
  std::mt19937 rng(7);
  SeedSet base = labelled(2);
  add(base, random_made(rng, 1, 0));
  add(base, random_made(rng, 2, 1));
  SeedSet one = labelled(2);
  add(one, random_made(rng, 1, 2));
  SeedSet other_owner = labelled(2);
  add(other_owner, random_made(rng, 2, 3));
  SeedSet two = labelled(2);
  add(two, random_made(rng, 1, 4));
  add(two, random_made(rng, 2, 5));
  SeedSet relabelled;
  relabelled.owner_code("O2");
  relabelled.owner_code("O1");
  add(relabelled, random_made(rng, 1, 6));
  auto refused = [&](const std::vector<int32_t>& which, const SeedSet& by) {
    try {
      base.replaced(which, by);
    } catch (const Error& e) {
      return e.kind() == ErrorKind::internal;
    }
    return false;
  };
  EXPECT_TRUE(refused({1}, one));          // feature 1 is O2's, its replacement O1's
  EXPECT_TRUE(refused({0}, other_owner));  // likewise
  EXPECT_TRUE(refused({0}, two));          // two replacements for one feature
  EXPECT_TRUE(refused({1, 0}, two));       // out of order
  EXPECT_TRUE(refused({0, 0}, two));       // repeated
  EXPECT_TRUE(refused({2}, one));          // no such feature
  EXPECT_TRUE(refused({0}, relabelled));   // owners numbered otherwise
  EXPECT_FALSE(refused({0, 1}, two));      // and one that fits
  EXPECT_NO_THROW(base.replaced({}, labelled(2)));
}

TEST(SeedSet, AdjustedFollowsEveryChange) {
  SeedSet s = labelled(2);
  std::mt19937 rng(5);
  Made plain = random_made(rng, 1, 0);
  plain.weight = 1.0;
  plain.reach = std::numeric_limits<double>::infinity();
  add(s, plain);
  add(s, plain);
  EXPECT_FALSE(s.adjusted());
  s.set_adjustment(1, 2.0, std::numeric_limits<double>::infinity());
  EXPECT_TRUE(s.adjusted());
  s.set_adjustment(0, 1.0, 10.0);
  s.set_adjustment(1, 1.0, std::numeric_limits<double>::infinity());
  EXPECT_TRUE(s.adjusted()) << "feature 0 keeps a reach";
  s.scale_reaches(1e308);  // 10 * 1e308 overflows: the reach is infinite, the feature plain
  EXPECT_EQ(s.adjusted(), scanned_adjusted(s));
  EXPECT_FALSE(s.adjusted());
  s.set_adjustment(0, 1.0, 10.0);
  std::vector<int32_t> site_of;
  EXPECT_FALSE(s.without({true, false}, site_of).adjusted()) << "the adjusted feature dropped";
  EXPECT_TRUE(s.without({false, true}, site_of).adjusted());
  SeedSet by = labelled(2);
  add(by, plain);
  EXPECT_FALSE(s.replaced({0}, by).adjusted()) << "the adjusted feature replaced by a plain one";
  const SeedSet copy = s;
  EXPECT_TRUE(copy.adjusted());
  const SeedSet parts = SeedSet::from_parts(s.sites(), s.polygons(), s.features(), s.owner_labels());
  EXPECT_TRUE(parts.adjusted());
}

TEST(SeedSet, CopiesShareTheirSourceNames) {
  SeedSet s = labelled(1);
  const std::string name = "a long source name: coast.gpkg:coastline:fid 123456";
  s.add_point(s.add_feature(1, name), Vec2{1.0, 2.0});
  s.add_point(s.add_feature(1), Vec2{3.0, 4.0});
  const SeedSet copy = s;
  EXPECT_EQ(copy.features()[0].source.str(), name);
  EXPECT_EQ(&copy.features()[0].source.str(), &s.features()[0].source.str()) << "one text, shared";
  EXPECT_TRUE(copy.features()[1].source.empty());
  EXPECT_EQ(copy.feature_name(1), "feature 2");
  // The name's bytes are counted: its shared block and its text.
  SeedSet unnamed = labelled(1);
  unnamed.add_point(unnamed.add_feature(1), Vec2{1.0, 2.0});
  unnamed.add_point(unnamed.add_feature(1), Vec2{3.0, 4.0});
  EXPECT_GE(s.memory_bytes() - unnamed.memory_bytes(), static_cast<int64_t>(name.size()));
}

}  // namespace
}  // namespace rv
