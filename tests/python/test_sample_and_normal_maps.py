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


def test_sample_calls_fit_a_server_with_a_small_message_limit(client, cli, tmp_path):
    """Both clients size Sample calls so that the request (the queries' arrays) and the reply (7
    floats per sample) each fit half of the smaller message limit, the server's included. Before,
    Client.sample ignored the request (K = 1 with a world frame: 72 bytes of queries for 28 of
    reply) and `glint sample` ignored the server's limit, so against `glintd --max-message-mb 1`
    both were refused with RESOURCE_EXHAUSTED. The samples must equal those of the default
    server, where fewer calls carry them: they depend on (seed, query, sample index) only."""
    from conftest import running_glintd

    rng = np.random.default_rng(5)
    n = 30000  # 2.2 MB of queries at K = 1: two of the small server's messages
    wo = unit_vectors(rng, n, min_z=0.05)
    # Every query array but wi: 72 bytes per query against 28 of reply at K = 1.
    frame = dict(position=rng.uniform(-5, 5, (n, 3)).astype(np.float32),
                 normal=np.tile(np.float32([0, 0, 1]), (n, 1)),
                 tangent=np.tile(np.float32([1, 0, 0]), (n, 1)),
                 uv=rng.uniform(0, 1, (n, 2)).astype(np.float32),
                 footprint=np.tile(np.float32([1e-3, 0, 0, 1e-3]), (n, 1)))
    expected_1 = client.sample(GGX, wo=wo, samples=1, seed=9, **frame)
    m, k = 2000, 64  # 3.6 MB of samples
    expected_64 = client.sample(GGX, wo=wo[:m], samples=k, seed=9)

    material = tmp_path / "ggx.json"
    material.write_text(__import__("json").dumps(GGX))
    queries = tmp_path / "q.csv"
    np.savetxt(queries, wo[:m].astype(np.float64), fmt="%.9g", delimiter=",", header="wox,woy,woz",
               comments="")
    out = tmp_path / "s.csv"
    with running_glintd("--max-message-mb", "1") as (address, _):
        with glint.Client(address) as small:
            got_1 = small.sample(GGX, wo=wo, samples=1, seed=9, **frame)
        cmd = [cli.binary, "sample", "--server", address, "--material", str(material), "--queries",
               str(queries), "--samples", str(k), "--seed", "9", "--out", str(out)]
        run = subprocess.run(cmd, capture_output=True, text=True)
    for name in ("wi", "pdf", "weight"):
        assert np.array_equal(_bits(getattr(got_1, name)), _bits(getattr(expected_1, name))), name
    assert run.returncode == 0, run.stderr
    table = np.loadtxt(out, delimiter=",", skiprows=1)
    assert table.shape == (m * k, 8)
    assert np.array_equal(_bits(expected_64.wi.reshape(-1, 3)), _bits(table[:, 1:4].astype(np.float32)))
    assert np.array_equal(_bits(expected_64.weight.reshape(-1, 3)), _bits(table[:, 5:8].astype(np.float32)))
    assert np.count_nonzero(expected_64.pdf) > m * k // 2


def test_empty_batches_give_empty_results_without_a_call(client):
    """N = 0 is an empty result, as numpy gives for empty arrays (before: evaluate was refused
    by the server, 'queries.count: 0', and sample raised 'range() arg 3 must not be zero')."""
    rgb = client.evaluate(GGX, wo=np.zeros((0, 3)), wi=np.zeros((0, 3)))
    assert rgb.shape == (0, 3) and rgb.dtype == np.float32
    s = client.sample(GGX, wo=np.zeros((0, 3)), samples=8)
    assert s.wi.shape == (0, 8, 3) and s.pdf.shape == (0, 8) and s.weight.shape == (0, 8, 3)


def test_out_of_range_integers_are_refused_naming_the_argument(client):
    """seed is a uint64 and samples a uint32 on the wire; protobuf's own error named neither."""
    with pytest.raises(ValueError, match=r"seed: -1; expected an integer in \[0, 2\^64\)"):
        client.evaluate(GGX, wo=[0, 0, 1], wi=[0, 0, 1], seed=-1)
    with pytest.raises(ValueError, match=r"samples: -1; expected an integer in \[0, 2\^32\)"):
        client.evaluate(GGX, wo=[0, 0, 1], wi=[0, 0, 1], samples=-1)
    with pytest.raises(ValueError, match=r"seed: 18446744073709551616"):
        client.sample(GGX, wo=[0, 0, 1], samples=4, seed=2**64)
