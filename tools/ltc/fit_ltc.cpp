// glint_fit_ltc: fits glint's LTC tables and writes data/ltc/ltc_{ggx,beckmann}.inc.
//
//   glint_fit_ltc --out-dir data/ltc [--threads 2] [--ndf ggx|beckmann|all]
//   glint_fit_ltc --only A,T [--ndf ...]     prints one entry (refits row A up to T), no files
//
// Rows (fixed roughness index a) are independent fits (see ltc_fit.h), so they are handed out to
// std::threads one row at a time; the output does not depend on the thread count.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include "tools/ltc/ltc_fit.h"

namespace {

using glint::ltc::FitEntry;
using glint::ltc::kGridSize;
using glint::ltc::Ndf;

// The command that regenerates the checked-in tables, recorded in their header comment. The
// results do not depend on --threads or on the build directory.
constexpr const char *kCommand =
    "cmake --build build-ltc --target glint_fit_ltc && "
    "build-ltc/tools/ltc/glint_fit_ltc --out-dir data/ltc --threads 2";

struct Options {
  std::string out_dir;
  int threads = 2;
  std::vector<Ndf> ndfs{Ndf::kGgx, Ndf::kBeckmann};
  int only_a = -1, only_t = -1;
};

[[noreturn]] void usage(const char *msg) {
  std::fprintf(stderr,
               "error: %s\nusage: glint_fit_ltc --out-dir DIR [--threads N] "
               "[--ndf ggx|beckmann|all]\n       glint_fit_ltc --only A,T [--ndf ...]\n",
               msg);
  std::exit(2);
}

Options parse(int argc, char **argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) usage(("missing value after " + arg).c_str());
      return argv[++i];
    };
    if (arg == "--out-dir") {
      o.out_dir = value();
    } else if (arg == "--threads") {
      o.threads = std::max(1, std::atoi(value().c_str()));
    } else if (arg == "--ndf") {
      std::string v = value();
      if (v == "ggx") {
        o.ndfs = {Ndf::kGgx};
      } else if (v == "beckmann") {
        o.ndfs = {Ndf::kBeckmann};
      } else if (v != "all") {
        usage("--ndf must be ggx, beckmann or all");
      }
    } else if (arg == "--only") {
      if (std::sscanf(value().c_str(), "%d,%d", &o.only_a, &o.only_t) != 2 || o.only_a < 0 ||
          o.only_a >= kGridSize || o.only_t < 0 || o.only_t >= kGridSize)
        usage("--only takes A,T with 0 <= A, T < 64");
    } else {
      usage(("unknown argument " + arg).c_str());
    }
  }
  if (o.only_a < 0 && o.out_dir.empty()) usage("--out-dir or --only is required");
  return o;
}

void print_entry(Ndf ndf, const FitEntry &e) {
  std::printf(
      "%s a=%d t=%d alpha=%.17g cos_theta=%.17g\n  m11=%.17g m22=%.17g m13=%.17g\n"
      "  inv=[%.17g, %.17g, %.17g, %.17g]\n  magnitude=%.17g fresnel=%.17g d_pr=%.17g "
      "d_h=%.17g\n  avg=(%.17g, 0, %.17g) objective=%.6g evaluations=%d\n",
      glint::ltc::ndf_name(ndf), e.a, e.t, e.alpha, e.cos_theta, e.params.m11, e.params.m22,
      e.params.m13, e.inv[0], e.inv[1], e.inv[2], e.inv[3], e.moments.magnitude, e.moments.fresnel,
      e.moments.d_pr, e.moments.d_h, e.moments.avg_x, e.moments.avg_z, e.objective, e.evaluations);
}

// Float literal with 7 significant digits (float carries ~7.2), always with a '.' or exponent
// so that the 'f' suffix is valid C / OpenCL C.
std::string flit(double v) {
  char buf[48];
  std::snprintf(buf, sizeof buf, "%.7g", static_cast<double>(static_cast<float>(v)));
  std::string s = buf;
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s + "f";
}

// Samples per dimension and strategy for the fit-quality statistics of the header comment.
constexpr int kStatSamples = 128;

// Error statistics of one region of the grid.
struct RegionStats {
  const char *name;
  int a_lo, a_hi, t_lo, t_hi;  // inclusive
  double l1_sum = 0, l1_max = 0, leak_max = 0;
  int l1_max_a = 0, l1_max_t = 0, n = 0;
};

