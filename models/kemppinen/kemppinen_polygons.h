/* Polygon lights for the Kemppinen glint model (K25 has point lights and
 * environment maps only), one query per work-item (clipping branches per
 * query). The reflected radiance of a light of radiance L is
 *   L_o = int_light L f cos_i dwi = int_R rho(x) S(x) dx,
 *   rho(x) = L f(wi, wo) cos_i 4 (wo.h) / |J_T(h)|        (dwi = 4 wo.h dh, dh = dx / |J_T|)
 * over the light's image R in U (models/kemppinen/kemppinen_image.h), with S
 * = D_star / D = explicit facet lobes + compensation (kemppinen_ndf.h). Per
 * MIP level l (weight w_l) of the query's footprint:
 *  - explicit facets: the n x n angular cells around R's centroid (n = the
 *    material's sqrt(k), widened up to 4 to cover R's bounding box), times the
 *    2x2 spatial block. Facet i contributes
 *      rho_l R(r_i, w_l) N_s,i M_i / res_a^2,
 *    N_s,i its pixel-filter weight (cells), M_i its lobe's mass over R
 *    (kemppinen_image_mass, an approximation), rho_l = rho at the centroid
 *    of the block's part of R (rho taken constant over the block);
 *  - compensation through the smooth area integral L_smooth of the request's
 *    area method: w_l (L_smooth - rho_l P_s A_l) in the mean colour, with A_l
 *    the area of R inside the block and P_s the pixel filter's mass in the
 *    spatial block: the expectation of the explicit part over uv (facets
 *    uniform in their cells), so the sum is unbiased up to the lobes' spill
 *    over R's edges inside the block (int_B M vs A_l).
 * APPROXIMATIONS, measured against Monte Carlo over the light in
 * models/kemppinen/tests/kemppinen_test.cpp: R's straight edges between the
 * images of arc points; the lobe
 * width |J_T| and rho taken at R's centroid / the block's part of R; facets of
 * cells beyond the explicit block enter only through the compensation (a
 * light whose image spans more than 4 x 4 cells of a level has smooth parts).
 * The result is clamped at 0 per channel.
 * NEIGHBOURHOOD (material.kemppinen.neighborhood, session 20): the point pass's
 * estimators. ONE_LEVEL: one level per query at weight 1, the point pass's
 * dither (kemppinen_dithered_level), no roulette; ONE_CELL: also only the
 * spatial cell holding the query, P_s that cell's filter mass (both with the
 * point pass's 7.1.27 erfc, kemppinen_neighborhood_outside). E[explicit] =
 * rho_l P_s A_l per level still holds (facets uniform in their cells, each
 * level a point process of density K_P), so the sum stays unbiased over uv. */
#ifndef GLINT_KEMPPINEN_POLYGONS_H
#define GLINT_KEMPPINEN_POLYGONS_H

#include "kernels/area/area_lights.h"
#include "kernels/area/polygon_lights.h"
#include "models/kemppinen/kemppinen_eval.h"
#include "models/kemppinen/kemppinen_image.h"
#include "models/kemppinen/kemppinen_image_lines.h"

/* Widest explicit angular block for a polygon light (cells per axis). */
#define GLINT_KEMPPINEN_POLYGON_MAX_SIDE 4

/* A facet whose pixel-filter exponent e (ns = sn exp(-e)) exceeds this, i.e.
 * farther than 7 standard scores from the query in the filter's metric
 * (7^2 / 2), is left out before its lobe mass: its term keep ns M <= sn
 * e^-24.5 = 2.3e-11 sn, and all the 2 x 4 x 16 facets of a light together
 * below 3e-9 of one facet at the filter's peak, under the fp32 resolution of
 * that facet's term (the point pass's erfc is dropped at 6 scores already,
 * GLINT_KEMPPINEN_ERFC_CUT). A spatial cell whose nearest point is that far
 * (kemppinen_filter_cell_min) is skipped before its hashes. */
#define GLINT_KEMPPINEN_FILTER_CUT 24.5

/* Lower bound of the pixel-filter exponent q(d) = qxx dx^2 + qxy dx dy +
 * qyy dy^2 over the facets of a spatial cell, d = (dxc - sx, dyc - sy) with
 * the facet's offsets sx, sy in [0, 1): the exact minimum of q over the
 * closed cell [dxc - 1, dxc] x [dyc - 1, dyc] (q convex, qxx, qyy > 0: the filter is regularised,
 * kemppinen_footprint): 0 when the cell holds d = 0, else the smallest of
 * the four sides' minima, each a 1D quadratic minimised at its clamped
 * vertex (side dx = X: qyy dy^2 + qxy X dy + qxx X^2, at dy = -qxy X / (2
 * qyy)). Session 11 bounded q by the smallest eigenvalue times the distance
 * squared, loose for an elongated filter: 80% of the facets hashed in the
 * bench's quad were then cut by their own exponent. Scaled by (1 - 1e-5)
 * so that rounding cannot lift it above a facet's own q (relative errors
 * ~1e-7 in fp32): it stays a lower bound. */
