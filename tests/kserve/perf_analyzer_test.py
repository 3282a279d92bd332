"""Triton's perf_analyzer load-tests glintd over the Open Inference Protocol, unchanged.

perf_analyzer and its libcudart are fetched once into CACHE_DIR (in the build directory) by
perf_analyzer_install.py; the test exits 77 (skip) with a message where they cannot be had.

It starts glintd with one model, runs perf_analyzer at concurrency 1 to 4 against it on
loopback, and checks that perf_analyzer exits 0, reports a positive throughput for every
concurrency, saw only successful requests on the server side, and printed no error.

usage: perf_analyzer_test.py GLINTD EXAMPLES_DIR CACHE_DIR   (run by tests/kserve/python_env.sh)
"""
import os
import re
import subprocess
import sys

from glintd_server import Glintd
from perf_analyzer_install import install, write_input_data


def main():
    glintd, examples, cache = sys.argv[1:4]
    perf_analyzer, env = install(cache)
    data = os.path.join(cache, "wo_4096.json")
    write_input_data(data, 4096)
    model = (f"paint={examples}/materials/paint_schlick.json,"
             f"{examples}/lights/studio.json")
    with Glintd(glintd, ["--model", model]) as server:
        # -s 100: on a loaded 2-core machine latency varies by more than the default 10 %
        # between windows; this test checks that the protocol works, not a stable number.
        cmd = [perf_analyzer, "-m", "paint", "-i", "grpc", "-u", server.address,
               "--input-data", data, "--concurrency-range", "1:4",
               "--measurement-interval", "2000", "-s", "100", "--max-trials", "10"]
        print(" ".join(cmd), flush=True)
        try:
            run = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
        except subprocess.TimeoutExpired:
            print("FAIL: perf_analyzer did not finish within 300 s")
            return 1
        print(run.stdout + run.stderr)
        failures = []
        if run.returncode != 0:
            failures.append(f"perf_analyzer exited {run.returncode}")
        out = run.stdout + run.stderr
        for line in out.splitlines():
            if re.search(r"error|fail", line, re.IGNORECASE):
                failures.append("perf_analyzer printed: " + line.strip())
        throughput = {int(c): float(t) for c, t in re.findall(
            r"^Concurrency: (\d+), throughput: ([0-9.]+) infer/sec", out, re.MULTILINE)}
        if sorted(throughput) != [1, 2, 3, 4] or min(throughput.values(), default=0) <= 0:
            failures.append(f"throughput per concurrency: {throughput}; expected > 0 for 1..4")
        served = [int(n) for n in re.findall(r"Successful request count: (\d+)", out)]
        counted = [int(n) for n in re.findall(r"Inference count: (\d+)", out)]
        if len(served) != 4 or served != counted or min(served, default=0) <= 0:
            failures.append(f"server-side successful requests {served} vs inferences {counted}")
        for f in failures:
            print("FAIL: " + f)
        if failures:
            print(server.log())
        return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
