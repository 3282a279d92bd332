#!/usr/bin/env bash
# "Show it" for the Chermain et al. 2020 glint model: renders `--scene plane` previews under the
# sun of Table 1's sparkling stone, fabric and car paint (colour table), of examples/materials/sparkle_chermain.json at
# three densities, and of the smooth Beckmann model, and Table 1's brushed aluminium (the plane's
# G-buffer with uv stretched 1000:1, shaded by `glint render`), then assembles a labelled contact
# sheet and prints per-image statistics.
#
#   bash scripts/chermain_figure.sh
#
# Writes out/chermain/<name>.{exr,png}, out/chermain/stats.md and docs/chermain_figure.png.
# Expects a built tree (scripts/build.sh runs if the binaries are missing) and Python 3 with
# numpy, Pillow and OpenEXR (scripts/lib/figure_common.sh: the system's, or a venv of its own).
# Environment: GLINT_BUILD_DIR (default build), GLINT_OUT_DIR (default out/chermain),
# GLINT_FIGURE (default docs/chermain_figure.png), GLINT_SIZE (default 480x270).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR="${GLINT_BUILD_DIR:-build}"
OUT="${GLINT_OUT_DIR:-$PWD/out/chermain}"
FIGURE="${GLINT_FIGURE:-$PWD/docs/chermain_figure.png}"
SIZE="${GLINT_SIZE:-480x270}"

source scripts/lib/figure_common.sh
figure_require_build
figure_python

mkdir -p "$OUT/materials" "$(dirname "$FIGURE")"
figure_start_glintd "$OUT/glintd.log"

# The materials: Table 1's stone and fabric (alpha, ln rho, beta, zeta), the example at three
# densities, and the smooth Beckmann reference of the example.
"$PY" - "$OUT/materials" <<'EOF'
import json, sys
out = sys.argv[1]
base = json.load(open("examples/materials/sparkle_chermain.json"))
def variant(name, **kw):
    m = json.loads(json.dumps(base))
    for k in ("alpha_x", "alpha_y"):
        if k in kw: m[k] = kw.pop(k)
    m["chermain"].update(kw)
    json.dump(m, open(f"{out}/{name}.json", "w"))
variant("stone", alpha_x=1.0, alpha_y=1.0, log_density=20, relative_area=0.01, density_randomisation=2)
variant("fabric", alpha_x=0.3, alpha_y=0.3, log_density=20, relative_area=0.2, density_randomisation=2)
for ld in (8, 14, 20):
    variant(f"sparkle_{ld}", log_density=ld)
json.dump(json.load(open("examples/materials/carpaint_chermain.json")), open(f"{out}/carpaint.json", "w"))
smooth = {k: v for k, v in base.items() if k != "chermain"}
smooth["model"] = "SMOOTH"
json.dump(smooth, open(f"{out}/smooth.json", "w"))
# Table 1 brushed aluminium: alpha (0.5, 0.1), ln rho 20.6, beta 0.9, zeta 0.01, max anisotropy 8.
json.dump({"model": "CHERMAIN", "ndf": "BECKMANN", "alpha_x": 0.5, "alpha_y": 0.1,
           "schlick": {"f0": [0.91, 0.92, 0.92]},
           "chermain": {"log_density": 20.6, "relative_area": 0.9, "density_randomisation": 0.01,
                        "max_anisotropy": 8, "dictionary_size": 192}},
          open(f"{out}/brushed.json", "w"))
EOF

PREVIEWS="stone fabric carpaint sparkle_8 sparkle_14 sparkle_20 smooth"
NAMES="$PREVIEWS brushed rect_14"
for n in $PREVIEWS; do
  "$BUILD_DIR/client/cli/glint" preview --server "$SERVER" --material "$OUT/materials/$n.json" \
    --lights examples/lights/sun.json --scene plane --size "$SIZE" --seed 1 \
    --out "$OUT/$n.exr" --gbuffer-out "$OUT/plane_gbuffer.exr" >/dev/null
  echo "rendered $OUT/$n.{exr,png}"
done

# Brushed aluminium (CSDD20 Sec. 7.1, Fig. 13: the surface position stretched by 1,000 along x,
# max anisotropy 8): the plane's G-buffer with v (and dv/dx, dv/dy) divided by 1000, i.e. u
# stretched 1000:1 against v, at a scale where the clamped footprint spans a few hundred level-0
# cells (the preview plane's uv is 2 units per world unit, too coarse to stretch u alone: the LOD
# would pass the last level and give the smooth BRDF). The exposure of its PNG is -1.8 stops
# (the streaked highlight fills the plane at ~2 W/m^2/sr, which the preview's PNG clips).
"$PY" - "$OUT/plane_gbuffer.exr" "$OUT/plane_gbuffer_brushed.exr" <<'EOF'
import sys
import numpy as np
import OpenEXR
f = OpenEXR.File(sys.argv[1])
ch = {k: np.array(v.pixels) for k, v in f.channels().items()}
for k in ("uv.V", "dvdx", "dvdy"):
    ch[k] = (ch[k] / 1000).astype(np.float32)
OpenEXR.File(f.header(), ch).write(sys.argv[2])
EOF
"$BUILD_DIR/client/cli/glint" render --server "$SERVER" --gbuffer "$OUT/plane_gbuffer_brushed.exr" \
  --material "$OUT/materials/brushed.json" --lights examples/lights/sun.json --seed 1 \
  --out "$OUT/brushed.exr" >/dev/null
echo "rendered $OUT/brushed.exr"

