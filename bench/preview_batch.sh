#!/usr/bin/env bash
# Batch material previews vs one `glint preview` command per material (issue 14): N variants
# of the Kemppinen car paint (examples/materials/carpaint_kemppinen.json with the flake colour,
# density and roughness varied) rendered at SIZE on the sphere under examples/lights/studio.json,
# against a running glintd.
#
#   bench/preview_batch.sh --server 127.0.0.1:50051 [--glint build/client/cli/glint]
#                          [--count 50] [--size 512x512] [--json]
#
# Prints one line per mode, or with --json one JSON object per line:
#   {"bench": "preview_batch", "mode": "batch" | "one_command_each", "materials": N,
#    "size": "WxH", "seconds": S, "materials_per_s": R}
# Wall-clock times of the whole commands (process start, scene set-up, evaluation, EXR + PNG
# writing); the batch also writes the contact sheet. Both modes write the same files.
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
server="" glint="$here/build/client/cli/glint" count=50 size=512x512 json=0
while [ $# -gt 0 ]; do
  case "$1" in
    --server) server="$2"; shift 2 ;;
    --glint) glint="$2"; shift 2 ;;
    --count) count="$2"; shift 2 ;;
    --size) size="$2"; shift 2 ;;
    --json) json=1; shift ;;
    *) echo "preview_batch.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
[ -n "$server" ] || { echo "preview_batch.sh: --server ADDR is required" >&2; exit 2; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/materials" "$work/single" "$work/batch"
for i in $(seq 1 "$count"); do
  # Deterministic variants: hue of the flakes, flake density and base roughness.
  r=$(awk -v i="$i" 'BEGIN { printf "%.3f", 0.5 + 0.5 * sin(i * 0.7) }')
  g=$(awk -v i="$i" 'BEGIN { printf "%.3f", 0.5 + 0.5 * sin(i * 1.3 + 2) }')
  b=$(awk -v i="$i" 'BEGIN { printf "%.3f", 0.5 + 0.5 * sin(i * 1.9 + 4) }')
  density=$(awk -v i="$i" 'BEGIN { printf "%.0f", 1e5 * (1 + (i % 5)) }')
  alpha=$(awk -v i="$i" 'BEGIN { printf "%.3f", 0.15 + 0.02 * (i % 7) }')
  printf '{"model": "KEMPPINEN", "ndf": "BECKMANN", "alpha_x": %s, "alpha_y": %s,\n "schlick": {"f0": [0.9, 0.9, 0.9]},\n "kemppinen": {"density": %s, "microroughness": 0.02, "filter_size": 0.7, "neighbors": 4,\n               "colors": [%s, %s, %s, 1, 0.9, 0.2]}}\n' \
    "$alpha" "$alpha" "$density" "$r" "$g" "$b" > "$work/materials/paint_$(printf %02d "$i").json"
done
lights="$here/examples/lights/studio.json"

report() {  # mode seconds
  local rate
  rate=$(awk -v n="$count" -v s="$2" 'BEGIN { printf "%.3f", n / s }')
  if [ "$json" = 1 ]; then
    printf '{"bench": "preview_batch", "mode": "%s", "materials": %s, "size": "%s", "seconds": %s, "materials_per_s": %s}\n' \
      "$1" "$count" "$size" "$2" "$rate"
  else
    printf '%-17s %3s materials at %s: %8.2f s, %6.3f materials/s\n' "$1" "$count" "$size" "$2" "$rate"
  fi
}

start=$(date +%s.%N)
for m in "$work"/materials/*.json; do
  "$glint" preview --server "$server" --material "$m" --lights "$lights" --size "$size" \
    --out "$work/single/p_$(basename "$m" .json).exr" > /dev/null
done
end=$(date +%s.%N)
report one_command_each "$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.3f", b - a }')"

start=$(date +%s.%N)
"$glint" preview --server "$server" --materials "$work/materials" --lights "$lights" --size "$size" \
  --out "$work/batch/p.exr" --contact-sheet "$work/batch/sheet.png" > "$work/batch.log"
end=$(date +%s.%N)
report batch "$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.3f", b - a }')"
[ "$json" = 1 ] || head -2 "$work/batch.log" >&2

# Both modes must have produced the same images.
for f in "$work"/single/*.exr; do
  cmp -s "$f" "$work/batch/$(basename "$f")" || { echo "preview_batch.sh: $(basename "$f") differs" >&2; exit 1; }
done
if [ -n "${KEEP_SHEET:-}" ]; then cp "$work/batch/sheet.png" "$KEEP_SHEET"; fi