GLINT_FN real kemppinen_filter_quad(real qxx, real qxy, real qyy, real dx, real dy) {
  return qxx * dx * dx + qxy * dx * dy + qyy * dy * dy;
}

GLINT_FN real kemppinen_filter_cell_min(real qxx, real qxy, real qyy, real dxc, real dyc) {
  real x0 = dxc - GLINT_R(1.0), y0 = dyc - GLINT_R(1.0);
  if (x0 <= GLINT_R(0.0) && dxc >= GLINT_R(0.0) && y0 <= GLINT_R(0.0) && dyc >= GLINT_R(0.0))
    return GLINT_R(0.0);
  real hx = GLINT_R(-0.5) * qxy / qxx, hy = GLINT_R(-0.5) * qxy / qyy;
  /* Sides dx = x0, dx = dxc (dy free in [y0, dyc]), then dy = y0, dy = dyc. */
  real m = kemppinen_filter_quad(qxx, qxy, qyy, x0, clamp(hy * x0, y0, dyc));
  m = fmin(m, kemppinen_filter_quad(qxx, qxy, qyy, dxc, clamp(hy * dxc, y0, dyc)));
  m = fmin(m, kemppinen_filter_quad(qxx, qxy, qyy, clamp(hx * y0, x0, dxc), y0));
  m = fmin(m, kemppinen_filter_quad(qxx, qxy, qyy, clamp(hx * dyc, x0, dxc), dyc));
  return fmax(m, GLINT_R(0.0)) * GLINT_R(0.99999);
}

/* rho at U point (x, y) (see the header comment), RGB, without L. */
GLINT_FN real3 kemppinen_image_rho(SmoothMaterial m, real3 wo, real x, real y) {
  real3 zero = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  real3 h = kemppinen_from_disk(m.ndf, x, y, m.alpha_x, m.alpha_y);
  real oh = r3_dot(wo, h);
  if (!(h.z > GLINT_R(0.0)) || !(oh > GLINT_R(0.0))) return zero;
  real3 wi = r3_sub(r3_scale(h, GLINT_R(2.0) * oh), wo);
  DiskPoint d =
      kemppinen_to_disk(m.ndf, h, m.alpha_x, m.alpha_y, ndf_D(m.ndf, h, m.alpha_x, m.alpha_y));
  if (!(d.jac > GLINT_R(0.0))) return zero;
  return r3_scale(smooth_reflect_cos(m, wi, wo), GLINT_R(4.0) * oh / d.jac);
}

/* One polygon light's glinty radiance (RGB): `smooth` is its smooth radiance
 * by the request's area method, `L` its emitted radiance, R its image. */
