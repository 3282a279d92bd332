#!/usr/bin/env bash
# The README's main command: install, build, start glintd on loopback, render
# preview images of a material on a sphere and a plane, and print where they are.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
BUILD_DIR="${GLINT_BUILD_DIR:-build}"
OUT="${GLINT_OUT_DIR:-$PWD/out}"
mkdir -p "$OUT"
PORT_FILE="$(mktemp)"
"$BUILD_DIR/server/glintd" --listen 127.0.0.1:0 --port-file "$PORT_FILE" 2>"$OUT/glintd.log" &
GLINTD=$!
trap 'kill $GLINTD 2>/dev/null || true; rm -f "$PORT_FILE"' EXIT
# The port file appears once glintd reports SERVING, i.e. after it has compiled and run its
# warm-up kernels: tens of seconds with a cold kernel cache on a 2-core CPU, instant after.
echo "Waiting for glintd to compile its kernels (first run only) ..."
for _ in $(seq 1 6000); do
  [ -s "$PORT_FILE" ] && break
  kill -0 $GLINTD 2>/dev/null || { cat "$OUT/glintd.log"; exit 1; }
  sleep 0.1
done
[ -s "$PORT_FILE" ] || { echo "glintd did not report SERVING within 600 s; see $OUT/glintd.log"; exit 1; }
SERVER="127.0.0.1:$(cat "$PORT_FILE")"
GLINT="$BUILD_DIR/client/cli/glint"
"$GLINT" info --server "$SERVER"
for scene in sphere plane; do
  "$GLINT" preview --server "$SERVER" --material examples/materials/gold_aniso.json \
    --lights examples/lights/studio.json --scene "$scene" --size 512x384 \
    --out "$OUT/preview_$scene.exr"
done
# An area light: a two-sided softbox quad (LTC integration) plus a point light.
"$GLINT" preview --server "$SERVER" --material examples/materials/gold_aniso.json \
  --lights examples/lights/softbox.json --scene sphere --size 512x384 \
  --out "$OUT/preview_softbox.exr"
# Binomial glints (Kneiphof & Klein 2024): a sparkly metal plane under a small rect light.
"$GLINT" preview --server "$SERVER" --material examples/materials/sparkle_binomial.json \
  --lights examples/lights/rect_small.json --scene plane --size 512x384 --seed 1 \
  --out "$OUT/preview_glints.exr"
# Procedural glints (Chermain et al. 2020): a sparkly metal plane under the sun.
"$GLINT" preview --server "$SERVER" --material examples/materials/sparkle_chermain.json \
  --lights examples/lights/sun.json --scene plane --size 512x384 --seed 1 \
  --out "$OUT/preview_chermain.exr"
echo
echo "Preview images are in $OUT:"
ls -1 "$OUT"/preview_*
