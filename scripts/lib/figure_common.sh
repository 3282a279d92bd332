# Shared by scripts/*_figure.sh (sourced from the repository root): a built tree, a Python with
# numpy, Pillow and OpenEXR, and a glintd on a free loopback port for the figure's renders.
#
# Python: the system python3 when it has the three modules (e.g. Debian's python3-numpy,
# python3-pil, python3-openexr), else a venv of glint's own (GLINT_FIGURE_VENV, default
# ~/.cache/glint/figure-venv) filled from PyPI once. Never `pip install` into the system Python:
# Debian refuses it (PEP 668, "externally-managed-environment"), and a user's Python is theirs.

# Runs scripts/build.sh when glintd or the CLI is missing from BUILD_DIR.
figure_require_build() {
  if [ ! -x "$BUILD_DIR/server/glintd" ] || [ ! -x "$BUILD_DIR/client/cli/glint" ]; then
    bash scripts/build.sh
  fi
}

# Sets PY to a Python interpreter that imports numpy, PIL and OpenEXR.
figure_python() {
  local need='import numpy, PIL, OpenEXR'
  if python3 -c "$need" 2>/dev/null; then
    PY=python3
    return
  fi
  local venv="${GLINT_FIGURE_VENV:-${XDG_CACHE_HOME:-$HOME/.cache}/glint/figure-venv}"
  if ! "$venv/bin/python" -c "$need" 2>/dev/null; then
    echo "figure: creating $venv (numpy, Pillow, OpenEXR from PyPI)" >&2
    python3 -m venv "$venv"
    "$venv/bin/pip" install -q numpy pillow OpenEXR
  fi
  PY="$venv/bin/python"
}

# Starts glintd on 127.0.0.1:0 with its log in the file named by the first argument and waits
# for SERVING, up to 600 s as scripts/demo.sh (on a fresh kernel cache glintd compiles its warm-up
# variants first: minutes on a loaded 2-core machine). Sets GLINTD (its pid) and SERVER
# (host:port); an EXIT trap stops it.
figure_start_glintd() {
  local log="$1"
  FIGURE_PORT_FILE="$(mktemp)"
  "$BUILD_DIR/server/glintd" --listen 127.0.0.1:0 --port-file "$FIGURE_PORT_FILE" --quiet \
    2>"$log" &
  GLINTD=$!
  trap 'kill $GLINTD 2>/dev/null || true; rm -f "$FIGURE_PORT_FILE"' EXIT
  for _ in $(seq 1 6000); do
    [ -s "$FIGURE_PORT_FILE" ] && break
    kill -0 $GLINTD 2>/dev/null || { cat "$log"; exit 1; }
    sleep 0.1
  done
  [ -s "$FIGURE_PORT_FILE" ] || { echo "glintd did not report SERVING; see $log" >&2; exit 1; }
  SERVER="127.0.0.1:$(cat "$FIGURE_PORT_FILE")"
}
