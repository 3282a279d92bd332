// glint sample (client/cli/sample_command.cpp): importance sampling through the Sample RPC.
#pragma once

namespace glint::client {

// Runs `glint sample` with the arguments after the command name; returns the exit code
// (0 success, 1 failure at run time, 2 wrong command line).
int RunSampleCommand(int argc, char **argv);

}  // namespace glint::client
