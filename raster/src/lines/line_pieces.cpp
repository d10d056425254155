// LinePieces (rv/lines/strip_lines.hpp) as bytes, and the checks an edit runs on them. The layout
// is flat, field by field (never a struct's bytes, whose padding is undefined: equal pieces must
// give equal bytes, since the run records their checksum). Also the comparisons by which an
// edit's refinement finds its segments in an earlier state's (RefinedSegments).
#include <algorithm>
#include <bit>
#include <string_view>

#include "field/byte_codec.hpp"
#include "lines/line_pieces.hpp"
#include "rv/field/error.hpp"

namespace rv {
namespace {

constexpr std::string_view kMagic = "rvoronoi-lines";
constexpr uint32_t kVersion = 1;
using detail::ByteReader;
using detail::ByteWriter;

constexpr int8_t kTieBit = 4;  // BoundaryVertex::tie, stored beside its arc

void put_vertex(ByteWriter& o, const BoundaryVertex& v) {
  o.vec(v.p);
  o.put(v.site_a);
  o.put(v.site_b);
  o.put(v.distance);
  o.put(v.residual);
  o.put(v.distance_a);
  o.put(v.distance_b);
  o.put(static_cast<int8_t>(v.arc | (v.tie ? kTieBit : 0)));  // (arc is 0, 1 or 2: one byte holds both)
}

BoundaryVertex get_vertex(ByteReader& in) {
  BoundaryVertex v;
  v.p = in.vec();
  v.site_a = in.get<int32_t>();
  v.site_b = in.get<int32_t>();
  v.distance = in.get<double>();
  v.residual = in.get<double>();
  v.distance_a = in.get<double>();
  v.distance_b = in.get<double>();
  const auto arc = in.get<int8_t>();
  v.arc = static_cast<int8_t>(arc & ~kTieBit);
  v.tie = (arc & kTieBit) != 0;
  return v;
}

void put_tripoint(ByteWriter& o, const Tripoint& t) {
  o.vec(t.p);
  for (int k = 0; k < 3; ++k) {
    o.put(t.owners[k]);
    o.put(t.sites[k]);
    o.put(t.distances[k]);
  }
  o.put(t.distance);
  o.put(t.residual);
  o.put(t.cost);
}

Tripoint get_tripoint(ByteReader& in) {
  Tripoint t;
  t.p = in.vec();
  for (int k = 0; k < 3; ++k) {
    t.owners[k] = in.get<int32_t>();
    t.sites[k] = in.get<int32_t>();
    t.distances[k] = in.get<double>();
  }
  t.distance = in.get<double>();
  t.residual = in.get<double>();
  t.cost = in.get<double>();
  return t;
}

template <class T, class F>
void put_all(ByteWriter& o, const std::vector<T>& v, F&& put_one) {
  o.put<uint64_t>(v.size());
  for (const T& x : v) put_one(x);
}

template <class T, class F>
std::vector<T> get_all(ByteReader& in, uint64_t min_bytes, F&& get_one) {
  std::vector<T> v(in.count(min_bytes));
  for (T& x : v) x = get_one();
  return v;
}

}  // namespace

LinePieces::LinePieces() = default;
LinePieces::LinePieces(std::shared_ptr<const Data> d) : d_(std::move(d)) {}
bool LinePieces::empty() const { return d_ == nullptr; }

const std::string& LinePieces::key() const {
  static const std::string none;
  return d_ ? d_->key : none;
}

int64_t LinePieces::memory_bytes() const {
  if (!d_) return 0;
  auto bytes = [](const auto& v) { return static_cast<int64_t>(v.capacity() * sizeof(v[0])); };
  int64_t b = static_cast<int64_t>(sizeof(Data) + d_->key.capacity());
  for (const Data::Boundary& p : d_->boundary)
    b += bytes(p.crossings) + bytes(p.slivers) + bytes(p.tripoints) + bytes(p.tripoint_row) + bytes(p.links) +
         bytes(p.link_pair) + bytes(p.link_row) + bytes(p.unplaced) + bytes(p.counts);
  for (const Data::Limit& p : d_->limits) b += bytes(p.edges) + bytes(p.verts) + bytes(p.links) + bytes(p.link_row);
  return b;
}

std::string LinePieces::encode() const {
  if (!d_) throw Error(ErrorKind::invalid_argument, "line pieces: none to encode");
  const Data& d = *d_;
  ByteWriter o;
  for (const char c : kMagic) o.put(c);
  o.put(kVersion);
  o.text(d.key);
  o.put(d.width);
  o.put(d.height);
  o.put<uint64_t>(d.boundary.size());
  for (const Data::Boundary& b : d.boundary) {
    put_all(o, b.crossings, [&](const boundary_stages::Crossing& c) {
      o.put(c.edge);
      o.put(c.owner_lo);
      o.put(c.owner_hi);
      put_vertex(o, c.v);
    });
    put_all(o, b.slivers, [&](const std::pair<int64_t, int32_t>& s) {
      o.put(s.first);
      o.put(s.second);
    });
    put_all(o, b.tripoints, [&](const Tripoint& t) { put_tripoint(o, t); });
    put_all(o, b.tripoint_row, [&](int32_t r) { o.put(r); });
    put_all(o, b.links, [&](const std::array<int32_t, 2>& l) {
      o.put(l[0]);
      o.put(l[1]);
    });
    put_all(o, b.link_pair, [&](int64_t p) { o.put(p); });
    put_all(o, b.link_row, [&](int32_t r) { o.put(r); });
    put_all(o, b.unplaced, [&](const std::array<int64_t, 2>& u) {
      o.put(u[0]);
      o.put(u[1]);
    });
    put_all(o, b.counts, [&](const auto& row) {
      for (const int64_t n : row) o.put(n);
    });
  }
  o.put<uint64_t>(d.limits.size());
  for (const Data::Limit& l : d.limits) {
    put_all(o, l.edges, [&](int64_t e) { o.put(e); });
    put_all(o, l.verts, [&](const LimitVertex& v) {
      o.vec(v.p);
      o.put(v.site);
      o.put(v.residual);
    });
    put_all(o, l.links, [&](const std::array<int32_t, 2>& k) {
      o.put(k[0]);
      o.put(k[1]);
    });
    put_all(o, l.link_row, [&](int32_t r) { o.put(r); });
  }
  return o.take();
}

namespace {

// Every row list in range and non-decreasing; every link's nodes among the pieces; one row of
// counts per grid row: else the bytes are damaged.
bool consistent(const LinePieces::Data& d) {
  auto rows_ok = [&](auto first, auto last, auto&& row_of) {
    int64_t prev = 0;
    for (auto it = first; it != last; ++it) {
      const int64_t r = row_of(*it);
      if (r < prev || r >= d.height) return false;
      prev = r;
    }
    return true;
  };
  auto plain = [](auto r) { return static_cast<int64_t>(r); };
  auto edge_row = [&](int64_t e) { return e < 0 ? int64_t{-1} : d.edge_row(e); };
  for (const LinePieces::Data::Boundary& b : d.boundary) {
    const auto nx = static_cast<int64_t>(b.crossings.size()), nt = static_cast<int64_t>(b.tripoints.size());
    if (!rows_ok(b.crossings.begin(), b.crossings.end(), [&](const auto& c) { return edge_row(c.edge); }) ||
        !rows_ok(b.slivers.begin(), b.slivers.end(), [&](const auto& s) { return edge_row(s.first); }) ||
        !rows_ok(b.tripoint_row.begin(), b.tripoint_row.end(), plain) ||
        !rows_ok(b.link_row.begin(), b.link_row.end(), plain) ||
        !rows_ok(b.unplaced.begin(), b.unplaced.end(), [](const auto& u) { return u[1]; }) ||
        b.tripoint_row.size() != b.tripoints.size() || b.link_pair.size() != b.links.size() ||
        b.link_row.size() != b.links.size() || static_cast<int64_t>(b.counts.size()) != d.height)
      return false;
    for (const auto& l : b.links)
      for (const int32_t n : l)
        if (n >= nx || (n < 0 && -1 - n >= nt)) return false;
  }
  for (const LinePieces::Data::Limit& l : d.limits) {
    if (!rows_ok(l.edges.begin(), l.edges.end(), edge_row) || !rows_ok(l.link_row.begin(), l.link_row.end(), plain) ||
        l.verts.size() != l.edges.size() || l.link_row.size() != l.links.size())
      return false;
    for (const auto& k : l.links)
      for (const int32_t n : k)
        if (n < 0 || n >= static_cast<int64_t>(l.edges.size())) return false;
  }
  return true;
}

}  // namespace

LinePieces LinePieces::decode(std::string_view bytes) {
  ByteReader in(bytes, "line pieces");
  for (const char c : kMagic)
    if (in.get<char>() != c) throw Error(ErrorKind::invalid_input, "line pieces: not rvoronoi line pieces");
  if (in.get<uint32_t>() != kVersion)
    throw Error(ErrorKind::invalid_input, "line pieces: written by another format version");
  auto d = std::make_shared<Data>();
  d->key = in.text();
  d->width = in.get<int64_t>();
  d->height = in.get<int64_t>();
  if (d->width < 1 || d->height < 1) in.fail();
  d->boundary.resize(in.count(1));
  if (d->boundary.size() > 1) in.fail();
  for (Data::Boundary& b : d->boundary) {
    b.crossings = get_all<boundary_stages::Crossing>(in, 73, [&] {
      boundary_stages::Crossing c;
      c.edge = in.get<int64_t>();
      c.owner_lo = in.get<int32_t>();
      c.owner_hi = in.get<int32_t>();
      c.v = get_vertex(in);
      return c;
    });
    b.slivers = get_all<std::pair<int64_t, int32_t>>(in, 12, [&] {
      const auto e = in.get<int64_t>();
      return std::pair<int64_t, int32_t>{e, in.get<int32_t>()};
    });
    b.tripoints = get_all<Tripoint>(in, 88, [&] { return get_tripoint(in); });
    b.tripoint_row = get_all<int32_t>(in, 4, [&] { return in.get<int32_t>(); });
    b.links = get_all<std::array<int32_t, 2>>(in, 8, [&] {
      const auto a = in.get<int32_t>();
      return std::array<int32_t, 2>{a, in.get<int32_t>()};
    });
    b.link_pair = get_all<int64_t>(in, 8, [&] { return in.get<int64_t>(); });
    b.link_row = get_all<int32_t>(in, 4, [&] { return in.get<int32_t>(); });
    b.unplaced = get_all<std::array<int64_t, 2>>(in, 16, [&] {
      const auto c = in.get<int64_t>();
      return std::array<int64_t, 2>{c, in.get<int64_t>()};
    });
    b.counts = get_all<std::array<int64_t, boundary_stages::RowCounts::kCounters>>(
        in, 8 * boundary_stages::RowCounts::kCounters, [&] {
          std::array<int64_t, boundary_stages::RowCounts::kCounters> row{};
          for (int64_t& n : row) n = in.get<int64_t>();
          return row;
        });
  }
  d->limits.resize(in.count(32));
  for (Data::Limit& l : d->limits) {
    l.edges = get_all<int64_t>(in, 8, [&] { return in.get<int64_t>(); });
    l.verts = get_all<LimitVertex>(in, 28, [&] {
      LimitVertex v;
      v.p = in.vec();
      v.site = in.get<int32_t>();
      v.residual = in.get<double>();
      return v;
    });
    l.links = get_all<std::array<int32_t, 2>>(in, 8, [&] {
      const auto a = in.get<int32_t>();
      return std::array<int32_t, 2>{a, in.get<int32_t>()};
    });
    l.link_row = get_all<int32_t>(in, 4, [&] { return in.get<int32_t>(); });
  }
  if (!in.done() || !consistent(*d)) in.fail();
  return LinePieces(std::move(d));
}

std::vector<int64_t> LinePieces::rows_naming_dropped(std::span<const int32_t> site_map) const {
  std::vector<int64_t> rows;
  if (!d_ || site_map.empty()) return rows;
  auto dropped = [&](int32_t s) {
    return s != kNoSite &&
           (s < 0 || static_cast<size_t>(s) >= site_map.size() || site_map[static_cast<size_t>(s)] == kNoSite);
  };
  for (const Data::Boundary& b : d_->boundary) {
    for (const boundary_stages::Crossing& c : b.crossings)
      if (dropped(c.v.site_a) || dropped(c.v.site_b)) rows.push_back(d_->edge_row(c.edge));
    for (size_t i = 0; i < b.tripoints.size(); ++i)
      for (const int32_t s : b.tripoints[i].sites)
        if (dropped(s)) rows.push_back(b.tripoint_row[i]);
  }
  for (const Data::Limit& l : d_->limits)
    for (size_t i = 0; i < l.edges.size(); ++i)
      if (dropped(l.verts[i].site)) rows.push_back(d_->edge_row(l.edges[i]));
  std::sort(rows.begin(), rows.end());
  rows.erase(std::unique(rows.begin(), rows.end()), rows.end());
  return rows;
}

}  // namespace rv

