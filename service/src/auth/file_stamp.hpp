// What tells a configuration file that is read again when it changes (the JWKS file, the token
// file) from its last read: its size and modification time (nanoseconds), and its inode, so that a
// file replaced by a rename (the safe way to edit it) always counts as changed.
// Thread safety: a pure function of the file system.
#pragma once

#include <sys/stat.h>

#include <string>

namespace rv::auth {

// "" when the file cannot be stat'ed (missing, unreadable folder).
inline std::string file_stamp(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return {};
  return std::to_string(st.st_size) + "/" + std::to_string(st.st_mtim.tv_sec) + "." +
         std::to_string(st.st_mtim.tv_nsec) + "/" + std::to_string(st.st_ino);
}

}  // namespace rv::auth
