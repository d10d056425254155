// Fuzz target: an uploaded seed file of one format (RV_FUZZ_FORMAT: gpkg, zip, fgb, kml, geojson),
// read as a daemon job reads it - confined, the daemon's drivers, small limits - and every text
// that comes out of it (owner labels, feature sources, warnings, the error message) carried
// through the daemon's own answer: the problem+json of the error table, the report's JSON.
//
// Input: the bytes of the file, written to /vsimem/ as the daemon stages an upload (a zip is
// opened through /vsizip/, as the daemon does).
// Findings: a crash or sanitizer report; an exception other than rv::Error; an rv::Error of a
// kind load_seeds does not document for uploads (not_found never: the file is ours); text that
// is not valid UTF-8 (a message, label, source or warning: the defect that used to abort the
// daemon in nlohmann's dump), or an answer that does not parse back as JSON; a limit not held
// (more features or vertices than allowed in the result).
#include <cstdint>
#include <cstdlib>
#include <string>

#include <cpl_vsi.h>
#include <nlohmann/json.hpp>

#include "daemon/server_api.hpp"
#include "rv/error_map.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/json_text.hpp"

#ifndef RV_FUZZ_FORMAT
#error "define RV_FUZZ_FORMAT (gpkg, zip, fgb, kml or geojson)"
#endif
#define RV_STRINGIFY2(x) #x
#define RV_STRINGIFY(x) RV_STRINGIFY2(x)

namespace {

void require(bool ok) {
  if (!ok) std::abort();
}

const std::string kExtension = RV_STRINGIFY(RV_FUZZ_FORMAT);
const std::string kFile = "/vsimem/rvoronoi/fuzz/seeds_0." + kExtension;

// The daemon's answer for an error, as a client receives it: it must be JSON again.
void answer_parses(const rv::Error& e) {
  const rv::ErrorInfo& info = rv::error_info(e.kind());
  const rv::daemon::ApiResponse r = rv::daemon::problem_response(
      static_cast<unsigned>(info.http_status), std::string(info.type), std::string(info.title), e.what(), "/x");
  const nlohmann::json back = nlohmann::json::parse(r.body, nullptr, false);
  require(!back.is_discarded() && back.at("detail").is_string());
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  rv::gdal_init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 512 * 1024) return 0;
  VSILFILE* f = VSIFileFromMemBuffer(kFile.c_str(), const_cast<GByte*>(data), static_cast<vsi_l_offset>(size), FALSE);
  if (f == nullptr) return 0;
  VSIFCloseL(f);

  rv::SeedReadOptions o;
  o.paths = {kExtension == "zip" ? "/vsizip/" + kFile : kFile};
  o.confined = true;
  o.max_features = 2000;
  o.max_vertices = 20000;
  o.max_input_bytes = 8 << 20;
  o.max_memory_bytes = 64 << 20;
  // Half the inputs name an owner field that the corpus files have, half use positions.
  if (size > 0 && (data[size - 1] & 1)) o.owner_field = "state";
  try {
    const rv::LoadedSeeds loaded = rv::load_seeds(o);
    nlohmann::json report = nlohmann::json::array();
    for (const std::string& label : loaded.seeds.owner_labels()) {
      require(rv::is_valid_utf8(label));
      report.push_back(label);
    }
    for (const rv::Feature& feature : loaded.seeds.features()) require(rv::is_valid_utf8(feature.source.str()));
    for (const std::string& w : loaded.report.warnings) {
      require(rv::is_valid_utf8(w));
      report.push_back(w);
    }
    require(loaded.report.features_read + loaded.report.features_skipped_empty <= o.max_features);
    const nlohmann::json back = nlohmann::json::parse(rv::json_text(report), nullptr, false);
    require(!back.is_discarded());
  } catch (const rv::Error& e) {
    require(rv::is_valid_utf8(e.what()));
    const rv::ErrorKind k = e.kind();
    require(k == rv::ErrorKind::invalid_input || k == rv::ErrorKind::invalid_argument || k == rv::ErrorKind::conflict ||
            k == rv::ErrorKind::too_large);
    answer_parses(e);
  }
  VSIUnlink(kFile.c_str());
  return 0;
}
