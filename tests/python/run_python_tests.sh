#!/usr/bin/env bash
# ctest entry python.client: installs client/python into a fresh venv and runs its pytest suite
# against a real glintd (started by conftest.py) and the glint CLI.
#
#   run_python_tests.sh GLINTD GLINT_CLI WORK_DIR [pytest args...]
#
# Wheels come from PyPI once and are kept in WORK_DIR/wheelhouse; every run builds a new venv and
# installs the package from there without the network (a clean install each time, in seconds).
# When the wheelhouse cannot satisfy the requirements and PyPI cannot be reached either, the test
# is skipped with exit code 77 (ctest SKIP_RETURN_CODE) and says why; any other failure fails.
set -euo pipefail
if [ $# -lt 3 ]; then
  echo "usage: $0 GLINTD GLINT_CLI WORK_DIR [pytest args...]" >&2
  exit 2
fi
glintd="$(realpath "$1")" glint_cli="$(realpath "$2")" work="$3"
shift 3
src="$(cd "$(dirname "$0")/../.." && pwd)"
python="${GLINT_TEST_PYTHON:-python3}"
mkdir -p "$work"
work="$(cd "$work" && pwd)"
wheelhouse="$work/wheelhouse"
venv="$work/venv"
mkdir -p "$wheelhouse"

if ! "$python" -c 'import venv, ensurepip' 2>/dev/null; then
  echo "python.client: $python cannot create venvs (Debian: apt-get install python3-venv)" >&2
  exit 1
fi
rm -rf "$venv"
# pip comes from the wheelhouse when it is there: ensurepip byte-compiles all of pip, which took
# longer than the rest of the install on a loaded machine.
pip_wheel="$( (ls "$wheelhouse"/pip-*.whl 2>/dev/null || true) | sort -V | tail -n 1)"
if [ -n "$pip_wheel" ]; then
  "$python" -m venv --without-pip "$venv"
  "$venv/bin/python" "$pip_wheel/pip" install -q --no-index --no-compile "$pip_wheel"
else
  "$python" -m venv "$venv"
fi
pip=("$venv/bin/python" -m pip --disable-pip-version-check --no-input -q)
# Installed from a copy: setuptools writes build/ and *.egg-info/ next to the sources it builds,
# and a test must not write into the source tree.
rm -rf "$work/package"
cp -r "$src/client/python" "$work/package"
rm -rf "$work/package/build" "$work/package"/*.egg-info
package="$work/package[test]"

# Offline first, from the wheels of earlier runs; then fetch what is missing (also pip's own
# wheel, for the next run's venv).
offline_ok=false
if "${pip[@]}" install --no-compile --no-index --find-links "$wheelhouse" "$package" \
    > "$work/pip-offline.log" 2>&1; then
  offline_ok=true
fi
if ! $offline_ok || [ -z "$pip_wheel" ]; then
  echo "python.client: fetching wheels from PyPI into $wheelhouse"
  # setuptools: the package's build backend, for pip's isolated build environment.
  if ! "${pip[@]}" download -d "$wheelhouse" "$package" "setuptools>=61" pip > "$work/pip-download.log" 2>&1; then
    if $offline_ok; then
      echo "python.client: could not add pip's wheel to $wheelhouse; continuing with the installed package"
    elif ! "${pip[@]}" index versions pip > /dev/null 2>&1; then
      echo "SKIP: python.client: PyPI is unreachable and $wheelhouse lacks wheels for the" \
           "package's requirements (pip: $(grep -m 1 'ERROR' "$work/pip-download.log" | sed 's/^ *//'))"
      exit 77
    else
      echo "python.client: pip download failed although PyPI answers:" >&2
      cat "$work/pip-download.log" >&2
      exit 1
    fi
  elif ! $offline_ok; then
    "${pip[@]}" install --no-compile --no-index --find-links "$wheelhouse" "$package"
  fi
fi

# Run from the work dir so that `import glint` can only find the installed package.
cd "$work"
export GLINTD="$glintd" GLINT_CLI="$glint_cli" GLINT_SOURCE_DIR="$src"
exec "$venv/bin/python" -m pytest -p no:cacheprovider -q -rs "$src/tests/python" "$@"
