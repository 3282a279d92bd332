"""``glint.Client``: one channel to glintd, numpy arrays in and out.

Mirrors the C++ client (client/lib/glint_client.cpp) so that both send the same messages: a
batch within the server's ``max_batch`` and half its message limit (and ``max_chunk_bytes``) goes
as one unary ``Evaluate``; a larger one is cut into equal chunks of consecutive queries (the last
one shorter) sent over ``EvaluateStream`` in order, the first chunk carrying the settings. The
server's determinism contract makes the radiance bit-identical however a batch is carried.
"""

from __future__ import annotations

import dataclasses
import os
import pathlib
import threading
import time
from typing import Any, Callable, Iterator, Optional, Union

import grpc
import numpy as np

from glint._errors import Error
from glint._queries import Queries
from glint._retry import RetryPolicy, call_with_retries
from glint._settings import LightsLike, MaterialLike, to_area_method, to_lights, to_material, to_precision
from glint.v1 import glint_pb2 as pb
from glint.v1 import glint_pb2_grpc as pb_grpc

# gRPC's default receive limit, assumed when a server does not advertise its own.
_GRPC_DEFAULT_MESSAGE_BYTES = 4 << 20
# Serialized bytes per query of a response: 3 packed floats.
_RESPONSE_BYTES_PER_QUERY = 12
# Room for framing, tags, stats and the chunk envelope on top of the payload (as the C++ client).
_ENVELOPE_BYTES = 4096

# The wire contract's sizes (proto/glint/v1/glint.proto), as the C++ client names them
# (client/lib/glint_client.h):
# replies may exceed Capabilities.max_message_bytes by this much (the server's send limit is its
# receive limit + 4096), so the channel receives up to max_message_bytes + this;
REPLY_OVERHEAD_BYTES = 4096
# each sample adds this many bytes to a SampleResponse (7 packed floats: wi 3, pdf 1, weight 3);
SAMPLE_REPLY_BYTES_PER_SAMPLE = 28
# maps asked for per ListNormalMaps page when listing them all (the server's largest page).
NORMAL_MAP_PAGE_SIZE = 1000

ProgressLike = Union[None, bool, Callable[[int, int], None]]


@dataclasses.dataclass
class EvaluateInfo:
    """How the last ``evaluate`` was carried out."""

    streamed: bool = False
    chunks: int = 0  # 1 for a unary call
    chunk_queries: int = 0  # queries per chunk (the last one may be smaller)
    device: str = ""  # from the server's EvaluateStats


class _Progress:
    """Adapts ``progress=`` (False, True for a tqdm bar, or a callable(done, total))."""

    def __init__(self, progress: ProgressLike, total: int):
        self._fn: Optional[Callable[[int, int], None]] = None
        self._bar = None
        if progress is True:
            try:
                from tqdm.auto import tqdm
            except ImportError:
                raise ImportError(
                    "progress=True draws a tqdm bar: pip install tqdm (or glint[progress])"
                ) from None
            self._bar = tqdm(total=total, unit="q", unit_scale=True, desc="glint")
        elif callable(progress):
            self._fn = progress
        elif progress not in (None, False):
            raise TypeError("progress: expected True, False or a callable(done, total)")

    def update(self, done: int, total: int, step: int) -> None:
        if self._bar is not None:
            self._bar.update(step)
        if self._fn is not None:
            self._fn(done, total)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()


def _unsigned(value: Any, bits: int, what: str) -> int:
    """``value`` as an integer of a ``uint<bits>`` field, or a ValueError naming the argument
    (protobuf's own says only "Value out of range")."""
    v = int(value)
    if not 0 <= v < (1 << bits):
        raise ValueError(f"{what}: {v}; expected an integer in [0, 2^{bits})")
    return v


def _radiance(values: Any, n: int) -> np.ndarray:
    return np.fromiter(values, dtype=np.float32, count=3 * n).reshape(n, 3)


