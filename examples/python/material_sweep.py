#!/usr/bin/env python3
"""Renders a roughness x facet-density sweep of the binomial glint model (Kneiphof & Klein 2024)
on spheres with the glint Python client and lays it out with matplotlib.

    pip install ./client/python matplotlib          # once, in a venv
    build/server/glintd --listen 127.0.0.1:50051 &
    python examples/python/material_sweep.py --server 127.0.0.1:50051 --out sweep.png

Each cell is one `Client.evaluate` of every covered pixel of a unit sphere seen by an orthographic
camera: world-space position, normal and tangent, a lat-long uv and its exact per-pixel footprint,
lit by a sun-like directional light (finite cone, so the glint model sees a light of finite size)
and a dim point fill. Rows vary the roughness alpha, columns the facets per unit uv area: few
facets per pixel sparkle, many converge to the smooth GGX highlight.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import glint

# uv = (U_SCALE * (phi / 2 pi + 1/2), V_SCALE * (1 - theta / pi)): square texels on the equator.
U_SCALE, V_SCALE = 8.0, 4.0


def sphere_queries(size: int):
    """Queries of the unit sphere at the origin seen from -y (orthographic, z up), one per pixel
    whose centre falls on the sphere. Returns the pixel mask and the query arrays."""
    h = 2.0 / size  # pixel size in world units: the image spans [-1, 1]^2
    c = (np.arange(size) + 0.5) * h - 1.0
    X, Z = np.meshgrid(c, -c)  # row 0 at the top (z = +1)
    mask = X**2 + Z**2 < 1.0
    x, z = X[mask], Z[mask]
    s = np.sqrt(1.0 - x**2 - z**2)  # -y of the visible surface point
    position = np.stack([x, -s, z], axis=1)
    normal = position  # unit sphere
    phi = np.arctan2(x, s)  # 0 on the meridian facing the camera
    theta = np.arccos(np.clip(z, -1.0, 1.0))
    tangent = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=1)  # dp/dphi, unit
    uv = np.stack([U_SCALE * (phi / (2 * math.pi) + 0.5), V_SCALE * (1 - theta / math.pi)], axis=1)
    # Footprint (du/dx, dv/dx, du/dy, dv/dy) per pixel: x one column right (+X), y one row down
    # (-Z). From phi = atan2(X, s): dphi/dX = 1/s, dphi/dZ = X Z / (s (1 - Z^2)); from
    # theta = acos(Z): dtheta/dZ = -1 / sqrt(1 - Z^2). Clamped at the silhouette and poles,
    # where the footprint grows without bound.
    s_c = np.maximum(s, 1e-3)
    rz = np.maximum(1.0 - z**2, 1e-6)
    du_dX = U_SCALE / (2 * math.pi) / s_c
    du_dZ = U_SCALE / (2 * math.pi) * x * z / (s_c * rz)
    dv_dZ = V_SCALE / (math.pi * np.sqrt(rz))
    footprint = np.stack([du_dX * h, np.zeros_like(x), -du_dZ * h, -dv_dZ * h], axis=1)
    wo = np.array([0.0, -1.0, 0.0])  # towards the camera, the same for every pixel
    return mask, dict(position=position, normal=normal, tangent=tangent, uv=uv, footprint=footprint, wo=wo)


def tonemap(rgb: np.ndarray, exposure: float) -> np.ndarray:
    """Reinhard on linear radiance times 2^exposure, then the sRGB transfer curve."""
    x = rgb * 2.0**exposure
    x = x / (1.0 + x)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055).clip(0, 1)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--server", default="127.0.0.1:50051")
    ap.add_argument("--out", default="material_sweep.png")
    ap.add_argument("--size", type=int, default=192, help="pixels per sphere (square)")
    ap.add_argument("--alphas", default="0.05,0.1,0.2,0.4")
    ap.add_argument("--densities", default="1e4,1e6,1e8,1e10", help="facets per unit uv area")
    ap.add_argument("--exposure", type=float, default=0.0, help="stops")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    alphas = [float(a) for a in args.alphas.split(",")]
    densities = [float(d) for d in args.densities.split(",")]

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    mask, queries = sphere_queries(args.size)
    sun = np.array([-0.45, -0.7, 0.55])
    lights = {"lights": [
        {"directional": {"direction": list(sun / np.linalg.norm(sun)), "irradiance": [3, 3, 3],
                         "cone_half_angle_deg": 1.0}},
        {"point": {"position": [2.5, -2.0, -1.0], "intensity": [0.4, 0.45, 0.6], "radius": 0.2}},
    ]}
    fig, axes = plt.subplots(len(alphas), len(densities), figsize=(2.2 * len(densities), 2.2 * len(alphas)),
                             squeeze=False, facecolor="black")
    with glint.Client(args.server) as client:
        for i, alpha in enumerate(alphas):
            for j, density in enumerate(densities):
                material = {"model": "BINOMIAL", "ndf": "GGX", "alpha_x": alpha, "alpha_y": alpha,
                            "schlick": {"f0": [0.95, 0.93, 0.88]},
                            "binomial": {"density": density, "p_mode": "AREA"}}
                rgb = client.evaluate(material, lights=lights, seed=args.seed, **queries)
                image = np.zeros((args.size, args.size, 3), dtype=np.float32)
                image[mask] = rgb
                ax = axes[i][j]
                ax.imshow(tonemap(image, args.exposure), interpolation="nearest")
                ax.set_xticks([])
                ax.set_yticks([])
                if i == 0:
                    ax.set_title(f"density {density:.0e}", color="white", fontsize=9)
                if j == 0:
                    ax.set_ylabel(f"alpha {alpha:g}", color="white", fontsize=9)
    fig.suptitle("binomial glints: roughness x facet density", color="white")
    fig.tight_layout()
    fig.savefig(args.out, dpi=100, facecolor=fig.get_facecolor())
    print(f"wrote {args.out} ({len(alphas) * len(densities)} spheres, {int(mask.sum())} queries each)")


if __name__ == "__main__":
    main()
