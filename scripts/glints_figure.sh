#!/usr/bin/env bash
# "Show it" for the binomial glint model (Kneiphof & Klein 2024): renders the sparkle material
# (examples/materials/sparkle_binomial.json) on the `--scene plane` preview under a small and a
# large rectangle light of equal power and under the sun, at three facet densities plus the
# smooth model, then assembles a labelled contact sheet and prints per-image statistics.
#
#   bash scripts/glints_figure.sh
#
# Writes out/glints/<light>_<density>.{exr,png} (density "smooth" for the reference),
# out/glints/stats.md (the table), docs/glints_figure.png (the contact sheet).
# Expects a built tree (scripts/build.sh runs if the binaries are missing) and Python 3 with
# numpy, Pillow and OpenEXR (scripts/lib/figure_common.sh: the system's, or a venv of its own).
#
# Environment: GLINT_BUILD_DIR (default build), GLINT_OUT_DIR (default out/glints),
# GLINT_FIGURE (default docs/glints_figure.png), GLINT_SIZE (default 640x360),
# GLINT_DENSITIES (default "1e4 1e6 1e8"), GLINT_SEED (default 1).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR="${GLINT_BUILD_DIR:-build}"
OUT="${GLINT_OUT_DIR:-$PWD/out/glints}"
FIGURE="${GLINT_FIGURE:-$PWD/docs/glints_figure.png}"
SIZE="${GLINT_SIZE:-640x360}"
DENSITIES="${GLINT_DENSITIES:-1e4 1e6 1e8}"
SEED="${GLINT_SEED:-1}"
MATERIAL=examples/materials/sparkle_binomial.json
LIGHTS="rect_small rect_large sun"
# PNG exposure (stops) per row: the same for every image of a row so brightness compares.
declare -A EXPOSURE=([rect_small]=0 [rect_large]=0 [sun]=-0.5)

source scripts/lib/figure_common.sh
figure_require_build
figure_python

mkdir -p "$OUT" "$(dirname "$FIGURE")"
figure_start_glintd "$OUT/glintd.log"
GLINT="$BUILD_DIR/client/cli/glint"

# Material variants: one per density (the example's binomial block with that density), and
# the smooth reference (same NDF, roughness and Fresnel, no binomial block).
mkdir -p "$OUT/materials"
"$PY" - "$MATERIAL" "$OUT/materials" $DENSITIES <<'EOF'
import json, sys
src, out, densities = sys.argv[1], sys.argv[2], sys.argv[3:]
m = json.load(open(src))
for d in densities:
    v = json.loads(json.dumps(m))
    v["binomial"]["density"] = float(d)
    json.dump(v, open(f"{out}/sparkle_{d}.json", "w"))
s = {k: v for k, v in m.items() if k != "binomial"}
s["model"] = "SMOOTH"
json.dump(s, open(f"{out}/sparkle_smooth.json", "w"))
EOF

for light in $LIGHTS; do
  for d in $DENSITIES smooth; do
    "$GLINT" preview --server "$SERVER" --material "$OUT/materials/sparkle_$d.json" \
      --lights "examples/lights/$light.json" --scene plane --size "$SIZE" --seed "$SEED" \
      --exposure "${EXPOSURE[$light]}" --out "$OUT/${light}_$d.exr" >/dev/null
    echo "rendered $OUT/${light}_$d.{exr,png}"
  done
done

# Statistics (from the EXRs) and the contact sheet (from the PNGs).
EXPOSURES="$(for l in $LIGHTS; do printf '%s %s, ' "$l" "${EXPOSURE[$l]}"; done)"
"$PY" - "$OUT" "$FIGURE" "$SIZE" "$MATERIAL" "$LIGHTS" "$DENSITIES" "${EXPOSURES%, }" <<'EOF'
import json, math, sys
import numpy as np
import OpenEXR
from PIL import Image, ImageDraw, ImageFont

out, figure, size, material, lights, densities, exposures = sys.argv[1:8]
lights, densities = lights.split(), densities.split()
width, height = (int(x) for x in size.split("x"))
mat = json.load(open(material))

def read(path):
    return np.asarray(OpenEXR.File(path).channels()["RGB"].pixels, dtype=np.float64)

# Per-pixel uv footprint area of the plane preview (client/preview/preview_scene.h: camera eye
# (0,-6.5,3.5) looking at (0,-0.4,0), 30 deg vertical FOV, plane z = 0, |x|,|y| <= 2,
# uv = 2 (x, y)), for N_P = density * |det J|; centred half-pixel differences as the client.
eye = np.array([0.0, -6.5, 3.5]); look = np.array([0.0, -0.4, 0.0]); up = np.array([0.0, 0.0, 1.0])
fwd = (look - eye) / np.linalg.norm(look - eye)
right = np.cross(fwd, up); right /= np.linalg.norm(right); cup = np.cross(right, fwd)
tv = math.tan(math.radians(15.0)); th = tv * width / height
def hit_uv(px, py):
    d = (fwd[None, None, :] + ((2 * px / width - 1) * th)[..., None] * right
         + ((1 - 2 * py / height) * tv)[..., None] * cup)
    t = -eye[2] / d[..., 2]
    p = eye + t[..., None] * d
    return 2.0 * p[..., 0], 2.0 * p[..., 1], p
