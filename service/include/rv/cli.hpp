// The `rvoronoi` command line. Thread safety: call from the main thread only.
#pragma once

namespace rv {

// Runs the command line; returns the process exit status (error_info(kind).exit_code on error).
int cli_main(int argc, char** argv);

}  // namespace rv
