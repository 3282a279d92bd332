// glint preview: one material, or a batch of materials over one stream with a contact sheet
// (preview_command.cpp).
#ifndef GLINT_CLIENT_CLI_PREVIEW_COMMAND_H
#define GLINT_CLIENT_CLI_PREVIEW_COMMAND_H

#include <string>
#include <vector>

#include "client/cli/cli_common.h"

namespace glint::cli {

extern const char *const kPreviewUsage;
extern const std::vector<std::string> kPreviewOptions;  // options with a value
int RunPreview(const Options &options);

}  // namespace glint::cli

#endif  // GLINT_CLIENT_CLI_PREVIEW_COMMAND_H
