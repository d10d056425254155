// What a run keeps for edits, and an edit's base (edit_base.hpp).
#include "edit_base.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "atomic_file.hpp"
#include "rv/error.hpp"
#include "rv/json_text.hpp"
#include "rv/seed_archive.hpp"

namespace rv::detail {
namespace fs = std::filesystem;

namespace {

constexpr const char* kFormat = "rvoronoi-edit-base";
constexpr int kFormatVersion = 1;

// 64-bit multiply-xorshift over 8-byte words (and the tail bytes): fast enough to run over every
// cell a run writes (the writers' threads do it as they encode).
uint64_t mix(uint64_t h, uint64_t v) {
  h ^= v;
  h *= 0x9e3779b97f4a7c15ULL;
  return h ^ (h >> 29);
}

uint64_t hash_bytes(const unsigned char* p, size_t n, uint64_t h) {
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    uint64_t w;
    std::memcpy(&w, p + i, 8);
    h = mix(h, w);
  }
  uint64_t tail = 0;
  std::memcpy(&tail, p + i, n - i);
  return mix(h, tail ^ (static_cast<uint64_t>(n - i) << 56));
}

std::string hex(uint64_t v) {
  char t[17];
  std::snprintf(t, sizeof t, "%016llx", static_cast<unsigned long long>(v));
  return t;
}

std::string read_whole(const std::string& path, const std::string& name) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(ErrorKind::not_found, "base: " + name + " is missing");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) throw Error(ErrorKind::io, "base: reading " + name + " failed");
  return s.str();
}

std::string unique_suffix() {
  static std::atomic<int> n{0};
  return std::to_string(::getpid()) + "-" + std::to_string(n++);
}

// The parameters an edit must repeat, as the manifest records them.
nlohmann::json request_params(const JobSpec& spec, const PreparedJob& job) {
  const GridSpec& g = job.grid;
  const double max_d = job.compute.max_distance;
  return {{"grid",
           {{"width", g.width},
            {"height", g.height},
            {"xmin", g.xmin},
            {"ymax", g.ymax},
            {"resolution", g.res},
            {"crs", g.crs}}},
          {"metric", job.metric.kind == MetricSpec::geodesic ? "geodesic" : "planar"},
          {"geodesic_crs", job.located() ? job.loaded.seed_crs.name : ""},
          {"method", to_string(spec.method)},
          {"distance_units", job.unit},
          {"max_distance", std::isfinite(max_d) ? nlohmann::json(max_d) : nlohmann::json()},
          {"compression", to_string(spec.outputs.compression)}};
}

// What differs between the base's parameters and the new job's, in words; "" when nothing.
std::string differences(const nlohmann::json& base, const nlohmann::json& now) {
  std::string out;
  auto note = [&](const std::string& what, const nlohmann::json& b, const nlohmann::json& n) {
    if (b == n) return;
    auto text = [](const nlohmann::json& v) {
      if (v.is_null()) return std::string("none");
      if (v.is_string()) {
        const std::string s = v.get<std::string>();
        return s.size() > 60 ? s.substr(0, 57) + "..." : s;
      }
      return v.dump();
    };
    out += (out.empty() ? "" : "; ") + what + " " + text(n) + " (base: " + text(b) + ")";
  };
  for (const char* k : {"width", "height", "xmin", "ymax", "resolution", "crs"})
    note(std::string("grid ") + k, base["grid"].value(k, nlohmann::json()), now["grid"][k]);
  for (const char* k : {"metric", "geodesic_crs", "method", "distance_units", "max_distance", "compression"})
    note(k, base.value(k, nlohmann::json()), now[k]);
  return out;
}

}  // namespace

void BandHasher::add_bytes(const unsigned char* rows, int64_t count, int64_t cell_bytes) {
  const auto row_bytes = static_cast<size_t>(width_ * cell_bytes);
  for (int64_t r = 0; r < count; ++r) {
    h_ = hash_bytes(rows + static_cast<size_t>(r) * row_bytes, row_bytes, h_);
    if (++rows_in_band_ == kBandRows) {
      bands_.push_back(h_);
      h_ = 0;
      rows_in_band_ = 0;
    }
  }
}

