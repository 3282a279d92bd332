"""Triton's perf_analyzer load-tests glintd over the Open Inference Protocol, unchanged.

perf_analyzer comes from the tritonclient==2.34.0 manylinux wheel on PyPI (its
tritonclient-2.34.0.data/data/bin/perf_analyzer); it links libb64 (Debian libb64-0d) and
libcudart.so.12, taken from the PyPI package nvidia-cuda-runtime-cu12 (no GPU is used). Both
wheels are downloaded once into CACHE_DIR (in the build directory). The test exits 77 (skip)
with a message where they cannot be had: no package index, not Linux x86-64, libb64 missing.

It starts glintd with one model, runs perf_analyzer at concurrency 1 to 4 against it on
loopback, and checks that perf_analyzer exits 0, reports a positive throughput for every
concurrency, saw only successful requests on the server side, and printed no error.

usage: perf_analyzer_test.py GLINTD EXAMPLES_DIR CACHE_DIR   (run by tests/kserve/python_env.sh)
"""
import json
import os
import platform
import re
import stat
import subprocess
import sys
import zipfile

import numpy as np

from glintd_server import Glintd

TRITONCLIENT = "tritonclient==2.34.0"
PERF_ANALYZER_MEMBER = "tritonclient-2.34.0.data/data/bin/perf_analyzer"
CUDART = "nvidia-cuda-runtime-cu12==12.9.79"
CUDART_MEMBER = "nvidia/cuda_runtime/lib/libcudart.so.12"
SKIP = 77


def skip(why):
    print("SKIP: " + why)
    sys.exit(SKIP)


def fetch(requirement, wheel_platform, member, target, cache):
    """Extracts `member` of the wheel of `requirement` to `target`, downloading it once."""
    if os.path.exists(target):
        return
    wheels = os.path.join(cache, "wheels")
    cmd = [sys.executable, "-m", "pip", "download", "--disable-pip-version-check", "-q",
           "--no-deps", "--only-binary=:all:", "--platform", wheel_platform,
           "--python-version", "3.11", "--timeout", "30", "-d", wheels, requirement]
    if subprocess.run(cmd).returncode != 0:
        skip(f"pip could not download {requirement} (no package index reachable?)")
    name = requirement.split("==")[0].replace("-", "_")
    version = requirement.split("==")[1]
    found = [w for w in os.listdir(wheels) if w.startswith(f"{name}-{version}-")]
    if not found:
        skip(f"no wheel of {requirement} for {wheel_platform} in {wheels}")
    with zipfile.ZipFile(os.path.join(wheels, found[0])) as z:
        data = z.read(member)
    os.makedirs(os.path.dirname(target), exist_ok=True)
    with open(target + ".tmp", "wb") as f:
        f.write(data)
    os.chmod(target + ".tmp", stat.S_IRWXU | stat.S_IRGRP | stat.S_IXGRP)
    os.replace(target + ".tmp", target)


def install(cache):
    if platform.system() != "Linux" or platform.machine() != "x86_64":
        skip("the perf_analyzer of the tritonclient wheel is built for Linux x86-64 only")
    perf_analyzer = os.path.join(cache, "bin", "perf_analyzer")
    cudart = os.path.join(cache, "lib", "libcudart.so.12")
    fetch(TRITONCLIENT, "manylinux1_x86_64", PERF_ANALYZER_MEMBER, perf_analyzer, cache)
    fetch(CUDART, "manylinux2014_x86_64", CUDART_MEMBER, cudart, cache)
    env = dict(os.environ, LD_LIBRARY_PATH=os.path.dirname(cudart))
    ldd = subprocess.run(["ldd", perf_analyzer], env=env, capture_output=True, text=True)
    missing = [line.split()[0] for line in ldd.stdout.splitlines() if "not found" in line]
    if missing:
        skip("perf_analyzer needs " + ", ".join(missing) +
             " (libb64.so.0d: apt-get install libb64-0d; scripts/install-deps.sh does)")
    return perf_analyzer, env


def write_input_data(path, rows):
    """perf_analyzer's JSON input data: wo, unit vectors (its default random bytes would be
    refused by validation, which is the point of validation)."""
    rng = np.random.default_rng(1)
    z = rng.uniform(0.2, 1.0, rows)
    phi = rng.uniform(0, 2 * np.pi, rows)
    r = np.sqrt(1 - z * z)
    wo = np.stack([r * np.cos(phi), r * np.sin(phi), z], 1).astype(np.float32)
    with open(path, "w") as f:
        json.dump({"data": [{"wo": {"content": wo.ravel().tolist(), "shape": [rows, 3]}}]}, f)


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