GLINT_FN real3 kemppinen_polygon_glints(SmoothMaterial m, KemppinenParams p, KemppinenFootprint fp,
                                        real3 wo, real3 L, real3 smooth,
                                        const GLINT_PRIVATE KemppinenUPolygon *R) {
  real3 out = r3_mul(smooth, p.mean_color);
  if (R->n < 3 || !(R->area > GLINT_R(0.0))) return out;
  /* The lobe width (Eq. 4) at the image's centroid. */
  real3 hc = kemppinen_from_disk(m.ndf, R->cx, R->cy, m.alpha_x, m.alpha_y);
  if (!(hc.z > GLINT_R(0.0))) return out;
  KemppinenAngular a = kemppinen_angular(
      p,
      kemppinen_to_disk(m.ndf, hc, m.alpha_x, m.alpha_y, ndf_D(m.ndf, hc, m.alpha_x, m.alpha_y)));
  a.x = R->cx;
  a.y = R->cy;
  /* R's bounding box, for the block's width. */
  real bw = GLINT_R(0.0), bh = GLINT_R(0.0);
  {
    real x0 = R->x[0], x1 = R->x[0], y0 = R->y[0], y1 = R->y[0];
    for (int k = 1; k < R->n; ++k) {
      x0 = fmin(x0, R->x[k]);
      x1 = fmax(x1, R->x[k]);
      y0 = fmin(y0, R->y[k]);
      y1 = fmax(y1, R->y[k]);
    }
    bw = x1 - x0;
    bh = y1 - y0;
  }
  /* R's edges in the lobe's whitened coordinates, once for both levels:
   * bounds that skip the cells beyond R and the integrals of lobes and
   * blocks far from its edges (kemppinen_image_lines.h). */
  KemppinenULines lines = kemppinen_image_lines(R, a.sx, a.sy);
  real lf = glint_floor(fp.lambda);
  real w1 = fp.lambda - lf;
  /* The material's neighbourhood (kemppinen_query_levels_into for the point pass): the paper's
   * two levels at the tent weights, or one level at weight 1, dithered by the point pass's own
   * function of the footprint (kemppinen_dithered_level), so a query's polygon and point lights
   * see the same level's facets. */
  int n_levels = p.one_level ? 1 : 2;
  for (int lv = 0; lv < n_levels; ++lv) {
    real w = p.one_level ? GLINT_R(1.0) : lv == 0 ? GLINT_R(1.0) - w1 : w1;
    if (!(w > GLINT_R(0.0))) continue;
    real level = p.one_level ? kemppinen_dithered_level(fp)
                             : fmin(lf + (real)lv, GLINT_R(GLINT_KEMPPINEN_MAX_LEVEL));
    real res_a = glint_floor(exp2(level) + GLINT_R(0.5));
    /* Cells per axis covering R's bounding box (+1: it straddles a border). */
    real cover = (real)ceil(fmax(bw, bh) * res_a) + GLINT_R(1.0);
    KemppinenParams pb = p;
    pb.n_side = (int)fmin(fmax((real)p.n_side, cover), (real)GLINT_KEMPPINEN_POLYGON_MAX_SIDE);
    KemppinenBlocks b = kemppinen_blocks(pb, fp, a, level);
    /* ONE_CELL: only the spatial cell holding the query (its facets hash as that cell of the
     * 2x2 block); the compensation below then takes the filter's mass outside that cell. */
    if (p.one_cell) kemppinen_blocks_one_cell(&b);
    int n_cells = p.one_cell ? 1 : 4;
    real bx0 = b.ba_x / res_a, bx1 = b.ea_x / res_a, by0 = b.ba_y / res_a, by1 = b.ea_y / res_a;
    real expect = kemppinen_lines_block_mass(R, &lines, bx0, bx1, by0, by1, a.sx, a.sy);
    if (!(expect > GLINT_R(0.0))) continue; /* no explicit lobe reaches R */
    KemppinenUPolygon RB = kemppinen_image_clip_rect(*R, bx0, bx1, by0, by1);
    /* rho where the block meets R (R's centroid when only lobes reach it). */
    real rx = RB.area > GLINT_R(0.0) ? RB.cx : R->cx, ry = RB.area > GLINT_R(0.0) ? RB.cy : R->cy;
    real3 rho = r3_mul(L, kemppinen_image_rho(m, wo, rx, ry));
    /* The pixel filter normalised in spatial cells: b.norm holds both
     * Gaussians' norms, the angular one 1 / (2 pi sax say) in cells. */
    real sn = b.norm * GLINT_R(2.0) * GLINT_PI * (a.sx * res_a) * (a.sy * res_a);
    real3 sum = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
    /* res_a = 2^l (l <= 24): a product by inv_res_a is the exact quotient,
     * without a division per cell and facet. */
    real inv_res_a = GLINT_R(1.0) / res_a;
    int n = pb.n_side;
    for (int j = 0; j < n_cells; ++j) {
      real cx = b.bs_x + (real)(j & 1);
      real cy = b.bs_y + (real)(j >> 1);
      if (kemppinen_filter_cell_min(b.qxx, b.qxy, b.qyy, b.ts_x - cx, b.ts_y - cy) >
          GLINT_R(GLINT_KEMPPINEN_FILTER_CUT))
        continue;
      kemp_uint key = kemppinen_spatial_key(fp.seed_key, level, cx, cy);
      /* Rows outer, columns inner, in the order of the former single loop
       * over mm (ix = mm % n, iy = mm / n): the same sum, no integer division. */
      for (int my = 0; my < n; ++my) {
        real iy = b.ba_y + (real)my;
        if (!(iy < b.ea_y)) break;
        for (int mx = 0; mx < n; ++mx) {
          real ix = b.ba_x + (real)mx;
          if (!(ix < b.ea_x)) break;
          /* No lobe centred in this cell reaches R: mass 0, skip the hash. */
          if (kemppinen_lines_rect_apart(&lines, ix * inv_res_a, (ix + GLINT_R(1.0)) * inv_res_a,
                                         iy * inv_res_a, (iy + GLINT_R(1.0)) * inv_res_a))
            continue;
          /* kemppinen_facet (kemppinen_ndf.h: the same hashes and fields),
           * in the order of its tests' costs: the spatial offsets (one mix)
           * and the filter cut first (most facets of a cell lie beyond it
           * when the filter is smaller than the cell), then the roulette (a
           * second mix), the angular offsets and the disk's rejection. Each
           * test only drops the facet, so the order does not change the sum. */
          kemp_uint fkey = kemppinen_facet_key(key, ix, iy);
          kemp_uint h1 = kemppinen_facet_spatial_hash(fkey);
          real dx = b.ts_x - cx - kemppinen_u16_hi(h1), dy = b.ts_y - cy - kemppinen_u16_lo(h1);
          real es = b.qxx * dx * dx + b.qxy * dx * dy + b.qyy * dy * dy;
          if (es > GLINT_R(GLINT_KEMPPINEN_FILTER_CUT)) continue;
          /* One level (w = 1): R(r, 1) = 1 for every r (kemppinen_level_facet_add), no roulette,
           * and a white material reads no colour pick: no third mix. keep = 1 is exact. */
          kemp_uint h2 = fkey;
          real keep = GLINT_R(1.0);
          if (!(p.one_level && p.white)) h2 = kemppinen_facet_draws(fkey);
          if (!p.one_level) {
            keep = kemppinen_roulette(kemppinen_u16_hi(h2), w);
            if (!(keep > GLINT_R(0.0))) continue;
          }
          real gx = (ix + kemppinen_u16_hi(fkey)) * inv_res_a,
               gy = (iy + kemppinen_u16_lo(fkey)) * inv_res_a;
          real ox = gx - GLINT_R(0.5), oy = gy - GLINT_R(0.5);
          if (ox * ox + oy * oy >= GLINT_R(0.25)) continue; /* rejected (3.3.1) */
          KemppinenFacet g;                                 /* the fields of kemppinen_facet */
          g.sx = kemppinen_u16_hi(h1);
          g.sy = kemppinen_u16_lo(h1);
          g.ax = kemppinen_u16_hi(fkey);
          g.ay = kemppinen_u16_lo(fkey);
          g.r = kemppinen_u16_hi(h2);
          g.pick = kemppinen_u16_lo(h2);
          real ns = sn * exp(-es);
          real mass = kemppinen_lines_mass(R, &lines, gx, gy, a.sx, a.sy);
          sum = r3_add(sum, r3_scale(kemppinen_facet_color_of(&p, g), keep * ns * mass));
        }
      }
    }
    real ps = GLINT_R(1.0) - kemppinen_spatial_outside(p, fp, b);
    real3 expected = r3_scale(p.mean_color, w * ps * expect);
    out = r3_add(out, r3_mul(rho, r3_sub(r3_scale(sum, GLINT_R(1.0) / (res_a * res_a)), expected)));
  }
  return make_real3(fmax(out.x, GLINT_R(0.0)), fmax(out.y, GLINT_R(0.0)),
                    fmax(out.z, GLINT_R(0.0)));
}