# A polygon light (beyond the paper; models/chermain/chermain_polygons.h): the ln rho 14 example
# under examples/lights/rect_small.json (LTC area method).
cp "$OUT/materials/sparkle_14.json" "$OUT/materials/rect_14.json"
"$BUILD_DIR/client/cli/glint" preview --server "$SERVER" --material "$OUT/materials/rect_14.json" \
  --lights examples/lights/rect_small.json --scene plane --size "$SIZE" --seed 1 \
  --out "$OUT/rect_14.exr" >/dev/null
"$BUILD_DIR/client/cli/glint" preview --server "$SERVER" --material "$OUT/materials/smooth.json" \
  --lights examples/lights/rect_small.json --scene plane --size "$SIZE" --seed 1 \
  --out "$OUT/smooth_rect.exr" >/dev/null  # its reference (statistics only)
echo "rendered $OUT/rect_14.{exr,png}"

"$PY" - "$OUT" "$FIGURE" "$NAMES" <<'EOF'
import json, sys
import numpy as np
import OpenEXR
from PIL import Image, ImageDraw, ImageFont
out, figure, names = sys.argv[1], sys.argv[2], sys.argv[3].split()
def read(path):  # preview EXRs hold RGB, render's RGBA
    c = OpenEXR.File(path).channels()
    return np.asarray(c["RGB" if "RGB" in c else "RGBA"].pixels, dtype=np.float64)[..., :3]
def to_png(img, stops):  # linear -> sRGB, 8 bits
    x = np.clip(img * 2.0 ** stops, 0, 1)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)
    return Image.fromarray((x * 255 + 0.5).astype(np.uint8), "RGB")
refs = {n: read(f"{out}/smooth.exr").mean(axis=2) for n in names}
refs["rect_14"] = read(f"{out}/smooth_rect.exr").mean(axis=2)  # same light
rows, images = [], {}
for n in names:
    img = read(f"{out}/{n}.exr")
    y = img.mean(axis=2)
    ref = refs[n]
    mask = ref > 0
    m = json.load(open(f"{out}/materials/{n}.json"))
    c = m.get("chermain", {})
    rows.append(dict(name=n, alpha=m["alpha_x"], ld=c.get("log_density"), beta=c.get("relative_area"),
                     lit=((y > 0) & mask).sum() / mask.sum(), ratio=y[mask].mean() / ref[mask].mean(),
                     peak=y[mask].max(), ok=bool(np.isfinite(img).all() and (img >= 0).all())))
    if n == "brushed":
        images[n] = to_png(img, -1.8)
        images[n].save(f"{out}/{n}.png")
    else:
        images[n] = Image.open(f"{out}/{n}.png").convert("RGB")
table = ["| image | alpha | ln(rho) | beta | lit pixels | mean L / smooth | max L | finite, >= 0 |",
         "| --- | --- | --- | --- | --- | --- | --- | --- |"]
for r in rows:
    table.append(f"| {r['name']} | {r['alpha']} | {r['ld'] if r['ld'] is not None else '-'} "
                 f"| {r['beta'] if r['beta'] is not None else '-'} | {100 * r['lit']:.1f}% "
                 f"| {r['ratio']:.3f} | {r['peak']:.4g} | {'yes' if r['ok'] else 'NO'} |")
open(f"{out}/stats.md", "w").write("\n".join(table) + "\n")
print("\n".join(table))
w, h = images[names[0]].size
pad, top, foot = 6, 30, 22
def font(sz):
    try:
        return ImageFont.load_default(size=sz)
    except TypeError:
        return ImageFont.load_default()
cols = 3
rows_n = (len(names) + cols - 1) // cols
sheet = Image.new("RGB", (cols * (w + pad) + pad, rows_n * (h + top + foot) + 26), (24, 24, 24))
draw = ImageDraw.Draw(sheet)
label = {"stone": "Table 1 stone: alpha 1, ln rho 20, beta 0.01",
         "fabric": "Table 1 fabric: alpha 0.3, ln rho 20, beta 0.2",
         "carpaint": "Table 1 2CV paint: alpha 0.1, ln rho 23, beta 0.3, 4 colours",
         "sparkle_8": "alpha 0.15, ln rho 8", "sparkle_14": "alpha 0.15, ln rho 14",
         "sparkle_20": "alpha 0.15, ln rho 20", "smooth": "SMOOTH Beckmann alpha 0.15 (reference)",
         "brushed": "Table 1 brushed alu.: alpha (0.5, 0.1), ln rho 20.6, uv 1000:1, gamma 8",
         "rect_14": "alpha 0.15, ln rho 14 under a rect light (polygon approx.)"}
for k, (n, r) in enumerate(zip(names, rows)):
    x0 = pad + (k % cols) * (w + pad)
    y0 = (k // cols) * (h + top + foot)
    draw.text((x0 + 4, y0 + 8), label.get(n, n), fill="white", font=font(15))
    sheet.paste(images[n], (x0, y0 + top))
    draw.text((x0 + 4, y0 + top + h + 3), f"lit {100 * r['lit']:.1f}%, mean/smooth {r['ratio']:.2f}",
              fill=(190, 190, 190), font=font(13))
draw.text((8, sheet.height - 22), "CHERMAIN, Beckmann, Schlick f0 (0.95, 0.93, 0.88) (paint: 1), zeta 2 (paint: 0.01), "
          "max anisotropy 4-8, N = 192; sun E = 1 (last: rect L = 150); scene plane; brushed -1.8 stops",
          fill=(190, 190, 190), font=font(13))
sheet.save(figure)
print(f"contact sheet: {figure}")
EOF
