"""The Python client returns exactly what the C++ CLI (`glint eval`) returns for the same queries:
two independent clients of one server, compared bit for bit, through a unary call and through a
stream of many chunks (the server's determinism contract: results do not depend on batching)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import glint
from conftest import EXAMPLES, unit_vectors

N = 2000


def _bits(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=np.float32).view(np.uint32)


def _glint_footprints(rng: np.random.Generator, n: int) -> np.ndarray:
    # Jacobians spanning 1e-4 .. 1e-1 uv units per pixel, sheared: from a few facets per
    # footprint (sparkles) to many (the smooth limit).
    scale = 10.0 ** rng.uniform(-4, -1, size=(n, 1))
    return (scale * rng.uniform(-1, 1, size=(n, 4)) + scale * np.array([1, 0, 0, 1])).astype(np.float32)


def _frames(rng: np.random.Generator, n: int):
    """World-space shading frames around +z: positions near the origin, normals within ~60 deg
    of +z, tangents orthogonalised against them, and views above each surface."""
    position = rng.uniform(-0.5, 0.5, size=(n, 3)).astype(np.float32)
    normal = unit_vectors(rng, n, min_z=0.5)
    t = rng.normal(size=(n, 3))
    t -= np.sum(t * normal, axis=1, keepdims=True) * normal
    tangent = (t / np.linalg.norm(t, axis=1, keepdims=True)).astype(np.float32)
    wo = unit_vectors(rng, n)
    below = np.sum(wo * normal, axis=1) < 0.05
    wo[below] = normal[below]
    return position, normal, tangent, wo


def _around(rng: np.random.Generator, n: int, center, spread: float) -> np.ndarray:
    """Unit views scattered around `center` (so that a small light's glints are in view), kept
    above the horizon."""
    v = np.asarray(center, dtype=np.float64) + spread * rng.normal(size=(n, 3))
    v[:, 2] = np.maximum(np.abs(v[:, 2]), 0.05)
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


# name -> (material file, lights file or None, queries builder, CLI flags / client kwargs)
def _case(name: str, rng: np.random.Generator):
    uv = rng.uniform(-4, 4, size=(N, 2)).astype(np.float32)
    if name == "probes":
        return ("gold_aniso.json", None, dict(uv=uv, wo=unit_vectors(rng, N, 0.0), wi=unit_vectors(rng, N, 0.0)), {})
    if name == "probes_fp64":
        return ("plastic_beckmann.json", None,
                dict(wo=unit_vectors(rng, N, 0.0), wi=unit_vectors(rng, N, 0.0)), {"precision": "fp64"})
    if name == "lights":
        return ("paint_schlick.json", "studio.json", dict(uv=uv, wo=unit_vectors(rng, N, 0.0)), {})
    if name == "area_mc":
        return ("gold_aniso.json", "softbox.json", dict(wo=unit_vectors(rng, N, 0.0)),
                {"area_method": "mc", "samples": 16, "seed": 3})
    if name == "binomial_uv_footprint":
        return ("sparkle_binomial.json", "rect_small.json",
                dict(uv=uv, footprint=_glint_footprints(rng, N), wo=_around(rng, N, [0, -0.85, 0.53], 0.3)),
                {"seed": 7})
    if name == "chermain_world_frames":
        p, n, t, wo = _frames(rng, N)
        return ("sparkle_chermain.json", "sun.json",
                dict(uv=uv, footprint=_glint_footprints(rng, N), wo=wo, position=p, normal=n, tangent=t), {"seed": 11})
    if name == "kemppinen_world_frames":
        p, n, t, wo = _frames(rng, N)
        return ("carpaint_kemppinen.json", "rect_large.json",
                dict(uv=uv, footprint=_glint_footprints(rng, N), wo=wo, position=p, normal=n, tangent=t), {})
    raise KeyError(name)


CASES = ["probes", "probes_fp64", "lights", "area_mc", "binomial_uv_footprint", "chermain_world_frames",
         "kemppinen_world_frames"]


def _cli_flags(kwargs):
    flags = []
    if "precision" in kwargs:
        flags += ["--precision", kwargs["precision"]]
    if "seed" in kwargs:
        flags += ["--seed", str(kwargs["seed"])]
    if "area_method" in kwargs:
        flags += ["--area-method", kwargs["area_method"]]
    if "samples" in kwargs:
        flags += ["--samples", str(kwargs["samples"])]
    return flags


@pytest.fixture(scope="module")
def cli_results(cli):
    """Each case evaluated once by the CLI (one unary call each)."""
    out = {}
    for i, name in enumerate(CASES):
        material, lights, arrays, kwargs = _case(name, np.random.default_rng(1000 + i))
        out[name] = cli.eval(EXAMPLES / "materials" / material,
                             None if lights is None else EXAMPLES / "lights" / lights, arrays, *_cli_flags(kwargs))
    return out


@pytest.mark.parametrize("transport", ["unary", "stream"])
@pytest.mark.parametrize("name", CASES)
def test_equals_cli_bit_for_bit(name, transport, server_address, cli_results):
    material, lights, arrays, kwargs = _case(name, np.random.default_rng(1000 + CASES.index(name)))
    # 333 queries per chunk: 7 chunks whose boundaries fall inside every array's rows.
    with glint.Client(server_address, max_chunk_queries=333 if transport == "stream" else 0) as c:
        rgb = c.evaluate(EXAMPLES / "materials" / material, lights=None if lights is None else EXAMPLES / "lights" / lights,
                         **arrays, **kwargs)
        assert c.last_info.streamed == (transport == "stream")
        assert c.last_info.chunks == (7 if transport == "stream" else 1)
    expected = cli_results[name]
    assert rgb.shape == (N, 3) and rgb.dtype == np.float32
    assert expected.shape == (N, 3) and expected.dtype == np.float32
    # Zeros equal to zeros would prove little: most queries of every case carry light.
    assert np.count_nonzero(expected.any(axis=1)) > N // 10
    mismatch = np.flatnonzero((_bits(rgb) != _bits(expected)).any(axis=1))
    assert mismatch.size == 0, (
        f"{mismatch.size} of {N} queries differ from the CLI, first {mismatch[0]}: "
        f"{rgb[mismatch[0]]} vs {expected[mismatch[0]]}"
    )


def test_dicts_and_messages_equal_files(client, cli_results):
    """Materials and lights given as proto3-JSON dicts (json.load of the CLI's files) or as the
    generated messages evaluate to the same bits as the file paths."""
    material, lights, arrays, kwargs = _case("lights", np.random.default_rng(1000 + CASES.index("lights")))
    m = json.loads((EXAMPLES / "materials" / material).read_text())
    l = json.loads((EXAMPLES / "lights" / lights).read_text())
    from google.protobuf import json_format

    as_dicts = client.evaluate(m, lights=l, **arrays, **kwargs)
    as_light_list = client.evaluate(m, lights=l["lights"], **arrays, **kwargs)
    as_messages = client.evaluate(json_format.ParseDict(m, glint.pb.Material()),
                                  lights=json_format.ParseDict(l, glint.pb.LightList()), **arrays, **kwargs)
    for got in (as_dicts, as_light_list, as_messages):
        assert np.array_equal(_bits(got), _bits(cli_results["lights"]))


def test_both_clients_stream_a_large_batch_alike(client, cli, tmp_path):
    """A batch over the 8 MiB message budget: both clients stream it in the same chunks (the same
    sizing rule) and get the same bits, with a non-default area method and sample count that the
    first chunk must carry (the C++ client once dropped it from streams)."""
    rng = np.random.default_rng(77)
    # Every array but wi: 72 bytes per query, so chunks of 116,447 queries and 2 chunks here.
    n = 125_000
    p, nrm, t, wo = _frames(rng, n)
    arrays = dict(uv=rng.uniform(-4, 4, size=(n, 2)).astype(np.float32), footprint=_glint_footprints(rng, n),
                  wo=wo, wi=None, position=p, normal=nrm, tangent=t)
    softbox = json.loads((EXAMPLES / "lights" / "softbox.json").read_text())
    lights = tmp_path / "polygon.json"  # the softbox's polygon alone
    lights.write_text(json.dumps({"lights": [l for l in softbox["lights"] if "polygon" in l]}))
    material = EXAMPLES / "materials" / "gold_aniso.json"
    # Monte Carlo with 4 samples: area method, sample count and seed must all reach the server.
    # --transport tcp: on loopback the CLI would otherwise use shared memory (no chunks to compare).
    expected = cli.eval(material, lights, arrays, "--area-method", "mc", "--samples", "4", "--seed", "5",
                        "--transport", "tcp")
    rgb = client.evaluate(material, lights=lights, area_method="mc", samples=4, seed=5, **arrays)
    assert client.last_info.streamed and client.last_info.chunks == 2
    assert f"via stream (2 chunks of <= {client.last_info.chunk_queries} queries)" in cli.last_stdout
    head = {k: v[:1000] for k, v in arrays.items() if v is not None}
    ltc = client.evaluate(material, lights=lights, **head)
    assert not np.array_equal(_bits(ltc), _bits(expected[:1000]))  # the setting matters here
    assert np.count_nonzero(expected.any(axis=1)) > n // 10
    assert np.array_equal(_bits(rgb), _bits(expected))
