// glint load: the closed-loop load generator (client/lib/load_runner.h) as a CLI command.
#pragma once

namespace glint::cli {

// `glint load ARGS...`: argv holds the options after "load". Returns the process exit code
// (0 every level answered without errors, 1 errors or nothing answered, 2 bad command line).
int RunLoad(int argc, char **argv);

}  // namespace glint::cli
