"""glint.Client against a real glintd: a closed form, the server's refusals as glint.Error, a
4 M-query batch streamed in chunks, progress reporting and argument handling."""

from __future__ import annotations

import grpc
import numpy as np
import pytest

import glint
from conftest import unit_vectors

GGX = {"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.1, "schlick": {"f0": [0.9, 0.6, 0.3]}}
F32_U = 2.0**-24  # unit roundoff of float32


def test_capabilities(client):
    caps = client.capabilities()
    assert isinstance(caps, glint.pb.Capabilities)
    assert "SMOOTH" in caps.models and caps.max_batch > 0 and caps.max_message_bytes > 0


def test_probe_at_normal_incidence_is_the_closed_form(client):
    """wo = wi = n: F = f0 (Schlick at cos 1), D = 1 / (pi ax ay) (GGX at the normal), G2 = 1, so
    f cos_i = f0 D / (4 cos_o) = f0 / (4 pi ax ay), per RGB channel in that order. fp32 kernels:
    a few dozen roundings, well inside 64 u."""
    rgb = client.evaluate(GGX, wo=[[0, 0, 1]] * 5, wi=[[0, 0, 1]] * 5)
    expected = np.array([0.9, 0.6, 0.3]) / (4 * np.pi * 0.3 * 0.1)
    assert rgb.shape == (5, 3) and rgb.dtype == np.float32
    np.testing.assert_allclose(rgb, np.broadcast_to(expected, (5, 3)), rtol=64 * F32_U, atol=0)


def test_one_vector_is_broadcast_to_every_query(client):
    rng = np.random.default_rng(5)
    wi = unit_vectors(rng, 100, 0.0)
    wo = np.array([0.3, -0.2, np.sqrt(1 - 0.13)], dtype=np.float32)
    shared = client.evaluate(GGX, wo=wo, wi=wi)
    tiled = client.evaluate(GGX, wo=np.tile(wo, (100, 1)), wi=wi)
    assert np.array_equal(shared.view(np.uint32), tiled.view(np.uint32))


def _expect_error(fn, code, *fragments):
    with pytest.raises(glint.Error) as info:
        fn()
    e = info.value
    assert e.code == code, str(e)
    for fragment in fragments:
        assert fragment in e.details, f"'{fragment}' not in '{e.details}'"
    assert str(e).startswith(code.name)
    return e


def test_invalid_query_names_field_and_index(client):
    wo = np.tile(np.float32([0, 0, 1]), (40, 1))
    wo[17] = [np.nan, 0, 1]
    _expect_error(lambda: client.evaluate(GGX, wo=wo, wi=[0, 0, 1]), grpc.StatusCode.INVALID_ARGUMENT, "queries.wo[17]")


def test_invalid_query_in_a_stream_names_chunk_and_global_index(server_address):
    wo = np.tile(np.float32([0, 0, 1]), (1000, 1))
    wo[250] = [0, 0, 2]  # not unit
    with glint.Client(server_address, max_chunk_queries=100) as c:
        _expect_error(lambda: c.evaluate(GGX, wo=wo, wi=[0, 0, 1]), grpc.StatusCode.INVALID_ARGUMENT,
                      "chunk 2:", "queries.wo[250]")


def test_invalid_frame_names_field_and_index(client):
    n = 10
    normal = np.tile(np.float32([0, 0, 1]), (n, 1))
    normal[5] = [0, 0, 1.5]
    _expect_error(
        lambda: client.evaluate(GGX, wo=[0, 0, 1], wi=[0, 0, 1], position=np.zeros((n, 3)), normal=normal,
                                tangent=[1, 0, 0]),
        grpc.StatusCode.INVALID_ARGUMENT, "normal[5]")


def test_invalid_material_and_lights_are_refused(client):
    bad = dict(GGX, alpha_x=1e-5)
    _expect_error(lambda: client.evaluate(bad, wo=[0, 0, 1], wi=[0, 0, 1]), grpc.StatusCode.INVALID_ARGUMENT,
                  "material.alpha_x")
    sun = {"lights": [{"directional": {"direction": [0, 0, 1], "irradiance": [1, 1, 1]}}]}
    # A probe batch (wi) must not carry lights.
    e = _expect_error(lambda: client.evaluate(GGX, wo=[0, 0, 1], wi=[0, 0, 1], lights=sun),
                      grpc.StatusCode.INVALID_ARGUMENT)
    assert "light" in e.details


def test_arguments_that_cannot_form_a_request(client):
    with pytest.raises(ValueError, match=r"wi: expected an array of shape \(N, 3\)"):
        client.evaluate(GGX, wo=[[0, 0, 1]], wi=[[0, 1]])
    with pytest.raises(ValueError, match="disagree"):
        client.evaluate(GGX, wo=np.zeros((3, 3)), wi=np.zeros((4, 3)))
    with pytest.raises(ValueError, match="material.*alpha_z"):  # typo: unknown fields are refused
        client.evaluate(dict(GGX, alpha_z=0.1), wo=[0, 0, 1], wi=[0, 0, 1])
    with pytest.raises(ValueError, match="area_method: 'ltcx'"):
        client.evaluate(GGX, wo=[0, 0, 1], wi=[0, 0, 1], area_method="ltcx")
    with pytest.raises(ValueError, match="precision"):
        client.evaluate(GGX, wo=[0, 0, 1], wi=[0, 0, 1], precision="fp16")
    with pytest.raises(ValueError, match="cannot read .*no_such.json"):
        client.evaluate("no_such.json", wo=[0, 0, 1], wi=[0, 0, 1])


def test_unreachable_server_is_unavailable():
    import socket

    with socket.socket() as s:  # a port nobody listens on: bound, never listening
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
        with glint.Client(f"127.0.0.1:{port}", timeout=5) as c:
            _expect_error(c.capabilities, grpc.StatusCode.UNAVAILABLE)


def test_four_million_queries_stream_in_chunks(client):
    """4 Mi BRDF probes (fp32) in one call: streamed in the chunk size the C++ client would pick,
    results in query order. The batch repeats a block of 997 queries (a prime, so chunk
    boundaries fall at every phase of it); each query is evaluated independently, so the result
    must be the block's own unary result repeated, bit for bit."""
    rng = np.random.default_rng(42)
    period = 997
    wo, wi = unit_vectors(rng, period, 0.0), unit_vectors(rng, period, 0.0)
    block = client.evaluate(GGX, wo=wo, wi=wi)
    assert not client.last_info.streamed

    n = 4 << 20
    reps = -(-n // period)
    seen = []
    rgb = client.evaluate(GGX, wo=np.tile(wo, (reps, 1))[:n], wi=np.tile(wi, (reps, 1))[:n],
                          progress=lambda done, total: seen.append((done, total)))
    info = client.last_info
    caps = client.capabilities()
    # Same sizing rule as client/lib/glint_client.cpp: min(half the message limit, 8 MiB) minus
    # settings and envelope, over 24 bytes per query (wo + wi), capped at max_batch.
    budget = min(caps.max_message_bytes // 2, 8 << 20)
    settings = glint.pb.Material()
    from google.protobuf import json_format

    json_format.ParseDict(GGX, settings)
    assert info.streamed
    assert info.chunk_queries == min((budget - settings.ByteSize() - 4096) // 24, caps.max_batch)
    assert info.chunks == -(-n // info.chunk_queries) > 1
    assert [d for d, _ in seen] == [min((k + 1) * info.chunk_queries, n) for k in range(info.chunks)]
    assert all(t == n for _, t in seen)
    expected = np.tile(block, (reps, 1))[:n]
    assert rgb.shape == (n, 3)
    mismatch = np.flatnonzero((rgb.view(np.uint32) != expected.view(np.uint32)).any(axis=1))
    assert mismatch.size == 0, f"{mismatch.size} queries differ, first {mismatch[0]}"


def test_tqdm_progress_bar(client, capsys):
    pytest.importorskip("tqdm")
    with glint.Client(client.address, max_chunk_queries=50) as c:
        c.evaluate(GGX, wo=unit_vectors(np.random.default_rng(1), 200, 0.0), wi=[0, 0, 1], progress=True)
        assert c.last_info.chunks == 4
    assert "200/200" in capsys.readouterr().err


def test_wait_until_serving(client):
    client.wait_until_serving(timeout=30)  # the fixture's server is SERVING: returns at once


def test_wait_until_serving_gives_up_on_a_dead_address():
    """Checked by what it raises, not by how long it took: "not SERVING after 1.5 s" is only said
    once the wait reached its timeout, and the last attempt's UNAVAILABLE says why. A call that
    never returned would be caught by the suite's ctest TIMEOUT."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))  # bound, never listening: connections are refused
        with glint.Client(f"127.0.0.1:{s.getsockname()[1]}") as c:
            _expect_error(lambda: c.wait_until_serving(timeout=1.5), grpc.StatusCode.DEADLINE_EXCEEDED,
                          "not SERVING after 1.5 s", "UNAVAILABLE")


def test_an_exception_in_progress_cancels_the_stream(server_address):
    """A callback that raises (as KeyboardInterrupt would) ends the stream at once; the error
    reaches the caller unchanged and the client stays usable."""
    wi = unit_vectors(np.random.default_rng(2), 500, 0.0)
    calls = []

    def stop(done, total):
        calls.append(done)
        raise RuntimeError("stop here")

    with glint.Client(server_address, max_chunk_queries=50) as c:
        with pytest.raises(RuntimeError, match="stop here"):
            c.evaluate(GGX, wo=[0, 0, 1], wi=wi, progress=stop)
        assert calls == [50]
        rgb = c.evaluate(GGX, wo=[0, 0, 1], wi=wi)
        assert c.last_info.chunks == 10 and rgb.shape == (500, 3)
