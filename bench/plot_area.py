#!/usr/bin/env python3
"""Error-vs-speed scatter of the polygon-light methods from bench_area's CSV.

    build/bench/bench_area --beckmann --csv docs/area_speed_accuracy.csv
    python3 bench/plot_area.py docs/area_speed_accuracy.csv [--out docs/area_speed_accuracy]

Writes OUT.svg and OUT.png (default docs/area_speed_accuracy): log-log, x = evaluations per
second on the device (fp32), y = relative error against bench_area's fp64 truth; per method a
filled marker for the mean and a hollow one for the 95th percentile, joined by a line, labelled
"METHOD n" (n = area_samples where it matters). One panel per NDF in the CSV. Rows whose status
is not "ok" (methods the server refused) are listed under the plot instead. Needs matplotlib
(pip install matplotlib).
"""
import argparse
import csv
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLOURS = {
    "LTC": "tab:blue",
    "LECOCQ": "tab:orange",
    "LECOCQ_PEARSON": "tab:red",
    "MONTE_CARLO": "tab:green",
    "REFERENCE": "tab:purple",
}


def label(row):
    m = row["method"]
    if m in ("MONTE_CARLO", "REFERENCE"):
        return f"{m} {row['samples']}"
    return m


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv")
    ap.add_argument("--out", default=os.path.join("docs", "area_speed_accuracy"),
                    help="output path without extension (default docs/area_speed_accuracy)")
    args = ap.parse_args()

    with open(args.csv, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{args.csv}: no rows")
    ndfs = list(dict.fromkeys(r["ndf"] for r in rows))
    ok = [r for r in rows if r["status"] == "ok" and r["evals_per_s"]]
    skipped = [r for r in rows if r["status"] != "ok"]

    fig, axes = plt.subplots(1, len(ndfs), figsize=(6.4 * len(ndfs), 5.2), squeeze=False)
    for ax, ndf in zip(axes[0], ndfs):
        for r in (r for r in ok if r["ndf"] == ndf):
            x = float(r["evals_per_s"])
            mean, p95 = float(r["mean"]), float(r["p95"])
            # log axes: clamp exact zeros to a visible floor
            mean, p95 = max(mean, 1e-7), max(p95, 1e-7)
            c = COLOURS.get(r["method"], "black")
            ax.plot([x, x], [mean, p95], color=c, lw=1, alpha=0.6)
            ax.scatter([x], [mean], color=c, marker="o", s=36, zorder=3)
            ax.scatter([x], [p95], facecolors="none", edgecolors=c, marker="s", s=36, zorder=3)
            dy = -12 if r["method"] == "LECOCQ_PEARSON" else -3  # LECOCQ often sits next to it
            ax.annotate(label(r), (x, mean), textcoords="offset points", xytext=(6, dy),
                        fontsize=8, color=c)
        ax.margins(x=0.25, y=0.15)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("polygon-light evaluations / s (device, fp32)")
        ax.set_ylabel("relative error vs fp64 truth (adaptive quadrature)")
        ax.set_title(f"{ndf.upper() if ndf == 'ggx' else ndf.capitalize()}: "
                     "mean (filled) and p95 (hollow)")
        ax.grid(True, which="both", alpha=0.3)
    notes = sorted({f"{label(r)}: {r['status']}" for r in skipped})
    if notes:
        fig.text(0.01, 0.01, "\n".join(notes), fontsize=7, va="bottom")
        fig.subplots_adjust(bottom=0.12 + 0.03 * len(notes))
    fig.suptitle("Polygon lights on the smooth model: speed vs accuracy (bench/bench_area.cpp)",
                 fontsize=11)
    fig.tight_layout(rect=(0, 0.03 * len(notes), 1, 0.96))
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    for ext in ("svg", "png"):
        fig.savefig(f"{args.out}.{ext}", dpi=120)
        print(f"wrote {args.out}.{ext}")


if __name__ == "__main__":
    main()
