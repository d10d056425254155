// Whole small files (the JSON report, the preview PNG) written atomically: into a temporary name
// beside the target (`<path>.tmp-<pid>-<n>`, unique across processes and calls), then renamed,
// so a reader never sees half a file and a failure leaves nothing behind.
// Throws rv::Error(io) when the file cannot be created, written (disk full) or renamed.
// Thread-safe.
#pragma once

#include <string>
#include <string_view>

namespace rv {

void write_file_atomically(const std::string& path, std::string_view bytes);

}  // namespace rv
