// Seed sets as bytes (rv/seed_archive.hpp).
//
// A plain tagged layout rather than a general serialisation library: the core depends on the
// standard library alone, and the set has five flat parts. Every count is checked against the
// bytes left before anything is allocated, so a damaged archive fails with a message instead of
// a huge allocation.
#include "rv/seed_archive.hpp"

#include <bit>
#include <cstring>

#include "rv/error.hpp"

namespace rv {
namespace {

constexpr std::string_view kMagic = "rvoronoi-seeds";
constexpr uint32_t kVersion = 1;

static_assert(std::endian::native == std::endian::little, "the archive is written in the machine's order");

class Out {
 public:
  template <class T>
  void put(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    s_.append(b, sizeof(T));
  }
  void text(const std::string& t) {
    put<uint64_t>(t.size());
    s_ += t;
  }
  void vec(Vec2 v) {
    put(v.x);
    put(v.y);
  }
  std::string take() { return std::move(s_); }

 private:
  std::string s_;
};

class In {
 public:
  explicit In(std::string_view b) : b_(b) {}
  template <class T>
  T get() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, b_.data(), sizeof(T));
    b_.remove_prefix(sizeof(T));
    return v;
  }
  // A count of items of at least `min_bytes` each: no more than the bytes left can hold.
  uint64_t count(uint64_t min_bytes) {
    const auto n = get<uint64_t>();
    if (n > b_.size() / min_bytes) fail();
    return n;
  }
  std::string text() {
    const uint64_t n = count(1);
    std::string t(b_.substr(0, n));
    b_.remove_prefix(n);
    return t;
  }
  Vec2 vec() {
    const auto x = get<double>();
    return Vec2{x, get<double>()};
  }
  void need(size_t n) const {
    if (b_.size() < n) fail();
  }
  bool done() const { return b_.empty(); }
  [[noreturn]] static void fail() { throw Error(ErrorKind::invalid_input, "seed archive: truncated or damaged"); }

 private:
  std::string_view b_;
};

}  // namespace

std::string encode_seed_archive(const SeedSet& seeds, const std::vector<int64_t>& numbering) {
  Out o;
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
  In in(bytes);
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
    if (kind > static_cast<uint8_t>(GeometryKind::mixed)) In::fail();
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
    if (kind > static_cast<uint8_t>(SiteKind::area)) In::fail();
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
  if (!in.done()) In::fail();
  if (!out.numbering.empty() && out.numbering.size() != features.size()) In::fail();
  out.seeds = SeedSet::from_parts(std::move(sites), std::move(polygons), std::move(features), std::move(labels));
  return out;
}

}  // namespace rv
