// Memory files (rv/gdal/memory_files.hpp).
#include "rv/gdal/memory_files.hpp"

#include <cpl_vsi.h>

#include "rv/field/error.hpp"

namespace rv {

std::string read_memory_file(const std::string& path) {
  vsi_l_offset size = 0;
  // Not taken over (FALSE): the file stays GDAL's; its bytes are copied.
  const GByte* bytes = VSIGetMemFileBuffer(path.c_str(), &size, FALSE);
  if (bytes == nullptr) throw Error(ErrorKind::not_found, "no memory file " + path);
  return std::string(reinterpret_cast<const char*>(bytes), static_cast<size_t>(size));
}

void write_memory_file(const std::string& path, const std::string& bytes) {
  VSILFILE* f = VSIFOpenL(path.c_str(), "wb");
  if (f == nullptr) throw Error(ErrorKind::io, "cannot create memory file " + path);
  const bool ok = VSIFWriteL(bytes.data(), 1, bytes.size(), f) == bytes.size();
  if (VSIFCloseL(f) != 0 || !ok) throw Error(ErrorKind::io, "cannot write memory file " + path);
}

void remove_memory_files(const std::string& directory) { VSIRmdirRecursive(directory.c_str()); }

}  // namespace rv
