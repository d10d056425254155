// What a run keeps for edits, and an edit's base (edit_base.hpp).
#include "job/edit_base.hpp"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <thread>
#include <unordered_map>

#include "common/atomic_file.hpp"
#include "rv/edit/seed_archive.hpp"
#include "rv/field/checksum.hpp"
#include "rv/field/error.hpp"
#include "rv/json_text.hpp"

namespace rv::detail {
namespace fs = std::filesystem;

namespace {

constexpr const char* kFormat = "rvoronoi-edit-base";
constexpr int kFormatVersion = 2;  // 2: checksums per tile of every raster

constexpr int64_t kTile = TileSummaries::kTile;

uint64_t bytes_checksum(const std::string& bytes) { return checksum64(bytes.data(), bytes.size()); }

// A base's files may come from anyone: a FIFO or a device in their place is refused, never
// waited on.
std::string read_whole(const std::string& path, const std::string& name) {
  return read_regular_file(path, "base: " + name);
}

// A file of the kept directory `dir` and its manifest entry: its name and the checksum of its bytes.
nlohmann::json write_kept(const std::string& dir, const std::string& file, const std::string& bytes) {
  write_file_atomically(dir + "/" + file, bytes);
  return {{"file", file}, {"hash", checksum_hex(bytes_checksum(bytes))}};
}

// The bytes of the kept file a manifest `entry` (write_kept's) names in `dir`, checked against its
// checksum. Throws rv::Error: not_found (missing), invalid_input (named outside the directory, or
// modified since the base run); nlohmann::json's errors for an entry without those members.
std::string read_kept(const fs::path& dir, const std::string& dir_name, const nlohmann::json& entry) {
  const std::string file = entry.at("file").get<std::string>();
  if (file.empty() || fs::path(file).has_parent_path())
    throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json names a file outside it");
  const std::string shown = dir_name + "/" + file;
  std::string bytes = read_whole((dir / file).string(), shown);
  if (entry.at("hash").get<std::string>() != checksum_hex(bytes_checksum(bytes)))
    throw Error(ErrorKind::invalid_input, "base: " + shown + " was modified since the base run");
  return bytes;
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

// The base site of each site code (index 0: none): index + 1 for a fresh run's, else its
// site_codes.bin, checked. Throws as EditBase's constructor.
std::vector<int32_t> site_codes(const nlohmann::json& m, const fs::path& dir, const std::string& dir_name,
                                int32_t sites) {
  if (!m.contains("site_codes")) {
    std::vector<int32_t> out(1, kNoSite);
    for (int32_t i = 0; i < sites; ++i) out.push_back(i);
    return out;
  }
  const nlohmann::json& sc = m.at("site_codes");
  const std::string bytes = read_kept(dir, dir_name, sc);
  try {
    return decode_site_codes(bytes, sc.at("codes").get<size_t>(), sites);
  } catch (const Error& e) {
    throw Error(ErrorKind::invalid_input,
                "base: " + dir_name + "/site_codes.bin does not fit its seeds (" + e.what() + ")");
  }
}

// The line pieces the manifest names, each checked and decoded. Throws as EditBase's
// constructor: a file missing, modified or damaged is an error like any other of the base's.
std::map<std::string, LinePieces> kept_line_pieces(const nlohmann::json& m, const fs::path& dir,
                                                   const std::string& dir_name) {
  std::map<std::string, LinePieces> out;
  if (!m.contains("line_pieces")) return out;
  for (const auto& [name, e] : m.at("line_pieces").items()) {
    const std::string bytes = read_kept(dir, dir_name, e);
    try {
      out[name] = LinePieces::decode(bytes);
    } catch (const Error& err) {
      throw Error(ErrorKind::invalid_input,
                  "base: " + dir_name + "/" + e.at("file").get<std::string>() + ": " + err.what());
    }
    if (out[name].key() != e.at("key").get<std::string>())
      throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json is damaged");
  }
  return out;
}

// The rasters the manifest names, by role: each relative to the directory, with its tiles'
// checksums (their count is checked against the grid by the constructor). Throws as EditBase's
// constructor; nlohmann::json's errors and std::invalid_argument for members of the wrong form.
std::map<std::string, EditBase::Earlier> kept_rasters(const nlohmann::json& m, const fs::path& dir,
                                                      const std::string& dir_name) {
  std::map<std::string, EditBase::Earlier> out;
  for (const auto& [role, e] : m.at("rasters").items()) {
    EditBase::Earlier r;
    const std::string file = e.at("file").get<std::string>();
    if (file.empty() || fs::path(file).is_absolute())
      throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json names a raster outside it");
    r.path = (dir / file).lexically_normal().string();
    r.display = "base: " + (fs::path(file).has_parent_path() ? file : dir_name + "/" + file);
    // A raster that is gone is encoded afresh; one replaced by a FIFO or a device is refused
    // (GDAL would wait on it for ever).
    std::error_code ec;
    const fs::file_status status = fs::status(r.path, ec);
    if (fs::exists(status) && !fs::is_regular_file(status))
      throw Error(ErrorKind::invalid_input, r.display + " is not a regular file");
    for (const nlohmann::json& h : e.at("tiles")) {
      const std::string hex = h.get<std::string>();
      if (hex.size() != 16) throw nlohmann::json::type_error::create(302, "a checksum of 16 digits", nullptr);
      r.checksums.push_back(std::stoull(hex, nullptr, 16));
    }
    out[role] = std::move(r);
  }
  return out;
}

}  // namespace

std::string edit_base_dir(const std::string& report) { return report + ".rvbase"; }

EditBaseWriter::EditBaseWriter(const JobSpec& spec, const PreparedJob& job) : tiles(TileSummaries::for_grid(job.grid)) {
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
  manifest_ = request_params(spec, job);
  manifest_["format"] = kFormat;
  manifest_["version"] = kFormatVersion;
  manifest_["sites"] = sites_;
  manifest_["seeds"] = write_kept(temp_, "seeds.bin", seeds);
  manifest_["seeds"]["bytes"] = seeds.size();
}

EditBaseWriter::~EditBaseWriter() {
  if (committed_) return;
  std::error_code ec;
  fs::remove_all(temp_, ec);
}

void EditBaseWriter::set_line_pieces(const std::map<std::string, LinePieces>& pieces) {
  for (const auto& [name, p] : pieces) lines_[name] = {p.key(), p.encode()};
}

void EditBaseWriter::set_site_codes(std::vector<int32_t> site_of_code) { site_of_code_ = std::move(site_of_code); }

GeoTiffOptions EditBaseWriter::site_options() const {
  GeoTiffOptions o;
  o.max_code = site_of_code_.empty() ? sites_ : static_cast<int64_t>(site_of_code_.size()) - 1;
  o.metadata["CONTENT"] =
      site_of_code_.empty()
          ? "nearest site index + 1 (0 = none), kept for edits of this run"
          : "nearest site's code (0 = none; site_codes.bin gives its index), kept for edits of this run";
  return o;
}

GeoTiffOptions EditBaseWriter::distance_options() const {
  GeoTiffOptions o;
  o.metadata["CONTENT"] = "distance to the nearest site in metric units, kept for edits of this run";
  return o;
}

std::vector<uint64_t>* EditBaseWriter::record(const std::string& role, const std::string& path) {
  auto& r = rasters_[role];
  r.first = path;
  return &r.second;
}

std::string EditBaseWriter::commit() {
  // Files in the directory by their names in it; the job's files relative to it, so that the
  // directory and the outputs beside it may move together.
  const fs::path temp = fs::absolute(temp_).lexically_normal(), dir = fs::absolute(dir_).lexically_normal();
  nlohmann::json rasters = nlohmann::json::object();
  for (const auto& [role, r] : rasters_) {
    const fs::path p = fs::absolute(r.first).lexically_normal();
    const std::string file = p.parent_path() == temp ? p.filename().string() : p.lexically_relative(dir).string();
    nlohmann::json sums = nlohmann::json::array();
    for (const uint64_t v : r.second) sums.push_back(checksum_hex(v));
    rasters[role] = {{"file", file}, {"tiles", sums}};
  }
  // The job's distance raster when it is the kept one.
  if (!shared_distance_.empty() && rasters.contains("output_distance"))
    rasters["distance"] = rasters["output_distance"];
  manifest_["rasters"] = rasters;
  if (!site_of_code_.empty()) {
    manifest_["site_codes"] = write_kept(temp_, "site_codes.bin", encode_site_codes(site_of_code_));
    manifest_["site_codes"]["codes"] = site_of_code_.size() - 1;
  }
  nlohmann::json lines = nlohmann::json::object();
  for (const auto& [name, kb] : lines_) {
    lines[name] = write_kept(temp_, "lines_" + name + ".bin", kb.second);
    lines[name]["key"] = kb.first;
  }
  if (!lines.empty()) manifest_["line_pieces"] = lines;
  manifest_["tiles"] = {{"size", TileSummaries::kTile},
                        {"cols", tiles.cols},
                        {"rows", tiles.rows},
                        {"max_distance", tiles.max_distance},
                        {"max_cost", tiles.max_cost},
                        {"unowned", tiles.unowned},
                        {"bands", TileSummaries::kBands},
                        {"band_max_distance", tiles.band_max_distance},
                        {"band_unowned", tiles.band_unowned}};
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
  std::map<std::string, Earlier> rasters;   // by role (EditBaseWriter::record)
  std::map<std::string, LinePieces> lines;  // by extraction (EditBaseWriter::set_line_pieces)
  std::vector<int32_t> site_of_code;        // code -> base site (kNoSite for 0 and removed ones)
  bool identity_codes = false;              // code = site index + 1 (a fresh run's)
  TileSummaries tiles;
  GridSpec grid;
  MetricSpec metric;
  std::shared_ptr<const Geolocator> geolocator;
  int64_t next_row = 0;
  double files_seconds = 0.0;  // EditBase::read_files'
  EditBase::Costs costs;
};

namespace {

// The manifest's "costs" (EditBaseWriter::set_costs). Advisory: what is missing or malformed is
// left unknown, never an error (a base without them is edited by recoding, as before they were kept).
EditBase::Costs read_costs(const nlohmann::json& m) {
  EditBase::Costs c;
  const auto it = m.find("costs");
  if (it == m.end() || !it->is_object()) return c;
  if (const auto e = it->find("engine_s"); e != it->end() && e->is_number()) c.engine_s = e->get<double>();
  if (const auto w = it->find("encode_s"); w != it->end() && w->is_object())
    for (const auto& [role, v] : w->items())
      if (v.is_number()) c.encode_s[role] = v.get<double>();
  return c;
}

}  // namespace

// What EditBase reads of a base before the job is known: the report, the manifest and the files
// it names, parsed and decoded. A failure is kept where the constructor would have met it: before
// the job is compared with the base (`early`: the report, the manifest, its format) or after
// (`late`: the seed archive, the site codes, the line pieces, the rasters' entries).
struct EditBaseFiles {
  std::string report;
  fs::path dir;
  std::string dir_name;
  nlohmann::json manifest;
  SeedArchive archive;
  std::vector<int32_t> site_of_code;
  std::map<std::string, LinePieces> lines;
  std::map<std::string, EditBase::Earlier> rasters;
  std::exception_ptr early, late;
  double seconds = 0.0;
};

std::shared_ptr<EditBaseFiles> EditBase::read_files(const std::string& report) {
  const auto started = std::chrono::steady_clock::now();
  auto f = std::make_shared<EditBaseFiles>();
  f->report = report;
  const fs::path report_path(report);
  const std::string name = report_path.filename().string();
  try {
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
    f->dir = report_path.parent_path() / r["edit_base"].get<std::string>();
    f->dir_name = f->dir.filename().string();
    try {
      f->manifest =
          nlohmann::json::parse(read_whole((f->dir / "manifest.json").string(), f->dir_name + "/manifest.json"));
    } catch (const nlohmann::json::exception&) {
      throw Error(ErrorKind::invalid_input, "base: " + f->dir_name + "/manifest.json is damaged");
    }
    const nlohmann::json& m = f->manifest;
    // A manifest with a member of the wrong type is as damaged as one that does not parse.
    if (!m.is_object() || m.value("format", "") != kFormat || m.value("version", 0) != kFormatVersion ||
        !m.contains("grid") || !m["grid"].is_object())
      throw Error(ErrorKind::invalid_input,
                  "base: " + f->dir_name + "/manifest.json is not a kept base of this version");
  } catch (...) {
    f->early = std::current_exception();
    return f;
  }
  try {
    const nlohmann::json& m = f->manifest;
    try {
      const std::string seeds = read_kept(f->dir, f->dir_name, m.at("seeds"));
      f->archive = decode_seed_archive(seeds);
      if (static_cast<int64_t>(f->archive.seeds.sites().size()) != m.value("sites", int64_t{-1}))
        throw Error(ErrorKind::invalid_input, "base: " + f->dir_name + "/manifest.json does not fit its seeds");
      f->site_of_code = site_codes(m, f->dir, f->dir_name, static_cast<int32_t>(f->archive.seeds.sites().size()));
      f->lines = kept_line_pieces(m, f->dir, f->dir_name);
      f->rasters = kept_rasters(m, f->dir, f->dir_name);
    } catch (const nlohmann::json::exception&) {
      throw Error(ErrorKind::invalid_input, "base: " + f->dir_name + "/manifest.json is damaged");
    } catch (const std::invalid_argument&) {
      throw Error(ErrorKind::invalid_input, "base: " + f->dir_name + "/manifest.json is damaged");
    }
  } catch (...) {
    f->late = std::current_exception();
  }
  f->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  return f;
}

EditBase::EditBase(const std::string& report, const JobSpec& spec, const PreparedJob& job)
    : EditBase(read_files(report), spec, job) {}

EditBase::EditBase(std::shared_ptr<EditBaseFiles> files, const JobSpec& spec, const PreparedJob& job)
    : st_(std::make_unique<State>()), report_(files->report) {
  if (spec.method != Method::exact)
    throw Error(ErrorKind::invalid_argument,
                "base: an edit recomputes part of a field, which only the exact method does (method " +
                    std::string(to_string(spec.method)) + ")");
  if (spec.validate) throw Error(ErrorKind::invalid_argument, "base: an edit is not validated (drop --validate)");
  if (job.partial.any())
    throw Error(ErrorKind::invalid_argument,
                "base: partial effect compares whole fields; an edit of it is a fresh run (drop the base)");
  if (files->early) std::rethrow_exception(files->early);
  const std::string& dir_name = files->dir_name;
  State& st = *st_;
  st.files_seconds = files->seconds;
  st.manifest = std::move(files->manifest);
  const nlohmann::json& m = st.manifest;
  st.costs = read_costs(m);
  try {
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
    if (files->late) std::rethrow_exception(files->late);
    st.archive = std::move(files->archive);
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
      // The bands' summaries, where the base has them of this layout (else the tiles' stand for them).
      st.tiles.band_max_distance.clear();
      st.tiles.band_unowned.clear();
      if (t.value("bands", int64_t{0}) == TileSummaries::kBands && t.contains("band_max_distance")) {
        st.tiles.band_max_distance = t.at("band_max_distance").get<std::vector<float>>();
        st.tiles.band_unowned = t.at("band_unowned").get<std::vector<uint8_t>>();
        if (!st.tiles.has_bands()) throw Error(ErrorKind::invalid_input, "");
      }
    } catch (const std::exception&) {
      throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json has no tile summaries of its grid");
    }
    st.site_of_code = std::move(files->site_of_code);
    st.lines = std::move(files->lines);
    st.identity_codes = !m.contains("site_codes");
    const int64_t tile_count = ((job.grid.width + kTile - 1) / kTile) * ((job.grid.height + kTile - 1) / kTile);
    st.rasters = std::move(files->rasters);
    for (const auto& [role, r] : st.rasters)
      if (static_cast<int64_t>(r.checksums.size()) != tile_count)
        throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json does not fit its grid");
  } catch (const nlohmann::json::exception&) {
    throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json is damaged");
  } catch (const std::invalid_argument&) {
    throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json is damaged");
  }
  auto open = [&](const char* role, auto& reader) {
    const auto it = st.rasters.find(role);
    if (it == st.rasters.end())
      throw Error(ErrorKind::invalid_input, "base: " + dir_name + "/manifest.json names no " + role + " raster");
    const std::string& path = it->second.path;
    if (!fs::exists(path)) throw Error(ErrorKind::not_found, it->second.display + " is missing");
    if (!fs::is_regular_file(path))
      throw Error(ErrorKind::invalid_input, it->second.display + " is not a regular file");
    reader = std::make_unique<typename std::remove_reference_t<decltype(reader)>::element_type>(path);
    const GridSpec& g = reader->grid();
    if (g.width != job.grid.width || g.height != job.grid.height)
      throw Error(ErrorKind::invalid_input, it->second.display + " does not fit the grid");
  };
  open("site", st.site);
  open("distance", st.distance);
  st.grid = job.grid;
  st.metric = job.compute.metric;
  st.geolocator = job.compute.geolocator;
}

EditBase::~EditBase() = default;

const SeedSet& EditBase::seeds() const { return st_->archive.seeds; }
double EditBase::files_seconds() const { return st_->files_seconds; }
const std::vector<int64_t>& EditBase::numbering() const { return st_->archive.numbering; }
const std::vector<int32_t>& EditBase::site_of_code() const { return st_->site_of_code; }

SiteCodeTable edit_site_codes(const EditBase& base, const Edit& edit, size_t edited_sites) {
  const std::vector<int32_t>& remap = edit.site_map();
  const std::vector<int32_t>& before = base.site_of_code();
  SiteCodeTable t;
  t.site_of_code.assign(before.size(), -1);
  t.code_of_site.assign(edited_sites, 0);
  for (size_t k = 1; k < before.size(); ++k) {
    if (before[k] == kNoSite) continue;
    const int32_t s = remap[static_cast<size_t>(before[k])];
    if (s == kNoSite) continue;
    t.site_of_code[k] = s;
    t.code_of_site[static_cast<size_t>(s)] = static_cast<int32_t>(k);
  }
  for (size_t s = 0; s < edited_sites; ++s)
    if (t.code_of_site[s] == 0) {
      t.code_of_site[s] = static_cast<int32_t>(t.site_of_code.size());
      t.site_of_code.push_back(static_cast<int32_t>(s));
    }
  return t;
}
const TileSummaries& EditBase::tiles() const { return st_->tiles; }

const EditBase::Costs& EditBase::costs() const { return st_->costs; }

std::optional<EditBase::Earlier> EditBase::earlier(const std::string& role) const {
  const auto it = st_->rasters.find(role);
  if (it == st_->rasters.end()) return std::nullopt;
  return it->second;
}

LinePieces EditBase::line_pieces(const std::string& name, const std::string& key) const {
  const auto it = st_->lines.find(name);
  return it != st_->lines.end() && it->second.key() == key ? it->second : LinePieces();
}

void EditBase::read(int64_t row0, int64_t rows, NearestField& out, const std::vector<uint8_t>* tiles) {
  State& st = *st_;
  const GridSpec& g = st.grid;
  if (row0 != st.next_row) throw Error(ErrorKind::internal, "EditBase::read: rows out of order");
  if (row0 % kTile != 0 || (rows % kTile != 0 && row0 + rows != g.height))
    throw Error(ErrorKind::internal, "EditBase::read: strips of whole bands of tiles");
  const int64_t cols = (g.width + kTile - 1) / kTile;
  if (tiles && static_cast<int64_t>(tiles->size()) != cols * ((g.height + kTile - 1) / kTile))
    throw Error(ErrorKind::internal, "EditBase::read: tile flags that do not fit the grid");
  const Window w{0, row0, g.width, rows};
  out.site.retarget(g, w);
  out.distance.retarget(g, w);
  out.metric = st.metric;
  out.geolocator = st.geolocator;
  // The tiles to read, as (column, row) of the grid's tiles.
  std::vector<std::pair<int64_t, int64_t>> read;
  for (int64_t by = row0 / kTile; by * kTile < row0 + rows; ++by)
    for (int64_t bx = 0; bx < cols; ++bx)
      if (!tiles || (*tiles)[static_cast<size_t>(by * cols + bx)]) read.emplace_back(bx, by);
  if (read.empty()) {
    st.next_row = row0 + rows;
    return;
  }
  // Each file's tiles: decoded (whole rows when every tile is read) and checked.
  auto take = [&](auto& reader, auto* cells, const Earlier& e) {
    if (!tiles) reader.read_rows(row0, rows, cells);
    for (const auto& [bx, by] : read) {
      const int64_t c0 = bx * kTile, r0 = by * kTile;
      const int64_t tw = std::min(kTile, g.width - c0), th = std::min(kTile, g.height - r0);
      if (tiles) reader.read_window(c0, r0, tw, th, cells + (r0 - row0) * g.width + c0, g.width);
      reader.check_tile(bx, by, e.checksums[static_cast<size_t>(by * cols + bx)], e.display);
    }
  };
  // The two files side by side (independent GDAL datasets): decoding and checking each is about
  // half of an edit's reading.
  std::exception_ptr failed;
  std::thread other([&] {
    try {
      take(*st.distance, out.distance.data(), st.rasters.at("distance"));
    } catch (...) {
      failed = std::current_exception();
    }
  });
  try {
    take(*st.site, out.site.data(), st.rasters.at("site"));
  } catch (...) {
    other.join();
    throw;
  }
  other.join();
  if (failed) std::rethrow_exception(failed);
  st.next_row = row0 + rows;
  // Site codes -> the base's sites: a fresh run's are index + 1 (a subtraction the compiler
  // vectorises, checked once per run of cells); an edit's go through its table.
  const auto codes = static_cast<uint32_t>(st.site_of_code.size());
  auto translate = [&](int32_t* cells, int64_t n) {
    if (st.identity_codes) {
      uint32_t top = 0;
      for (int64_t c = 0; c < n; ++c) {
        top = std::max(top, static_cast<uint32_t>(cells[c]));
        cells[c] -= 1;  // 0 -> kNoSite
      }
      return top < codes;
    }
    for (int64_t c = 0; c < n; ++c) {
      const auto v = static_cast<uint32_t>(cells[c]);
      if (v >= codes || (v > 0 && st.site_of_code[v] == kNoSite)) return false;
      cells[c] = st.site_of_code[v];  // 0 -> kNoSite
    }
    return true;
  };
  bool ok = true;
  if (!tiles) {
    ok = translate(out.site.data(), rows * g.width);
  } else {
    for (const auto& [bx, by] : read) {
      const int64_t c0 = bx * kTile, r0 = by * kTile;
      const int64_t tw = std::min(kTile, g.width - c0), th = std::min(kTile, g.height - r0);
      for (int64_t r = r0; r < r0 + th && ok; ++r) ok = translate(out.site.data() + (r - row0) * g.width + c0, tw);
    }
  }
  if (!ok) throw Error(ErrorKind::invalid_input, "base: site.tif holds a site its seeds lack");
}

EditCodes code_maps(const EditBase& base, const Edit& edit, const LoadedSeeds& edited) {
  const SeedSet& b = base.seeds();
  EditCodes out;
  auto set = [](CodeMap& m, size_t from, int32_t to) {
    m.to[from] = to;
    m.identity = m.identity && (to < 0 || to == static_cast<int32_t>(from));
  };
  // Owners by label.
  const std::vector<int32_t> owners = owner_codes_in(b, edited.seeds);
  out.owners.to.assign(owners.size(), -1);
  out.owners.to[0] = 0;
  for (size_t i = 1; i < owners.size(); ++i) set(out.owners, i, owners[i]);
  // Features by their numbers in each run, through their sites: a feature changed only in
  // geometry keeps the cells of its unchanged sites.
  const std::vector<int32_t>& remap = edit.site_map();
  const std::vector<int64_t>& nb = base.numbering();
  const std::vector<int64_t>& ne = edited.input_position;
  auto number = [](const std::vector<int64_t>& n, int32_t f) {
    return n.empty() ? static_cast<int64_t>(f) + 1 : n[static_cast<size_t>(f)];
  };
  int64_t top = 0;
  for (size_t f = 0; f < b.features().size(); ++f) top = std::max(top, number(nb, static_cast<int32_t>(f)));
  // The map is a table over the numbers (the tiles' codes go through it): numbers far beyond the
  // features (skipped empty ones count) are a crafted archive's, not a run's; no such table is
  // allocated for them.
  const auto features = static_cast<int64_t>(b.features().size());
  if (top > std::max(JobLimits{}.max_features, 2 * features))
    throw Error(ErrorKind::invalid_input, "base: the seed archive numbers its " + std::to_string(features) +
                                              " features up to " + std::to_string(top) +
                                              ", beyond what a run reads; the base is damaged");
  out.features.to.assign(static_cast<size_t>(top) + 1, -1);
  out.features.to[0] = 0;
  for (size_t i = 0; i < remap.size(); ++i) {
    if (remap[i] == kNoSite) continue;
    const auto from = static_cast<size_t>(number(nb, b.sites()[i].feature));
    const auto to = static_cast<int32_t>(number(ne, edited.seeds.sites()[static_cast<size_t>(remap[i])].feature));
    if (out.features.to[from] >= 0 && out.features.to[from] != to) out.features.valid = false;
    set(out.features, from, to);
  }
  return out;
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
          {"tiles_planned", std::count(tally.tiles_planned.begin(), tally.tiles_planned.end(), true)},
          {"tiles_encoded", tally.tiles_encoded},
          {"tiles_copied", tally.tiles_copied},
          {"tiles_recoded", tally.tiles_recoded},
          {"tiles_not_copied", tally.not_copied},
          {"cells_of_removed_features", tally.cells_of_removed},
          {"owner_changed_cells", tally.changes.owner_cells},
          {"distance_only_changed_cells", tally.changes.distance_only_cells},
          {"area_moved", moved},
          {"area_units", geodesic ? "m2" : "crs-units^2"},
          {"strips", tally.strips},
          {"strips_by_engine", tally.strips_by_engine},
          {"files_where_codes_move", tally.choice},
          {"timings_s",
           {{"read_base", tally.read_seconds},
            {"plan", tally.plan_seconds},
            {"recompute", tally.apply_seconds},
            {"engine", tally.engine_seconds},
            {"tally", tally.tally_seconds}}}};
}

}  // namespace rv::detail
