#include "client/cli/normal_map_commands.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "client/lib/glint_client.h"
#include "client/lib/server_list.h"
#include "client/preview/image_io.h"
#include "server/normal_map_decode.h"
#include "tools/normal_map/normal_map_gen.h"

namespace glint::cli {
namespace {

constexpr const char *kUploadUsage = R"(usage: glint upload --server ADDR FILE [--tls-ca PEM]
                    [--tls-cert PEM --tls-key PEM] [--token-file FILE]

Uploads a normal map (OpenEXR float RGB or 8/16-bit RGB PNG tangent-space normals) to glintd
and prints its digest, sha256:<hex>, for material JSON {"normal_map": {"digest": ...}}. The
server stores a map once however often it is uploaded.
)";

constexpr const char *kNormalMapsUsage =
    R"(usage: glint normal-maps list --server ADDR [--page-size N]
       glint normal-maps delete --server ADDR DIGEST
                         [--tls-ca PEM] [--tls-cert PEM --tls-key PEM] [--token-file FILE]

list    prints every normal map the server holds, one per line in digest order:
        digest, width x height, bytes held, file name (tab-separated). Follows the server's
        pages (ListNormalMaps page_token) until the last; --page-size N asks for N maps per call
        (default 1000, the server's largest page).
delete  drops the map DIGEST from the server (requests naming it then get NOT_FOUND).
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
  // The file's name, not its path, as the Python client sends: the server keeps and lists it,
  // and refuses names over 255 bytes (NAME_MAX), which a path may exceed.
  const std::string name = std::filesystem::path(path).filename().string();
  if (grpc::Status st = client.UploadNormalMap(name, bytes, &info); !st.ok())
    throw std::runtime_error("UploadNormalMap " + path + ": " + client::FormatStatus(st));
  if (info.digest() != digest)
    throw std::runtime_error("UploadNormalMap " + path + ": the server computed " + info.digest() +
                             ", the client " + digest);
  *uploaded = true;
  return digest;
}

constexpr const char *kNormalMapUsage =
    R"(usage: glint normal-map bumpy|flakes|brushed|scratches --size N --out FILE.exr
                        [--seed S] [--roughness R]

Generates a periodic N x N tangent-space normal map of one of the material families of Yan et al.
2014 and writes it as a float RGB OpenEXR (R, G, B = x, y, z of the unit normal), ready for
glint upload or --normal-map. Deterministic: the same arguments give the same file.

  bumpy      isotropic Gaussian-spectrum heightfield, random phase (N a power of two)
  flakes     Poisson-disk Voronoi cells, each with one Beckmann-distributed normal
  brushed    anisotropic spectrum: long along u, short along v (N a power of two)
  scratches  grooves of random direction, length and depth, plus dents
  --size N       texels per side, 4 to 8192 (default 512)
  --seed S       random seed (default 1)
  --roughness R  RMS slope of bumpy / brushed / scratches, Beckmann alpha of flakes
                 (default 0.2)
)";

}  // namespace

int RunNormalMap(int argc, char **argv) {
  normal_map_gen::Options o;
  std::string out;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    try {
      if (a == "--help" || a == "-h") {
        std::fputs(kNormalMapUsage, stdout);
        return 0;
      } else if (a == "--size") {
        o.size = uint32_t(std::stoul(value()));
      } else if (a == "--seed") {
        o.seed = std::stoull(value());
      } else if (a == "--roughness") {
        o.roughness = std::stod(value());
      } else if (a == "--out") {
        out = value();
      } else if (a.rfind("--", 0) != 0 && o.kind.empty()) {
        o.kind = a;
      } else {
        throw std::invalid_argument("unexpected argument '" + a + "'");
      }
    } catch (const std::exception &e) {
      std::fprintf(stderr, "glint normal-map: %s\n\n%s", e.what(), kNormalMapUsage);
      return 2;
    }
  }
  if (o.kind.empty() || out.empty() || out.size() < 4 || out.substr(out.size() - 4) != ".exr" ||
      !(o.roughness > 0.0 && o.roughness <= 10.0)) {
    std::fprintf(stderr, "glint normal-map: %s\n\n%s",
                 o.kind.empty() ? "missing the kind (bumpy, flakes, brushed, scratches)"
                 : out.empty()  ? "missing --out FILE.exr"
                 : !(o.roughness > 0.0 && o.roughness <= 10.0) ? "--roughness: expected (0, 10]"
                                                               : "--out: expected a .exr file",
                 kNormalMapUsage);
    return 2;
  }
  DecodedNormalMap map;
  std::string error;
  if (!normal_map_gen::Generate(o, &map, &error)) {
    std::fprintf(stderr, "glint normal-map: %s\n", error.c_str());
    return 2;
  }
  // The digest a server gives this file: of the texels its decoder keeps (renormalised in
  // double, rounded to float), not of the generator's floats, which differ in the last bits for
  // some kinds (bumpy, brushed), so the printed digest would name no uploaded map.
  DecodedNormalMap held;
  try {
    client::WriteExrRgb(out, int(map.width), int(map.height), map.xyz, false);
    const Status decoded = DecodeNormalMap(out, ReadWholeFile(out), UINT64_MAX, &held);
    if (!decoded.ok()) throw std::runtime_error(decoded.message());
  } catch (const std::exception &e) {
    std::fprintf(stderr, "glint: %s\n", e.what());
    return 1;
  }
  std::printf("%s\n", out.c_str());
  std::fprintf(stderr, "glint normal-map: %s %ux%u seed %llu -> %s (%s)\n", o.kind.c_str(),
               map.width, map.height, static_cast<unsigned long long>(o.seed), out.c_str(),
               NormalMapDigest(held).c_str());
  return 0;
}