class Client:
    """A connection to one glintd (any gRPC target: ``"127.0.0.1:50051"``, ``"dns:///glint:50051"``,
    ``"unix:/path"``). Thread-safe; use as a context manager or call :meth:`close`.

    ``max_message_bytes`` is this side's gRPC send limit (at least the server's, so the client is
    never the side that refuses; replies are received up to it + ``REPLY_OVERHEAD_BYTES``, the
    most a reply may exceed the server's limit by); ``max_chunk_bytes`` bounds one message (a few MiB
    keeps latency and memory small); ``max_chunk_queries`` caps queries per message (0: only the
    server's ``max_batch``); ``timeout`` (seconds) applies to ``capabilities()``,
    ``list_normal_maps()`` and ``delete_normal_map()`` only, since a large batch may legitimately
    take minutes. ``retry`` is how :meth:`upload_normal_map` retries
    the server's pushback (glint.RetryPolicy; ``RetryPolicy(max_attempts=1)`` never retries).
    """

    def __init__(
        self,
        address: str,
        *,
        max_message_bytes: int = 64 << 20,
        max_chunk_bytes: int = 8 << 20,
        max_chunk_queries: int = 0,
        timeout: float = 10.0,
        retry: Optional[RetryPolicy] = None,
    ):
        self.address = address
        self.max_message_bytes = int(max_message_bytes)
        self.max_chunk_bytes = int(max_chunk_bytes)
        self.max_chunk_queries = int(max_chunk_queries)
        self.timeout = timeout
        self.retry = retry if retry is not None else RetryPolicy()
        self.last_info = EvaluateInfo()
        self._caps: Optional[pb.Capabilities] = None
        self._lock = threading.Lock()
        self._channel = grpc.insecure_channel(
            address,
            options=[
                ("grpc.max_receive_message_length", min(self.max_message_bytes + REPLY_OVERHEAD_BYTES, 2**31 - 1)),
                ("grpc.max_send_message_length", self.max_message_bytes),
                # gRPC backs off up to 120 s between connection attempts by default; a client of
                # a server that is starting wants to notice it within a second or so.
                ("grpc.initial_reconnect_backoff_ms", 100),
                ("grpc.max_reconnect_backoff_ms", 1000),
                # Not grpc.min_reconnect_backoff_ms: gRPC core takes it as the minimum connect
                # timeout (20 s by default); at 100 ms a connection slower than that to connect
                # and handshake on a loaded machine failed with UNAVAILABLE "tcp handshaker
                # shutdown" (the C++ client had the same; client/lib/glint_client.cpp).
            ],
        )
        self._stub = pb_grpc.GlintServiceStub(self._channel)

    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"glint.Client({self.address!r})"

    # -- health ---------------------------------------------------------------------------------

    def wait_until_serving(self, timeout: float = 60.0) -> None:
        """Polls ``grpc.health.v1.Health/Check`` until the server reports SERVING (it does once
        its kernels are compiled and warm). Raises :class:`glint.Error` (``DEADLINE_EXCEEDED``,
        saying what the last attempt saw) when it does not within ``timeout`` seconds, or
        ``UNIMPLEMENTED`` at once for a server without the health service."""
        from grpc_health.v1 import health_pb2, health_pb2_grpc

        health = health_pb2_grpc.HealthStub(self._channel)
        end = time.monotonic() + timeout
        last = "no health check attempted"
        while True:
            left = end - time.monotonic()
            if left <= 0:
                break
            try:
                # Fail fast (no wait_for_ready) so a refused connection reports its reason; the
                # loop does the waiting.
                reply = health.Check(health_pb2.HealthCheckRequest(service=""), timeout=min(left, 1.0))
                if reply.status == health_pb2.HealthCheckResponse.SERVING:
                    return
                last = "health status " + health_pb2.HealthCheckResponse.ServingStatus.Name(reply.status)
            except grpc.RpcError as e:
                error = Error.from_rpc_error(e)
                if error.code == grpc.StatusCode.UNIMPLEMENTED:
                    raise Error(error.code, f"server does not implement grpc.health.v1.Health ({error})") from None
                # A check cut short by this wait's own end (its timeout is at most what was left)
                # keeps the earlier answer, which says more than a bare DEADLINE_EXCEEDED.
                cut_short = error.code == grpc.StatusCode.DEADLINE_EXCEEDED and time.monotonic() >= end
                if not (cut_short and last != "no health check attempted"):
                    last = str(error)
            time.sleep(0.1)
        raise Error(grpc.StatusCode.DEADLINE_EXCEEDED, f"{self.address} not SERVING after {timeout:g} s: {last}")

    # -- capabilities -----------------------------------------------------------------------

    def capabilities(self) -> pb.Capabilities:
        """The server's ``glint.v1.Capabilities`` (device, models, limits), asked afresh; also
        refreshes the limits ``evaluate`` sizes its messages by."""
        try:
            caps = self._stub.GetCapabilities(pb.GetCapabilitiesRequest(), timeout=self.timeout)
        except grpc.RpcError as e:
            raise Error.from_rpc_error(e) from None
        with self._lock:
            self._caps = caps
        return caps

    def _cached_capabilities(self) -> pb.Capabilities:
        with self._lock:
            if self._caps is not None:
                return self._caps
        return self.capabilities()

    # -- evaluate ---------------------------------------------------------------------------

    def evaluate(
        self,
        material: MaterialLike,
        wo: Any,
        wi: Any = None,
        uv: Any = None,
        footprint: Any = None,
        position: Any = None,
        normal: Any = None,
        tangent: Any = None,
        lights: LightsLike = None,
        precision: Union[str, int] = "fp32",
        seed: int = 0,
        area_method: Union[str, int] = "ltc",
        samples: Optional[int] = None,
        progress: ProgressLike = False,
        max_error: Optional[float] = None,
    ) -> np.ndarray:
        """Reflected radiance of every query, an (N, 3) float32 array in query order.

        Arrays are (N, k) (or (k,) for one vector shared by every query), converted to float32:
        ``wo`` (N, 3) unit, towards the viewer; ``wi`` (N, 3) for BRDF probes (no lights),
        returning f(wi, wo) cos(theta_i); ``uv`` (N, 2); ``footprint`` (N, 4) = (du/dx, dv/dx,
        du/dy, dv/dy); ``position``, ``normal``, ``tangent`` (N, 3) all or none, for world-space
        directions and lights. ``material`` and ``lights`` are messages, dicts in the proto3 JSON
        form of the CLI's files, or paths to such files. ``precision`` "fp32" | "fp64";
        ``area_method`` "ltc" | "lecocq" | "lecocq-pearson" | "mc" | "reference" with
        ``samples`` (quadrature nodes or Monte Carlo samples) for polygon lights, or "auto" with
        ``max_error`` (the relative error allowed per query and light, e.g. 0.05). ``progress``:
        True for a tqdm bar, or a callable(done, total) called as results arrive.

        N = 0 (empty arrays) returns a (0, 3) array without calling the server, so the material
        and lights of an empty batch are not checked.

        Raises :class:`glint.Error` for a failed call (the server's refusals are
        ``INVALID_ARGUMENT`` naming the field and query index), ``ValueError`` / ``TypeError``
        for arguments that cannot form a request.
        """
        queries = Queries(
            uv=uv, footprint=footprint, wo=wo, wi=wi, position=position, normal=normal, tangent=tangent
        )
        settings = pb.EvaluateRequest(
            material=to_material(material),
            lights=to_lights(lights),
            precision=to_precision(precision),
            seed=_unsigned(seed, 64, "seed"),
            area_method=to_area_method(area_method),
        )
        if samples is not None:
            settings.area_samples = _unsigned(samples, 32, "samples")
        if max_error is not None:
            settings.max_relative_error = float(max_error)
        if queries.count == 0:
            # Nothing to ask (the server refuses an empty batch): an empty result, as numpy
            # operations on empty arrays give, so a renderer's empty tile needs no special case.
            self.last_info = EvaluateInfo(False, 0, 0, "")
            return np.empty((0, 3), dtype=np.float32)
        bar = _Progress(progress, queries.count)
        try:
            return self._evaluate(settings, queries, bar)
        finally:
            bar.close()

    def _evaluate(self, settings: pb.EvaluateRequest, queries: Queries, bar: _Progress) -> np.ndarray:
        caps = self._cached_capabilities()
        # The smaller of the server's and our message limit and of the server's batch limit and
        # our chunk cap; 0 from the server means "not reported".
        message_limit = min(caps.max_message_bytes or _GRPC_DEFAULT_MESSAGE_BYTES, self.max_message_bytes)
        max_batch = caps.max_batch or 0xFFFFFFFF
        if self.max_chunk_queries:
            max_batch = min(max_batch, self.max_chunk_queries)
        # One message stays at half the limit (framing estimates never matter) and within
        # max_chunk_bytes.
        budget = min(message_limit // 2, self.max_chunk_bytes)
        count = queries.count
        settings_size = settings.ByteSize()
        response_bytes = count * _RESPONSE_BYTES_PER_QUERY + _ENVELOPE_BYTES
        if (
            count <= max_batch
            and response_bytes <= budget
            and settings_size + count * queries.bytes_per_query() <= budget
        ):
            request = pb.EvaluateRequest()
            request.CopyFrom(settings)
            request.queries.CopyFrom(queries.batch(0, count))
            if request.ByteSize() <= budget:  # the C++ client's test, on the exact size
                out = self._unary(request, count)
                bar.update(count, count, count)
                return out

        # Chunk size as in the C++ client: every chunk sized as if it carried the settings.
        settings_bytes = settings.material.ByteSize() + sum(l.ByteSize() + 8 for l in settings.lights)
        overhead = settings_bytes + _ENVELOPE_BYTES
        if budget <= overhead:
            raise Error(
                grpc.StatusCode.RESOURCE_EXHAUSTED,
                f"material and lights alone ({settings_bytes} bytes) exceed the chunk size budget "
                f"of {budget} bytes",
            )
        per_query = max(queries.bytes_per_query(), _RESPONSE_BYTES_PER_QUERY)
        chunk_queries = min(max(1, (budget - overhead) // per_query), max_batch)
        return self._streamed(settings, queries, chunk_queries, bar)

    def _unary(self, request: pb.EvaluateRequest, count: int) -> np.ndarray:
        try:
            response = self._stub.Evaluate(request)
        except grpc.RpcError as e:
            raise Error.from_rpc_error(e) from None
        if len(response.radiance) != 3 * count:
            raise Error(
                grpc.StatusCode.INTERNAL,
                f"server returned {len(response.radiance)} radiance floats for {count} queries",
            )
        self.last_info = EvaluateInfo(False, 1, count, response.stats.device)
        return _radiance(response.radiance, count)

    def _streamed(
        self, settings: pb.EvaluateRequest, queries: Queries, chunk_queries: int, bar: _Progress
    ) -> np.ndarray:
        count = queries.count
        chunks = (count + chunk_queries - 1) // chunk_queries
        info = EvaluateInfo(True, chunks, chunk_queries, "")

        def requests() -> Iterator[pb.EvaluateChunk]:
            # Consumed by gRPC on its own thread while results are read below, so both HTTP/2
            # windows keep moving; chunks are built lazily, a few at a time.
            for k in range(chunks):
                chunk = pb.EvaluateChunk(chunk_index=k)
                if k == 0:
                    chunk.request.CopyFrom(settings)  # material, lights, precision, seed, area method
                begin = k * chunk_queries
                end = min(begin + chunk_queries, count)
                chunk.request.queries.CopyFrom(queries.batch(begin, end))
                yield chunk

        out = np.empty((count, 3), dtype=np.float32)
        call = self._stub.EvaluateStream(requests())
        received = 0
        try:
            for result in call:
                first = received * chunk_queries
                n = min(chunk_queries, count - min(first, count))
                problem = ""
                if received >= chunks:
                    problem = (
                        f"server sent a result for chunk {result.chunk_index} after all {chunks} "
                        f"chunks were answered"
                    )
                elif result.chunk_index != received:
                    problem = f"server answered chunk {result.chunk_index} where chunk {received} was expected"
                elif result.first_query != first:
                    problem = f"chunk {received} reports first_query {result.first_query}, expected {first}"
                elif len(result.result.radiance) != 3 * n:
                    problem = (
                        f"chunk {received} carries {len(result.result.radiance)} radiance floats "
                        f"for {n} queries"
                    )
                if problem:
                    call.cancel()
                    raise Error(grpc.StatusCode.INTERNAL, problem)
                out[first : first + n] = _radiance(result.result.radiance, n)
                if not info.device:
                    info.device = result.result.stats.device
                received += 1
                bar.update(first + n, count, n)
        except grpc.RpcError as e:
            raise Error.from_rpc_error(e) from None
        except BaseException:
            call.cancel()  # e.g. KeyboardInterrupt: the server stops at once, not at the end
            raise
        if received != chunks:
            raise Error(
                grpc.StatusCode.DATA_LOSS, f"stream ended after {received} of {chunks} chunk results"
            )
        self.last_info = info
        return out

    # -- importance sampling ----------------------------------------------------------------

    def sample(
        self,
        material: MaterialLike,
        wo: Any,
        samples: int,
        uv: Any = None,
        footprint: Any = None,
        position: Any = None,
        normal: Any = None,
        tangent: Any = None,
        precision: Union[str, int] = "fp32",
        seed: int = 0,
    ) -> "SampleResult":
        """``samples`` (K) incident directions per query drawn by the Sample RPC, with their pdf
        (solid angle) and weight f(wi, wo) cos_i / pdf: a :class:`SampleResult` of arrays
        ``wi`` (N, K, 3), ``pdf`` (N, K), ``weight`` (N, K, 3), float32. Query arrays as in
        :meth:`evaluate` (no ``wi``, no lights). Queries are sent in calls of at most
        max_batch / K queries and half the message limit, as ``glint sample`` does; samples
        depend only on (seed, the query, the sample index), so the split does not change them.
        Models without a sampler (BINOMIAL) are refused with ``INVALID_ARGUMENT``. N = 0 returns
        empty arrays without calling the server."""
        k = int(samples)
        if not 1 <= k <= 65536:
            raise ValueError(f"samples: {k}; expected 1 to 65536")
        queries = Queries(
            uv=uv, footprint=footprint, wo=wo, position=position, normal=normal, tangent=tangent
        )
        caps = self._cached_capabilities()
        settings = dict(material=to_material(material), samples_per_query=k, seed=_unsigned(seed, 64, "seed"),
                        precision=to_precision(precision))
        # As SampleQueriesPerCall in the C++ client: the request (settings, then the queries'
        # arrays) and the reply (7 floats per sample) both within half the smaller message limit.
        message_limit = min(caps.max_message_bytes or _GRPC_DEFAULT_MESSAGE_BYTES, self.max_message_bytes)
        room = max(0, message_limit // 2 - pb.SampleRequest(**settings).ByteSize() - _ENVELOPE_BYTES)
        per_query = max(queries.bytes_per_query(), k * SAMPLE_REPLY_BYTES_PER_SAMPLE, 1)
        by_batch = max(1, (caps.max_batch or 0xFFFFFFFF) // k)
        by_bytes = max(1, room // per_query)
        per_call = max(1, min(by_batch, by_bytes, queries.count))
        n = queries.count
        wi = np.empty((n, k, 3), dtype=np.float32)
        pdf = np.empty((n, k), dtype=np.float32)
        weight = np.empty((n, k, 3), dtype=np.float32)
        for first in range(0, n, per_call):
            m = min(per_call, n - first)
            request = pb.SampleRequest(queries=queries.batch(first, first + m), **settings)
            try:
                response = self._stub.Sample(request)
            except grpc.RpcError as e:
                raise Error.from_rpc_error(e) from None
            if len(response.pdf) != m * k or len(response.wi) != 3 * m * k or len(response.weight) != 3 * m * k:
                raise Error(grpc.StatusCode.INTERNAL,
                            f"server returned {len(response.pdf)} samples for {m} queries x {k}")
            wi[first : first + m] = np.asarray(response.wi, dtype=np.float32).reshape(m, k, 3)
            pdf[first : first + m] = np.asarray(response.pdf, dtype=np.float32).reshape(m, k)
            weight[first : first + m] = np.asarray(response.weight, dtype=np.float32).reshape(m, k, 3)
        return SampleResult(wi, pdf, weight)

    # -- normal maps ------------------------------------------------------------------------

    def upload_normal_map(self, path: "os.PathLike[str] | str") -> str:
        """Uploads a normal map file (OpenEXR float RGB or 8/16-bit RGB PNG tangent-space
        normals) in 1 MiB chunks and returns its digest, ``sha256:<hex>``, for a NORMAL_MAP
        material's ``normal_map.digest``. The server stores a map once however often it is
        uploaded; a bad file is refused with ``INVALID_ARGUMENT`` naming it.

        Retried as the C++ client retries it (glint._retry, the client's ``retry`` policy): the
        server refuses an upload with ``RESOURCE_EXHAUSTED`` and its retry pushback while other
        uploads fill its upload gate, and an upload is idempotent (a map is stored once by its
        digest); ``UNAVAILABLE`` is retried too. Other errors are raised at once."""
        data = pathlib.Path(path).read_bytes()
        name = pathlib.Path(path).name

        def chunks() -> Iterator[pb.NormalMapChunk]:
            step = 1 << 20
            for offset in range(0, max(len(data), 1), step):
                yield pb.NormalMapChunk(filename=name if offset == 0 else "", data=data[offset : offset + step])

        try:
            info = call_with_retries(self.retry, lambda: self._stub.UploadNormalMap(chunks()))
        except grpc.RpcError as e:
            raise Error.from_rpc_error(e) from None
        return info.digest

    def list_normal_maps(self, page_size: int = NORMAL_MAP_PAGE_SIZE) -> "list[pb.NormalMapInfo]":
        """Every normal map the server holds, in digest order (``pb.NormalMapInfo``: digest, width,
        height, bytes, filename). Follows the server's pages (``ListNormalMaps``, AIP-158
        ``page_token``) until the last, ``page_size`` maps per call (1 to 1000)."""
        if not 1 <= int(page_size) <= NORMAL_MAP_PAGE_SIZE:
            raise ValueError(f"page_size: {page_size}; expected 1 to {NORMAL_MAP_PAGE_SIZE}")
        maps: "list[pb.NormalMapInfo]" = []
        token = ""
        while True:
            request = pb.ListNormalMapsRequest(page_size=int(page_size), page_token=token)
            try:
                page = self._stub.ListNormalMaps(request, timeout=self.timeout)
            except grpc.RpcError as e:
                raise Error.from_rpc_error(e) from None
            maps.extend(page.maps)
            if not page.next_page_token:
                return maps
            if page.next_page_token == token:  # would never end; the server's tokens advance
                raise Error(grpc.StatusCode.INTERNAL, "ListNormalMaps: the same page token twice")
            token = page.next_page_token

    def delete_normal_map(self, digest: str) -> None:
        """Drops the map ``digest`` from the server (``NOT_FOUND`` if it does not hold it)."""
        try:
            self._stub.DeleteNormalMap(pb.DeleteNormalMapRequest(digest=digest), timeout=self.timeout)
        except grpc.RpcError as e:
            raise Error.from_rpc_error(e) from None


@dataclasses.dataclass
class SampleResult:
    """What :meth:`Client.sample` returns: sample j of query q is ``wi[q, j]``, ``pdf[q, j]``,
    ``weight[q, j]``. A sample without a direction is wi = 0, pdf 0, weight 0."""

    wi: np.ndarray
    pdf: np.ndarray
    weight: np.ndarray