std::vector<RegionStats> regions() {
  // Roughness r = a/63 in thirds; grazing = cos(theta_o) < 0.5 (t >= 45, theta_o > 60 deg).
  return {{"low r<0.33, view<60deg", 0, 20, 0, 44},    {"low r<0.33, grazing", 0, 20, 45, 63},
          {"mid r<0.66, view<60deg", 21, 41, 0, 44},   {"mid r<0.66, grazing", 21, 41, 45, 63},
          {"high r>=0.66, view<60deg", 42, 63, 0, 44}, {"high r>=0.66, grazing", 42, 63, 45, 63}};
}

bool write_table(const Options &o, Ndf ndf, const std::vector<FitEntry> &table, double seconds) {
  std::vector<RegionStats> stats = regions();
  std::vector<double> l1(table.size()), leak(table.size());
  double mag_min = 1e30, mag_max = 0;
  for (size_t i = 0; i < table.size(); ++i) {
    const FitEntry &e = table[i];
    auto err =
        glint::ltc::lobe_error(ndf, e.alpha, e.cos_theta, e.inv, e.moments.magnitude, kStatSamples);
    l1[i] = err.l1;
    leak[i] = err.leak;
    mag_min = std::min(mag_min, e.moments.magnitude);
    mag_max = std::max(mag_max, e.moments.magnitude);
    for (RegionStats &r : stats) {
      if (e.a < r.a_lo || e.a > r.a_hi || e.t < r.t_lo || e.t > r.t_hi) continue;
      r.n++;
      r.l1_sum += err.l1;
      if (err.l1 > r.l1_max) r.l1_max = err.l1, r.l1_max_a = e.a, r.l1_max_t = e.t;
      r.leak_max = std::max(r.leak_max, err.leak);
    }
  }
  const char *name = glint::ltc::ndf_name(ndf);
  std::string path = o.out_dir + "/ltc_" + name + ".inc";
  FILE *f = std::fopen(path.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "cannot write %s\n", path.c_str());
    return false;
  }
  std::string upper = name;
  for (char &c : upper) c = static_cast<char>(c - 'a' + 'A');
  std::fprintf(f,
               "/* LTC table for glint's smooth BRDF, %s NDF (generated, do not edit).\n"
               " *\n"
               " * Regenerate (from the repository root; fitting took %.0f s with %d threads):\n"
               " *   %s\n"
               " * Fitting code and conventions: tools/ltc/ (README.md, ltc_fit.h).\n"
               " *\n"
               " * BRDF: f cos_i = kernels/smooth_brdf.h smooth_reflect_cos with Schlick f0 = 1\n"
               " * (F = 1), isotropic alpha, height-correlated Smith G2.\n"
               " *\n"
               " * Grid: 64 x 64, entry (a, t) at index (t * 64 + a) * 8:\n"
               " *   a -> roughness r = a / 63, alpha = max(r^2, 1e-4)\n"
               " *   t -> cos(theta_o) = max(1 - (t / 63)^2, 1e-3)  (t / 63 = sqrt(1 - cos))\n"
               " * Bilinear lookup: x = sqrt(alpha) * 63, y = sqrt(1 - cos(theta_o)) * 63.\n"
               " * View wo = (sin theta_o, 0, cos theta_o), +x towards the viewer.\n"
               " *\n"
               " * Entry (8 floats):\n"
               " *   [0..3] M^-1 / M^-1[1][1], entries (row, col) (0,0), (0,2), (2,0), (2,2);\n"
               " *          M^-1 = [[e0, 0, e1], [0, 1, 0], [e2, 0, e3]], LTC density\n"
               " *          D(w) = max(0, o.z) |det M^-1| / (pi |o|^4), o = M^-1 w (HDHN16 Eq. 3)\n"
               " *   [4] magnitude = int f cos_i dw_i with F = 1 (also the FGD of Kneiphof &\n"
               " *       Klein 2024 Eq. 18 with F = 1)\n"
               " *   [5] fresnel = int f cos_i (1 - wo.h)^5 dw_i; with Schlick F(f0),\n"
               " *       int f cos_i F dw_i = f0 * [4] + (1 - f0) * [5]\n"
               " *   [6] D_PR = int_{wi.z > 0} D(h) / (4 h.wi) dw_i (Kneiphof & Klein Eq. 19)\n"
               " *   [7] D_H = int D(h) dw_h over the hemisphere (their Eq. 29 / 30; depends on a\n"
               " *       only, repeated per t so one fetch gives p = [6] * LTC / [7])\n"
               " * Shading a polygon P: [4..5] Fresnel term * int_P D(w) dw.\n"
               " *\n"
               " * Fit quality (relative L1 = int |f cos / magnitude - D| over the sphere,\n"
               " * 0 = identical, 2 = disjoint; leak = LTC mass below the horizon), estimated\n"
               " * with 2 x 128^2 MIS samples per entry (low by up to ~0.04 for the thin lobes\n"
               " * at t = 63; tests/ltc prints converged values), magnitude range\n"
               " * [%.5f, %.5f]:\n"
               " *   region                      mean L1   max L1 (a, t)     max leak\n",
               upper.c_str(), seconds, o.threads, kCommand, mag_min, mag_max);
  for (const RegionStats &r : stats)
    std::fprintf(f, " *   %-26s  %7.4f   %7.4f (%2d, %2d)  %7.4f\n", r.name, r.l1_sum / r.n,
                 r.l1_max, r.l1_max_a, r.l1_max_t, r.leak_max);
  std::fprintf(f,
               " */\n"
               "#ifndef GLINT_LTC_STORAGE\n"
               "#ifdef __OPENCL_VERSION__\n"
               "#define GLINT_LTC_STORAGE __constant\n"
               "#else\n"
               "#define GLINT_LTC_STORAGE static const\n"
               "#endif\n"
               "#endif\n"
               "#ifndef GLINT_LTC_SIZE\n"
               "#define GLINT_LTC_SIZE 64\n"
               "#define GLINT_LTC_ENTRY_FLOATS 8\n"
               "#endif\n"
               "GLINT_LTC_STORAGE float glint_ltc_%s[GLINT_LTC_SIZE * GLINT_LTC_SIZE * "
               "GLINT_LTC_ENTRY_FLOATS] = {\n",
               name);
  for (int t = 0; t < kGridSize; ++t) {
    std::fprintf(f, "/* t = %d, cos(theta_o) = %.7g */\n", t, glint::ltc::grid_cos_theta(t));
    for (int a = 0; a < kGridSize; ++a) {
      const FitEntry &e = table[t * kGridSize + a];
      double v[8] = {e.inv[0],          e.inv[1],       e.inv[2],     e.inv[3], e.moments.magnitude,
                     e.moments.fresnel, e.moments.d_pr, e.moments.d_h};
      std::string line;
      for (double x : v) {
        if (!std::isfinite(x)) {
          std::fprintf(stderr, "%s: non-finite value at a=%d t=%d\n", name, a, t);
          std::fclose(f);
          return false;
        }
        line += flit(x) + ",";
      }
      std::fprintf(f, "%s\n", line.c_str());
    }
  }
  std::fprintf(f, "};\n");
  std::fclose(f);
  std::printf("wrote %s\n", path.c_str());
  for (const RegionStats &r : stats)
    std::printf("  %-26s mean L1 %.4f max L1 %.4f at (%d, %d) max leak %.4f\n", r.name,
                r.l1_sum / r.n, r.l1_max, r.l1_max_a, r.l1_max_t, r.leak_max);
  return true;
}

}  // namespace

