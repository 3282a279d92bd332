/* The AUTO area method: per query and polygon light, the cheapest integrator
 * whose predicted relative error is within the request's budget
 * (EvaluateRequest.max_relative_error), from the error table fitted by
 * tools/area_auto/ (models/smooth/area_auto_table.h; its cells:
 * kernels/area/area_auto_features.h).
 *
 * Candidates: the deterministic methods LTC, LECOCQ, LECOCQ_PEARSON and
 * REFERENCE with 4, 8, 16 or 32 nodes per dimension, whose table entry is a
 * high quantile of the relative error measured in the cell, and MONTE_CARLO
 * with any even n in [4, 1024], whose error is statistical: its table entry is
 * the per-sample coefficient of variation cv (a high quantile over the cell of
 * sqrt(n) std(estimate) / truth), and n samples meet the budget b with about
 * 95% probability when z cv / sqrt(n) <= b, z = 1.96 (the central limit
 * theorem; the MIS estimator is unbiased, area_monte_carlo.h), i.e.
 * n = ceil((z cv / b)^2). Costs are the table's measured device times. When no
 * candidate is predicted to meet the budget, the one with the smallest
 * predicted error runs (so a tiny budget costs at most REFERENCE 32 or
 * MONTE_CARLO 1024 per light).
 *
 * Where: on the device, per query and light, inside the polygon kernels, so a
 * request stays one launch and the result depends only on the query's own
 * inputs (bit-identical under chunking and batching). Grouping queries per
 * method on the host would need the features (a clip and a solid angle per
 * query and light) on the host first and one launch per method, and a query
 * with several lights would need several methods in one sum anyway.
 *
 * The budget reaches the kernels in area_samples as millionths (EvalPlan,
 * server/eval_plan.cpp), so the kernel arguments stay as they are.
 * GLINT_LANES == 1. */
#ifndef GLINT_AREA_AUTO_H
#define GLINT_AREA_AUTO_H

#include "kernels/area/area_auto_features.h"
#include "kernels/compat.h"
#include "kernels/layout.h"
#include "models/smooth/area_auto_table.h"

/* A table fitted for other bins would be read at the wrong cells (and a shorter
 * initialiser is silently zero-filled: "LTC is exact"); refuse to build. */
#if GLINT_AUTO_TABLE_ALPHA_BINS != GLINT_AUTO_ALPHA_BINS ||         \
    GLINT_AUTO_TABLE_VIEW_BINS != GLINT_AUTO_VIEW_BINS ||           \
    GLINT_AUTO_TABLE_OMEGA_BINS != GLINT_AUTO_OMEGA_BINS ||         \
    GLINT_AUTO_TABLE_ELEVATION_BINS != GLINT_AUTO_ELEVATION_BINS || \
    GLINT_AUTO_TABLE_ALIGN_BINS != GLINT_AUTO_ALIGN_BINS
#error "models/smooth/area_auto_table.h was fitted for other cells: regenerate it (tools/area_auto)"
#endif

/* Deterministic candidates k = 0 .. GLINT_AUTO_CANDIDATES - 1 of the table. */
GLINT_FN int area_auto_candidate_method(int k) {
  return k == 0   ? GLINT_AREA_LTC
         : k == 1 ? GLINT_AREA_LECOCQ
         : k == 2 ? GLINT_AREA_LECOCQ_PEARSON
                  : GLINT_AREA_REFERENCE;
}
GLINT_FN int area_auto_candidate_samples(int k) {
  return k < 3 ? 0 : 4 << (k - 3); /* REFERENCE 4, 8, 16, 32 */
}

#define GLINT_AUTO_MC_Z 1.96f
#define GLINT_AUTO_MC_MIN 4
#define GLINT_AUTO_MC_MAX 1024

typedef struct {
  int method;      /* GLINT_AREA_* */
  int samples;     /* REFERENCE nodes, MONTE_CARLO samples; 0 for the others */
  float predicted; /* the table's error bound for it (> budget: nothing was predicted to meet it) */
} AreaChoice;

/* MONTE_CARLO's sample count for a per-sample cv and budget b, or 0 when more
 * than GLINT_AUTO_MC_MAX would be needed. Even, so both MIS techniques get
 * n / 2 samples. In float on every path so that host and device agree. */
GLINT_FN int area_auto_mc_samples(float cv, float budget) {
  float r = GLINT_AUTO_MC_Z * cv / budget;
  float n = r * r;
  if (!(n <= (float)GLINT_AUTO_MC_MAX)) return 0;
  int k = (int)n;
  k += (float)k < n;
  k = k < GLINT_AUTO_MC_MIN ? GLINT_AUTO_MC_MIN : k;
  return k + (k & 1);
}

/* The method for one light: `ndf` GLINT_NDF_*, alpha = sqrt(alpha_x alpha_y),
 * wo local, v[0..n-1] the light relative to the shading point (local frame),
 * budget the relative error allowed. */
GLINT_FN AreaChoice area_auto_choose(int ndf, real alpha, real3 wo, const GLINT_PRIVATE real3 *v,
                                     int n, float budget) {
  AreaChoice best;
  best.method = GLINT_AREA_LTC;
  best.samples = 0;
  best.predicted = 0.0f;
  int cell = area_auto_cell(alpha, wo, v, n);
  if (cell < 0) return best; /* every method gives 0: the cheapest */
  int t = ndf == GLINT_NDF_BECKMANN ? 1 : 0;
  const GLINT_CONSTANT float *e =
      glint_area_auto_error + (t * GLINT_AUTO_CELLS + cell) * GLINT_AUTO_CELL_FLOATS;
  const GLINT_CONSTANT float *cost = glint_area_auto_cost + t * GLINT_AUTO_COSTS;
  int found = 0;
  float best_cost = 0.0f;
  for (int k = 0; k < GLINT_AUTO_CANDIDATES; ++k) {
    if (e[k] <= budget && (!found || cost[k] < best_cost)) {
      found = 1;
      best_cost = cost[k];
      best.method = area_auto_candidate_method(k);
      best.samples = area_auto_candidate_samples(k);
      best.predicted = e[k];
    }
  }
  float cv = e[GLINT_AUTO_CANDIDATES];
  int mc = area_auto_mc_samples(cv, budget);
  if (mc > 0) {
    float c = cost[GLINT_AUTO_CANDIDATES] + cost[GLINT_AUTO_CANDIDATES + 1] * (float)mc;
    if (!found || c < best_cost) {
      found = 1;
      best_cost = c;
      best.method = GLINT_AREA_MONTE_CARLO;
      best.samples = mc;
      best.predicted = GLINT_AUTO_MC_Z * cv / sqrt((float)mc);
    }
  }
  if (found) return best;
  /* Nothing meets the budget: the smallest predicted error. */
  float best_error = GLINT_AUTO_MC_Z * cv / sqrt((float)GLINT_AUTO_MC_MAX);
  best.method = GLINT_AREA_MONTE_CARLO;
  best.samples = GLINT_AUTO_MC_MAX;
  for (int k = 0; k < GLINT_AUTO_CANDIDATES; ++k) {
    if (e[k] < best_error) {
      best_error = e[k];
      best.method = area_auto_candidate_method(k);
      best.samples = area_auto_candidate_samples(k);
    }
  }
  best.predicted = best_error;
  return best;
}

#endif /* GLINT_AREA_AUTO_H */
