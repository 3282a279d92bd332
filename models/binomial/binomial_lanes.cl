/* Entry of the binomial glint model (models/binomial/binomial_eval.h) for
 * directional, point and polygon lights by LTC: each work-item evaluates
 * GLINT_LANES (16, binomial_model.cpp) queries as the lanes of OpenCL vectors,
 * the footprint grids, the LTC clips and the count draws per lane with selects (binomial_count.h
 * says what diverges). Polygon lights by the other area methods run one query
 * per work-item (binomial.cl). Light kinds the request lacks are compiled out
 * (GLINT_HAS_DIRECTIONAL, GLINT_HAS_POINT).
 * Why 16 lanes and not 8 (until session 15): one zmm instruction does the work of two ymm ones,
 * and the kernel's dependent chains (cell-key hashes, the LTC clip, the draw) are shared by
 * twice as many queries; the longer exact searches of a 16-lane work-item (it pays its longest
 * lane) cost less than that at every N_P measured (models/binomial/README.md "Quad throughput
 * (session 15)"). The result per query is the same bit for bit: every lane runs the scalar
 * arithmetic whatever the width.
 * fp32 work-items evaluate GLINT_BLOCKS (4, binomial_model.cpp) such blocks one after the other;
 * with one light and STOCHASTIC (one draw per query) on AVX-512 the blocks' count draws run with
 * their lanes regrouped by regime (binomial_lanes_regrouped below, GLINT_BINOMIAL_REGROUP). */
#include "kernels/kernel_args.h"
#include "kernels/simd_io.h"
#include "kernels/work_item.h"
#include "models/binomial/binomial_eval.h"

#ifndef GLINT_BLOCKS
#define GLINT_BLOCKS 1
#endif
/* The regrouped draws (binomial_lanes_regrouped) need AVX-512's compress and expand (and its
 * mask registers) on 16 fp32 lanes; every other device, width and precision runs the blocks one
 * after the other (the plain loop in glint_binomial_lanes), with the same results: server/model.h
 * builds every fp32 lights request with GLINT_BLOCKS, whatever the device. As the other AVX-512
 * paths (kernels/compat.h glint_any_by_mask, GLINT_FAST_ROOTS). */
#if GLINT_BLOCKS > 1 && GLINT_LANES == 16 && !GLINT_USE_DOUBLE && defined(__AVX512DQ__)
#define GLINT_BINOMIAL_REGROUP 1
#else
#define GLINT_BINOMIAL_REGROUP 0
#endif

/* Component k of the `stride` floats per query of array a, for the queries [base, base +
 * GLINT_LANES), in lanes; lanes past n repeat query n - 1 (as block_load3). */
GLINT_FN real binomial_lanes_load(const __global float *a, uint stride, uint k, uint base, uint n) {
  float t[GLINT_LANES];
  for (uint j = 0; j < GLINT_LANES; ++j) t[j] = a[stride * (size_t)min(base + j, n - 1) + k];
  return GLINT_FLOATS_TO_REAL(GLINT_VLOADN(0, t));
}

/* binomial_shade of the block of queries [base, base + GLINT_LANES), its light recorded in
 * `defer` where not 0 (BinomialDeferred). */
