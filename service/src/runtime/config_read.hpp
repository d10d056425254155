// Reading the daemon's configuration document: the checks every section shares. Each throws
// rv::Error(invalid_argument) naming the key at fault ("section.key") and why; never its value
// (a value may be a secret). Thread safety: free functions.
#pragma once

#include <cstdint>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

namespace rv::config_read {

[[noreturn]] void bad(const std::string& key, const std::string& why);
// Rejects keys we do not know: a misspelt limit would otherwise silently keep its default.
void check_keys(const nlohmann::json& object, const std::string& where, const std::set<std::string>& known);
int64_t get_int(const nlohmann::json& object, const std::string& where, const char* key, int64_t fallback,
                int64_t min_value);
// (0, 1e7] seconds.
double get_seconds(const nlohmann::json& object, const std::string& where, const char* key, double fallback);
std::string get_string(const nlohmann::json& object, const char* key, const std::string& fallback);
// The same, named "where.key" in messages.
std::string get_string(const nlohmann::json& object, const std::string& where, const char* key,
                       const std::string& fallback);

}  // namespace rv::config_read
