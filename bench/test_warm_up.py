#!/usr/bin/env python3
"""bench_models' kernel warm-up in processes (ctest bench_models_warm_up; no timing asserted).

    test_warm_up.py BENCH_MODELS BENCH_TABLES_PY

Runs `bench_models --tiny` on SMOOTH probes, device path (schlick and conductor x fp32 and fp64:
four kernel variants),
twice, each on a fresh kernel cache: with --compile-jobs 2 (a compile child takes some variants,
this process loads them from the shared disk cache) and with --compile-jobs 1 (this process
compiles all four). Checks:
  - the JSON passes bench_tables.py --validate;
  - the processes warmed four variants, and this process built each program once: compiled
    plus loaded is 4, and with two processes at least one was loaded from the child's compile
    in the shared cache (PoCL's own cache on PoCL, program binaries elsewhere; a child that
    failed or never ran leaves this process compiling all four: loaded 0), and no child failed;
  - the rows' errors (against the fp64 host path) are the same numbers in both runs: kernels
    loaded from another process's compile compute the same bits as kernels compiled here.
"""

import json
import os
import shutil
import subprocess
import sys
import tempfile


def run(binary, jobs, workdir):
    cache = os.path.join(workdir, f"cache{jobs}")
    out = os.path.join(workdir, f"warm{jobs}.json")
    shutil.rmtree(cache, ignore_errors=True)
    cmd = [binary, "--tiny", "--models", "SMOOTH", "--lights", "probe", "--paths", "device",
           "--compile-jobs", str(jobs), "--cache-dir", cache, "--json", out]
    # PoCL's cache under the fresh --cache-dir too (bench_models points it there when unset): a
    # POCL_CACHE_DIR from the caller would hold the first run's compiles for the second.
    env = dict(os.environ)
    env.pop("POCL_CACHE_DIR", None)
    done = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                          env=env)
    if done.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({done.returncode}):\n{done.stderr}")
    with open(out, encoding="utf-8") as f:
        return out, json.load(f)


def main():
    binary, tables = sys.argv[1], sys.argv[2]
    failures = []
    with tempfile.TemporaryDirectory() as workdir:
        results = {}
        for jobs in (2, 1):
            path, doc = run(binary, jobs, workdir)
            if subprocess.run([sys.executable, tables, path, "--validate"]).returncode != 0:
                failures.append(f"--compile-jobs {jobs}: the JSON fails --validate")
            m = doc["machine"]
            warm = m["time_breakdown"]
            compiled, loaded = m["kernels_compiled"], m["kernels_from_cache"]
            print(f"--compile-jobs {jobs}: {warm['kernel_warm_up_variants']} variants in "
                  f"{warm['kernel_warm_up_processes']} processes; this process compiled "
                  f"{compiled}, loaded {loaded}")
            if warm["kernel_warm_up_variants"] != 4:
                failures.append(f"--compile-jobs {jobs}: {warm['kernel_warm_up_variants']} "
                                "variants warmed; expected 4")
            if warm["kernel_warm_up_child_failures"] != 0:
                failures.append(f"--compile-jobs {jobs}: "
                                f"{warm['kernel_warm_up_child_failures']} compile children failed")
            if warm["kernel_warm_up_processes"] != jobs:
                failures.append(f"--compile-jobs {jobs}: {warm['kernel_warm_up_processes']} "
                                "processes")
            if compiled + loaded != 4 or (loaded < 1 if jobs == 2 else loaded != 0):
                failures.append(f"--compile-jobs {jobs}: compiled {compiled}, loaded {loaded}")
            results[jobs] = {(r["variant"], r["precision"]): (r["error_mean"], r["error_p95"],
                                                              r["error_max"])
                             for r in doc["rows"]}
        if results[1] != results[2]:
            failures.append(f"errors differ: one process {results[1]}, two {results[2]}")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
