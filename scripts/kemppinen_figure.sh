#!/usr/bin/env bash
# "Show it" for the Kemppinen et al. 2025 glinty NDF, like the paper's Fig. 10: one row per
# parameter (density, microroughness, roughness, anisotropy) varied over its range, all others
# constant, plus the coloured car paint (examples/materials/carpaint_kemppinen.json). Renders
# every material as `glint preview` spheres under examples/lights/studio.json in one batch (one
# stream), then assembles a labelled figure and prints per-image statistics; fails if an image
# is black, not finite, negative, or identical to its neighbour in its row.
#
#   bash scripts/kemppinen_figure.sh
#
# Writes out/kemppinen/k_<name>.{exr,png}, out/kemppinen/stats.md and docs/kemppinen_figure.png.
# Expects a built tree (scripts/build.sh runs if the binaries are missing) and Python 3 with
# numpy, Pillow and OpenEXR (scripts/lib/figure_common.sh: the system's, or a venv of its own).
# Environment: GLINT_BUILD_DIR (default build), GLINT_OUT_DIR (default out/kemppinen),
# GLINT_FIGURE (default docs/kemppinen_figure.png), GLINT_SIZE (default 192x192).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR="${GLINT_BUILD_DIR:-build}"
OUT="${GLINT_OUT_DIR:-$PWD/out/kemppinen}"
FIGURE="${GLINT_FIGURE:-$PWD/docs/kemppinen_figure.png}"
SIZE="${GLINT_SIZE:-192x192}"

source scripts/lib/figure_common.sh
figure_require_build
figure_python

rm -rf "$OUT/materials"
mkdir -p "$OUT/materials" "$(dirname "$FIGURE")"
figure_start_glintd "$OUT/glintd.log"

# The rows (name, field, values); the base material is GGX alpha 0.3, density 1e5 facets per
# unit uv, microroughness 0.02, filter 0.7, 4 neighbours, isotropic glints.
"$PY" - "$OUT/materials" <<'EOF'
import json, sys
out = sys.argv[1]
base = {"model": "KEMPPINEN", "ndf": "GGX", "alpha_x": 0.3, "alpha_y": 0.3,
        "schlick": {"f0": [0.9, 0.9, 0.9]},
        "kemppinen": {"density": 1e5, "microroughness": 0.02, "filter_size": 0.7, "neighbors": 4,
                      "anisotropy": 1.0}}
rows = {"density": [1e3, 1e5, 1e7, 1e9], "microroughness": [0.005, 0.02, 0.05, 0.15],
        "alpha": [0.1, 0.2, 0.4, 0.7], "anisotropy": [0.25, 0.5, 2.0, 4.0]}
for row, values in rows.items():
    for k, v in enumerate(values):
        m = json.loads(json.dumps(base))
        if row == "alpha":
            m["alpha_x"] = m["alpha_y"] = v
        else:
            m["kemppinen"][row] = v
        json.dump(m, open(f"{out}/{row}_{k}.json", "w"))
json.dump(rows, open(f"{out}/../rows.json", "w"))
json.dump(json.load(open("examples/materials/carpaint_kemppinen.json")),
          open(f"{out}/carpaint.json", "w"))
EOF

"$BUILD_DIR/client/cli/glint" preview --server "$SERVER" --materials "$OUT/materials" \
  --lights examples/lights/studio.json --scene sphere --size "$SIZE" --seed 1 \
  --out "$OUT/k.exr"

"$PY" - "$OUT" "$FIGURE" <<'EOF'
import json, sys
import numpy as np
import OpenEXR
from PIL import Image, ImageDraw, ImageFont
out, figure = sys.argv[1], sys.argv[2]
rows = json.load(open(f"{out}/rows.json"))
def read(path):
    c = OpenEXR.File(path).channels()
    return np.asarray(c["RGB" if "RGB" in c else "RGBA"].pixels, dtype=np.float64)[..., :3]
