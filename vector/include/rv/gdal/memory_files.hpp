// Files held in GDAL's memory file system (/vsimem/): what the writers write where nothing may
// reach the disk (a session's deliverables, rv/session.hpp). Thread-safe.
#pragma once

#include <string>

namespace rv {

// The bytes of the memory file `path` ("/vsimem/..."). Throws rv::Error(not_found) when there is
// none.
std::string read_memory_file(const std::string& path);
// Writes `bytes` to the memory file `path` ("/vsimem/..."), replacing it. Throws rv::Error(io).
void write_memory_file(const std::string& path, const std::string& bytes);
// Removes every memory file under `directory` ("/vsimem/..."); nothing when there is none.
void remove_memory_files(const std::string& directory);

}  // namespace rv
