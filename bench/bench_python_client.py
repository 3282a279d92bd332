#!/usr/bin/env python3
"""Throughput of the Python client (client/python) against a running glintd: BRDF probe batches
(SMOOTH GGX, fp32) of several sizes, unary or streamed as the client decides, best of --repeat
runs. Reports wall time, queries/s and the client process's CPU time per query (numpy <->
protobuf conversion and gRPC), so client overhead can be told apart from the server's work.

    python bench/bench_python_client.py --server 127.0.0.1:50051 [--sizes 65536,1048576,4194304]
                                        [--repeat 3] [--json]

Needs the package installed (pip install ./client/python). --json: one JSON object per row.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

import glint

GGX = {"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.1, "schlick": {"f0": [0.9, 0.6, 0.3]}}


def directions(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 1e-3
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--server", default="127.0.0.1:50051")
    ap.add_argument("--sizes", default="65536,1048576,4194304")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    with glint.Client(args.server) as c:
        c.wait_until_serving(timeout=600)
        if not args.json:
            print(f"{'queries':>9} {'transport':>16} {'wall ms':>9} {'Mq/s':>7} {'client cpu ns/q':>16}")
        for n in (int(s) for s in args.sizes.split(",")):
            wo, wi = directions(rng, n), directions(rng, n)
            best = None
            for _ in range(args.repeat):
                w0, c0 = time.perf_counter(), time.process_time()
                c.evaluate(GGX, wo=wo, wi=wi)
                wall, cpu = time.perf_counter() - w0, time.process_time() - c0
                if best is None or wall < best[0]:
                    best = (wall, cpu)
            info = c.last_info
            transport = f"stream x{info.chunks}" if info.streamed else "unary"
            row = {"bench": "python_client_probe_fp32", "queries": n, "transport": transport,
                   "chunk_queries": info.chunk_queries, "wall_ms": best[0] * 1e3,
                   "queries_per_s": n / best[0], "client_cpu_ns_per_query": best[1] / n * 1e9}
            if args.json:
                print(json.dumps(row))
            else:
                print(f"{n:>9} {transport:>16} {row['wall_ms']:>9.1f} {row['queries_per_s'] / 1e6:>7.2f} "
                      f"{row['client_cpu_ns_per_query']:>16.0f}")


if __name__ == "__main__":
    main()
