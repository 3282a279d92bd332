// What the polygon loader's range check (kernels/area/polygon_scale.h, area_polygon_load_n)
// costs on ordinary lights: every area method on one quad at distance ~3, host fp32 (the kernel
// headers compiled as C++, as the host path runs them), with the check (namespace `on`) and
// without it (`off`: GLINT_POLYGON_SCALE_OFF), timed in interleaved rounds by the thread's CPU
// time (load-independent on a shared machine), median per variant, and their ratio. A `load`
// row times the loader alone (one quad's four vertices, the part the check is added to). Also
// checks that both variants give the same radiance bit for bit (the check never fires on these
// lights).
//
//   bench_polygon_scale [--rounds R] [--queries N] [--only on|off [--row NAME]]
// --only runs one variant once per row (or the row NAME, e.g. LTC), untimed: for
// valgrind --tool=callgrind, whose instruction counts do not depend on the machine's load.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "data/ltc/ltc_table.h"

namespace on {
#define GLINT_USE_DOUBLE 0
#include "kernels/area/area_lights.h"
}  // namespace on

#undef GLINT_AREA_AUTO_FEATURES_H
#undef GLINT_AREA_AUTO_H
#undef GLINT_AREA_AUTO_TABLE_H
#undef GLINT_AREA_LECOCQ_H
#undef GLINT_AREA_LIGHTS_H
#undef GLINT_AREA_LTC_H
#undef GLINT_AREA_MONTE_CARLO_H
#undef GLINT_ATAN_POLY_H
#undef GLINT_COMPAT_H
#undef GLINT_FRAME_H
#undef GLINT_FRESNEL_H
#undef GLINT_HOST_LANES_H
#undef GLINT_LAYOUT_H
#undef GLINT_LTC_LOOKUP_H
#undef GLINT_NDF_H
#undef GLINT_POLYGON_H
#undef GLINT_POLYGON_SCALE_H
#undef GLINT_POLYGON_WEDGE_H
#undef GLINT_RNG_H
#undef GLINT_SMOOTH_BRDF_H
#undef GLINT_SPHERICAL_TRIANGLE_H
#undef GLINT_UNROLL_H
#undef GLINT_USE_DOUBLE
#undef GLINT_R

namespace off {
#define GLINT_USE_DOUBLE 0
#define GLINT_POLYGON_SCALE_OFF 1
#include "kernels/area/area_lights.h"
}  // namespace off

namespace {

double ThreadCpuSeconds() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct Row {
  const char *name;
  int method;   // GLINT_AREA_* through area_shade_keyed; 0: area_ltc_shade (the LTC lane
                // pass's whole light loop) directly; -1: the loader alone
  int samples;  // area samples (AUTO: the budget in millionths)
};

// One variant's pass over the queries: the sum of the red channel (kept, so nothing is
// optimised away, and compared between the variants; it must be > 0: the light is seen).
template <class Real3, class Material, class Frame, class Shade, class Ltc, class Load>
double Pass(const Row &row, const std::vector<Real3> &wo, const Material &m, const Frame &f,
            const std::vector<float> &rec, Shade shade, Ltc ltc, Load load) {
  const float *table = glint::ltc_table::table(glint::ltc_table::Ndf::kGgx);
  double sum = 0;
  for (size_t i = 0; i < wo.size(); ++i) {
    if (row.method == 0) {
      const Real3 origin = {0, 0, 0};
      sum += double(ltc(m, table, wo[i], 0, f, origin, rec.data(), 1u).x);
    } else if (row.method < 0) {
      Real3 v[GLINT_POLYGON_MAX_VERTICES];
      load(rec.data(), 4, 0, f, wo[i], v);  // wo as the shading point: a different load per query
      sum += double(v[0].x) + double(v[3].z);
    } else {
      const Real3 origin = {0, 0, 0};
      sum += double(
          shade(m, table, row.method, row.samples, wo[i], 0, f, origin, rec.data(), 1u, uint32_t(i))
              .x);
    }
  }
  return sum;
}

}  // namespace

