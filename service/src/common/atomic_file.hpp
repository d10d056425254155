// Whole small files (the JSON report, the preview PNG) written atomically, and files the project
// did not just create opened only when they are regular files.
// Thread-safe.
#pragma once

#include <string>
#include <string_view>

namespace rv {

// Writes into a temporary name beside the target (`<path>.tmp-<pid>-<n>`, unique across processes
// and calls), then renames, so a reader never sees half a file and a failure leaves nothing
// behind. Throws rv::Error(io) when the file cannot be created, written (disk full) or renamed.
void write_file_atomically(const std::string& path, std::string_view bytes);

// Opens an existing file for reading if it is a regular file: opened with O_NONBLOCK, so that a
// FIFO or a device cannot block the open, then fstat()ed, and put back in blocking mode. Returns
// the descriptor (O_CLOEXEC; the caller closes it), or -1 with errno set: open()'s, or EINVAL
// for anything but a regular file (a FIFO, a device, a directory).
int open_regular_file(const std::string& path);

// The whole bytes of a regular file (open_regular_file). Throws rv::Error: not_found (missing),
// invalid_input (not a regular file), io (reading failed); `name` names the file in messages.
std::string read_regular_file(const std::string& path, const std::string& name);

}  // namespace rv
