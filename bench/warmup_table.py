#!/usr/bin/env python3
"""First-request latency table (issue 13): build/bench/bench_warmup on a fresh kernel cache (every
variant compiled: what the first request of a variant waits for without warm-up) and again on the
same, now warm, cache (disk load: glintd's warm-up after a restart), serially (one thread, per
variant) and in parallel (--threads 2, the total glintd's start-up waits for).

  python3 bench/warmup_table.py [--warm common|all] [--bench build/bench/bench_warmup]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile


def run(bench, cache, warm, threads, tmp, tag):
    out = os.path.join(tmp, tag + ".json")
    env = dict(os.environ)
    env.pop("POCL_CACHE_DIR", None)  # PoCL's cache then lives under --cache-dir (fresh too)
    subprocess.run([bench, "--cache-dir", cache, "--warm", warm, "--threads", str(threads),
                    "--json", out], check=True, env=env, stdout=subprocess.DEVNULL)
    with open(out) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--warm", default="common")
    ap.add_argument("--bench", default="build/bench/bench_warmup")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        serial, parallel = os.path.join(tmp, "serial"), os.path.join(tmp, "parallel")
        cold1 = run(args.bench, serial, args.warm, 1, tmp, "cold1")
        disk1 = run(args.bench, serial, args.warm, 1, tmp, "disk1")
        cold2 = run(args.bench, parallel, args.warm, 2, tmp, "cold2")
        disk2 = run(args.bench, parallel, args.warm, 2, tmp, "disk2")
    load = os.getloadavg()
    print(f"--warm {args.warm}, {os.cpu_count()} cores, load average {load[0]:.2f} {load[1]:.2f} "
          f"{load[2]:.2f} at the end\n")
    print("| variant | cold compile s | disk-cache load s |")
    print("|---|---|---|")
    disk = {r["variant"]: r["seconds"] for r in disk1["rows"]}
    for r in cold1["rows"]:
        print(f"| {r['variant']} | {r['seconds']:.2f} | {disk[r['variant']]:.2f} |")
    print(f"| **all, serial (1 thread)** | {cold1['total_seconds']:.1f} | "
          f"{disk1['total_seconds']:.2f} |")
    print(f"| **all, parallel (2 threads, glintd)** | {cold2['total_seconds']:.1f} | "
          f"{disk2['total_seconds']:.2f} |")
    print(f"\nprograms compiled / loaded: cold {cold1['programs_compiled']}/"
          f"{cold1['programs_loaded']}, disk {disk1['programs_compiled']}/"
          f"{disk1['programs_loaded']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