names = [f"{r}_{k}" for r in rows for k in range(4)] + ["carpaint"]
imgs = {n: read(f"{out}/k_{n}.exr") for n in names}
cover = np.isfinite(imgs[names[0]]).all(axis=2)  # every pixel is finite when all is well
table = ["| image | parameter | mean L | lit pixels | max L | finite, >= 0 |",
         "| --- | --- | --- | --- | --- | --- |"]
bad = []
for n in names:
    img = imgs[n]
    y = img.mean(axis=2)
    ok = bool(np.isfinite(img).all() and (img >= 0).all())
    lit = (y > 0).mean()
    row, k = (n.rsplit("_", 1) + ["-"])[:2]
    value = rows[row][int(k)] if row in rows else "colours"
    table.append(f"| {n} | {row} = {value} | {y.mean():.4f} | {100 * lit:.1f}% | {y.max():.4g} "
                 f"| {'yes' if ok else 'NO'} |")
    if not ok or not (y.max() > 0):
        bad.append(f"{n}: black or not finite / negative")
for r in rows:
    for k in range(3):
        a, b = imgs[f"{r}_{k}"], imgs[f"{r}_{k + 1}"]
        if np.array_equal(a, b):
            bad.append(f"{r}_{k} and {r}_{k + 1} are identical")
open(f"{out}/stats.md", "w").write("\n".join(table) + "\n")
print("\n".join(table))
if bad:
    sys.exit("kemppinen_figure: " + "; ".join(bad))

tiles = {n: Image.open(f"{out}/k_{n}.png").convert("RGB") for n in names}
w, h = tiles[names[0]].size
def font(sz):
    try:
        return ImageFont.load_default(size=sz)
    except TypeError:
        return ImageFont.load_default()
left, pad, cap, top = 118, 4, 18, 28
label = {"density": "density (facets / uv area)", "microroughness": "microroughness",
         "alpha": "roughness alpha", "anisotropy": "glint anisotropy"}
fmt = {"density": lambda v: f"{v:.0e}", "microroughness": lambda v: f"{v:g}",
       "alpha": lambda v: f"{v:g}", "anisotropy": lambda v: f"{v:g}"}
n_rows = len(rows) + 1
sheet = Image.new("RGB", (left + 4 * (w + pad), top + n_rows * (h + cap + pad) + 22), (24, 24, 24))
draw = ImageDraw.Draw(sheet)
draw.text((8, 6), "KEMPPINEN (Kemppinen et al. 2025), after Fig. 10: each row varies one parameter",
          fill="white", font=font(15))
for i, r in enumerate(rows):
    y0 = top + i * (h + cap + pad)
    words = label[r].split(" ", 1)
    draw.text((8, y0 + h // 2 - 14), words[0], fill="white", font=font(14))
    if len(words) > 1:
        draw.text((8, y0 + h // 2 + 4), words[1], fill=(190, 190, 190), font=font(12))
    for k, v in enumerate(rows[r]):
        x0 = left + k * (w + pad)
        sheet.paste(tiles[f"{r}_{k}"], (x0, y0))
        draw.text((x0 + 4, y0 + h + 2), f"{r} {fmt[r](v)}", fill=(190, 190, 190), font=font(12))
y0 = top + len(rows) * (h + cap + pad)
draw.text((8, y0 + h // 2 - 14), "car paint", fill="white", font=font(14))
draw.text((8, y0 + h // 2 + 4), "2 glint colours", fill=(190, 190, 190), font=font(12))
sheet.paste(tiles["carpaint"], (left, y0))
draw.text((left + 4, y0 + h + 2), "Beckmann 0.25, density 3e5", fill=(190, 190, 190), font=font(12))
draw.text((left + w + 16, y0 + 10),
          "base: GGX alpha 0.3, density 1e5,\nmicroroughness 0.02, filter 0.7,\n4 neighbours, "
          "anisotropy 1, f0 0.9;\nstudio lights (sun + 2 points),\nseed 1, glint preview spheres",
          fill=(190, 190, 190), font=font(13))
sheet.save(figure, optimize=True)
print(f"figure: {figure}")
EOF