namespace rv {
namespace {

// A site of an earlier state in this one's numbering (kNoSite where it is gone).
int32_t renumbered(int32_t s, std::span<const int32_t> map) {
  if (s == kNoSite || map.empty()) return s;
  return s >= 0 && static_cast<size_t>(s) < map.size() ? map[static_cast<size_t>(s)] : kNoSite;
}
bool same_bits(double x, double y) { return std::bit_cast<uint64_t>(x) == std::bit_cast<uint64_t>(y); }
bool same_site(int32_t now, int32_t old, std::span<const int32_t> map) {
  return old == kNoSite ? now == kNoSite : now != kNoSite && renumbered(old, map) == now;
}

}  // namespace

bool same_vertex(const BoundaryVertex& now, const BoundaryVertex& old, std::span<const int32_t> map) {
  return same_bits(now.p.x, old.p.x) && same_bits(now.p.y, old.p.y) && same_site(now.site_a, old.site_a, map) &&
         same_site(now.site_b, old.site_b, map) && same_bits(now.distance, old.distance) &&
         same_bits(now.residual, old.residual) && same_bits(now.distance_a, old.distance_a) &&
         same_bits(now.distance_b, old.distance_b) && now.arc == old.arc && now.tie == old.tie;
}

bool same_vertex(const LimitVertex& now, const LimitVertex& old, std::span<const int32_t> map) {
  return same_bits(now.p.x, old.p.x) && same_bits(now.p.y, old.p.y) && same_site(now.site, old.site, map) &&
         same_bits(now.residual, old.residual);
}

bool renumber(BoundaryVertex& v, std::span<const int32_t> map) {
  const int32_t a = renumbered(v.site_a, map), b = renumbered(v.site_b, map);
  if ((v.site_a != kNoSite && a == kNoSite) || (v.site_b != kNoSite && b == kNoSite)) return false;
  v.site_a = a;
  v.site_b = b;
  return true;
}

bool renumber(LimitVertex& v, std::span<const int32_t> map) {
  const int32_t s = renumbered(v.site, map);
  if (v.site != kNoSite && s == kNoSite) return false;
  v.site = s;
  return true;
}

uint64_t segment_hash(int32_t a, int32_t b, Vec2 u, Vec2 v) {
  // splitmix64's finaliser over the words, one after another.
  auto mix = [](uint64_t h, uint64_t x) {
    h ^= x + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2);
    h ^= h >> 30;
    h *= 0xbf58476d1ce4e5b9ULL;
    h ^= h >> 27;
    h *= 0x94d049bb133111ebULL;
    return h ^ (h >> 31);
  };
  uint64_t h = mix(static_cast<uint64_t>(static_cast<uint32_t>(a)), static_cast<uint64_t>(static_cast<uint32_t>(b)));
  for (const double d : {u.x, u.y, v.x, v.y}) h = mix(h, std::bit_cast<uint64_t>(d));
  return h;
}

}  // namespace rv
