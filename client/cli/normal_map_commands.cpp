#include "client/cli/normal_map_commands.h"

#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "client/lib/glint_client.h"
#include "server/normal_map_decode.h"

namespace glint::cli {
namespace {

constexpr const char *kUploadUsage = R"(usage: glint upload --server ADDR FILE

Uploads a normal map (OpenEXR float RGB or 8/16-bit RGB PNG tangent-space normals) to glintd
and prints its digest, sha256:<hex>, for material JSON {"normal_map": {"digest": ...}}. The
server stores a map once however often it is uploaded.
)";

std::string ReadWholeFile(const std::string &path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Checks the file with the server's decoder (so a bad file is reported before any upload) and
// returns its digest; uploads it when the server does not list that digest.
std::string EnsureUploaded(client::GlintClient &client, const std::string &path, bool *uploaded) {
  const std::string bytes = ReadWholeFile(path);
  glint::v1::Capabilities caps;
  if (grpc::Status st = client.GetCapabilities(&caps); !st.ok())
    throw std::runtime_error("GetCapabilities: " + client::FormatStatus(st));
  DecodedNormalMap map;
  const uint64_t max_texels = caps.max_normal_map_texels() ? caps.max_normal_map_texels() : ~0ull;
  Status s = DecodeNormalMap(path, bytes, max_texels, &map);
  if (!s.ok()) throw std::runtime_error(s.message());
  const std::string digest = NormalMapDigest(map);
  glint::v1::ListNormalMapsResponse list;
  if (grpc::Status st = client.ListNormalMaps(&list); !st.ok())
    throw std::runtime_error("ListNormalMaps: " + client::FormatStatus(st));
  *uploaded = false;
  for (const auto &m : list.maps())
    if (m.digest() == digest) return digest;
  glint::v1::NormalMapInfo info;
  if (grpc::Status st = client.UploadNormalMap(path, bytes, &info); !st.ok())
    throw std::runtime_error("UploadNormalMap " + path + ": " + client::FormatStatus(st));
  if (info.digest() != digest)
    throw std::runtime_error("UploadNormalMap " + path + ": the server computed " + info.digest() +
                             ", the client " + digest);
  *uploaded = true;
  return digest;
}

}  // namespace

int RunUpload(int argc, char **argv) {
  std::string server, file;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kUploadUsage, stdout);
      return 0;
    }
    if (a == "--server" && i + 1 < argc) {
      server = argv[++i];
    } else if (a.rfind("--server=", 0) == 0) {
      server = a.substr(9);
    } else if (a.rfind("--", 0) != 0 && file.empty()) {
      file = a;
    } else {
      std::fprintf(stderr, "glint upload: unexpected argument '%s'\n\n%s", a.c_str(), kUploadUsage);
      return 2;
    }
  }
  if (server.empty() || file.empty()) {
    std::fprintf(stderr, "glint upload: %s\n\n%s",
                 server.empty() ? "missing --server" : "missing FILE", kUploadUsage);
    return 2;
  }
  try {
    client::GlintClient client(server);
    bool uploaded = false;
    const std::string digest = EnsureUploaded(client, file, &uploaded);
    std::printf("%s\n", digest.c_str());
    std::fprintf(stderr, "glint upload: %s %s\n", file.c_str(),
                 uploaded ? "uploaded" : "already held by the server");
    return 0;
  } catch (const std::exception &e) {
    std::fprintf(stderr, "glint: %s\n", e.what());
    return 1;
  }
}

void AttachNormalMap(const std::string &server, const std::string &path,
                     glint::v1::Material *material) {
  client::GlintClient client(server);
  bool uploaded = false;
  material->mutable_normal_map()->set_digest(EnsureUploaded(client, path, &uploaded));
}

}  // namespace glint::cli
