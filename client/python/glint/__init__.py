"""Python client of glintd, the glint BRDF evaluation service.

    import glint
    with glint.Client("127.0.0.1:50051") as c:
        rgb = c.evaluate({"model": "SMOOTH", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.3,
                          "schlick": {"f0": [0.9, 0.6, 0.3]}},
                         wo=[[0, 0, 1]], wi=[[0, 0, 1]])   # (1, 3) float32

The wire messages are in ``glint.v1.glint_pb2`` (generated from proto/glint/v1/glint.proto).
"""

from glint._client import (
    NORMAL_MAP_PAGE_SIZE,
    REPLY_OVERHEAD_BYTES,
    SAMPLE_REPLY_BYTES_PER_SAMPLE,
    Client,
    EvaluateInfo,
    SampleResult,
)
from glint._errors import Error
from glint._retry import RetryPolicy
from glint.v1 import glint_pb2 as pb

# Tracebacks and reprs name the public path (glint.Error), not the private module.
for _public in (Client, EvaluateInfo, Error, RetryPolicy, SampleResult):
    _public.__module__ = "glint"
del _public

__version__ = "0.1.0"
__all__ = [
    "Client",
    "Error",
    "EvaluateInfo",
    "NORMAL_MAP_PAGE_SIZE",
    "REPLY_OVERHEAD_BYTES",
    "RetryPolicy",
    "SAMPLE_REPLY_BYTES_PER_SAMPLE",
    "SampleResult",
    "pb",
    "__version__",
]
