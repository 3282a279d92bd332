"""Client.upload_normal_map retries the server's pushback as the C++ client does
(client/lib/retry.h, client/python/glint/_retry.py): RESOURCE_EXHAUSTED with the trailing metadata
glint-retry-pushback-ms (glintd's upload gate is full: server/upload_gate.h) and UNAVAILABLE are
retried, after at least the pushback and at most max_attempts attempts in all; RESOURCE_EXHAUSTED
without it (a limit the same upload exceeds again) is raised at once.

The server is an in-process gRPC GlintService whose UploadNormalMap refuses a scripted number of
attempts and then answers: it counts the attempts and the bytes each one carried, independently
of the client's own bookkeeping. The waits are recorded instead of slept (no wall-clock)."""

from __future__ import annotations

import concurrent.futures
import threading

import grpc
import pytest

import glint
import glint._retry
from glint.v1 import glint_pb2 as pb
from glint.v1 import glint_pb2_grpc as pb_grpc

DIGEST = "sha256:" + "ab" * 32


class ScriptedUploads(pb_grpc.GlintServiceServicer):
    """Refuses the first len(refusals) attempts with (code, pushback_ms or None), then answers."""

    def __init__(self, refusals):
        self.refusals = list(refusals)
        self.attempts = []  # bytes received by each attempt
        self.lock = threading.Lock()

    def UploadNormalMap(self, request_iterator, context):
        data = b"".join(chunk.data for chunk in request_iterator)
        with self.lock:
            self.attempts.append(data)
            n = len(self.attempts)
        if n <= len(self.refusals):
            code, pushback_ms = self.refusals[n - 1]
            if pushback_ms is not None:
                context.set_trailing_metadata(((glint._retry.PUSHBACK_METADATA, str(pushback_ms)),))
            context.abort(code, f"refusal {n}")
        return pb.NormalMapInfo(digest=DIGEST, width=4, height=4)


@pytest.fixture
def fake_server():
    servers = []

    def start(refusals):
        servicer = ScriptedUploads(refusals)
        server = grpc.server(concurrent.futures.ThreadPoolExecutor(max_workers=2))
        pb_grpc.add_GlintServiceServicer_to_server(servicer, server)
        port = server.add_insecure_port("127.0.0.1:0")
        server.start()
        servers.append(server)
        return f"127.0.0.1:{port}", servicer

    yield start
    for server in servers:
        server.stop(None)


@pytest.fixture
def waits(monkeypatch):
    recorded = []
    monkeypatch.setattr(glint._retry, "_sleep", recorded.append)
    return recorded


@pytest.fixture
def map_file(tmp_path):
    path = tmp_path / "map.exr"
    path.write_bytes(bytes(range(256)) * 9000)  # > 2 chunks of 1 MiB: every attempt resends all
    return path


BUSY = (grpc.StatusCode.RESOURCE_EXHAUSTED, 250)


def test_pushback_is_retried_after_at_least_its_wait(fake_server, waits, map_file):
    address, server = fake_server([BUSY, BUSY])
    with glint.Client(address) as c:
        assert c.upload_normal_map(map_file) == DIGEST
    assert len(server.attempts) == 3
    assert all(a == map_file.read_bytes() for a in server.attempts)
    # Each wait is the larger of the jitter (at most the 0.1 s then 0.2 s ceilings) and 0.25 s.
    assert waits == [0.25, 0.25]


def test_unavailable_is_retried_with_jittered_backoff(fake_server, waits, map_file):
    address, server = fake_server([(grpc.StatusCode.UNAVAILABLE, None)] * 3)
    with glint.Client(address) as c:
        assert c.upload_normal_map(map_file) == DIGEST
    assert len(server.attempts) == 4
    assert len(waits) == 3
    for n, w in enumerate(waits, start=1):  # uniform(0, min(2, 0.1 x 2^(n-1)))
        assert 0.0 <= w <= 0.1 * 2 ** (n - 1)


def test_resource_exhausted_without_pushback_is_raised_at_once(fake_server, waits, map_file):
    address, server = fake_server([(grpc.StatusCode.RESOURCE_EXHAUSTED, None)])
    with glint.Client(address) as c, pytest.raises(glint.Error) as e:
        c.upload_normal_map(map_file)
    assert e.value.code == grpc.StatusCode.RESOURCE_EXHAUSTED and e.value.details == "refusal 1"
    assert len(server.attempts) == 1 and waits == []


def test_malformed_pushback_is_no_pushback(fake_server, waits, map_file):
    address, server = fake_server([(grpc.StatusCode.RESOURCE_EXHAUSTED, "-5")])
    with glint.Client(address) as c, pytest.raises(glint.Error):
        c.upload_normal_map(map_file)
    assert len(server.attempts) == 1 and waits == []


def test_attempts_are_bounded_by_the_policy(fake_server, waits, map_file):
    address, server = fake_server([BUSY] * 10)
    with glint.Client(address) as c, pytest.raises(glint.Error) as e:
        c.upload_normal_map(map_file)
    assert e.value.details == "refusal 5"  # the default policy: 5 attempts in all
    assert len(server.attempts) == 5 and len(waits) == 4
    with glint.Client(address, retry=glint.RetryPolicy(max_attempts=1)) as c, pytest.raises(glint.Error) as e:
        c.upload_normal_map(map_file)
    assert e.value.details == "refusal 6" and len(server.attempts) == 6