int RunUpload(int argc, char **argv) {
  std::string server, file;
  std::map<std::string, std::string> security;  // --tls-ca, --tls-cert, --tls-key, --token-file
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
    } else if ((a == "--tls-ca" || a == "--tls-cert" || a == "--tls-key" || a == "--token-file") &&
               i + 1 < argc) {
      security[a.substr(2)] = argv[++i];
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
    client::ClientOptions options;
    options.security = client::LoadChannelSecurity(security["tls-ca"], security["tls-cert"],
                                                   security["tls-key"], security["token-file"]);
    // A --server list: every replica must hold the map (a chunk may go to any of them).
    std::string digest;
    for (const std::string &one : client::SplitServerList(server)) {
      client::GlintClient client(one, options);
      bool uploaded = false;
      digest = EnsureUploaded(client, file, &uploaded);
      std::fprintf(stderr, "glint upload: %s %s\n", file.c_str(),
                   uploaded ? ("uploaded to " + one).c_str() : ("already held by " + one).c_str());
    }
    std::printf("%s\n", digest.c_str());
    return 0;
  } catch (const std::exception &e) {
    std::fprintf(stderr, "glint: %s\n", e.what());
    return 1;
  }
}

int RunNormalMaps(int argc, char **argv) {
  auto usage = [](const std::string &problem) {
    std::fprintf(stderr, "glint normal-maps: %s\n\n%s", problem.c_str(), kNormalMapsUsage);
    return 2;
  };
  if (argc >= 1 && (std::strcmp(argv[0], "--help") == 0 || std::strcmp(argv[0], "-h") == 0)) {
    std::fputs(kNormalMapsUsage, stdout);
    return 0;
  }
  if (argc < 1) return usage("missing list or delete");
  const std::string verb = argv[0];
  if (verb != "list" && verb != "delete") return usage("unknown action '" + verb + "'");
  std::string server, digest;
  int32_t page_size = client::kNormalMapPageSize;
  std::map<std::string, std::string> security;  // --tls-ca, --tls-cert, --tls-key, --token-file
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::fputs(kNormalMapsUsage, stdout);
      return 0;
    }
    if (a == "--server" && i + 1 < argc) {
      server = argv[++i];
    } else if (a == "--page-size" && i + 1 < argc && verb == "list") {
      const std::string v = argv[++i];
      char *end = nullptr;
      const long n = std::strtol(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || n < 1 || n > client::kNormalMapPageSize)
        return usage("--page-size " + v + ": expected 1 to " +
                     std::to_string(client::kNormalMapPageSize));
      page_size = int32_t(n);
    } else if ((a == "--tls-ca" || a == "--tls-cert" || a == "--tls-key" || a == "--token-file") &&
               i + 1 < argc) {
      security[a.substr(2)] = argv[++i];
    } else if (verb == "delete" && a.rfind("--", 0) != 0 && digest.empty()) {
      digest = a;
    } else {
      return usage("unexpected argument '" + a + "'");
    }
  }
  if (server.empty()) return usage("missing --server");
  if (verb == "delete" && digest.empty()) return usage("missing DIGEST");
  try {
    client::ClientOptions options;
    options.security = client::LoadChannelSecurity(security["tls-ca"], security["tls-cert"],
                                                   security["tls-key"], security["token-file"]);
    client::GlintClient client(server, options);
    if (verb == "delete") {
      if (grpc::Status st = client.DeleteNormalMap(digest); !st.ok())
        throw std::runtime_error("DeleteNormalMap: " + client::FormatStatus(st));
      std::fprintf(stderr, "glint normal-maps: deleted %s\n", digest.c_str());
      return 0;
    }
    // Page by page, printed as they come: the list may be long.
    glint::v1::ListNormalMapsRequest request;
    request.set_page_size(page_size);
    uint64_t listed = 0;
    do {
      glint::v1::ListNormalMapsResponse page;
      if (grpc::Status st = client.ListNormalMapsPage(request, &page); !st.ok())
        throw std::runtime_error("ListNormalMaps: " + client::FormatStatus(st));
      if (!page.next_page_token().empty() && page.next_page_token() == request.page_token())
        throw std::runtime_error("ListNormalMaps: the server returned the same page token twice");
      for (const auto &m : page.maps())
        std::printf("%s\t%ux%u\t%llu\t%s\n", m.digest().c_str(), m.width(), m.height(),
                    static_cast<unsigned long long>(m.bytes()), m.filename().c_str());
      listed += uint64_t(page.maps_size());
      request.set_page_token(page.next_page_token());
    } while (!request.page_token().empty());
    std::fprintf(stderr, "glint normal-maps: %llu maps\n", static_cast<unsigned long long>(listed));
    return 0;
  } catch (const std::exception &e) {
    std::fprintf(stderr, "glint: %s\n", e.what());
    return 1;
  }
}

void AttachNormalMap(const std::string &server, const client::ClientOptions &options,
                     const std::string &path, glint::v1::Material *material) {
  for (const std::string &one : client::SplitServerList(server)) {  // every replica of a list
    client::GlintClient client(one, options);
    bool uploaded = false;
    material->mutable_normal_map()->set_digest(EnsureUploaded(client, path, &uploaded));
  }
}

}  // namespace glint::cli
