// The `rvoronoi` command line. Thread safety: call from the main thread only.
#pragma once

#include <string>

namespace rv {

// The CLI's reading of one numeric option value (--resolution, each --extent coordinate,
// --margin, --max-distance): the whole text must be a number in strtod syntax, and finite.
// Pure, thread-safe. Throws rv::Error(invalid_argument) naming `option` and the text.
double parse_number_arg(const std::string& option, const std::string& text);

// Runs the command line; returns the process exit status (error_info(kind).exit_code on error).
int cli_main(int argc, char** argv);

}  // namespace rv
