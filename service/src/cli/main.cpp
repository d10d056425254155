#include "rv/cli.hpp"

int main(int argc, char** argv) { return rv::cli_main(argc, argv); }
