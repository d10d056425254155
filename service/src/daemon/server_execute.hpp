// Translation of an OGC API - Processes execute request for the process "voronoi" into a
// JobSpec. Untrusted input: every value is checked here, uploads go to /vsimem/ only, and no
// value can make the server fetch a URL or open a path on its disk (hrefs are refused, CRS
// definitions are restricted to authority codes, OGC URIs and WKT, seed paths are always ours).
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "rv/job.hpp"
#include "rv/server_config.hpp"

namespace rv::daemon {

// A job's in-memory input files under /vsimem/rvoronoi/<job id>/; unlinked on destruction.
// Not thread-safe; owned by one job at a time.
class VsiMemFiles {
 public:
  explicit VsiMemFiles(std::string directory) : directory_(std::move(directory)) {}
  ~VsiMemFiles();
  VsiMemFiles(const VsiMemFiles&) = delete;
  VsiMemFiles& operator=(const VsiMemFiles&) = delete;
  // Writes `bytes` to directory/name and returns its /vsimem/ path. Throws rv::Error(io).
  std::string write(const std::string& name, std::string_view bytes);

 private:
  std::string directory_;
  std::vector<std::string> files_;
};

// The outputs of the process, in the order of OutputRequest.
inline constexpr const char* kOutputIds[] = {"ownership", "distance", "report"};

struct Execution {
  JobSpec spec;                           // outputs.* paths left empty (the job manager sets them)
  std::vector<std::string> outputs;       // requested output ids, in kOutputIds order
  std::vector<std::string> transmission;  // per output: "value" or "reference"
  bool raw = false;                       // "response": "raw" (one output, its bytes)
  nlohmann::json inputs_summary;          // the inputs as stored with the job (uploads summarised)
  std::shared_ptr<VsiMemFiles> uploads;   // keeps the seed files alive until the job ends
};

// Throws rv::Error: invalid_argument (malformed request or parameter, naming the input),
// invalid_input (seed data of the wrong kind, naming the input and its position),
// unsupported (multipart raw responses, callbacks), too_large (grid over the configured limits
// when extent and resolution make it known up front).
Execution parse_execution(const nlohmann::json& body, const std::string& job_id,
                          const ServerConfig& config);

// The checked CRS definition of an input value. Throws rv::Error(invalid_argument).
std::string checked_crs(const nlohmann::json& value, const std::string& input);

}  // namespace rv::daemon
