#!/usr/bin/env python3
"""Prints the kCost initializer of tools/area_auto/fit_area_auto.cpp from bench_area's CSV
(docs/area_speed_accuracy.csv): device fp32 microseconds per light evaluation, per NDF (GGX, then
Beckmann), in the candidate order LTC, LECOCQ, LECOCQ_PEARSON, REFERENCE 4, 8, 16, 32, then
MONTE_CARLO's a and b of a + b n.
  - LTC, LECOCQ, LECOCQ_PEARSON: 1e6 / evals_per_s as measured;
  - REFERENCE n: a + b (4 ceil(n / 4))^2 (the nodes per triangle) through the measured 8 and 32;
  - MONTE_CARLO: a + b n, least squares through the measured sample counts;
  an intercept a below LTC's cost (noise; it went negative on a loaded machine) is set to LTC's
  cost and b refitted with it.

    python3 tools/area_auto/costs_from_bench_area.py docs/area_speed_accuracy.csv
"""
import csv
import math
import sys


def costs(rows):
    us = {(r["method"], int(r["samples"])): 1e6 / float(r["evals_per_s"]) for r in rows}
    out = [us[("LTC", 0)], us[("LECOCQ", 0)], us[("LECOCQ_PEARSON", 0)]]
    nodes = lambda n: (4 * math.ceil(n / 4)) ** 2
    floor = us[("LTC", 0)]
    ref = [(nodes(n), us[("REFERENCE", n)]) for n in (8, 32)]
    a, b = line(ref, floor)
    out += [a + b * nodes(n) for n in (4, 8, 16, 32)]
    out += list(line(sorted((n, t) for (m, n), t in us.items() if m == "MONTE_CARLO"), floor))
    return out


def line(points, floor):
    """Least squares a + b x. An intercept below `floor` (LTC's cost: every method pays at least
    the per-light set-up LTC pays; timing noise on a loaded machine can make it negative, a
    candidate cheaper than free) is set to `floor` and b refitted with that intercept."""
    mx = sum(x for x, _ in points) / len(points)
    my = sum(y for _, y in points) / len(points)
    b = sum((x - mx) * (y - my) for x, y in points) / sum((x - mx) ** 2 for x, _ in points)
    if my - b * mx >= floor:
        return my - b * mx, b
    return floor, sum(x * (y - floor) for x, y in points) / sum(x * x for x, _ in points)


def literal(x):
    s = "%.3g" % x
    return (s if ("." in s or "e" in s) else s + ".0") + "f"


def main():
    with open(sys.argv[1]) as f:
        rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
    print("const float kCost[2][kCandidates + 2] = {")
    for ndf in ("ggx", "beckmann"):
        c = costs([r for r in rows if r["ndf"] == ndf])
        print("    {" + ", ".join(literal(x) for x in c) + "},")
    print("};")


if __name__ == "__main__":
    main()
