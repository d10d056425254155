// The process "describe-seeds": what uploaded seed files hold, before a job is made of them. The
// map page (issue 34) asks it for the fields to offer as the owner field (with their values),
// the CRS and box the grid will default to, and the features to draw; any client may.
//
// POST /processes/describe-seeds/execution {"inputs": {"seeds": ..., "crs": ..., "features":
// true}} answers at once (sync-execute only) with the description itself, the process's one
// output: rv::describe_seeds() (rv/job.hpp) under the server's seed limits (a job's: features,
// vertices, inflated bytes, reading memory), the uploads staged and confined as a job's are.
// Runs on a thread of the daemon's describe pool, never a network thread (Api::describe), its
// memory reserved in the daemon's account as the reading goes; `features` is refused
// (too_large, 422) above the server's preview_max_vertices.
// Thread safety: pure functions of their arguments.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "rv/server_config.hpp"

namespace rv::daemon {

inline constexpr const char* kDescribeSeedsId = "describe-seeds";

nlohmann::json describe_seeds_summary(const std::string& base);
nlohmann::json describe_seeds_description(const std::string& base, const ServerConfig& config);

// The answer to an execution request. Throws rv::Error: invalid_argument (the request),
// invalid_input (the data), too_large (the limits), with the client's names for its uploads.
// `reserve` is called with the reading's memory estimate as it grows (it may throw to stop).
nlohmann::json describe_seeds_execute(const nlohmann::json& body, const ServerConfig& config,
                                      const std::function<void(int64_t)>& reserve);

}  // namespace rv::daemon