void BandHasher::finish() {
  if (rows_in_band_ > 0) bands_.push_back(h_);
  h_ = 0;
  rows_in_band_ = 0;
}

std::string edit_base_dir(const std::string& report) { return report + ".rvbase"; }

EditBaseWriter::EditBaseWriter(const JobSpec& spec, const PreparedJob& job)
    : site_hash(job.grid.width), distance_hash(job.grid.width), tiles(TileSummaries::for_grid(job.grid)) {
  dir_ = spec.outputs.edit_base.empty() ? edit_base_dir(spec.outputs.report) : spec.outputs.edit_base;
  temp_ = dir_ + ".tmp-" + unique_suffix();
  std::error_code ec;
  fs::create_directory(temp_, ec);
  if (ec) throw Error(ErrorKind::io, "cannot create " + temp_ + ": " + ec.message());
  site_path_ = temp_ + "/site.tif";
  distance_path_ = temp_ + "/distance.tif";
  if (!spec.outputs.distance.empty() && job.to_output == 1.0) shared_distance_ = spec.outputs.distance;
  sites_ = static_cast<int64_t>(job.loaded.seeds.sites().size());
  const std::string seeds = encode_seed_archive(job.loaded.seeds, job.loaded.input_position);
  write_file_atomically(temp_ + "/seeds.bin", seeds);
  manifest_ = request_params(spec, job);
  manifest_["format"] = kFormat;
  manifest_["version"] = kFormatVersion;
  manifest_["band_rows"] = kBandRows;
  manifest_["sites"] = sites_;
  manifest_["seeds"] = {
      {"file", "seeds.bin"},
      {"bytes", seeds.size()},
      {"hash", hex(hash_bytes(reinterpret_cast<const unsigned char*>(seeds.data()), seeds.size(), 0))}};
}

EditBaseWriter::~EditBaseWriter() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(temp_, ec);
}

GeoTiffOptions EditBaseWriter::site_options() const {
  GeoTiffOptions o;
  o.max_code = sites_;
  o.metadata["CONTENT"] = "nearest site index + 1 (0 = none), kept for edits of this run";
  return o;
}

GeoTiffOptions EditBaseWriter::distance_options() const {
  GeoTiffOptions o;
  o.metadata["CONTENT"] = "distance to the nearest site in metric units, kept for edits of this run";
  return o;
}

std::string EditBaseWriter::commit() {
  site_hash.finish();
  distance_hash.finish();
  auto hashes = [](const BandHasher& h) {
    nlohmann::json a = nlohmann::json::array();
    for (const uint64_t v : h.bands()) a.push_back(hex(v));
    return a;
  };
  manifest_["site"] = {{"file", "site.tif"}, {"hashes", hashes(site_hash)}};
  const std::string distance_file = shared_distance_.empty()
                                        ? std::string("distance.tif")
                                        : fs::absolute(shared_distance_)
                                              .lexically_normal()
                                              .lexically_relative(fs::absolute(dir_).lexically_normal())
                                              .string();
  manifest_["distance"] = {{"file", distance_file}, {"hashes", hashes(distance_hash)}};
  manifest_["tiles"] = {{"size", TileSummaries::kTile},       {"cols", tiles.cols},         {"rows", tiles.rows},
                        {"max_distance", tiles.max_distance}, {"max_cost", tiles.max_cost}, {"unowned", tiles.unowned}};
  write_file_atomically(temp_ + "/manifest.json", json_text(manifest_, 1) + "\n");
  std::error_code ec;
  std::string old;
  if (fs::exists(dir_, ec)) {
    old = dir_ + ".old-" + unique_suffix();
    fs::rename(dir_, old, ec);
    if (ec) throw Error(ErrorKind::io, "cannot replace " + dir_ + ": " + ec.message());
  }
  fs::rename(temp_, dir_, ec);
  if (ec) throw Error(ErrorKind::io, "cannot rename " + temp_ + " to " + dir_ + ": " + ec.message());
  committed_ = true;
  if (!old.empty()) fs::remove_all(old, ec);
  return dir_;
}

