"""The one exception type of the client: a failed call, with gRPC's status code."""

from __future__ import annotations

import grpc


class Error(Exception):
    """A call to glintd failed.

    ``code`` is the :class:`grpc.StatusCode` (``INVALID_ARGUMENT`` for a refused request,
    ``RESOURCE_EXHAUSTED`` when the server is full, ``UNAVAILABLE`` when it cannot be reached, ...)
    and ``details`` the server's message as it sent it, e.g.
    ``queries.wo[17]: (nan, 0, 1) is not finite``; a streamed batch's message starts with
    ``chunk N:`` and its query index counts from the start of the whole batch.
    """

    def __init__(self, code: grpc.StatusCode, details: str):
        self.code = code
        self.details = details
        super().__init__(f"{code.name}: {details}" if details else code.name)

    @classmethod
    def from_rpc_error(cls, error: grpc.RpcError) -> "Error":
        # Every RpcError raised by a call is also a grpc.Call carrying code() and details().
        code = error.code() if hasattr(error, "code") else grpc.StatusCode.UNKNOWN
        details = error.details() if hasattr(error, "details") else str(error)
        return cls(code, details or "")