int main(int argc, char **argv) {
  int rounds = 15;
  size_t queries = 4096;
  std::string only, row_name;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--rounds")
      rounds = std::max(1, std::stoi(v));
    else if (a == "--queries")
      queries = size_t(std::max(16, std::stoi(v)));
    else if (a == "--only")
      only = v;
    else if (a == "--row")
      row_name = v;
    else {
      std::fprintf(stderr, "bench_polygon_scale: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  // The quad overhead at distance ~3, facing the shading point at the origin (clockwise seen
  // from above: its right-hand normal points down), and views above the horizon.
  const float quad[12] = {-1, -1, 3, -1, 1, 3, 1, 1, 3, 1, -1, 3};
  std::vector<float> rec(GLINT_POLYGON_FLOATS, 0.0f);
  rec[0] = 4, rec[1] = 0, rec[2] = 1, rec[3] = 0.7f, rec[4] = 0.4f;
  std::memcpy(rec.data() + GLINT_POLYGON_VERTEX_OFFSET, quad, sizeof quad);
  std::mt19937 rng(9);
  std::normal_distribution<double> g(0, 1);
  std::vector<on::real3> wo_on;
  std::vector<off::real3> wo_off;
  for (size_t i = 0; i < queries; ++i) {
    double x = g(rng), y = g(rng), z = std::fabs(g(rng)) + 0.05;
    const double l = std::sqrt(x * x + y * y + z * z);
    wo_on.push_back(on::make_real3(float(x / l), float(y / l), float(z / l)));
    wo_off.push_back(off::make_real3(float(x / l), float(y / l), float(z / l)));
  }
  on::SmoothMaterial m_on;
  off::SmoothMaterial m_off;
  m_on.ndf = m_off.ndf = GLINT_NDF_GGX;
  m_on.alpha_x = m_off.alpha_x = 0.3f;
  m_on.alpha_y = m_off.alpha_y = 0.1f;
  m_on.fresnel.kind = m_off.fresnel.kind = GLINT_FRESNEL_SCHLICK;
  m_on.fresnel.a = on::make_real3(0.9f, 0.6f, 0.3f);
  m_off.fresnel.a = off::make_real3(0.9f, 0.6f, 0.3f);
  m_on.fresnel.b = on::make_real3(0, 0, 0);
  m_off.fresnel.b = off::make_real3(0, 0, 0);
  const on::ShadingFrame f_on = on::frame_identity();
  const off::ShadingFrame f_off = off::frame_identity();

  const Row rows[] = {{"load", -1, 0},
                      {"area_ltc_shade", 0, 0},
                      {"LTC", GLINT_AREA_LTC, 0},
                      {"LECOCQ", GLINT_AREA_LECOCQ, 0},
                      {"LECOCQ_PEARSON", GLINT_AREA_LECOCQ_PEARSON, 0},
                      {"MONTE_CARLO 16", GLINT_AREA_MONTE_CARLO, 16},
                      {"REFERENCE 8", GLINT_AREA_REFERENCE, 8},
                      {"AUTO 5%", GLINT_AREA_AUTO, 50000}};
  auto run_on = [&](const Row &r) {
    return Pass(r, wo_on, m_on, f_on, rec, on::area_shade_keyed, on::area_ltc_shade,
                on::area_polygon_load_n);
  };
  auto run_off = [&](const Row &r) {
    return Pass(r, wo_off, m_off, f_off, rec, off::area_shade_keyed, off::area_ltc_shade,
                off::area_polygon_load_n);
  };
  if (!only.empty()) {
    double s = 0;
    for (const Row &r : rows)
      if (row_name.empty() || row_name == r.name) s += only == "on" ? run_on(r) : run_off(r);
    std::printf("%s checksum %.9g\n", only.c_str(), s);
    return 0;
  }
  std::printf("| row | off ns/query | on ns/query | on/off CPU (median of %d) | same radiance |\n",
              rounds);
  std::printf("|---|---|---|---|---|\n");
  for (const Row &r : rows) {
    // Repeat each pass until it takes >= 20 ms of CPU time.
    int reps = 1;
    for (;;) {
      const double c0 = ThreadCpuSeconds();
      for (int k = 0; k < reps; ++k) run_off(r);
      if (ThreadCpuSeconds() - c0 >= 0.02) break;
      reps *= 2;
    }
    std::vector<double> t_on, t_off, ratio;
    double s_on = 0, s_off = 0;
    for (int round = 0; round < rounds; ++round) {
      // Alternate which variant goes first, so that neither always runs on a warm cache.
      for (int half = 0; half < 2; ++half) {
        const bool first_on = (round + half) % 2 == 0;
        const double c0 = ThreadCpuSeconds();
        for (int k = 0; k < reps; ++k)
          (first_on ? s_on : s_off) = first_on ? run_on(r) : run_off(r);
        const double dt = (ThreadCpuSeconds() - c0) / (double(reps) * double(queries));
        (first_on ? t_on : t_off).push_back(dt);
      }
      ratio.push_back(t_on.back() / t_off.back());
    }
    std::printf("| %s | %.1f | %.1f | %.3f | %s |\n", r.name, 1e9 * Median(t_off),
                1e9 * Median(t_on), Median(ratio), s_on == s_off && s_on != 0 ? "yes" : "NO");
  }
  return 0;
}