struct EditBase::State {
  nlohmann::json manifest;
  SeedArchive archive;
  std::unique_ptr<GeoTiffRowReader<int32_t>> site;
  std::unique_ptr<GeoTiffRowReader<float>> distance;
  BandHasher site_hash, distance_hash;
  std::vector<std::string> site_bands, distance_bands;
  std::string distance_name;  // as the manifest names it
  TileSummaries tiles;
  size_t site_checked = 0, distance_checked = 0;
  GridSpec grid;
  MetricSpec metric;
  std::shared_ptr<const Geolocator> geolocator;
  int64_t next_row = 0;
};

EditBase::EditBase(const std::string& report, const JobSpec& spec, const PreparedJob& job)
    : st_(std::make_unique<State>()), report_(report) {
  if (spec.method != Method::exact)
    throw Error(ErrorKind::invalid_argument,
                "base: an edit recomputes part of a field, which only the exact method does (method " +
                    std::string(to_string(spec.method)) + ")");
  if (spec.validate) throw Error(ErrorKind::invalid_argument, "base: an edit is not validated (drop --validate)");
  if (job.partial.any())
    throw Error(ErrorKind::invalid_argument,
                "base: partial effect compares whole fields; an edit of it is a fresh run (drop the base)");
  const fs::path report_path(report);
  const std::string name = report_path.filename().string();
  nlohmann::json r;
  try {
    r = nlohmann::json::parse(read_whole(report, name));
  } catch (const nlohmann::json::exception&) {
    throw Error(ErrorKind::invalid_input, "base: " + name + " is not a JSON report");
  }
  if (!r.is_object() || !r.contains("edit_base") || !r["edit_base"].is_string())
    throw Error(ErrorKind::invalid_input,
                "base: " + name +
                    " names nothing kept for edits (only streamed runs of the exact method with a "
                    "report keep their field)");
  const fs::path dir = report_path.parent_path() / r["edit_base"].get<std::string>();
  const std::string dir_name = dir.filename().string();
  State& st = *st_;
  try {
    st.manifest = nlohmann::json::parse(read_whole((dir / "manifest.json").string(), dir_name + "/manifest.json"));
  } catch (const nlohmann::json::exception&) {
    throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json is damaged");
  }
  const nlohmann::json& m = st.manifest;
  // A manifest with a member of the wrong type is as damaged as one that does not parse.
  try {
    if (!m.is_object() || m.value("format", "") != kFormat || m.value("version", 0) != kFormatVersion ||
        m.value("band_rows", int64_t{0}) != kBandRows || !m.contains("grid") || !m["grid"].is_object())
      throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json is not a kept base of this version");
    std::string diff = differences(m, request_params(spec, job));
    // A grid taken from the seeds' extent moves with them: name the base's extent to give instead.
    if (diff.find("grid ") != std::string::npos && !spec.grid.extent && !m["grid"].value("crs", "").empty()) {
      try {
        const nlohmann::json& g = m["grid"];
        const double xmin = g.at("xmin"), ymax = g.at("ymax"), res = g.at("resolution");
        const double xmax = xmin + res * g.at("width").get<double>(), ymin = ymax - res * g.at("height").get<double>();
        char extent[160];
        std::snprintf(extent, sizeof extent, "%.17g %.17g %.17g %.17g", xmin, ymin, xmax, ymax);
        diff += std::string("; the extent follows the seeds unless given: the base's was ") + extent;
      } catch (const nlohmann::json::exception&) {
      }
    }
    if (!diff.empty()) throw Error(ErrorKind::invalid_argument, "base: the job differs from its base: " + diff);
    const std::string seeds = read_whole((dir / "seeds.bin").string(), dir_name + "/seeds.bin");
    const nlohmann::json& sm = m.value("seeds", nlohmann::json::object());
    if (sm.value("hash", "") != hex(hash_bytes(reinterpret_cast<const unsigned char*>(seeds.data()), seeds.size(), 0)))
      throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/seeds.bin was modified since the base run");
    st.archive = decode_seed_archive(seeds);
    if (static_cast<int64_t>(st.archive.seeds.sites().size()) != m.value("sites", int64_t{-1}))
      throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json does not fit its seeds");
    auto bands = [&](const char* key) {
      std::vector<std::string> out;
      const nlohmann::json& e = m.value(key, nlohmann::json::object());
      for (const nlohmann::json& h : e.value("hashes", nlohmann::json::array())) out.push_back(h.get<std::string>());
      if (static_cast<int64_t>(out.size()) != (job.grid.height + kBandRows - 1) / kBandRows)
        throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json does not fit its grid");
      return out;
    };
    try {
      const nlohmann::json& t = m.at("tiles");
      st.tiles = TileSummaries::for_grid(job.grid);
      if (t.at("size").get<int64_t>() != TileSummaries::kTile || t.at("cols").get<int64_t>() != st.tiles.cols ||
          t.at("rows").get<int64_t>() != st.tiles.rows)
        throw Error(ErrorKind::invalid_input, "");
      st.tiles.max_distance = t.at("max_distance").get<std::vector<float>>();
      st.tiles.max_cost = t.at("max_cost").get<std::vector<float>>();
      st.tiles.unowned = t.at("unowned").get<std::vector<uint8_t>>();
      const size_t n = static_cast<size_t>(st.tiles.cols * st.tiles.rows);
      if (st.tiles.max_distance.size() != n || st.tiles.max_cost.size() != n || st.tiles.unowned.size() != n)
        throw Error(ErrorKind::invalid_input, "");
    } catch (const std::exception&) {
      throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json has no tile summaries of its grid");
    }
    st.site_bands = bands("site");
    st.distance_bands = bands("distance");
  } catch (const nlohmann::json::exception&) {
    throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json is damaged");
  }
  auto open = [&](const char* file, auto& reader) {
    const std::string path = (dir / file).string();
    if (!fs::exists(path)) throw Error(ErrorKind::not_found, "base: " + dir_name + "/" + file + " is missing");
    reader = std::make_unique<typename std::remove_reference_t<decltype(reader)>::element_type>(path);
    const GridSpec& g = reader->grid();
    if (g.width != job.grid.width || g.height != job.grid.height)
      throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/" + file + " does not fit the grid");
  };
  open("site.tif", st.site);
  std::string distance_file;
  try {
    distance_file = m.value("distance", nlohmann::json::object()).value("file", "");
  } catch (const nlohmann::json::exception&) {
  }
  if (distance_file.empty() || fs::path(distance_file).is_absolute())
    throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json names no distance raster");
  open(distance_file.c_str(), st.distance);
  st.distance_name = distance_file;
  st.site_hash = BandHasher(job.grid.width);
  st.distance_hash = BandHasher(job.grid.width);
  st.grid = job.grid;
  st.metric = job.compute.metric;
  st.geolocator = job.compute.geolocator;
}