/* Polygon lights for query i, one query per work-item. */
GLINT_FN real3 kemppinen_polygons_query(EvalSpec spec, KernelInputs in, uint i) {
  real3 radiance = make_real3(GLINT_R(0.0), GLINT_R(0.0), GLINT_R(0.0));
  SmoothMaterial m = smooth_material_unpack(in.material, spec.ndf, spec.fresnel);
  KemppinenParams p = kemppinen_params_unpack(in.params);
  ShadingPoint sp = shading_point(spec, query_load(spec, in, i));
  real3 wo = sp.wo;
  if (!(wo.z > GLINT_R(0.0))) return radiance;
  real footprint[4];
  kemppinen_load_footprint(in, i, footprint);
  KemppinenFootprint fp = kemppinen_footprint(p, (real)in.uv[2 * i], (real)in.uv[2 * i + 1],
                                              footprint, in.seed_lo, in.seed_hi);
  uint area_key = area_query_key(in.seed_lo, in.seed_hi, in.wo + 3 * i,
                                 spec.has_frame ? in.position + 3 * i : 0);
  for (uint l = 0; l < in.n_polygon; ++l) {
    PolygonLight P = polygon_light(spec, in, sp, m, l, area_key);
    real3 ls = P.radiance;
    if (!(ls.x + ls.y + ls.z > GLINT_R(0.0))) continue;
    const GLINT_GLOBAL float *rec = in.polygons + GLINT_POLYGON_FLOATS * l;
    real3 L = make_real3((real)rec[2], (real)rec[3], (real)rec[4]);
    KemppinenUPolygon R = kemppinen_image(m.ndf, m.alpha_x, m.alpha_y, wo, P.v, P.n);
    radiance = r3_add(radiance, kemppinen_polygon_glints(m, p, fp, wo, L, ls, &R));
  }
  return radiance;
}

#endif /* GLINT_KEMPPINEN_POLYGONS_H */
