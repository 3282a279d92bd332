"""Shading queries as numpy arrays and their slices as ``glint.v1.QueryBatch`` messages."""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from glint.v1 import glint_pb2 as pb

# Every array of QueryBatch with its floats per query, in the order of the wire contract (and of
# kArrays in client/lib/glint_client.cpp). A field added to QueryBatch must be added here too or
# it could not be sent; tests/python compares this list with the message's descriptor.
ARRAYS: List[Tuple[str, int]] = [
    ("uv", 2),
    ("footprint", 4),
    ("wo", 3),
    ("wi", 3),
    ("position", 3),
    ("normal", 3),
    ("tangent", 3),
]
COMPONENTS: Dict[str, int] = dict(ARRAYS)


class Queries:
    """Validated query arrays: each present one float32, shaped (count, k) or (k,) (one vector
    for every query, broadcast when sliced). Values are left to the server's validation (NaN,
    unit length, partial frames), whose refusals name the field and the query index."""

    def __init__(self, **arrays: Optional[Any]):
        unknown = sorted(set(arrays) - set(COMPONENTS))
        if unknown:
            raise TypeError(f"unknown query arrays: {', '.join(unknown)}")
        self.arrays: Dict[str, np.ndarray] = {}
        rows: Dict[str, int] = {}
        for name, k in ARRAYS:
            value = arrays.get(name)
            if value is None:
                continue
            a = np.asarray(value, dtype=np.float32)
            if a.ndim == 2 and a.shape[1] == k:
                rows[name] = a.shape[0]
            elif a.shape != (k,):
                raise ValueError(
                    f"{name}: expected an array of shape (N, {k}) (or ({k},) for every query), "
                    f"got shape {a.shape}"
                )
            self.arrays[name] = a
        counts = set(rows.values())
        if len(counts) > 1:
            listing = ", ".join(f"{n} has {r}" for n, r in rows.items())
            raise ValueError(f"query arrays disagree on the number of queries: {listing} rows")
        self.count = counts.pop() if counts else 1
        if self.count > 0xFFFFFFFF:
            raise ValueError(f"{self.count} queries: at most 2^32 - 1 per call")

    def bytes_per_query(self) -> int:
        """Serialized bytes one query adds to a QueryBatch (packed floats of the present arrays),
        as BytesPerQuery in the C++ client."""
        return sum(4 * COMPONENTS[name] for name in self.arrays)

    def batch(self, begin: int, end: int) -> pb.QueryBatch:
        """Queries [begin, end) as a QueryBatch of their own; absent arrays stay absent."""
        if not 0 <= begin <= end <= self.count:
            raise IndexError(f"query range [{begin}, {end}) outside a batch of {self.count}")
        out = pb.QueryBatch(count=end - begin)
        for name, a in self.arrays.items():
            part = a[begin:end] if a.ndim == 2 else np.broadcast_to(a, (end - begin, a.shape[0]))
            # tolist() hands upb Python floats, about 3x faster than iterating numpy scalars;
            # float32 -> double -> float is exact.
            getattr(out, name).extend(part.ravel().tolist())
        return out
