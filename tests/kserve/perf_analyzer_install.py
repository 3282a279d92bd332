"""perf_analyzer for glintd: fetched from PyPI wheels into a cache directory, and its JSON
input data. Shared by tests/kserve/perf_analyzer_test.py and bench/kserve_perf_analyzer.py.

perf_analyzer comes from the tritonclient==2.34.0 manylinux wheel (its
tritonclient-2.34.0.data/data/bin/perf_analyzer); it links libb64 (Debian libb64-0d) and
libcudart.so.12, taken from the PyPI package nvidia-cuda-runtime-cu12 (no GPU is used). Where
they cannot be had (no package index, not Linux x86-64, libb64 missing) the caller exits 77
(ctest's skip code) with a message saying why.
"""
import json
import os
import platform
import stat
import subprocess
import sys
import zipfile

import numpy as np

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
