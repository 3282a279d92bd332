// glint render: shade a renderer's G-buffer EXR with a glint material (render_command.cpp).
#ifndef GLINT_CLIENT_CLI_RENDER_COMMAND_H
#define GLINT_CLIENT_CLI_RENDER_COMMAND_H

#include <string>
#include <vector>

#include "client/cli/cli_common.h"

namespace glint::cli {

extern const char *const kRenderUsage;
extern const std::vector<std::string> kRenderOptions;  // options with a value
int RunRender(const Options &options);

}  // namespace glint::cli

#endif  // GLINT_CLIENT_CLI_RENDER_COMMAND_H
