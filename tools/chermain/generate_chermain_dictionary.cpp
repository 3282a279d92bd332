// Writes the Chermain et al. 2020 dictionary (tools/chermain/chermain_dictionary.h)
// as a C array of exact hexadecimal float literals:
//   glint_generate_chermain_dictionary --out data/chermain/chermain_dictionary.inc
// Options: --marginals N (default 512), --seed S (default 20200601), --threads T.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "models/chermain/chermain_params.h"
#include "tools/chermain/chermain_dictionary.h"

int main(int argc, char **argv) {
  glint::chermain::DictionaryConfig config;
  std::string out_path;
  int threads = 1;
  for (int a = 1; a + 1 < argc; a += 2) {
    if (!std::strcmp(argv[a], "--out")) {
      out_path = argv[a + 1];
    } else if (!std::strcmp(argv[a], "--marginals")) {
      config.marginals = std::atoi(argv[a + 1]);
    } else if (!std::strcmp(argv[a], "--seed")) {
      config.seed = std::strtoull(argv[a + 1], nullptr, 10);
    } else if (!std::strcmp(argv[a], "--threads")) {
      threads = std::atoi(argv[a + 1]);
    } else {
      std::fprintf(stderr, "unknown option %s\n", argv[a]);
      return 2;
    }
  }
  if (out_path.empty() || config.marginals < 1) {
    std::fprintf(stderr, "usage: %s --out FILE [--marginals N] [--seed S] [--threads T]\n",
                 argv[0]);
    return 2;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<float> dict = glint::chermain::GenerateDictionary(config, threads);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::FILE *f = std::fopen(out_path.c_str(), "w");
  if (!f) {
    std::perror(out_path.c_str());
    return 1;
  }
  std::fprintf(f,
               "/* Chermain et al. 2020 dictionary of multiscale 1D marginals (generated, do not\n"
               " * edit): tools/chermain/chermain_dictionary.h, data/chermain/README.md.\n"
               " *   glint_generate_chermain_dictionary --out data/chermain/chermain_dictionary.inc"
               " --marginals %d --seed %llu\n"
               " * %d marginals x %d levels x %d nodes; marginal m, level l, node k at\n"
               " * ((m * %d) + l) * %d + k. FNV-1a 64 digest of the floats: 0x%016llx. */\n",
               config.marginals, (unsigned long long)config.seed, config.marginals,
               GLINT_CHERMAIN_LEVELS, GLINT_CHERMAIN_BINS, GLINT_CHERMAIN_LEVELS,
               GLINT_CHERMAIN_BINS,
               (unsigned long long)glint::chermain::DictionaryDigest(dict.data(), dict.size()));
  std::fprintf(f, "#define GLINT_CHERMAIN_DICTIONARY_MARGINALS %d\n", config.marginals);
  std::fprintf(f, "GLINT_CHERMAIN_STORAGE float glint_chermain_dictionary[%zu] = {\n", dict.size());
  for (size_t i = 0; i < dict.size(); i += GLINT_CHERMAIN_BINS) {
    for (int k = 0; k < GLINT_CHERMAIN_BINS; ++k)
      std::fprintf(f, "%af,", double(dict[i + size_t(k)]));
    std::fprintf(f, "\n");
  }
  std::fprintf(f, "};\n");
  std::fclose(f);
  std::fprintf(stderr, "wrote %s: %d marginals in %.1f s, digest 0x%016llx\n", out_path.c_str(),
               config.marginals, seconds,
               (unsigned long long)glint::chermain::DictionaryDigest(dict.data(), dict.size()));
  return 0;
}
