#!/usr/bin/env python3
"""Fits the three polynomials of models/binomial/binomial_trig.h (the arcsine count's fp32 sine
and arcsine) and prints their coefficients, constant term first, as the fp32 values the header
holds (the digits of each float exactly):

  P(w) ~ (sin x - x) / x^3,               w = x^2 in [0, 1],              degree 3
  Q(v) ~ (1 - cos y) / y^2,               v = y^2 in [0, (pi/2 - 1)^2],   degree 2
  R(t) ~ (asin(sqrt t) / sqrt t - 1) / t, t in [0, 1/4],                  degree 4

each near-minimax in the relative error of the function it serves (sin x = x + x (w P), cos y =
1 - v Q, asin s = s + s (t R): the error of the result is the polynomial's error times w, v or t,
which is the weight): least squares on 3000 Chebyshev nodes, then Lawson's reweighting towards
equal ripple, with the constant term fixed (fp32(-1/6), 1/2, fp32(1/6)). The function values
come from mpmath at 30 digits (the removable singularities at 0 excluded by the nodes).

    python3 tools/binomial/fit_trig_poly.py     # needs numpy and mpmath; ~10 s
"""
import mpmath as mp
import numpy as np

mp.mp.dps = 30


def p_of_w(w):
    x = mp.sqrt(w)
    return (mp.sin(x) - x) / x**3


def q_of_v(v):
    y = mp.sqrt(v)
    return (1 - mp.cos(y)) / v


def r_of_t(t):
    s = mp.sqrt(t)
    return (mp.asin(s) / s - 1) / t


def lawson(f, top, degree, c0, n=3000, iterations=300):
    """Coefficients (c0, c1, .., c_degree) of c0 + sum c_k u^k ~ f(u) on [0, top], minimising
    max |u (poly(u) - f(u))|; returns them rounded to fp32 and the weighted error with those."""
    u = (1 - np.cos(np.pi * (np.arange(n) + 0.5) / n)) / 2 * top
    fu = np.array([float(f(mp.mpf(float(v)))) for v in u])
    a = np.stack([u**k for k in range(1, degree + 1)], 1)
    y = fu - c0
    weight = np.ones(n) / n
    for _ in range(iterations):
        sw = np.sqrt(weight)
        c, *_ = np.linalg.lstsq(a * (sw * u)[:, None], y * sw * u, rcond=None)
        err = np.abs((a @ c - y) * u)
        weight = weight * err
        weight /= weight.sum()
    c32 = [np.float32(c0)] + [np.float32(v) for v in c]
    poly = np.polynomial.polynomial.polyval(u, np.array(c32, dtype=np.float64))
    return c32, np.max(np.abs((poly - fu) * u))


def main():
    fits = [
        ("P (sine below 1)", p_of_w, 1.0, 3, float(np.float32(-1.0 / 6.0))),
        ("Q (cosine of pi/2 - x from 1)", q_of_v, (np.pi / 2 - 1.0) ** 2, 2, 0.5),
        ("R (arcsine)", r_of_t, 0.25, 4, float(np.float32(1.0 / 6.0))),
    ]
    for name, f, top, degree, c0 in fits:
        c, err = lawson(f, top, degree, c0)
        print(f"{name}: relative error of the result {err:.3g}")
        for v in c:
            print(f"  {float(v)!r}")


if __name__ == "__main__":
    main()
