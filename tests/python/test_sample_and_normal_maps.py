"""Client.sample and Client.upload_normal_map against the C++ CLI (`glint sample`, `glint upload`):
two independent clients of one server give the same samples bit for bit and the same digest."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

import glint
from conftest import unit_vectors

GGX = {"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.15, "schlick": {"f0": [0.9, 0.6, 0.3]}}


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


def test_sample_equals_glint_sample_bit_for_bit(client, cli, tmp_path):
    rng = np.random.default_rng(11)
    n, k = 40, 16
    wo = unit_vectors(rng, n, min_z=0.05).astype(np.float32)
    got = client.sample(GGX, wo=wo, samples=k, seed=3)
    assert got.wi.shape == (n, k, 3) and got.pdf.shape == (n, k) and got.weight.shape == (n, k, 3)

    material = tmp_path / "ggx.json"
    material.write_text(__import__("json").dumps(GGX))
    queries = tmp_path / "q.csv"
    np.savetxt(queries, wo.astype(np.float64), fmt="%.9g", delimiter=",", header="wox,woy,woz", comments="")
    out = tmp_path / "s.csv"
    cmd = [cli.binary, "sample", "--server", cli.address, "--material", str(material), "--queries", str(queries),
           "--samples", str(k), "--seed", "3", "--out", str(out)]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    table = np.loadtxt(out, delimiter=",", skiprows=1)  # query,wix,wiy,wiz,pdf,r,g,b; %.9g round-trips
    assert table.shape == (n * k, 8)
    assert np.array_equal(table[:, 0].astype(int), np.repeat(np.arange(n), k))
    assert np.array_equal(_bits(got.wi.reshape(-1, 3)), _bits(table[:, 1:4].astype(np.float32)))
    assert np.array_equal(_bits(got.pdf.reshape(-1)), _bits(table[:, 4].astype(np.float32)))
    assert np.array_equal(_bits(got.weight.reshape(-1, 3)), _bits(table[:, 5:8].astype(np.float32)))
    assert np.count_nonzero(got.pdf) > n * k // 2  # not a comparison of empty samples


def test_sample_of_a_model_without_a_sampler_is_refused(client):
    binomial = {"model": "BINOMIAL", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.3, "schlick": {"f0": [1, 1, 1]},
                "binomial": {"density": 1e6}}
    with pytest.raises(glint.Error) as e:
        client.sample(binomial, wo=[0, 0, 1], uv=[0.5, 0.5], footprint=[1e-3, 0, 0, 1e-3], samples=4)
    assert e.value.code.name == "INVALID_ARGUMENT"
    assert "cannot be sampled" in e.value.details
    with pytest.raises(ValueError):
        client.sample(GGX, wo=[0, 0, 1], samples=0)


def test_upload_normal_map_gives_the_cli_digest_and_the_map_evaluates(client, cli, tmp_path):
    exr = tmp_path / "bumpy.exr"
    made = subprocess.run([cli.binary, "normal-map", "bumpy", "--size", "32", "--out", str(exr)],
                          capture_output=True, text=True)
    assert made.returncode == 0, made.stderr
    digest = client.upload_normal_map(exr)
    assert digest.startswith("sha256:") and len(digest) == len("sha256:") + 64
    up = subprocess.run([cli.binary, "upload", "--server", cli.address, str(exr)], capture_output=True, text=True)
    assert up.returncode == 0, up.stderr
    assert up.stdout.strip() == digest
    assert "already held" in up.stderr  # stored once
    # The digest `glint normal-map` prints is the one the server holds (bumpy and brushed maps'
    # generator floats are renormalised by the decoder: their digests used to differ).
    assert f"({digest})" in made.stderr, made.stderr
    brushed = tmp_path / "brushed.exr"
    made = subprocess.run([cli.binary, "normal-map", "brushed", "--size", "16", "--out", str(brushed)],
                          capture_output=True, text=True)
    assert made.returncode == 0, made.stderr
    assert f"({client.upload_normal_map(brushed)})" in made.stderr, made.stderr

    material = {"model": "NORMAL_MAP", "schlick": {"f0": [1, 1, 1]},
                "normal_map": {"digest": digest, "intrinsic_roughness": 0.05}}
    rng = np.random.default_rng(5)
    n = 256
    wo = unit_vectors(rng, n, min_z=0.2)
    rgb = client.evaluate(material, wo=wo, wi=wo * [-1, -1, 1], uv=rng.uniform(0, 1, (n, 2)),
                          footprint=[0.05, 0, 0, 0.05])
    assert np.isfinite(rgb).all() and (rgb >= 0).all() and (rgb > 0).any()

    bad = tmp_path / "bad.exr"
    bad.write_bytes(b"not an exr")
    with pytest.raises(glint.Error) as e:
        client.upload_normal_map(bad)
    assert e.value.code.name == "INVALID_ARGUMENT" and "bad.exr" in e.value.details
