// Translation of an OGC API - Processes execute request for the process "voronoi" into a
// JobSpec. Untrusted input: every value is checked here, uploads go to /vsimem/ only, and no
// value can make the server fetch a URL or open a path on its disk (hrefs are refused, CRS
// definitions are restricted to authority codes, OGC URIs and WKT, seed paths are always ours).
#pragma once

#include <functional>
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

// Media types of the result files.
inline constexpr const char* kMediaGeoTiff = "image/tiff; application=geotiff; profile=cloud-optimized";
inline constexpr const char* kMediaJson = "application/json";
inline constexpr const char* kMediaGeoJson = "application/geo+json";
inline constexpr const char* kMediaGeoPackage = "application/geopackage+sqlite3";
inline constexpr const char* kMediaPng = "image/png";
inline constexpr const char* kMediaCsv = "text/csv";

// One output of the process: the media types it can be written as (the first is the default)
// and the file name stem in the job's directory. The single place that knows which output is
// which kind of file: execution, the job manager and the results endpoint all ask here.
struct OutputFormat {
  const char* media_type;
  const char* extension;  // of the file in the job's directory, without the dot
};
struct OutputInfo {
  const char* id;
  const char* stem;
  std::vector<OutputFormat> formats;
  bool by_value = false;  // may be returned by value (the report); the rest are files, by reference
};
// The description of output `id`, or nullptr for an unknown id.
const OutputInfo* find_output(std::string_view id);
// The canonical media type of output `id` for a requested one (OGC "format": {"mediaType"}),
// compared without case and blanks; "" asks for the default. Throws
// rv::Error(invalid_argument) for an unknown output or a media type it cannot be written as.
std::string output_media_type(std::string_view id, std::string_view requested);
// The file name of output `id` written as `media_type` ("" = the output's default) inside the
// job's directory. Throws rv::Error(internal) for an unknown id or media type (ids and media
// types come from the store, checked when the job was accepted).
std::string output_file_name(std::string_view id, std::string_view media_type);

struct Execution {
  JobSpec spec;                           // outputs.* paths left empty (the job manager sets them)
  std::vector<std::string> outputs;       // requested output ids, in kOutputIds order
  std::vector<std::string> transmission;  // per output: "value" or "reference"
  std::vector<std::string> formats;       // per output: its canonical media type
  bool raw = false;                       // "response": "raw" (one output, its bytes)
  nlohmann::json inputs_summary;          // the inputs as stored with the job (uploads summarised)
  std::shared_ptr<VsiMemFiles> uploads;   // keeps the seed files alive until the job ends
  // The grid's cells when extent and resolution give them up front; 0 = known once planned.
  int64_t cells = 0;
  // What computes the job instead of the server's runner (a job made from a live session saves
  // the session's state); empty = the runner.
  std::function<JobResult(const JobSpec&, const JobLimits&, const JobHooks&)> run;
  // The execute request's body as received, kept with a shared store (which stores it, so that
  // whichever daemon claims the job parses it again); "" = not kept.
  std::string request;
};

// Throws rv::Error: invalid_argument (malformed request or parameter, naming the input),
// invalid_input (seed data of the wrong kind, naming the input and its position),
// unsupported (multipart raw responses, callbacks), too_large (grid over the configured limits
// when extent and resolution make it known up front).
// `staging` names the uploads' /vsimem/ folder instead of the job id (a claimed attempt's
// "<id>-a<n>": two attempts of one job on one daemon never share their files).
Execution parse_execution(const nlohmann::json& body, const std::string& job_id, const ServerConfig& config,
                          const std::string& staging = "");

// The "outputs" and "response" members of an execute request into `ex` (outputs, transmission,
// formats, raw): with no outputs, the ownership and distance rasters and the report. Throws
// rv::Error(invalid_argument / unsupported) as parse_execution.
void parse_outputs(const nlohmann::json& body, Execution& ex);

// The input "seeds" of `in` (one layer or an array: GeoJSON, or a base64 GeoPackage, zipped
// Shapefile or FlatGeobuf) written to `files`; their paths appended to read.paths and the reading
// confined to them (uploads are untrusted). Returns the summary stored with a job (one entry per
// layer: its type and size). Throws rv::Error(invalid_argument / invalid_input) naming the input.
nlohmann::json stage_seed_input(const nlohmann::json& in, SeedReadOptions& read, VsiMemFiles& files);

// The value of a literal input given bare or as a qualified value {"value": ...}. Throws
// rv::Error(invalid_argument) for a reference (href): the server never fetches.
const nlohmann::json& literal(const nlohmann::json& value, const std::string& input);

// The members of an execute request: an "inputs" object, and "outputs" and "response" at most.
// Throws rv::Error: unsupported ("subscriber": callbacks), invalid_argument (any other member).
void check_body_members(const nlohmann::json& body);

// A message with the upload paths of job `id` (/vsimem/rvoronoi/<id>/seeds_<n>.<ext>,
// relevantArea.<ext>, relevantCoasts.<ext>) in the names the client knows: seeds[n], the input.
std::string client_names(std::string message, const std::string& id);

// The checked CRS definition of an input value. Throws rv::Error(invalid_argument).
std::string checked_crs(const nlohmann::json& value, const std::string& input);

}  // namespace rv::daemon
