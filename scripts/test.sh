#!/usr/bin/env bash
# The README's test command: install dependencies, build, run the whole suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
BUILD_DIR="${GLINT_BUILD_DIR:-build}"
# A private kernel cache so a stale cache of another build cannot mask a bug.
export GLINT_CACHE_DIR="$PWD/$BUILD_DIR/test-kernel-cache"
ctest --test-dir "$BUILD_DIR" --output-on-failure -j 2 --timeout 600
