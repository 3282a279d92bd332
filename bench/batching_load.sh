#!/usr/bin/env bash
# Dynamic batching's gain (issue 12): `glint load` against glintd with batching off and on, at
# concurrency 1, 8 and 1000 (closed loop, one 256-query probe request in flight per client
# thread), printing one markdown row per configuration and level.
#
#   bash bench/batching_load.sh [BUILD_DIR] [SECONDS_PER_LEVEL] [BATCH]
#   (defaults: build, 10, 256)
# glintd runs with --workers 2 --max-pending 1100 (so 1000 clients are queued, not refused)
# and --quiet; --batch-max-queries 16384 when batching is on (up to 64 requests of 256 per
# launch).
set -euo pipefail
BUILD=${1:-build}
SECONDS_PER_LEVEL=${2:-10}
BATCH=${3:-256}
GLINTD="$BUILD/server/glintd"
GLINT="$BUILD/client/cli/glint"
WORK=$(mktemp -d)
trap 'kill "${PID:-}" 2>/dev/null || true; rm -rf "$WORK"' EXIT

echo "| batching | concurrency | requests/s | queries/s | p50 ms | p90 ms | p99 ms | ok | refused | errors |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for config in "off" "0" "200" "1000"; do
  flags=()
  label="off"
  if [ "$config" != "off" ]; then
    flags=(--batch-max-queries 16384 --batch-delay-us "$config")
    label="on, delay ${config} us"
  fi
  rm -f "$WORK/port"
  "$GLINTD" --listen 127.0.0.1:0 --port-file "$WORK/port" --quiet --workers 2 \
    --max-pending 1100 "${flags[@]}" 2> "$WORK/glintd.log" &
  PID=$!
  for _ in $(seq 1 2400); do [ -s "$WORK/port" ] && break; sleep 0.1; done
  [ -s "$WORK/port" ] || { cat "$WORK/glintd.log" >&2; exit 1; }
  "$GLINT" load --server "127.0.0.1:$(cat "$WORK/port")" --concurrency 1,8,1000 \
    --batch "$BATCH" --duration "$SECONDS_PER_LEVEL" --csv "$WORK/load.csv" > /dev/null
  tail -n +2 "$WORK/load.csv" | while IFS=, read -r c rps qps p50 p90 p99 ok refused errors; do
    printf '| %s | %s | %.0f | %.3g | %.2f | %.2f | %.2f | %s | %s | %s |\n' "$label" "$c" \
      "$rps" "$qps" "$p50" "$p90" "$p99" "$ok" "$refused" "$errors"
  done
  kill "$PID"
  wait "$PID" 2>/dev/null || true
  PID=
done
