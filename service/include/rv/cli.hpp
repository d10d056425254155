// The `rvoronoi` command line. Its job options, their parsing and their --help come from the option
// table (rv/options.hpp). Thread safety: call from the main thread only.
#pragma once

#include <string>

namespace rv {

// Runs the command line; returns the process exit status (error_info(kind).exit_code on error).
int cli_main(int argc, char** argv);

}  // namespace rv
