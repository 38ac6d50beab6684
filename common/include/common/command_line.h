// Command-line parsing shared by every executable: a wrong flag or value
// prints what is wrong and how to get the usage, and exits 2 (CLI11's own
// exit codes are 100 and up); --help prints the usage and exits 0.
#pragma once

#include <CLI/CLI.hpp>

#define HOLOFUSE_PARSE_FLAGS(app, argc, argv) \
  try {                                       \
    (app).parse((argc), (argv));              \
  } catch (const CLI::ParseError& e) {        \
    return (app).exit(e) == 0 ? 0 : 2;        \
  }
