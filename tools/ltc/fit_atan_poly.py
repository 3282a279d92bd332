#!/usr/bin/env python3
"""Fits the odd polynomial atan(z) ~ z * P(z^2), z in [0, 1], of kernels/area/atan_poly.h: P of
degree 8 in w = z^2, near-minimax in relative error (least squares on Chebyshev nodes in w,
then Lawson reweighting towards equal ripple). Prints the coefficients (constant first) and the
maximum relative error on a dense grid, evaluated in double and in float32 Horner form.

    python3 tools/ltc/fit_atan_poly.py        # needs numpy
"""
import numpy as np

DEGREE = 8


def main():
    n = 4000
    w = 0.5 * (1.0 - np.cos(np.pi * (np.arange(n) + 0.5) / n))
    z = np.sqrt(w)
    f = np.arctan(z) / z  # P(w); z > 0 on these nodes
    v = np.vander(w, DEGREE + 1, increasing=True)
    weight = np.ones(n)
    for _ in range(200):  # Lawson: reweight by the error towards the minimax (equal ripple) fit
        c, *_ = np.linalg.lstsq(v * np.sqrt(weight)[:, None], f * np.sqrt(weight), rcond=None)
        err = np.abs(v @ c - f) / f
        weight = weight * err / (weight * err).sum() * n
    zz = np.linspace(0.0, 1.0, 400001)[1:]
    exact = np.arctan(zz)
    rel = np.abs(zz * np.polyval(c[::-1], zz * zz) - exact) / exact
    c32 = c.astype(np.float32)
    z32 = zz.astype(np.float32)
    w32 = z32 * z32
    acc = np.full_like(w32, c32[-1])
    for cc in c32[-2::-1]:
        acc = acc * w32 + cc
    rel32 = np.abs((acc * z32).astype(np.float64) - exact) / exact
    print("coefficients (w^0 first):")
    for x in c:
        print("  %.9e" % x)
    print("max relative error: %.3g (double evaluation), %.3g (float32 Horner)" % (rel.max(), rel32.max()))


if __name__ == "__main__":
    main()
