// glint_fit_area_auto: measures the polygon-light methods on a seeded random training set and
// writes the AUTO area method's error table (models/smooth/area_auto_table.h). See README.md.
//
//   build/tools/area_auto/glint_fit_area_auto --out models/smooth/area_auto_table.h
//
// Flags: --configs N (lights per NDF, default 1000; 8 views each), --threads T (default 2),
// --out PATH (default: stdout), --cache DIR (keep the measured errors there and reuse them on
// the next run with the same --configs: refitting after a change of the cells or quantiles then
// takes seconds; delete it after changing a method). Deterministic: the same build writes the
// same file.
//
// After a change of some candidates only (e.g. REFERENCE): --remeasure 3,4,5,6 (candidate
// indices, LTC = 0 .. REFERENCE 32 = 6) --remeasure-from OLD_DIR (the previous --cache) re-runs
// those candidates and recovers each query's truth from the other candidates' cached errors
// instead of integrating it again (area_auto_fit.h Remeasure; minutes instead of ~40), writing
// the new measurements to --cache (required). --verify-every N (default 50) integrates the truth
// of every N-th light too and prints the recovered truth's largest deviation from it; one above
// area_auto_fit.h kMaxRecoveryDeviation (1e-6) fails the fit (exit 1, no table or cache written,
// --verify-every 0 checks nothing). A bad argument: a message naming it, exit 2.
#include <charconv>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include "kernels/area/area_auto_features.h"
#include "tools/area_auto/area_auto_fit.h"

namespace {

using namespace glint::area_auto;

// Device fp32 cost per evaluation of one light in microseconds, from bench_area's sweep on this
// 2-core PoCL machine (docs/area_speed_accuracy.csv, evals/s of each method, GGX then Beckmann):
// LTC, LECOCQ, LECOCQ_PEARSON as measured; REFERENCE n as a + b (4 ceil(n / 4))^2 through the
// measured REFERENCE 8 and 32 (the nodes per triangle); MONTE_CARLO as a + b n through the
// measured 4 ... 256 samples (least squares); an intercept below LTC's cost set to it. Printed by
// `python3 tools/area_auto/costs_from_bench_area.py docs/area_speed_accuracy.csv`. Measured
// 2026-11-30 on a loaded machine (load average 7-12: absolute costs ~5-10x the quiet ones, and
// noisier); only their order matters to the choice.
const float kCost[2][kCandidates + 2] = {
    {0.257f, 191.0f, 231.0f, 20.8f, 42.2f, 128.0f, 471.0f, 4.66f, 1.03f},
    {0.249f, 149.0f, 169.0f, 62.5f, 249.0f, 996.0f, 3.98e+03f, 0.249f, 1.49f},
};

std::string Num(float x) {
  char b[32];
  std::snprintf(b, sizeof b, "%.6gf", double(x));
  std::string s = b;
  if (s.find_first_of(".e") == std::string::npos) s.insert(s.size() - 1, ".0");
  return s;
}

// The cache: one line per query, the candidates' errors and the cv (cells are recomputed).
void SaveSamples(const std::string &path, const std::vector<Sample> &samples) {
  std::ofstream f(path);
  char b[32];
  for (const Sample &s : samples) {
    for (int k = 0; k < kCandidates; ++k) {
      std::snprintf(b, sizeof b, "%.9g ", double(s.error[k]));
      f << b;
    }
    std::snprintf(b, sizeof b, "%.9g\n", double(s.cv));
    f << b;
  }
}

bool LoadSamples(const std::string &path, const std::vector<Config> &set,
                 std::vector<Sample> *samples) {
  std::ifstream f(path);
  if (!f) return false;
  std::vector<Sample> out;
  for (const Config &c : set) {
    const std::vector<int> cells = Cells(c);
    for (int cell : cells) {
      Sample s;
      s.cell = cell;
      for (int k = 0; k < kCandidates; ++k) f >> s.error[k];
      f >> s.cv;
      out.push_back(s);
    }
  }
  if (!f) return false;
  *samples = std::move(out);
  return true;
}

// An integer flag value: the whole argument in [lo, hi], else a message naming the flag and
// false (std::stoi threw an uncaught exception on "abc" and took "12x" as 12).
bool ParseInt(const char *flag, const std::string &arg, int lo, int hi, int *out) {
  int v = 0;
  const auto [end, ec] = std::from_chars(arg.data(), arg.data() + arg.size(), v);
  if (ec != std::errc() || end != arg.data() + arg.size() || v < lo || v > hi) {
    std::fprintf(stderr, "%s: '%s' is not an integer in [%d, %d]\n", flag, arg.c_str(), lo, hi);
    return false;
  }
  *out = v;
  return true;
}

}  // namespace

