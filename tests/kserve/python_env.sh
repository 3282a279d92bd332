#!/usr/bin/env bash
# usage: python_env.sh VENV_DIR COMMAND [ARGS...]
# Runs COMMAND with VENV_DIR/bin first on PATH, after creating the venv (once; later runs reuse
# it) with Triton's pure-Python gRPC client and numpy from PyPI. Exits 77 (ctest's skip code)
# with a message when the venv or the packages cannot be had, e.g. on a machine without a
# package index.
set -u
venv=$1
shift
mkdir -p "$(dirname "$venv")"
# Two tests may start at once (ctest -j2): one creates the venv, the other waits.
exec 9>"$venv.lock"
flock 9
if [ ! -f "$venv/.glint-ready" ]; then
  rm -rf "$venv"
  if ! python3 -m venv "$venv"; then
    echo "SKIP: python3 -m venv failed (apt-get install python3-venv; scripts/install-deps.sh does)"
    exit 77
  fi
  if ! "$venv/bin/python" -m pip install --disable-pip-version-check -q --timeout 30 --retries 2 \
      'tritonclient[grpc]' numpy; then
    echo "SKIP: pip could not install tritonclient[grpc] and numpy (no package index reachable?)"
    exit 77
  fi
  touch "$venv/.glint-ready"
fi
flock -u 9
export PATH="$venv/bin:$PATH"
exec "$@"