GLINT_FN real3 binomial_lanes_shade(EvalSpec spec, KernelInputs in, const __global float *footprint,
                                    const __global float *uv, uint base, uint n,
                                    GLINT_PRIVATE BinomialDeferred *defer) {
  real fp[4]; /* du/dx, dv/dx, du/dy, dv/dy */
  real u, v;
#if GLINT_LANES == 8
  if (base + GLINT_LANES <= n) {
    /* A full block: the same floats by vector loads and shuffles instead of 48 scalar loads
     * (block_load3 does the same for the 3-vectors). */
    const __global float *f = footprint + 4 * (size_t)base;
    float8 f0 = vload8(0, f), f1 = vload8(1, f), f2 = vload8(2, f), f3 = vload8(3, f);
    fp[0] = GLINT_FLOATS_TO_REAL((float8)(f0.s04, f1.s04, f2.s04, f3.s04));
    fp[1] = GLINT_FLOATS_TO_REAL((float8)(f0.s15, f1.s15, f2.s15, f3.s15));
    fp[2] = GLINT_FLOATS_TO_REAL((float8)(f0.s26, f1.s26, f2.s26, f3.s26));
    fp[3] = GLINT_FLOATS_TO_REAL((float8)(f0.s37, f1.s37, f2.s37, f3.s37));
    const __global float *t = uv + 2 * (size_t)base;
    float8 t0 = vload8(0, t), t1 = vload8(1, t);
    u = GLINT_FLOATS_TO_REAL((float8)(t0.even, t1.even));
    v = GLINT_FLOATS_TO_REAL((float8)(t0.odd, t1.odd));
  } else
#elif GLINT_LANES == 16
  if (base + GLINT_LANES <= n) {
    /* The same for 16 lanes: 4 + 2 vload16 and shuffles instead of 96 scalar loads. */
    const __global float *f = footprint + 4 * (size_t)base;
    float16 f0 = vload16(0, f), f1 = vload16(1, f), f2 = vload16(2, f), f3 = vload16(3, f);
    fp[0] = GLINT_FLOATS_TO_REAL((float16)(f0.s048c, f1.s048c, f2.s048c, f3.s048c));
    fp[1] = GLINT_FLOATS_TO_REAL((float16)(f0.s159d, f1.s159d, f2.s159d, f3.s159d));
    fp[2] = GLINT_FLOATS_TO_REAL((float16)(f0.s26ae, f1.s26ae, f2.s26ae, f3.s26ae));
    fp[3] = GLINT_FLOATS_TO_REAL((float16)(f0.s37bf, f1.s37bf, f2.s37bf, f3.s37bf));
    const __global float *t = uv + 2 * (size_t)base;
    float16 t0 = vload16(0, t), t1 = vload16(1, t);
    u = GLINT_FLOATS_TO_REAL((float16)(t0.even, t1.even));
    v = GLINT_FLOATS_TO_REAL((float16)(t0.odd, t1.odd));
  } else
#endif
  {
    for (uint k = 0; k < 4; ++k) fp[k] = binomial_lanes_load(footprint, 4, k, base, n);
    u = binomial_lanes_load(uv, 2, 0, base, n);
    v = binomial_lanes_load(uv, 2, 1, base, n);
  }
  return binomial_shade(spec, in, block_load_queries(spec, in, base), u, v, fp, 0u, defer);
}

/* Adds what an earlier pass wrote (the binomial model has one pass per request, so only then)
 * and stores the block. */
GLINT_FN void binomial_lanes_store(__global float *out, int accumulate, uint base, uint n,
                                   real3 L) {
  if (accumulate) L = r3_add(block_load3(out, base, n), L);
  block_store3(out, base, n, L);
}

#if GLINT_BINOMIAL_REGROUP
/* Regime-homogeneous lanes for the count draw (models/binomial/README.md "Quad throughput
 * (session 19): one regime per lane group"). A 16-lane block pays every regime that any of its
 * lanes needs (binomial_count.h: the arcsine approximation and an exact search run for the
 * whole block), and at N_P = 1e2 nearly every block has lanes of both (about half approximated,
 * README "Quad throughput (session 12)"). Here a work-item evaluates GLINT_BLOCKS blocks up to
 * their draws (BinomialDeferred), packs the lanes of each stage of binomial_whole_prob from all
 * blocks into full groups of 16 (AVX-512 vcompressps: the lanes in block order, so a lane's
 * place depends only on the work-item's own queries), runs the stage once per group, and
 * scatters the results back (vexpandps). Each stage is the same per-lane arithmetic as
 * binomial_whole_prob's (binomial_whole_regime, _approx, _searches), and no lane's result
 * depends on the other lanes of its group (binomial_count.h "Lane-safe"), so every count is
 * bit for bit the unregrouped one. */
typedef float binomial_v16sf __attribute__((__vector_size__(64)));
typedef int binomial_v16si __attribute__((__vector_size__(64)));
/* Room for every lane of the blocks and one vector past the last packed lane. */
#define GLINT_BINOMIAL_PACKED ((GLINT_BLOCKS + 1) * GLINT_LANES)

GLINT_FN ushort binomial_mask_bits(glint_mask m) {
  return __builtin_ia32_cvtd2mask512(m);
}
/* Stores the lanes of m of x, in order, at dst (and zeros after them, up to 16 floats). */
GLINT_FN void binomial_pack(GLINT_PRIVATE float *dst, float16 x, ushort m) {
  vstore16(__builtin_convertvector(__builtin_ia32_compresssf512_mask(
                                       (binomial_v16sf)x, (binomial_v16sf)(float16)0.0f, m),
                                   float16),
           0, dst);
}
GLINT_FN void binomial_pack_int(GLINT_PRIVATE int *dst, int16 x, ushort m) {
  vstore16(
      __builtin_convertvector(
          __builtin_ia32_compresssi512_mask((binomial_v16si)x, (binomial_v16si)(int16)0, m), int16),
      0, dst);
}
/* The lanes of m from consecutive floats at src (the inverse of binomial_pack), `old` in the
 * others. */