int main(int argc, char **argv) {
  int configs = 1000, threads = 2;
  std::string out_path, cache, remeasure_from;
  std::vector<int> remeasure;
  int verify_every = 50;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--configs" && i + 1 < argc) {
      if (!ParseInt("--configs", argv[++i], 1, 1000000, &configs)) return 2;
    } else if (a == "--threads" && i + 1 < argc) {
      if (!ParseInt("--threads", argv[++i], 1, 1024, &threads)) return 2;
    } else if (a == "--out" && i + 1 < argc)
      out_path = argv[++i];
    else if (a == "--cache" && i + 1 < argc)
      cache = argv[++i];
    else if (a == "--remeasure-from" && i + 1 < argc)
      remeasure_from = argv[++i];
    else if (a == "--verify-every" && i + 1 < argc) {
      if (!ParseInt("--verify-every", argv[++i], 0, 1000000, &verify_every)) return 2;
    } else if (a == "--remeasure" && i + 1 < argc) {
      std::stringstream ss(argv[++i]);
      for (std::string k; std::getline(ss, k, ',');) {
        int c = 0;
        if (!ParseInt("--remeasure", k, 0, kCandidates - 1, &c)) return 2;
        remeasure.push_back(c);
      }
      if (remeasure.empty()) {
        std::fprintf(stderr, "--remeasure: no candidate given\n");
        return 2;
      }
    } else {
      std::fprintf(
          stderr,
          "usage: glint_fit_area_auto [--configs N] [--threads T] [--out PATH] [--cache DIR]\n"
          "       [--remeasure K,K,... --remeasure-from OLD_CACHE_DIR [--verify-every N]]\n");
      return 2;
    }
  }
  if (remeasure.empty() != remeasure_from.empty() || (!remeasure.empty() && cache.empty())) {
    std::fprintf(stderr, "--remeasure and --remeasure-from go together, with --cache\n");
    return 2;
  }
  std::ostringstream o;
  o << "/* Generated by tools/area_auto (glint_fit_area_auto --configs " << configs
    << "): do not edit.\n"
       " * Regenerate: build/tools/area_auto/glint_fit_area_auto --out "
       "models/smooth/area_auto_table.h\n"
       " * The AUTO area method's error table (kernels/area/area_auto.h). Training set: "
    << configs
    << " random lights x 8 views\n"
       " * per NDF (tools/area_auto/area_auto_data.h MakeConfigs, seed "
    << kTrainSeed << "; theta_o 0-" << kGrazingFromDeg
    << " deg, every fourth view from there to cos theta_o " << kGrazingMinCos
    << ");\n * truth by adaptive integration in double.\n"
       " * Per NDF (GGX, then Beckmann) and cell (kernels/area/area_auto_features.h), "
       "GLINT_AUTO_CELL_FLOATS floats:\n"
       " * the "
    << kErrorQuantile
    << " quantile of the relative error of LTC, LECOCQ, LECOCQ_PEARSON, REFERENCE 4, 8, 16, 32\n"
       " * (host path fp32 = the device's arithmetic), then the "
    << kCvQuantile
    << " quantile of MONTE_CARLO's per-sample\n"
       " * coefficient of variation. A cell with fewer than "
    << kMinPerCell
    << " training queries pools its neighbours (level\n"
       " * in its comment: 1 any elevation, 2 and any alignment, 3 and any solid angle, 4 and "
       "any view, 5 the NDF).\n"
       " * glint_area_auto_cost: device fp32 microseconds per light of the candidates, then "
       "MONTE_CARLO's a and b\n"
       " * (a + b n), per NDF (tools/area_auto/fit_area_auto.cpp kCost). */\n"
       "#ifndef GLINT_AREA_AUTO_TABLE_H\n#define GLINT_AREA_AUTO_TABLE_H\n\n"
       "#include \"kernels/area/area_auto_features.h\"\n#include \"kernels/compat.h\"\n\n"
       "#define GLINT_AUTO_CANDIDATES "
    << kCandidates << "\n#define GLINT_AUTO_CELL_FLOATS " << kCandidates + 1
    << "\n#define GLINT_AUTO_COSTS " << kCandidates + 2
    << "\n\n/* The cells the table was fitted for (kernels/area/area_auto.h refuses to compile "
       "against others). */\n"
       "#define GLINT_AUTO_TABLE_ALPHA_BINS "
    << GLINT_AUTO_ALPHA_BINS << "\n#define GLINT_AUTO_TABLE_VIEW_BINS " << GLINT_AUTO_VIEW_BINS
    << "\n#define GLINT_AUTO_TABLE_OMEGA_BINS " << GLINT_AUTO_OMEGA_BINS
    << "\n#define GLINT_AUTO_TABLE_ELEVATION_BINS " << GLINT_AUTO_ELEVATION_BINS
    << "\n#define GLINT_AUTO_TABLE_ALIGN_BINS " << GLINT_AUTO_ALIGN_BINS
    << "\n\n/* Program-scope __constant on the device; one private copy per host translation unit. "
       "*/\n"
       "#ifdef __OPENCL_VERSION__\n#define GLINT_AUTO_TABLE __constant\n#else\n"
       "#define GLINT_AUTO_TABLE static const\n#endif\n\n"
       "GLINT_AUTO_TABLE float glint_area_auto_cost[2 * GLINT_AUTO_COSTS] = {\n";
  for (int t = 0; t < 2; ++t) {
    o << "   ";
    for (int k = 0; k < kCandidates + 2; ++k) o << ' ' << Num(kCost[t][k]) << ',';
    o << "\n";
  }
  o << "};\n\nGLINT_AUTO_TABLE float glint_area_auto_error[2 * GLINT_AUTO_CELLS * "
       "GLINT_AUTO_CELL_FLOATS] = {\n";
  std::ostringstream fingerprint;  // the first training queries' measurements, per NDF
  for (int ndf = 1; ndf <= 2; ++ndf) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::vector<Config> set = MakeConfigs(kTrainSeed, configs, 8, ndf);
    const std::string cache_file = cache.empty() ? ""
                                                 : cache + "/ndf" + std::to_string(ndf) + "_" +
                                                       std::to_string(configs) + ".txt";
    std::vector<Sample> samples;
    if (!remeasure.empty()) {
      const std::string from =
          remeasure_from + "/ndf" + std::to_string(ndf) + "_" + std::to_string(configs) + ".txt";
      std::vector<Sample> old;
      if (!LoadSamples(from, set, &old)) {
        std::fprintf(stderr, "cannot read the measurements %s\n", from.c_str());
        return 1;
      }
      RemeasureStats st;
      samples = Remeasure(set, old, remeasure, threads, verify_every, &st);
      std::fprintf(stderr,
                   "%s: truth recovered from %s for %zu queries, integrated for %zu; verified "
                   "%zu recovered against the integration: max deviation %.3g\n",
                   ndf == 2 ? "beckmann" : "ggx", from.c_str(), st.recovered, st.integrated,
                   st.verified, st.max_deviation);
      // A recovered truth off by more than Remeasure's premises allow fails the fit rather than
      // writing a table (or a cache) measured against it (area_auto_fit.h kMaxRecoveryDeviation).
      const std::string problem = RemeasureProblem(st);
      if (!problem.empty()) {
        std::fprintf(stderr, "%s: %s; no table or cache written\n", ndf == 2 ? "beckmann" : "ggx",
                     problem.c_str());
        return 1;
      }
      SaveSamples(cache_file, samples);
    } else if (!cache_file.empty() && LoadSamples(cache_file, set, &samples)) {
      std::fprintf(stderr, "%s: measurements from %s\n", ndf == 2 ? "beckmann" : "ggx",
                   cache_file.c_str());
    } else {
      samples = Measure(set, threads);
      if (!cache_file.empty()) SaveSamples(cache_file, samples);
    }
    const NdfTable table = Fit(samples);
    fingerprint << "    /* " << (ndf == 2 ? "Beckmann" : "GGX") << " */\n";
    for (int q = 0; q < kFingerprintQueries; ++q) {
      const Sample &s = samples[size_t(q)];
      fingerprint << "   ";
      for (int k = 0; k < kCandidates; ++k) fingerprint << ' ' << Num(s.error[k]) << ',';
      fingerprint << ' ' << Num(s.cv) << ", /* cell " << s.cell << " */\n";
    }
    std::fprintf(stderr, "%s: %zu queries measured in %.1f s\n", ndf == 2 ? "beckmann" : "ggx",
                 samples.size(),
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    o << "    /* " << (ndf == 2 ? "Beckmann" : "GGX") << " */\n";
    for (int cell = 0; cell < GLINT_AUTO_CELLS; ++cell) {
      o << "   ";
      for (int k = 0; k <= kCandidates; ++k)
        o << ' ' << Num(table.values[size_t(cell) * (kCandidates + 1) + size_t(k)]) << ',';
      o << " /* " << cell << ": n " << table.count[size_t(cell)] << ", level "
        << table.level[size_t(cell)] << " */\n";
    }
  }
  o << "};\n\n"
       "/* The measurements behind the table of the first "
    << kFingerprintQueries
    << " training queries per NDF (GGX, then Beckmann;\n"
       " * LTC .. REFERENCE 32 errors, then MONTE_CARLO's cv): tests/area/area_auto_test.cpp "
       "measures them again,\n"
       " * so a change of a method, of the truth or of the training set since the fit fails "
       "there. Host only. */\n"
       "#ifndef __OPENCL_VERSION__\n"
       "#define GLINT_AUTO_FINGERPRINT_QUERIES "
    << kFingerprintQueries
    << "\nstatic const float glint_area_auto_fingerprint[2 * GLINT_AUTO_FINGERPRINT_QUERIES * "
       "GLINT_AUTO_CELL_FLOATS] = {\n"
    << fingerprint.str() << "};\n#endif\n\n#endif /* GLINT_AREA_AUTO_TABLE_H */\n";
  if (out_path.empty()) {
    std::cout << o.str();
  } else {
    std::ofstream f(out_path);
    f << o.str();
    if (!f) {
      std::fprintf(stderr, "cannot write %s\n", out_path.c_str());
      return 1;
    }
  }
  return 0;
}