EditBase::~EditBase() = default;

const SeedSet& EditBase::seeds() const { return st_->archive.seeds; }
const TileSummaries& EditBase::tiles() const { return st_->tiles; }

void EditBase::read(int64_t row0, int64_t rows, NearestField& out) {
  State& st = *st_;
  if (row0 != st.next_row) throw Error(ErrorKind::internal, "EditBase::read: rows out of order");
  const Window w{0, row0, st.grid.width, rows};
  out.site.retarget(st.grid, w);
  out.distance.retarget(st.grid, w);
  out.metric = st.metric;
  out.geolocator = st.geolocator;
  // The two files side by side (independent GDAL datasets): decoding and checking each is about
  // half of an edit's reading.
  std::exception_ptr failed;
  std::thread other([&] {
    try {
      st.distance->read_rows(row0, rows, out.distance.data());
      st.distance_hash.add_rows(out.distance.data(), rows);
    } catch (...) {
      failed = std::current_exception();
    }
  });
  try {
    st.site->read_rows(row0, rows, out.site.data());
    st.site_hash.add_rows(out.site.data(), rows);
  } catch (...) {
    other.join();
    throw;
  }
  other.join();
  if (failed) std::rethrow_exception(failed);
  st.next_row = row0 + rows;
  if (st.next_row == st.grid.height) {
    st.site_hash.finish();
    st.distance_hash.finish();
  }
  auto check = [&](const BandHasher& h, const std::vector<std::string>& expected, size_t& checked, const char* file) {
    for (; checked < h.bands().size(); ++checked)
      if (checked >= expected.size() || hex(h.bands()[checked]) != expected[checked])
        throw Error(ErrorKind::invalid_input, std::string("base: ") + file + " was modified since the base run (rows " +
                                                  std::to_string(checked * kBandRows) + " on)");
  };
  check(st.site_hash, st.site_bands, st.site_checked, "site.tif");
  check(st.distance_hash, st.distance_bands, st.distance_checked, st.distance_name.c_str());
  const auto sites = static_cast<int32_t>(st.archive.seeds.sites().size());
  for (int32_t& s : out.site.cells()) {
    if (s < 0 || s > sites) throw Error(ErrorKind::invalid_input, "base: site.tif holds a site its seeds lack");
    s -= 1;  // 0 -> kNoSite
  }
}

