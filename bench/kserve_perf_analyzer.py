"""Load-tests glintd over the Open Inference Protocol with Triton's perf_analyzer and prints a
markdown table (or, with --json, one JSON row per concurrency) for the README.

Starts glintd with the `paint` preset (examples/materials/paint_schlick.json under
examples/lights/studio.json: one directional and two point lights), sends requests of --rows
queries (wo only) at each concurrency, and reports perf_analyzer's client-side throughput
and latency percentiles beside its server-side split (queue / compute) from ModelStatistics.

usage (from the repository root, after a build; the venv and the tools are made once):
  tests/kserve/python_env.sh build/kserve-venv python bench/kserve_perf_analyzer.py \\
      --glintd build/server/glintd --cache build/kserve-tools --concurrency 1,4,16 [--json]
"""
import argparse
import csv
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tests", "kserve"))

from glintd_server import Glintd  # noqa: E402
from perf_analyzer_install import install, write_input_data  # noqa: E402


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--glintd", required=True)
    p.add_argument("--cache", required=True, help="where perf_analyzer and its data are kept")
    p.add_argument("--examples", default=os.path.join(HERE, "..", "examples"))
    p.add_argument("--concurrency", default="1,4,16")
    p.add_argument("--rows", type=int, default=4096, help="queries per request")
    p.add_argument("--interval-ms", type=int, default=5000, help="measurement window")
    p.add_argument("--stability", type=int, default=50,
                   help="perf_analyzer -s: allowed spread between windows, percent")
    p.add_argument("--glintd-arg", action="append", default=[], help="extra glintd flag")
    p.add_argument("--json", action="store_true", help="one JSON row per concurrency")
    args = p.parse_args()

    perf_analyzer, env = install(args.cache)
    data = os.path.join(args.cache, f"wo_{args.rows}.json")
    write_input_data(data, args.rows)
    model = (f"paint={args.examples}/materials/paint_schlick.json,"
             f"{args.examples}/lights/studio.json")
    rows = []
    with Glintd(args.glintd, ["--model", model] + args.glintd_arg) as server:
        for c in [int(x) for x in args.concurrency.split(",")]:
            out_csv = os.path.join(args.cache, f"perf_c{c}.csv")
            cmd = [perf_analyzer, "-m", "paint", "-i", "grpc", "-u", server.address,
                   "--input-data", data, "--concurrency-range", f"{c}:{c}",
                   "--measurement-interval", str(args.interval_ms),
                   "-s", str(args.stability), "-f", out_csv]
            run = subprocess.run(cmd, env=env, capture_output=True, text=True)
            if run.returncode != 0:
                sys.exit(f"perf_analyzer failed at concurrency {c}:\n{run.stdout}{run.stderr}")
            with open(out_csv) as f:
                r = next(csv.DictReader(f))
            rows.append({
                "concurrency": c, "rows_per_request": args.rows,
                "requests_per_s": float(r["Inferences/Second"]),
                "queries_per_s": float(r["Inferences/Second"]) * args.rows,
                "p50_us": int(r["p50 latency"]), "p90_us": int(r["p90 latency"]),
                "p99_us": int(r["p99 latency"]),
                "server_queue_us": int(r["Server Queue"]),
                "server_compute_us": int(r["Server Compute Input"]) +
                int(r["Server Compute Infer"]) + int(r["Server Compute Output"])})
    if args.json:
        for row in rows:
            print(json.dumps(row))
        return
    print("| concurrency | requests/s | queries/s | p50 | p90 | p99 | server queue | server compute |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for r in rows:
        print(f"| {r['concurrency']} | {r['requests_per_s']:.0f} | "
              f"{r['queries_per_s'] / 1e6:.2f} M | {r['p50_us'] / 1e3:.2f} ms | "
              f"{r['p90_us'] / 1e3:.2f} ms | {r['p99_us'] / 1e3:.2f} ms | "
              f"{r['server_queue_us'] / 1e3:.2f} ms | {r['server_compute_us'] / 1e3:.2f} ms |")


if __name__ == "__main__":
    main()
