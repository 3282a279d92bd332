#!/usr/bin/env bash
# "Show it" for the NORMAL_MAP model (Yan et al. 2014): the paper's four material families
# (bumpy plastic, metallic flakes, brushed metal, scratches; `glint normal-map` generators) as
# `glint preview` spheres under small lights (examples/lights/studio.json: a sun of 0.26 degrees
# and two point lights) and under a rectangular area light (examples/lights/rect_large.json,
# integrated by the model's MIS of light and P-NDF sampling, --samples per technique). Assembles
# a labelled 2 x 4 figure and prints per-image statistics; fails if an image is black, not
# finite, negative, or identical to another.
#
#   bash scripts/normal_map_figure.sh
#
# Writes out/normal_map/<family>_<light>.{exr,png}, out/normal_map/stats.md and
# docs/normal_map_figure.png. Expects a built tree (scripts/build.sh runs if the binaries are
# missing) and Python 3 with numpy, Pillow and OpenEXR (scripts/lib/figure_common.sh: the system's, or a venv of its own).
# Environment: GLINT_BUILD_DIR (default build), GLINT_OUT_DIR (default out/normal_map),
# GLINT_FIGURE (default docs/normal_map_figure.png), GLINT_SIZE (default 160x160),
# GLINT_MAP_SIZE (default 128), GLINT_AREA_SAMPLES (default 16).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR="${GLINT_BUILD_DIR:-build}"
OUT="${GLINT_OUT_DIR:-$PWD/out/normal_map}"
FIGURE="${GLINT_FIGURE:-$PWD/docs/normal_map_figure.png}"
SIZE="${GLINT_SIZE:-160x160}"
MAP_SIZE="${GLINT_MAP_SIZE:-128}"
SAMPLES="${GLINT_AREA_SAMPLES:-16}"

source scripts/lib/figure_common.sh
figure_require_build
figure_python

mkdir -p "$OUT" "$(dirname "$FIGURE")"
figure_start_glintd "$OUT/glintd.log"

# family: generator, f0, intrinsic roughness, PNG exposure (stops)
FAMILIES="bumpy:bumpy:0.04:0.02:4 flakes:flakes:0.95,0.8,0.5:0.01:0 brushed:brushed:0.9,0.9,0.92:0.02:0 scratches:scratches:0.9,0.9,0.9:0.01:0"
for entry in $FAMILIES; do
  IFS=: read -r name gen f0 sigma exposure <<<"$entry"
  "$BUILD_DIR/client/cli/glint" normal-map "$gen" --size "$MAP_SIZE" --seed 1 \
    --out "$OUT/map_$name.exr" 2>/dev/null
  "$PY" - "$OUT/m_$name.json" "$f0" "$sigma" <<'PY'
import json, sys
f0 = [float(x) for x in sys.argv[2].split(",")]
f0 = f0 * 3 if len(f0) == 1 else f0
json.dump({"model": "NORMAL_MAP", "schlick": {"f0": f0},
           "normal_map": {"intrinsic_roughness": float(sys.argv[3]), "cutoff_sigma": 5,
                          "subdivision": 1}}, open(sys.argv[1], "w"))
PY
  for light in small rect; do
    lights=examples/lights/studio.json
    [ "$light" = rect ] && lights=examples/lights/rect_large.json
    "$BUILD_DIR/client/cli/glint" preview --server "$SERVER" --material "$OUT/m_$name.json" \
      --lights "$lights" --normal-map "$OUT/map_$name.exr" --scene sphere --size "$SIZE" \
      --samples "$SAMPLES" --seed 1 --exposure "$exposure" --out "$OUT/${name}_$light.exr" \
      | grep -v '^/' || true
  done
done

"$PY" - "$OUT" "$FIGURE" "$MAP_SIZE" "$SAMPLES" <<'EOF'
import sys
import numpy as np
import OpenEXR
from PIL import Image, ImageDraw, ImageFont
out, figure, map_size, samples = sys.argv[1:5]
families = [("bumpy", "bumpy plastic", "f0 0.04, sigma_r 0.02, +4 EV"),
            ("flakes", "metallic flakes", "f0 gold, sigma_r 0.01"),
            ("brushed", "brushed metal", "f0 0.9, sigma_r 0.02"),
            ("scratches", "scratches", "f0 0.9, sigma_r 0.01")]
lights = [("small", "small lights (sun 0.26 deg + 2 points)"),
          ("rect", f"rect light (MIS, {samples} + {samples} samples)")]
def read(path):
    c = OpenEXR.File(path).channels()
    return np.asarray(c["RGB" if "RGB" in c else "RGBA"].pixels, dtype=np.float64)[..., :3]
names = [f"{f}_{l}" for f, _, _ in families for l, _ in lights]
imgs = {n: read(f"{out}/{n}.exr") for n in names}
table = ["| image | mean L | lit pixels | max L | finite, >= 0 |", "| --- | --- | --- | --- | --- |"]
bad = []
for n in names:
    img = imgs[n]
    y = img.mean(axis=2)
    ok = bool(np.isfinite(img).all() and (img >= 0).all())
    table.append(f"| {n} | {y.mean():.4g} | {100 * (y > 0).mean():.1f}% | {y.max():.4g} "
                 f"| {'yes' if ok else 'NO'} |")
    if not ok or not (y.max() > 0):
        bad.append(f"{n}: black or not finite / negative")
for i, a in enumerate(names):
    for b in names[i + 1:]:
        if np.array_equal(imgs[a], imgs[b]):
            bad.append(f"{a} and {b} are identical")
open(f"{out}/stats.md", "w").write("\n".join(table) + "\n")
print("\n".join(table))
if bad:
    sys.exit("normal_map_figure: " + "; ".join(bad))
tiles = {n: Image.open(f"{out}/{n}.png").convert("RGB") for n in names}
w, h = tiles[names[0]].size
def font(sz):
    try:
        return ImageFont.load_default(size=sz)
    except TypeError:
        return ImageFont.load_default()
left, pad, top, cap = 150, 4, 48, 30
sheet = Image.new("RGB", (left + 4 * (w + pad), top + 2 * (h + pad) + cap), (24, 24, 24))
draw = ImageDraw.Draw(sheet)
draw.text((8, 6), "NORMAL_MAP (Yan et al. 2014): P-NDF of generated normal maps "
          f"({map_size}^2, tiled once over the sphere's uv)", fill="white", font=font(15))
for k, (f, label, sub) in enumerate(families):
    x0 = left + k * (w + pad)
    draw.text((x0 + 4, top - 20), label, fill="white", font=font(14))
    draw.text((x0 + 4, top + 2 * (h + pad) + 2), sub, fill=(190, 190, 190), font=font(12))
for r, (l, label) in enumerate(lights):
    y0 = top + r * (h + pad)
    words = label.split(" (", 1)
    draw.text((8, y0 + h // 2 - 14), words[0], fill="white", font=font(14))
    if len(words) > 1:
        draw.text((8, y0 + h // 2 + 4), "(" + words[1], fill=(190, 190, 190), font=font(11))
    for k, (f, _, _) in enumerate(families):
        sheet.paste(tiles[f"{f}_{l}"], (left + k * (w + pad), y0))
sheet.save(figure, optimize=True)
print(f"figure: {figure}")
EOF
