"""Fixtures of the Python client tests: a real glintd on a free loopback port, the glint CLI as
an independent client to compare with, and query generators.

run_python_tests.sh sets GLINTD, GLINT_CLI and GLINT_SOURCE_DIR and runs pytest in a fresh venv
where client/python is installed.
"""

from __future__ import annotations

import contextlib
import os
import pathlib
import subprocess
import tempfile
import time
from typing import Dict, Optional

import numpy as np
import pytest

SOURCE_DIR = pathlib.Path(os.environ.get("GLINT_SOURCE_DIR", pathlib.Path(__file__).parents[2]))
EXAMPLES = SOURCE_DIR / "examples"
# glintd compiles and warms its kernels before it writes --port-file; with a cold kernel cache on
# a loaded 2-core machine that has taken minutes (scripts/demo.sh waits 600 s).
SERVER_START_TIMEOUT_S = 600


def _require_env(name: str) -> str:
    value = os.environ.get(name)
    if not value:
        pytest.fail(f"{name} is not set: run the suite through tests/python/run_python_tests.sh")
    return value


@contextlib.contextmanager
def running_glintd(*flags: str):
    """A glintd on a free loopback port with `flags`; yields (address, process) once SERVING."""
    glintd = _require_env("GLINTD")
    with tempfile.TemporaryDirectory(prefix="glint_py_") as tmp:
        port_file = pathlib.Path(tmp) / "port"
        log_path = pathlib.Path(tmp) / "glintd.log"
        with open(log_path, "wb") as log:
            proc = subprocess.Popen(
                [glintd, "--listen", "127.0.0.1:0", "--port-file", str(port_file), "--quiet", *flags],
                stdout=log,
                stderr=subprocess.STDOUT,
            )
        try:
            deadline = time.monotonic() + SERVER_START_TIMEOUT_S
            while not (port_file.exists() and port_file.read_text().strip()):
                if proc.poll() is not None:
                    pytest.fail(f"glintd exited with {proc.returncode}:\n{log_path.read_text()}")
                if time.monotonic() > deadline:
                    pytest.fail(f"glintd not SERVING after {SERVER_START_TIMEOUT_S} s:\n{log_path.read_text()}")
                time.sleep(0.1)
            yield f"127.0.0.1:{port_file.read_text().strip()}", proc
        finally:
            proc.terminate()
            try:
                proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


@pytest.fixture(scope="session")
def server_address():
    with running_glintd() as (address, _):
        yield address


@pytest.fixture(scope="session")
def client(server_address):
    import glint

    with glint.Client(server_address) as c:
        # The server is SERVING (it wrote its port file), but the calls of the library fail fast
        # (no wait_for_ready): a first connection attempt that fails on a loaded machine would
        # fail the first test's call with UNAVAILABLE. wait_until_serving retries until the
        # channel is connected and the server answers, so the tests start on a ready channel.
        c.wait_until_serving(timeout=SERVER_START_TIMEOUT_S)
        yield c


# CSV columns of `glint eval --queries` per query array, in the order the CLI documents.
CSV_COLUMNS = {
    "uv": ["u", "v"],
    "footprint": ["dudx", "dvdx", "dudy", "dvdy"],
    "wo": ["wox", "woy", "woz"],
    "wi": ["wix", "wiy", "wiz"],
    "position": ["px", "py", "pz"],
    "normal": ["nx", "ny", "nz"],
    "tangent": ["tx", "ty", "tz"],
}


class Cli:
    """`glint eval` of the C++ CLI: the same queries written as CSV, radiance read from .npy."""

    def __init__(self, binary: str, address: str, tmp: pathlib.Path):
        self.binary = binary
        self.address = address
        self.tmp = tmp
        self.calls = 0
        self.last_stdout = ""

    def eval(self, material: pathlib.Path, lights: Optional[pathlib.Path], arrays: Dict[str, np.ndarray],
             *extra: str) -> np.ndarray:
        self.calls += 1
        csv = self.tmp / f"q{self.calls}.csv"
        out = self.tmp / f"r{self.calls}.npy"
        names = [n for n in CSV_COLUMNS if arrays.get(n) is not None]
        table = np.concatenate([np.asarray(arrays[n], dtype=np.float32) for n in names], axis=1)
        header = ",".join(c for n in names for c in CSV_COLUMNS[n])
        # 9 significant digits read back as the same float32 (the CLI parses with from_chars).
        np.savetxt(csv, table.astype(np.float64), fmt="%.9g", delimiter=",", header=header, comments="")
        cmd = [self.binary, "eval", "--server", self.address, "--material", str(material),
               "--queries", str(csv), "--out", str(out), *extra]
        if lights is not None:
            cmd += ["--lights", str(lights)]
        run = subprocess.run(cmd, capture_output=True, text=True)
        assert run.returncode == 0, f"{' '.join(cmd)} failed:\n{run.stdout}{run.stderr}"
        self.last_stdout = run.stdout
        return np.load(out)


@pytest.fixture(scope="session")
def cli(server_address, tmp_path_factory):
    return Cli(_require_env("GLINT_CLI"), server_address, tmp_path_factory.mktemp("cli"))


def unit_vectors(rng: np.random.Generator, n: int, min_z: Optional[float] = None) -> np.ndarray:
    """n unit vectors, uniform on the sphere, or on the cap z >= min_z (mirrored into the upper
    hemisphere, then rejection)."""
    out = np.empty((0, 3))
    while len(out) < n:
        v = rng.normal(size=(2 * n, 3))
        v /= np.linalg.norm(v, axis=1, keepdims=True)
        if min_z is not None:
            v[:, 2] = np.abs(v[:, 2])
            v = v[v[:, 2] >= min_z]
        out = np.concatenate([out, v])
    return out[:n].astype(np.float32)