ys, xs = np.mgrid[0:height, 0:width].astype(np.float64) + 0.5
_, _, pc = hit_uv(xs, ys)
on_plane = (np.abs(pc[..., 0]) <= 2) & (np.abs(pc[..., 1]) <= 2)
u1, v1, _ = hit_uv(xs + 0.5, ys); u0, v0, _ = hit_uv(xs - 0.5, ys)
u3, v3, _ = hit_uv(xs, ys + 0.5); u2, v2, _ = hit_uv(xs, ys - 0.5)
uv_area = np.abs((u1 - u0) * (v3 - v2) - (u3 - u2) * (v1 - v0))[on_plane]

rows = []
images = {}
for light in lights:
    ref = read(f"{out}/{light}_smooth.exr").mean(axis=2)
    mask = ref > 0  # plane pixels the light reaches in the smooth model
    ref_mean = ref[mask].mean()
    for d in densities + ["smooth"]:
        img = read(f"{out}/{light}_{d}.exr")
        y = img.mean(axis=2)
        finite = np.isfinite(img).all()
        lit = (y > 0) & mask
        n_p = float(d) * np.median(uv_area) if d != "smooth" else float("nan")
        rows.append(dict(light=light, density=d, n_p=n_p, lit=lit.sum() / mask.sum(),
                         lit_mean=y[lit].mean() if lit.any() else 0.0,
                         mean=y[mask].mean(), ratio=y[mask].mean() / ref_mean,
                         peak=y[mask].max(), finite=finite, nonneg=(img >= 0).all()))
        images[light, d] = Image.open(f"{out}/{light}_{d}.png").convert("RGB")

table = ["| light | density [1/uv^2] | median N_P per pixel | lit pixels | mean L of lit pixels "
         "| mean L (all plane pixels) | / smooth mean | max L | finite, >= 0 |",
         "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
for r in rows:
    n_p = "-" if r["density"] == "smooth" else f"{r['n_p']:.3g}"
    table.append(f"| {r['light']} | {r['density']} | {n_p} | {100 * r['lit']:.2f}% "
                 f"| {r['lit_mean']:.4g} | {r['mean']:.4g} | {r['ratio']:.3f} | {r['peak']:.4g} "
                 f"| {'yes' if r['finite'] and r['nonneg'] else 'NO'} |")
open(f"{out}/stats.md", "w").write("\n".join(table) + "\n")
print("\n".join(table))
print(f"plane pixels: {on_plane.sum()}, uv area per pixel: median {np.median(uv_area):.3g}, "
      f"range {uv_area.min():.3g} .. {uv_area.max():.3g}")

# Contact sheet: rows = lights, columns = densities + smooth, cropped to the plane.
yy, xx = np.nonzero(on_plane)
box = (max(int(xx.min()) - 4, 0), max(int(yy.min()) - 4, 0),
       min(int(xx.max()) + 5, width), min(int(yy.max()) + 5, height))
cw, ch = box[2] - box[0], box[3] - box[1]
left, top, pad, foot = 150, 56, 6, 22
def font(sz):
    try:
        return ImageFont.load_default(size=sz)
    except TypeError:
        return ImageFont.load_default()
f_big, f_small = font(18), font(13)
sheet = Image.new("RGB", (left + len(densities + ["smooth"]) * (cw + pad),
                          top + len(lights) * (ch + foot + pad) + 30), (24, 24, 24))
draw = ImageDraw.Draw(sheet)
names = {"rect_small": "small rect\n0.4 x 0.4,\nL = 150",
         "rect_large": "large rect\n2 x 2, L = 6\n(25x area,\n1/25 radiance,\nsame power)",
         "sun": "sun\nE = 1,\n0.26 deg cone"}
cols = densities + ["smooth"]
for j, d in enumerate(cols):
    label = "smooth (reference)" if d == "smooth" else f"density {float(d):.0e} / uv^2"
    draw.text((left + j * (cw + pad) + 8, 8), label, fill="white", font=f_big)
    if d != "smooth":
        draw.text((left + j * (cw + pad) + 8, 32), f"N_P ~ {float(d) * np.median(uv_area):.3g} per pixel",
                  fill=(190, 190, 190), font=f_small)
for i, light in enumerate(lights):
    y0 = top + i * (ch + foot + pad)
    draw.multiline_text((8, y0 + 10), names.get(light, light), fill="white", font=f_big)
    for j, d in enumerate(cols):
        x0 = left + j * (cw + pad)
        sheet.paste(images[light, d].crop(box), (x0, y0))
        r = next(r for r in rows if r["light"] == light and r["density"] == d)
        draw.text((x0 + 4, y0 + ch + 3),
                  f"lit {100 * r['lit']:.1f}%, mean lit L {r['lit_mean']:.3g}, mean/smooth {r['ratio']:.2f}",
                  fill=(190, 190, 190), font=f_small)
mat_b = mat["binomial"]
draw.text((8, sheet.height - 24),
          f"{mat['ndf']} alpha {mat['alpha_x']}, Schlick f0 {mat['schlick']['f0']}, p_mode "
          f"{mat_b.get('p_mode', 'AREA')}, slope_cell {mat_b.get('slope_cell', 0.05)}; "
          f"rects of equal power; PNG exposure per row (stops): {exposures}; scene plane {width}x{height}",
          fill=(190, 190, 190), font=f_small)
sheet.save(figure)
print(f"contact sheet: {figure}")
EOF
