"""Client-side retries of transient failures, as the C++ client makes them (client/lib/retry.h).

Retried: ``UNAVAILABLE`` (no connection, server restarting), and ``RESOURCE_EXHAUSTED`` only
when glintd says the call may succeed later by sending the trailing metadata
``glint-retry-pushback-ms`` (a wait in milliseconds; e.g. its normal-map upload gate is full,
server/upload_gate.h). A ``RESOURCE_EXHAUSTED`` without it means "this request exceeds a limit"
and would be refused again, so it is raised at once.

Backoff as gRPC's retry design (gRFC A6): before retry n (n = 1, 2, ...) wait
uniform(0, min(max_backoff, initial_backoff x multiplier^(n-1))), "full jitter", and at least the
server's pushback; at most ``max_attempts`` attempts in all.
"""

from __future__ import annotations

import dataclasses
import random
import re
import time
from typing import Callable, Optional, TypeVar

import grpc

PUSHBACK_METADATA = "glint-retry-pushback-ms"
MAX_PUSHBACK_SECONDS = 30.0  # the longest wait one pushback can impose

T = TypeVar("T")

# Waits between attempts; tests replace it to record the waits instead of sleeping.
_sleep: Callable[[float], None] = time.sleep
# One generator for the process, seeded from the OS: jitter must differ between clients.
_rng = random.SystemRandom()


@dataclasses.dataclass(frozen=True)
class RetryPolicy:
    """How often and how long to retry (the C++ client's RetryPolicy defaults). Seconds."""

    max_attempts: int = 5  # including the first; 1 = never retry
    initial_backoff: float = 0.1
    multiplier: float = 2.0
    max_backoff: float = 2.0


def pushback_seconds(error: grpc.RpcError) -> Optional[float]:
    """The server's pushback of a failed call in seconds; None when absent, malformed or
    negative (as the C++ client's RetryHint::ReadFrom)."""
    trailing = error.trailing_metadata() if hasattr(error, "trailing_metadata") else None
    for key, value in trailing or ():
        if key != PUSHBACK_METADATA:
            continue
        text = value.decode() if isinstance(value, bytes) else str(value)
        if not re.fullmatch(r"[0-9]+", text):  # a whole number of ms: no sign, not empty
            return None
        return int(text) / 1000.0
    return None


def is_retryable(code: grpc.StatusCode, pushback: Optional[float]) -> bool:
    return code == grpc.StatusCode.UNAVAILABLE or (
        code == grpc.StatusCode.RESOURCE_EXHAUSTED and pushback is not None
    )


def backoff_ceiling(policy: RetryPolicy, retry: int) -> float:
    """The upper end of the jittered wait before retry ``retry`` >= 1."""
    return min(policy.initial_backoff * policy.multiplier ** max(0, retry - 1), policy.max_backoff)


def call_with_retries(policy: RetryPolicy, attempt: Callable[[], T]) -> T:
    """Runs ``attempt`` until it returns, raises a ``grpc.RpcError`` that is not retryable, or
    ``policy.max_attempts`` attempts were made (the last error is then raised)."""
    made = 0
    while True:
        try:
            return attempt()
        except grpc.RpcError as e:
            made += 1
            code = e.code() if hasattr(e, "code") else grpc.StatusCode.UNKNOWN
            pushback = pushback_seconds(e)
            if not is_retryable(code, pushback) or made >= policy.max_attempts:
                raise
            wait = _rng.uniform(0.0, backoff_ceiling(policy, made))
            # A pushback is the server's estimate; one rewritten or corrupted on the way (e.g.
            # 99999999 ms) must not stall the client for days: at most MAX_PUSHBACK_SECONDS.
            _sleep(max(wait, min(pushback or 0.0, MAX_PUSHBACK_SECONDS)))
