// Fuzz target: the daemon's execute request parser (OGC API - Processes execute JSON -> JobSpec,
// service/src/daemon/server_execute.hpp), then the confined seed loader on what it staged, as
// a job would run it.
//
// Input: the bytes of a request body, parsed as the server does (parse_body_json: JSON nesting at
// most kMaxBodyDepth levels); every document it accepts goes to parse_execution().
// Findings: a crash or sanitizer report (deep nesting included: bodies are up to the configured
// max_body_bytes, 64 MiB by default), an exception other than rv::Error (e.g. nlohmann's
// type_error escaping a check), an rv::Error of an undocumented kind, or an Execution breaking
// its contract: seed paths outside this job's /vsimem/ directory, outputs and transmission
// modes out of step, a missing or non-positive resolution, a non-finite extent; a message or
// owner label that is not valid UTF-8; not_found for an upload (it is bad input: 400).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "daemon/server_execute.hpp"
#include "runtime/server_util.hpp"
#include "rv/field/error.hpp"
#include "rv/field/text.hpp"
#include "rv/gdal/seed_reader.hpp"
#include "rv/server_config.hpp"

namespace {

void require(bool ok) {
  if (!ok) std::abort();
}

bool starts_with(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

constexpr const char* kJobId = "0123456789abcdef0123456789abcdef";

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  rv::gdal_init();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > 256 * 1024) return 0;
  // As the server parses bodies (depth-limited); what it refuses never reaches parse_execution.
  nlohmann::json body;
  try {
    body = rv::daemon::parse_body_json(std::string_view(reinterpret_cast<const char*>(data), size));
  } catch (const rv::Error& e) {
    require(e.kind() == rv::ErrorKind::invalid_argument);
    return 0;
  }
  rv::ServerConfig config;
  config.limits.max_cells = int64_t{1} << 26;
  config.limits.validate_max_cells = 1 << 20;
  try {
    const rv::daemon::Execution ex = rv::daemon::parse_execution(body, kJobId, config);
    const std::string dir = std::string("/vsimem/rvoronoi/") + kJobId + "/";
    require(!ex.spec.seeds.paths.empty());
    for (const std::string& p : ex.spec.seeds.paths) require(starts_with(p, dir) || starts_with(p, "/vsizip/" + dir));
    require(ex.outputs.size() == ex.transmission.size() && ex.outputs.size() == ex.formats.size() &&
            !ex.outputs.empty());
    require(ex.spec.grid.resolution && std::isfinite(*ex.spec.grid.resolution) && *ex.spec.grid.resolution > 0.0);
    if (ex.spec.grid.extent)
      for (double v : *ex.spec.grid.extent) require(std::isfinite(v));
    // The job's first step, on the staged uploads: confined, with small limits.
    rv::SeedReadOptions read = ex.spec.seeds;
    read.confined = true;
    read.max_features = 2000;
    read.max_vertices = 20000;
    read.max_input_bytes = 8 << 20;
    read.max_memory_bytes = 64 << 20;
    try {
      const rv::LoadedSeeds loaded = rv::load_seeds(read);
      for (const std::string& label : loaded.seeds.owner_labels()) require(rv::is_valid_utf8(label));
    } catch (const rv::Error& e) {
      // Never not_found: the staged files are the server's own; a broken upload is bad input.
      const rv::ErrorKind k = e.kind();
      require(k == rv::ErrorKind::invalid_input || k == rv::ErrorKind::invalid_argument ||
              k == rv::ErrorKind::conflict || k == rv::ErrorKind::too_large);
      require(rv::is_valid_utf8(e.what()));
    }
  } catch (const rv::Error& e) {
    require(rv::is_valid_utf8(e.what()));
    const rv::ErrorKind k = e.kind();
    require(k == rv::ErrorKind::invalid_argument || k == rv::ErrorKind::invalid_input ||
            k == rv::ErrorKind::unsupported || k == rv::ErrorKind::too_large);
  }
  return 0;
}
