// The turning-point report (turning_report.hpp).
#include "job/turning_report.hpp"

#include "rv/gdal/memory_files.hpp"

#include <array>
#include <cmath>
#include <memory>
#include <sstream>
#include <vector>

#include "common/atomic_file.hpp"
#include "rv/field/error.hpp"
#include "rv/field/parallel.hpp"
#include "rv/gdal/osr_geolocator.hpp"
#include "rv/report/treaty.hpp"
#include "rv/report/turning_points.hpp"

namespace rv::detail {

namespace {

// Where a job's positions are on the ellipsoid: grid positions (and basepoints, which the
// field's metric places in the grid's CRS on projected grids) to longitude/latitude.
struct Located {
  bool known = false;  // false: a grid without a CRS, no longitude/latitude
  MetricSpec ellipsoid;
  std::string datum;
  std::shared_ptr<const Geolocator> geolocator;  // null: the grid is longitude/latitude already
  Vec2 lonlat(Vec2 p) const {
    if (!geolocator) return p;
    Vec2 out;
    geolocator->to_lonlat(&p.x, &p.y, &out.x, &out.y, 1);
    return out;
  }
};

Located locate(const PreparedJob& job) {
  Located l;
  const CrsInfo& crs = job.loaded.crs;
  if (crs.wkt.empty()) return l;
  l.known = true;
  l.ellipsoid.kind = MetricSpec::geodesic;
  l.ellipsoid.semi_major = crs.semi_major;
  l.ellipsoid.flattening = crs.flattening;
  if (crs.geographic) {
    l.datum = crs.name;
    return l;
  }
  auto osr = job.compute.geolocator ? nullptr : std::make_shared<const OsrGeolocator>(crs.wkt);
  l.datum = osr ? osr->geographic_crs().name : OsrGeolocator(crs.wkt).geographic_crs().name;
  l.geolocator = job.compute.geolocator ? job.compute.geolocator : osr;
  return l;
}

// Positions and basepoints as the report states them.
struct Writer {
  const SeedSet& seeds;
  const Located& where;
  double k;  // metric units -> the job's distance units

