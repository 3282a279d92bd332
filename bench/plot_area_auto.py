#!/usr/bin/env python3
"""Achieved error and throughput of the AUTO area method against its budget, from
bench_area_auto's CSV.

    build/bench/bench_area_auto --csv docs/area_auto_validation.csv
    python3 -m venv /tmp/plotvenv && /tmp/plotvenv/bin/pip install matplotlib
    /tmp/plotvenv/bin/python bench/plot_area_auto.py docs/area_auto_validation.csv

Writes docs/area_auto.png (--out to change): one column per NDF. Top: the median and 95th
percentile of AUTO's relative error on the held-out queries against the budget (log-log; the
diagonal is "error = budget"). Middle: AUTO's device throughput against the budget, with the
fixed methods' throughput as horizontal lines (REFERENCE 32, the most accurate candidate; LTC,
the cheapest). Bottom: the percentage of queries above the budget, overall and among those
where the table predicted some method meets it, the share where nothing was, and the
fraction above the budget among the grazing views (theta_o >= 85 deg; one view in four).
"""
import argparse
import csv
import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def num(s):
    try:
        return float(s)
    except ValueError:
        return math.nan


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("--out", default="docs/area_auto.png")
    args = ap.parse_args()
    rows = list(csv.DictReader(open(args.csv)))
    ndfs = [n for n in ("ggx", "beckmann") if any(r["ndf"] == n for r in rows)]
    fig, axes = plt.subplots(3, len(ndfs), figsize=(5.5 * len(ndfs), 11), squeeze=False)
    for col, ndf in enumerate(ndfs):
        auto = sorted((r for r in rows if r["ndf"] == ndf and r["variant"] == "AUTO"),
                      key=lambda r: num(r["budget"]))
        fixed = {r["variant"]: r for r in rows if r["ndf"] == ndf and r["variant"] != "AUTO"}
        b = [num(r["budget"]) for r in auto]
        ax = axes[0][col]
        ax.loglog(b, [num(r["p50"]) for r in auto], "o-", label="AUTO median error")
        ax.loglog(b, [num(r["p95"]) for r in auto], "s--", label="AUTO 95th percentile")
        lo, hi = min(b) / 2, max(b) * 2
        ax.loglog([lo, hi], [lo, hi], "k:", label="error = budget")
        ax.set_xlabel("max_relative_error (budget)")
        ax.set_ylabel("achieved relative error (held-out queries)")
        ax.set_title(f"{ndf.upper() if ndf == 'ggx' else 'Beckmann'}: error vs budget")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)

        ax = axes[1][col]
        ax.loglog(b, [num(r["evals_per_s"]) for r in auto], "o-", label="AUTO")
        for name, style in (("LTC", "C2--"), ("REFERENCE:32", "C3--"), ("MONTE_CARLO:256", "C4:")):
            if name in fixed:
                ax.axhline(num(fixed[name]["evals_per_s"]), color=style[:2], linestyle=style[2:],
                           label=f"{name} (p95 error {num(fixed[name]['p95']):.2g})")
        ax.set_xlabel("max_relative_error (budget)")
        ax.set_ylabel("device fp32 evaluations / s (one light)")
        ax.set_title("cost: throughput vs budget")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)

        ax = axes[2][col]
        ax.semilogx(b, [100 * num(r["exceed"]) for r in auto], "o-", label="all queries")
        ax.semilogx(b, [100 * num(r["exceed_feasible"]) for r in auto], "s--",
                    label="where the table predicts a method meets it")
        ax.semilogx(b, [100 * (1 - num(r["feasible"])) for r in auto], "^:",
                    label="share where nothing is predicted to meet it")
        if auto and "exceed_grazing" in auto[0]:
            ax.semilogx(b, [100 * num(r["exceed_grazing"]) for r in auto], "v-.",
                        label="grazing views (>= 85 deg) only")
        ax.axhline(10, color="k", linestyle=":", label="stated bound 10%")
        ax.set_xlabel("max_relative_error (budget)")
        ax.set_ylabel("% of queries")
        ax.set_title("queries above the budget")
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    fig.savefig(args.out, dpi=110)
    print("wrote", args.out)


if __name__ == "__main__":
    main()