nlohmann::json edit_report(const EditBase& base, const Edit& edit, const SeedSet& edited, const EditTally& tally,
                           const GridSpec& grid, bool geodesic) {
  const SeedSet& before = base.seeds();
  const FeatureMatch& m = edit.match();

  // A feature removed and one added from the same source (the same file name, layer and id) are
  // one feature changed. The file's directory does not count: the daemon stages every job's
  // uploads in a directory of its own.
  auto describe = [&](const SeedSet& s, size_t f) {
    return nlohmann::json{{"feature", source_key(s.feature_name(static_cast<int32_t>(f)))},
                          {"owner", s.owner_labels()[static_cast<size_t>(s.features()[f].owner - 1)]}};
  };
  std::unordered_map<std::string, size_t> added_by_source;
  for (size_t f = 0; f < m.base_of_edited.size(); ++f)
    if (m.base_of_edited[f] < 0 && !edited.features()[f].source.empty())
      added_by_source.emplace(source_key(edited.features()[f].source), f);
  constexpr size_t kListed = 1000;
  nlohmann::json added = nlohmann::json::array(), removed = nlohmann::json::array(), changed = nlohmann::json::array();
  int64_t n_added = 0, n_removed = 0, n_changed = 0;
  std::vector<bool> paired(edited.features().size(), false);
  for (size_t f = 0; f < m.edited_of_base.size(); ++f) {
    if (m.edited_of_base[f] >= 0) continue;
    const auto it = added_by_source.find(source_key(before.features()[f].source));
    if (it != added_by_source.end() && !paired[it->second]) {
      paired[it->second] = true;
      if (changed.size() < kListed) changed.push_back(describe(edited, it->second));
      ++n_changed;
    } else {
      if (removed.size() < kListed) removed.push_back(describe(before, f));
      ++n_removed;
    }
  }
  for (size_t f = 0; f < m.base_of_edited.size(); ++f) {
    if (m.base_of_edited[f] >= 0 || paired[f]) continue;
    if (added.size() < kListed) added.push_back(describe(edited, f));
    ++n_added;
  }
  nlohmann::json moved = nlohmann::json::array();
  for (const auto& [pair, area] : tally.changes.moved)
    moved.push_back({{"from", pair.first.empty() ? nlohmann::json() : nlohmann::json(pair.first)},
                     {"to", pair.second.empty() ? nlohmann::json() : nlohmann::json(pair.second)},
                     {"area", area}});
  return {{"base", base.report_path()},
          {"features",
           {{"kept", m.kept()},
            {"added", n_added},
            {"removed", n_removed},
            {"changed", n_changed},
            {"owners_reordered", m.owners_reordered},
            {"added_list", added},
            {"removed_list", removed},
            {"changed_list", changed}}},
          {"cells", grid.cell_count()},
          {"cells_recomputed", tally.cells_recomputed},
          {"tiles", tally.tiles_read.size()},
          {"tiles_read", std::count(tally.tiles_read.begin(), tally.tiles_read.end(), true)},
          {"cells_of_removed_features", tally.cells_of_removed},
          {"owner_changed_cells", tally.changes.owner_cells},
          {"distance_only_changed_cells", tally.changes.distance_only_cells},
          {"area_moved", moved},
          {"area_units", geodesic ? "m2" : "crs-units^2"},
          {"strips", tally.strips},
          {"timings_s",
           {{"read_base", tally.read_seconds},
            {"plan", tally.plan_seconds},
            {"recompute", tally.apply_seconds},
            {"tally", tally.tally_seconds}}}};
}

}  // namespace rv::detail
