// The CLI's normal-map commands and helpers (issue 11): `glint upload`, `glint normal-map`
// (generators, tools/normal_map) and the `--normal-map FILE` option of eval and preview.
#pragma once

#include <string>

#include "client/lib/glint_client.h"
#include "glint/v1/glint.pb.h"

namespace glint::cli {

// glint upload --server ADDR FILE: prints "sha256:<hex>". argv holds the command's arguments.
int RunUpload(int argc, char **argv);

// glint normal-maps list|delete --server ADDR ...: the server's maps, following
// ListNormalMaps' pages; or drops one.
int RunNormalMaps(int argc, char **argv);

// glint normal-map bumpy|flakes|brushed|scratches --size N --out FILE [--seed S].
int RunNormalMap(int argc, char **argv);

// Names FILE in material->normal_map.digest, uploading it to `server` first when the server does
// not hold it. Throws std::runtime_error with the reason (bad file, RPC failure).
void AttachNormalMap(const std::string &server, const client::ClientOptions &options,
                     const std::string &path, glint::v1::Material *material);

}  // namespace glint::cli
