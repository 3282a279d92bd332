"""Clients that never read their replies (issue 12, memory bounded by the configuration).

glintd frees a request's --max-pending slot before answering, so a reply waiting on a client
whose HTTP/2 window is full used to sit outside every bound: each such client added its reply
(and more) to glintd's memory, without limit. Replies not yet taken are now counted up to
--max-undelivered-mb, beyond which new Evaluate calls are refused with RESOURCE_EXHAUSTED and a
retry pushback. The clients here call the unary Evaluate as a stream they never read, on
channels whose receive window stays at 64 KiB (no BDP probing), so each 7.2 MB reply stays on
the server.
"""

from __future__ import annotations

import time

import grpc
import numpy as np

from conftest import running_glintd
from glint.v1 import glint_pb2 as pb

QUERIES = 600_000  # 14.4 MB request, 7.2 MB reply
STUCK = 16  # replies that would hold ~115 MB without the budget


def _probe_request(n: int) -> pb.EvaluateRequest:
    r = pb.EvaluateRequest()
    m = r.material
    m.model = pb.SMOOTH
    m.ndf = pb.GGX
    m.alpha_x = m.alpha_y = 0.3
    m.schlick.f0.extend([1.0, 1.0, 1.0])
    r.queries.count = n
    r.queries.wo.extend(np.tile(np.float32([0.0, 0.6, 0.8]), n).tolist())
    r.queries.wi.extend(np.tile(np.float32([0.0, 0.0, 1.0]), n).tolist())
    return r


def _rss_mb(pid: int) -> float:
    with open(f"/proc/{pid}/status") as f:
        return int(f.read().split("VmRSS:")[1].split()[0]) / 1024.0


def test_replies_nobody_reads_are_bounded_by_max_undelivered(tmp_path):
    flags = ("--device", "host", "--max-pending", "2", "--max-message-mb", "16", "--max-undelivered-mb", "32")
    with running_glintd(*flags) as (address, proc):
        body = _probe_request(QUERIES).SerializeToString()
        small = _probe_request(1)
        with grpc.insecure_channel(address) as channel:
            evaluate = channel.unary_unary("/glint.v1.GlintService/Evaluate",
                                           request_serializer=pb.EvaluateRequest.SerializeToString,
                                           response_deserializer=pb.EvaluateResponse.FromString)
            # Warm: first-call allocations are not the replies'. wait_for_ready: the server is
            # SERVING, so a first connection attempt that fails on a loaded machine is retried
            # within the deadline instead of failing the call with UNAVAILABLE at once.
            evaluate(small, timeout=30, wait_for_ready=True)
            idle = _rss_mb(proc.pid)
            stuck = []
            for _ in range(STUCK):
                c = grpc.insecure_channel(address, options=[("grpc.http2.lookahead_bytes", 65536),
                                                            ("grpc.http2.bdp_probe", 0),
                                                            ("grpc.max_receive_message_length", 64 << 20)])
                call = c.stream_stream("/glint.v1.GlintService/Evaluate")(iter([body]))
                stuck.append((c, call))
                time.sleep(0.4)  # usually evaluated (host path, ~0.1 s) and its reply offered

            # Over the budget: refused, naming the flag, with the pushback that makes clients
            # retry (it can succeed once the readers read). Five unread replies (36 MB) are over
            # it; on a loaded machine the stuck calls may still be arriving or being evaluated,
            # so a small call is sent until the server has held enough to refuse it (a server
            # that never does fails at the deadline), rather than once after a guessed wait.
            refused = None
            deadline = time.monotonic() + 120
            while refused is None and time.monotonic() < deadline:
                try:
                    evaluate(small, timeout=30)
                    time.sleep(0.2)
                except grpc.RpcError as e:
                    transient = e.code() == grpc.StatusCode.UNAVAILABLE or (
                        e.code() == grpc.StatusCode.RESOURCE_EXHAUSTED
                        and "--max-undelivered-mb" not in (e.details() or ""))
                    if transient:  # --max-pending (a stuck call still evaluated) or a reconnect
                        time.sleep(0.2)
                        continue
                    refused = e
            peak = _rss_mb(proc.pid)
            assert refused is not None, "new calls were admitted for 120 s with 16 unread 7.2 MB replies sent"
            assert refused.code() == grpc.StatusCode.RESOURCE_EXHAUSTED, refused
            assert "--max-undelivered-mb 32" in refused.details(), refused.details()
            assert ("glint-retry-pushback-ms", "50") in (refused.trailing_metadata() or ())

            # The held replies stay within the budget plus what the in-flight calls may hold
            # (README "Memory": M x (3 x (max-pending + being received) + 2 x workers) + U, with
            # M = 14.4 MB, 2 pending, 1 being received, 2 workers, U = 32 MB: ~220 MB). Without
            # the budget the 16 replies and their requests held ~19 MB each (~300 MB).
            assert peak - idle < 14.4 * (3 * (2 + 1) + 2 * 2) + 32, (idle, peak)

            # Readers gone: their replies are released and the server admits work again.
            for c, call in stuck:
                call.cancel()
                c.close()
            # The replies are released when the cancels reach the server (an event, not a delay):
            # the 120 s bound is a hang guard that fails a server that never releases them, as
            # above, not a speed claim (30 s was a guess a loaded machine could exceed).
            deadline = time.monotonic() + 120
            while True:
                try:
                    response = evaluate(small, timeout=30)
                    break
                except grpc.RpcError as e:
                    assert e.code() == grpc.StatusCode.RESOURCE_EXHAUSTED and time.monotonic() < deadline, e
                    time.sleep(0.2)
            assert response.count == 1 and len(response.radiance) == 3
