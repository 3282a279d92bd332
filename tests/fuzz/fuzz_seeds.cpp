// Writes the fuzzer's seed corpus: every example material x light list (examples/) as a
// serialised glint.v1.EvaluateRequest with a few queries, by each area method, plus probes, and
// the same as stream chunks 0 and 1.
//   fuzz_seeds EXAMPLES_DIR OUT_DIR
#include <google/protobuf/util/json_util.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "glint/v1/glint.pb.h"

namespace fs = std::filesystem;

namespace {

std::string Read(const fs::path &p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void Queries(glint::v1::QueryBatch *q, bool probe) {
  q->set_count(3);
  const float wo[] = {0, 0, 1, 0.6f, 0, 0.8f, 0, -0.6f, 0.8f};
  for (float v : wo) q->add_wo(v);
  for (int i = 0; i < 3; ++i) {
    for (float v : {0.25f * float(i), 0.5f}) q->add_uv(v);
    for (float v : {0.001f, 0.0f, 0.0f, 0.001f}) q->add_footprint(v);
    if (probe)
      for (float v : {0.0f, 0.6f, 0.8f}) q->add_wi(v);
  }
}

}  // namespace

int main(int argc, char **argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: fuzz_seeds EXAMPLES_DIR OUT_DIR\n");
    return 2;
  }
  const fs::path examples = argv[1], out = argv[2];
  fs::create_directories(out);
  int written = 0;
  auto write = [&](const google::protobuf::Message &m) {
    std::ofstream(out / ("seed_" + std::to_string(written++)), std::ios::binary)
        << m.SerializeAsString();
  };
  for (const auto &mat : fs::directory_iterator(examples / "materials")) {
    glint::v1::EvaluateRequest probe;
    if (!google::protobuf::util::JsonStringToMessage(Read(mat.path()), probe.mutable_material())
             .ok()) {
      std::fprintf(stderr, "fuzz_seeds: cannot parse %s\n", mat.path().c_str());
      return 1;
    }
    Queries(probe.mutable_queries(), true);
    write(probe);
    for (const auto &lights : fs::directory_iterator(examples / "lights")) {
      glint::v1::LightList list;
      if (!google::protobuf::util::JsonStringToMessage(Read(lights.path()), &list).ok()) {
        std::fprintf(stderr, "fuzz_seeds: cannot parse %s\n", lights.path().c_str());
        return 1;
      }
      glint::v1::EvaluateRequest r;
      *r.mutable_material() = probe.material();
      *r.mutable_lights() = list.lights();
      Queries(r.mutable_queries(), false);
      for (int method = 1; method <= 5; ++method) {
        r.set_area_method(glint::v1::AreaMethod(method));
        r.set_area_samples(method >= 4 ? 8 : 0);
        write(r);
      }
      glint::v1::EvaluateChunk first, later;
      *first.mutable_request() = r;
      write(first);
      later.set_chunk_index(1);
      *later.mutable_request()->mutable_queries() = r.queries();
      write(later);
    }
  }
  std::printf("fuzz_seeds: %d seeds in %s\n", written, out.c_str());
  return 0;
}