int main(int argc, char **argv) {
  Options o = parse(argc, argv);
  if (o.only_a >= 0) {
    for (Ndf ndf : o.ndfs) print_entry(ndf, glint::ltc::refit_entry(ndf, o.only_a, o.only_t));
    return 0;
  }
  auto start = std::chrono::steady_clock::now();
  // One job per (ndf, row a); results land in fixed slots, so scheduling cannot change them.
  const int rows = static_cast<int>(o.ndfs.size()) * kGridSize;
  std::vector<std::vector<FitEntry>> results(rows);
  std::atomic<int> next{0}, done{0};
  auto worker = [&] {
    for (int job; (job = next.fetch_add(1)) < rows;) {
      results[job] = glint::ltc::fit_row(o.ndfs[job / kGridSize], job % kGridSize);
      int d = ++done;
      std::fprintf(stderr, "\rrows %d/%d", d, rows);
    }
  };
  std::vector<std::thread> pool;
  for (int i = 0; i < o.threads; ++i) pool.emplace_back(worker);
  for (std::thread &th : pool) th.join();
  std::fprintf(stderr, "\n");
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("fit %d rows in %.1f s with %d threads\n", rows, seconds, o.threads);
  for (size_t n = 0; n < o.ndfs.size(); ++n) {
    // Reorder rows (fixed a, all t) into the file's [t][a] layout.
    std::vector<FitEntry> table(kGridSize * kGridSize);
    for (int a = 0; a < kGridSize; ++a)
      for (int t = 0; t < kGridSize; ++t) table[t * kGridSize + a] = results[n * kGridSize + a][t];
    if (!write_table(o, o.ndfs[n], table, seconds)) return 1;
  }
  return 0;
}