GLINT_FN float16 binomial_unpack(const GLINT_PRIVATE float *src, float16 old, ushort m) {
  return __builtin_convertvector(
      __builtin_ia32_expandsf512_mask((binomial_v16sf)vload16(0, src), (binomial_v16sf)old, m),
      float16);
}
GLINT_FN int16 binomial_unpack_int(const GLINT_PRIVATE int *src, int16 old, ushort m) {
  return __builtin_convertvector(
      __builtin_ia32_expandsi512_mask((binomial_v16si)vload16(0, src), (binomial_v16si)old, m),
      int16);
}
/* The lanes of group j of `count` packed lanes that hold one. */
GLINT_FN glint_mask binomial_group_lanes(uint j, uint count) {
  const int16 lane = (int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  return lane < (int16)((int)count - 16 * (int)j);
}

/* binomial_whole_prob of the draws d[0 .. blocks) (their lanes of draw.has_whole), the
 * stages on regrouped lanes; k[b] the whole trials' count of block b. */
GLINT_FN void binomial_whole_regrouped(const GLINT_PRIVATE BinomialDeferred *d, uint blocks,
                                       real threshold, GLINT_PRIVATE real *k) {
  const glint_mask none = (glint_mask)0;
  real p1[GLINT_BLOCKS];
  glint_mask approx[GLINT_BLOCKS], near[GLINT_BLOCKS];
  /* Stage 1 per block, and the approximated lanes packed. */
  float pn[GLINT_BINOMIAL_PACKED], pp[GLINT_BINOMIAL_PACKED], pu[GLINT_BINOMIAL_PACKED],
      pp1[GLINT_BINOMIAL_PACKED], px[GLINT_BINOMIAL_PACKED];
  int pflags[GLINT_BINOMIAL_PACKED];
  uint offset[GLINT_BLOCKS + 1];
  offset[0] = 0u;
  for (uint b = 0; b < blocks; ++b) {
    glint_mask active = d[b].deferred ? d[b].draw.has_whole : none;
    approx[b] = binomial_whole_regime(d[b].draw.whole, d[b].p_draw, threshold, active, &p1[b]);
    ushort m = binomial_mask_bits(approx[b]);
    uint o = offset[b];
    binomial_pack(pn + o, d[b].draw.whole, m);
    binomial_pack(pp + o, d[b].p_draw, m);
    binomial_pack(pu + o, d[b].draw.u, m);
    binomial_pack(pp1 + o, p1[b], m);
    offset[b + 1] = o + (uint)popcount((uint)m);
  }
  /* Stage 2 on full groups: x and whether E(p1) is needed, in place of the packed lanes. */
  uint count = offset[blocks];
  for (uint j = 0; 16u * j < count; ++j) {
    glint_mask act = binomial_group_lanes(j, count);
    /* Lanes past the packed ones: values that keep their arithmetic finite (unused). */
    real n = glint_select(GLINT_R(128.0), vload16(j, pn), act);
    BinomialProb prob = binomial_prob(glint_select(GLINT_R(0.5), vload16(j, pp), act));
    real u = glint_select(GLINT_R(0.5), vload16(j, pu), act);
    real p1j = glint_select(GLINT_R(0.25), vload16(j, pp1), act);
    glint_mask near_p1;
    real x = binomial_whole_approx(n, &prob, u, p1j, act, &near_p1);
    vstore16(x, j, px);
    vstore16(near_p1, j, pflags);
  }
  /* Back to the blocks; then stage 3's lanes (the searches) packed. */
  real x[GLINT_BLOCKS];
  for (uint b = 0; b < blocks; ++b) {
    ushort m = binomial_mask_bits(approx[b]);
    x[b] = GLINT_R(0.0);
    near[b] = none;
    if (m) {
      x[b] = binomial_unpack(px + offset[b], x[b], m);
      near[b] = approx[b] & binomial_unpack_int(pflags + offset[b], none, m);
    }
  }
  for (uint b = 0; b < blocks; ++b) {
    glint_mask active = d[b].deferred ? d[b].draw.has_whole : none;
    real p = d[b].p_draw;
    glint_mask exact = active & !approx[b];
    glint_mask search = exact | (approx[b] & (p > GLINT_R(1.0) - p1[b]));
    ushort m = binomial_mask_bits(near[b] | search);
    uint o = offset[b];
    binomial_pack(pn + o, d[b].draw.whole, m);
    binomial_pack(pp + o, p, m);
    binomial_pack(pu + o, d[b].draw.u, m);
    binomial_pack(pp1 + o, glint_select(p, p1[b], near[b]), m); /* p_first */
    binomial_pack(px + o, x[b], m);
    binomial_pack_int(pflags + o, (approx[b] & 1) | (near[b] & 2) | (search & 4), m);
    offset[b + 1] = o + (uint)popcount((uint)m);
  }
  /* Stage 3 on full groups. */
  count = offset[blocks];
  for (uint j = 0; 16u * j < count; ++j) {
    glint_mask act = binomial_group_lanes(j, count);
    real n = glint_select(GLINT_R(1.0), vload16(j, pn), act);
    BinomialProb prob = binomial_prob(glint_select(GLINT_R(0.5), vload16(j, pp), act));
    real u = glint_select(GLINT_R(0.5), vload16(j, pu), act);
    real p_first = glint_select(GLINT_R(0.5), vload16(j, pp1), act);
    int16 flags = vload16(j, pflags);
    /* log(1 - q) of p_first: binomial_whole_prob's binomial_prob_log1m_q(prob) where p_first =
     * p, binomial_log1m_rarer(p1) where p1: the same function of the same value */
    real x0 = glint_select(GLINT_R(0.0), vload16(j, px), act); /* lanes past count: unset */
    real xj = binomial_whole_searches(n, &prob, u, x0, p_first, binomial_log1m_rarer(p_first),
                                      act & ((flags & 1) != 0), act & ((flags & 2) != 0),
                                      act & ((flags & 4) != 0));
    vstore16(xj, j, px);
  }
  for (uint b = 0; b < blocks; ++b) {
    glint_mask active = d[b].deferred ? d[b].draw.has_whole : none;
    glint_mask search = (active & !approx[b]) | (approx[b] & (d[b].p_draw > GLINT_R(1.0) - p1[b]));
    ushort m = binomial_mask_bits(near[b] | search);
    k[b] = m ? binomial_unpack(px + offset[b], x[b], m) : x[b];
  }
}

/* The GLINT_BLOCKS blocks from base0 with their one light's draws regrouped. */
GLINT_FN void binomial_lanes_regrouped(EvalSpec spec, KernelInputs in,
                                       const __global float *footprint, const __global float *uv,
                                       uint base0, uint n, int accumulate, __global float *out) {
  BinomialDeferred d[GLINT_BLOCKS];
  real3 L[GLINT_BLOCKS];
  uint blocks = 0;
  for (uint b = 0; b < GLINT_BLOCKS; ++b) {
    uint base = base0 + b * GLINT_LANES;
    if (base >= n) break;
    /* What the stages read of a block without a deferred light (active none): defined values,
     * not uninitialised ones (binomial_light sets them all where it defers). */
    d[b].deferred = 0;
    d[b].p_draw = GLINT_R(0.0);
    d[b].draw.whole = GLINT_R(0.0);
    d[b].draw.u = GLINT_R(0.0);
    d[b].draw.has_whole = (glint_mask)0;
    L[b] = binomial_lanes_shade(spec, in, footprint, uv, base, n, &d[b]);
    ++blocks;
  }
  real k[GLINT_BLOCKS];
  binomial_whole_regrouped(d, blocks, binomial_params_unpack(in.params).normal_threshold, k);
  for (uint b = 0; b < blocks; ++b) {
    real3 Lb = d[b].deferred ? binomial_deferred_finish(&d[b], k[b]) : L[b];
    binomial_lanes_store(out, accumulate, base0 + b * GLINT_LANES, n, Lb);
  }
}
#endif

__kernel void glint_binomial_lanes(GLINT_KERNEL_ARGS) {
  uint base0 = glint_work_item() * (GLINT_BLOCKS * GLINT_LANES);
  /* Padding work-items; uniform for all lanes of a work-item, not divergent. */
  if (base0 >= n) return;
  EvalSpec spec = kernel_spec();
  KernelInputs in = GLINT_KERNEL_INPUTS();
#if GLINT_BINOMIAL_REGROUP
  /* One draw per query (one light, one grid): the draws of the blocks regrouped by regime. A
   * uniform branch (one material and light set per request). */
  if (binomial_params_unpack(params).interpolation == GLINT_BINOMIAL_STOCHASTIC &&
      punctual_light_count(spec, in) + n_polygon == 1u) {
    binomial_lanes_regrouped(spec, in, footprint, uv, base0, n, accumulate, out);
    return;
  }
#endif
  for (uint blk = 0; blk < GLINT_BLOCKS; ++blk) {
    uint base = base0 + blk * GLINT_LANES;
    if (base >= n) break;
    binomial_lanes_store(out, accumulate, base, n,
                         binomial_lanes_shade(spec, in, footprint, uv, base, n, 0));
  }
}
