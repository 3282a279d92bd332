#!/usr/bin/env bash
# Regenerates the checked-in Python stubs of the wire contract (glint/v1/glint_pb2.py, .pyi and
# glint_pb2_grpc.py) from proto/glint/v1/glint.proto with a pinned grpcio-tools, so that the
# package installs without a code generator. tests/python checks that the checked-in files equal
# what this script produces.
#
#   pip install grpcio-tools==1.75.1 && bash client/python/regenerate_stubs.sh [OUT_DIR]
#
# OUT_DIR defaults to client/python (the stubs land in OUT_DIR/glint/v1/). The generator version
# fixes the protobuf runtime the stubs need (gencode 6.31.1: protobuf >= 6.31.1, < 7) and the
# grpcio they need (>= 1.75.1); pyproject.toml pins both. Changing it means changing those pins.
set -euo pipefail
GRPCIO_TOOLS_VERSION=1.75.1
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
out="${1:-$here}"
python="${PYTHON:-python3}"
have="$("$python" -c 'import importlib.metadata as m; print(m.version("grpcio-tools"))' 2>/dev/null || true)"
if [ "$have" != "$GRPCIO_TOOLS_VERSION" ]; then
  echo "regenerate_stubs: need grpcio-tools==$GRPCIO_TOOLS_VERSION in $python (found '${have:-none}')" >&2
  exit 1
fi
mkdir -p "$out/glint/v1"
"$python" -m grpc_tools.protoc -I "$root/proto" \
  --python_out="$out" --pyi_out="$out" --grpc_python_out="$out" \
  "$root/proto/glint/v1/glint.proto"