  void position(Vec2 p, nlohmann::json& into) const {
    into["x"] = p.x;
    into["y"] = p.y;
    if (!where.known) return;
    const Vec2 ll = where.lonlat(p);
    into["lon"] = ll.x;
    into["lat"] = ll.y;
    into["lon_dms"] = to_dms(ll.x, false);
    into["lat_dms"] = to_dms(ll.y, true);
  }
  nlohmann::json basepoint(const Basepoint& b) const {
    nlohmann::json j;
    const int32_t f = b.site == kNoSite ? -1 : seeds.site_feature(b.site);
    j["feature"] = f < 0 ? nlohmann::json() : nlohmann::json(seeds.feature_name(f));
    j["owner"] =
        f < 0 ? nlohmann::json()
              : nlohmann::json(
                    seeds.owner_labels()[static_cast<size_t>(seeds.features()[static_cast<size_t>(f)].owner - 1)]);
    position(b.at, j);
    j["distance"] = b.distance * k;
    // By sea: the path's last bend (its number as the via raster's codes give it).
    if (b.via >= 0) {
      nlohmann::json v;
      v["vertex"] = b.via + 1;
      position(b.via_at, v);
      j["via"] = std::move(v);
    }
    return j;
  }
  nlohmann::json basepoints(const std::vector<Basepoint>& side) const {
    nlohmann::json out = nlohmann::json::array();
    for (const Basepoint& b : side) out.push_back(basepoint(b));
    return out;
  }
};

// Each segment between consecutive turning points: on the ellipsoid (where the grid is located)
// and in the grid's plane (the straight segment and the true line's largest distance from it).
struct Segments {
  std::vector<SegmentOnEllipsoid> geo;
  std::vector<double> plane_length, plane_deviation;
};
Segments segments(const BoundaryResult& boundaries, const std::vector<TurningLine>& lines, const Located& where,
                  int threads) {
  struct Seg {
    size_t line, point;
  };
  std::vector<Seg> segs;
  // A ring's last point goes on to its first (the ring's start).
  for (size_t l = 0; l < lines.size(); ++l)
    for (size_t i = 0; i < lines[l].points.size(); ++i)
      if (i + 1 < lines[l].points.size() || lines[l].closed) segs.push_back({l, i});
  Segments out{std::vector<SegmentOnEllipsoid>(segs.size()), std::vector<double>(segs.size()),
               std::vector<double>(segs.size())};
  // On the threads: the deviation searches dominate.
  parallel_for(resolve_threads(threads), static_cast<int64_t>(segs.size()), [&](int64_t s, int) {
    const Seg sg = segs[static_cast<size_t>(s)];
    const TurningLine& tl = lines[sg.line];
    const BoundaryLine& bl = boundaries.lines[tl.line];
    const TurningPoint& from = tl.points[sg.point];
    const bool closing = sg.point + 1 == tl.points.size();
    const TurningPoint& to = tl.points[closing ? 0 : sg.point + 1];
    const size_t until = closing ? bl.vertices.size() : to.next_vertex;
    std::vector<Vec2> between;
    for (size_t v = from.next_vertex; v < until && v < bl.vertices.size(); ++v) between.push_back(bl.vertices[v].p);
    if (where.known) {
      std::vector<Vec2> ll;
      for (const Vec2& p : between) ll.push_back(where.lonlat(p));
      out.geo[static_cast<size_t>(s)] =
          segment_on_ellipsoid(where.lonlat(from.p), where.lonlat(to.p), ll, where.ellipsoid);
    }
    const double dx = to.p.x - from.p.x, dy = to.p.y - from.p.y, len = std::hypot(dx, dy);
    out.plane_length[static_cast<size_t>(s)] = len;
    double dev = 0.0;
    for (const Vec2& p : between) {
      const double t =
          len > 0.0 ? std::clamp(((p.x - from.p.x) * dx + (p.y - from.p.y) * dy) / (len * len), 0.0, 1.0) : 0.0;
      dev = std::max(dev, std::hypot(p.x - (from.p.x + t * dx), p.y - (from.p.y + t * dy)));
    }
    out.plane_deviation[static_cast<size_t>(s)] = dev;
  });
  return out;
}

// The limit lines' arcs, measured as the limits were: true distances.
nlohmann::json limits_json(const LimitResult& limits, const OwnerIndex& index, const PreparedJob& job, const Writer& w,
                           int threads) {
  std::unique_ptr<OwnerIndex> plain;
  if (index.adjusted()) plain = std::make_unique<OwnerIndex>(index.metric(), OwnerIndex::Measure::plain);
  nlohmann::json out = nlohmann::json::array();
  for (const LimitArcs& la : limit_arcs(limits, plain ? *plain : index, job.compute.geolocator.get(), threads)) {
    const LimitLine& line = limits.lines[la.line];
    nlohmann::json arcs = nlohmann::json::array();
    for (const LimitArc& arc : la.arcs) {
      nlohmann::json from, to;
      w.position(arc.from, from);
      w.position(arc.to, to);
      nlohmann::json base = w.basepoint(arc.basepoint);
      base.erase("distance");
      nlohmann::json j = {{"kind", arc.edge ? "parallel" : "arc"}, {"from", from}, {"to", to}};
      if (arc.edge) {
        nlohmann::json edge_to;
        w.position(arc.edge_to, edge_to);
        j["edge"] = {{"from", base}, {"to", edge_to}};
      } else {
        j["basepoint"] = base;
      }
      arcs.push_back(std::move(j));
    }
    out.push_back(
        {{"distance", line.distance * w.k},
         {"owner", line.owner == 0 ? std::string("all") : w.seeds.owner_labels()[static_cast<size_t>(line.owner - 1)]},
         {"closed", line.closed},
         {"arcs", arcs}});
  }
  return out;
}

}  // namespace

nlohmann::json turning_report(const BoundaryResult& boundaries, const LimitResult& limits, const OwnerIndex& index,
                              const PreparedJob& job, int threads) {
  const SeedSet& seeds = job.loaded.seeds;
  const Located where = locate(job);
  const Writer w{seeds, where, job.to_output};
  const std::vector<TurningLine> lines = turning_points(boundaries, index, job.compute.geolocator.get(), threads);
  const Segments segs = segments(boundaries, lines, where, threads);
  nlohmann::json out_lines = nlohmann::json::array();
  size_t s = 0;
  for (const TurningLine& tl : lines) {
    nlohmann::json points = nlohmann::json::array();
    for (size_t i = 0; i < tl.points.size(); ++i) {
      const TurningPoint& tp = tl.points[i];
      nlohmann::json j;
      j["kind"] = tp.kind == TurningPoint::Kind::end ? "end" : tp.kind == TurningPoint::Kind::turn ? "turn" : "start";
      w.position(tp.p, j);
      j["a"] = w.basepoints(tp.a);
      j["b"] = w.basepoints(tp.b);
      if (i + 1 < tl.points.size() || tl.closed) {
        nlohmann::json next;
        // Where a reach ends the line follows its arc: round the side's last basepoint here.
        next["follows"] = tp.arc == 0 ? "equidistance" : "arc";
        const std::vector<Basepoint>& centre = tp.arc == 1 ? tp.a : tp.b;
        if (tp.arc != 0 && !centre.empty()) {
          next["arc_side"] = tp.arc == 1 ? "a" : "b";
          next["arc_radius"] = centre.back().distance * w.k;
        }
        // A ring of one point (an enclave all of one arc) goes round back to it: no segment.
        const bool segment = tl.points.size() > 1;
        if (segment) {
          next["grid_length"] = segs.plane_length[s];
          next["grid_deviation"] = segs.plane_deviation[s];
        }
        if (segment && where.known) {
          const SegmentOnEllipsoid& g = segs.geo[s];
          next["length"] = g.length;
          next["azimuth"] = g.azimuth;
          next["rhumb_length"] = g.rhumb_length;
          next["rhumb_separation"] = g.rhumb_separation;
          next["deviation"] = g.deviation;
        }
        j["to_next"] = next;
        ++s;
      }
      points.push_back(std::move(j));
    }
    out_lines.push_back({{"owner_a", seeds.owner_labels()[static_cast<size_t>(tl.owner_a - 1)]},
                         {"owner_b", seeds.owner_labels()[static_cast<size_t>(tl.owner_b - 1)]},
                         {"closed", tl.closed},
                         {"points", points}});
  }
  nlohmann::json report = {{"distance_units", job.unit},
                           {"grid_units", job.loaded.crs.geographic ? "degrees" : "crs-units"},
                           {"lines", out_lines},
                           {"limits", limits_json(limits, index, job, w, threads)}};
  if (where.known) {
    report["datum"] = where.datum;
    report["geodesic_units"] = "m";
  }
  // By sea: distances along the paths, and each basepoint's last bend where its path bends.
  if (job.sea) report["by_sea"] = true;
  return report;
}

namespace {

std::string csv_field(const nlohmann::json& v) {
  if (v.is_null()) return "";
  if (v.is_number()) {
    std::ostringstream o;
    o.precision(17);
    o << v.get<double>();
    return o.str();
  }
  const std::string s = v.is_string() ? v.get<std::string>() : v.dump();
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

}  // namespace

namespace {
// A file, or a memory file (a session's deliverables, rv/gdal/memory_files.hpp).
void write_text(const std::string& path, const std::string& text) {
  if (path.rfind("/vsimem/", 0) == 0)
    write_memory_file(path, text);
  else
    write_file_atomically(path, text);
}
}  // namespace

void write_turning_report(const std::string& path, const nlohmann::json& report) {
  const bool csv = path.size() >= 4 && path.compare(path.size() - 4, 4, ".csv") == 0;
  if (!csv) {
    write_text(path, report.dump(1) + "\n");
    return;
  }
  // One row per turning point; a side's second basepoint (where it changes) in the columns 2.
  // By sea each side also names its path's last bend (via_*; empty where the path is straight).
  std::vector<std::string> side_cols = {"feature", "owner", "lon", "lat", "lon_dms", "lat_dms", "x", "y", "distance"};
  if (report.value("by_sea", false))
    for (const char* c : {"via_vertex", "via_lon", "via_lat", "via_x", "via_y"}) side_cols.push_back(c);
  const nlohmann::json none;
  // A side's column: its own, or its via's (via_*).
  auto side_value = [&none](const nlohmann::json& side, const std::string& c) -> nlohmann::json {
    if (c.rfind("via_", 0) == 0) return side.contains("via") ? side.at("via").value(c.substr(4), none) : none;
    return side.value(c, none);
  };
  std::vector<std::string> head = {"line", "seq",     "kind",    "owner_a", "owner_b", "lon",
                                   "lat",  "lon_dms", "lat_dms", "x",       "y"};
  for (const char* side : {"a1", "a2", "b1", "b2"})
    for (const std::string& c : side_cols) head.push_back(std::string(side) + "_" + c);
  // next_follows: "equidistance", or "arc" round the next_arc_side's last basepoint (a2_* or
  // b2_* where that side changes here, else a1_* or b1_*) at next_arc_radius.
  const std::vector<std::string> next_cols = {"length",    "azimuth",     "rhumb_separation",
                                              "deviation", "grid_length", "grid_deviation",
                                              "follows",   "arc_side",    "arc_radius"};
  for (const std::string& c : next_cols) head.push_back("next_" + c);
  head.push_back("datum");
  head.push_back("distance_units");
  // The limit lines' arcs follow, one row each (line "L1", "L2", ...): kind arc or parallel, the
  // limit's owner in owner_a, the arc's start in lon..y and its end in to_*, the basepoint in a1_*
  // (a parallel's edge: its feet at the start in a1_*, at the end in a2_*).
  const std::vector<std::string> to_cols = {"lon", "lat", "lon_dms", "lat_dms", "x", "y"};
  head.push_back("limit_distance");
  for (const std::string& c : to_cols) head.push_back("to_" + c);
  std::string out;
  for (size_t i = 0; i < head.size(); ++i) out += (i ? "," : "") + head[i];
  out += "\n";
  size_t line_no = 0;
  for (const auto& line : report.at("lines")) {
    ++line_no;
    size_t seq = 0;
    for (const auto& p : line.at("points")) {
      std::vector<std::string> row = {std::to_string(line_no), std::to_string(++seq), csv_field(p.at("kind")),
                                      csv_field(line.at("owner_a")), csv_field(line.at("owner_b"))};
      for (const char* c : {"lon", "lat", "lon_dms", "lat_dms", "x", "y"}) row.push_back(csv_field(p.value(c, none)));
      for (const char* side : {"a", "b"})
        for (size_t k = 0; k < 2; ++k) {
          const nlohmann::json& list = p.at(side);
          for (const std::string& c : side_cols)
            row.push_back(k < list.size() ? csv_field(side_value(list[k], c)) : "");
        }
      const nlohmann::json next = p.value("to_next", nlohmann::json::object());
      for (const std::string& c : next_cols) row.push_back(csv_field(next.value(c, none)));
      row.push_back(csv_field(report.value("datum", none)));
      row.push_back(csv_field(report.at("distance_units")));
      row.resize(head.size());
      for (size_t i = 0; i < row.size(); ++i) out += (i ? "," : "") + row[i];
      out += "\n";
    }
  }
  size_t limit_no = 0;
  for (const auto& line : report.value("limits", nlohmann::json::array())) {
    ++limit_no;
    size_t seq = 0;
    for (const auto& arc : line.at("arcs")) {
      std::vector<std::string> row = {"L" + std::to_string(limit_no), std::to_string(++seq), csv_field(arc.at("kind")),
                                      csv_field(line.at("owner")), ""};
      const nlohmann::json& from = arc.at("from");
      for (const char* c : {"lon", "lat", "lon_dms", "lat_dms", "x", "y"})
        row.push_back(csv_field(from.value(c, none)));
      const bool edge = arc.contains("edge");
      const nlohmann::json first = edge ? arc.at("edge").at("from") : arc.at("basepoint");
      nlohmann::json second;
      if (edge) {
        second = arc.at("edge").at("to");
        second["feature"] = first.value("feature", none);
        second["owner"] = first.value("owner", none);
      }
      for (const nlohmann::json* side : std::array<const nlohmann::json*, 4>{&first, &second, &none, &none})
        for (const std::string& c : side_cols)
          row.push_back(side->is_object() ? csv_field(c == "distance" ? none : side_value(*side, c)) : "");
      for (size_t k = 0; k < next_cols.size(); ++k) row.push_back("");
      row.push_back(csv_field(report.value("datum", none)));
      row.push_back(csv_field(report.at("distance_units")));
      row.push_back(csv_field(line.at("distance")));
      const nlohmann::json& to = arc.at("to");
      for (const std::string& c : to_cols) row.push_back(csv_field(to.value(c, none)));
      for (size_t i = 0; i < row.size(); ++i) out += (i ? "," : "") + row[i];
      out += "\n";
    }
  }
  write_text(path, out);
}

}  // namespace rv::detail
