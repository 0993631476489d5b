"""Shared helpers for the benchmark peers: PFM I/O, hdrflow's lat-long and sphere conventions,
the exact reference and the error measure. Pure NumPy, no timing-sensitive code here.

Conventions (must match hdrflow exactly; see src/geometry/latlong.rs and src/maths/render/relight/view.rs):
- W x H lat-long map, row 0 = zenith (+Y). Texel (x, y) centre: theta = pi (y + 0.5) / H,
  phi = 2 pi (x + 0.5) / W, d = (-sin t sin p, cos t, sin t cos p); solid angle
  (2 pi / W)(pi / H) sin(theta) (midpoint rule).
- S x S sphere image, unit sphere inscribed, orthographic, black background; see sphere_view().
"""

import json
import math
import os
import sys

import numpy as np


# ----------------------------------------------------------------------------------------------
# PFM


def read_pfm(path):
    """Reads a PFM (PF or Pf, either byte order) into a float32 array (H, W, C), row 0 at the top
    (PFM stores rows bottom to top). The scale's magnitude is not applied (as in hdrflow)."""
    with open(path, "rb") as f:
        data = f.read()
    pos = 0
    tokens = []
    while len(tokens) < 4:
        while data[pos : pos + 1].isspace():
            pos += 1
        start = pos
        while pos < len(data) and not data[pos : pos + 1].isspace():
            pos += 1
        tokens.append(data[start:pos])
    pos += 1  # exactly one whitespace byte after the scale
    magic = tokens[0]
    if magic not in (b"PF", b"Pf"):
        raise ValueError(f"{path}: not a PFM file (magic {magic!r})")
    channels = 3 if magic == b"PF" else 1
    w, h = int(tokens[1]), int(tokens[2])
    scale = float(tokens[3])
    dtype = "<f4" if scale < 0 else ">f4"
    count = w * h * channels
    arr = np.frombuffer(data, dtype=dtype, count=count, offset=pos).astype(np.float32)
    arr = arr.reshape(h, w, channels)[::-1]
    return np.ascontiguousarray(arr)


def write_pfm(path, img):
    """Writes an (H, W, 3) or (H, W) image as a little-endian PFM (scale -1.0), rows bottom to top,
    exactly as hdrflow's writer does."""
    img = np.asarray(img, dtype=np.float32)
    if img.ndim == 2:
        magic, img = "Pf", img[:, :, None]
    else:
        magic = "PF" if img.shape[2] != 1 else "Pf"
        if img.shape[2] > 3:
            img = img[:, :, :3]
    h, w = img.shape[:2]
    with open(path, "wb") as f:
        f.write(f"{magic}\n{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(img[::-1]).astype("<f4").tobytes())


# ----------------------------------------------------------------------------------------------
# Lat-long


def direction(theta, phi):
    """hdrflow's direction of (theta, phi) (arrays broadcast), stacked on the last axis."""
    st = np.sin(theta)
    return np.stack([-st * np.sin(phi), np.cos(theta) * np.ones_like(phi), st * np.cos(phi)], axis=-1)


def texel_directions(w, h):
    """(H, W, 3) float64 texel-centre directions and (H,) solid angles of a W x H map."""
    theta = math.pi * (np.arange(h) + 0.5) / h
    phi = 2.0 * math.pi * (np.arange(w) + 0.5) / w
    d = direction(theta[:, None], phi[None, :])
    sa = (2.0 * math.pi / w) * (math.pi / h) * np.sin(theta)
    return d, sa


def texel_of_direction(d, w, h):
    """hdrflow's texel_of_direction for an (..., 3) array of directions: (x, y) integer arrays."""
    d = np.asarray(d, dtype=np.float64)
    n = np.linalg.norm(d, axis=-1)
    theta = np.arccos(np.clip(d[..., 1] / n, -1.0, 1.0))
    phi = np.arctan2(-d[..., 0], d[..., 2])
    phi = np.where(phi < 0.0, phi + 2.0 * math.pi, phi)
    phi = np.where(phi >= 2.0 * math.pi, 0.0, phi)
    x = np.clip(np.floor(phi / (2.0 * math.pi) * w).astype(np.int64), 0, w - 1)
    y = np.clip(np.floor(theta / math.pi * h).astype(np.int64), 0, h - 1)
    return x, y


# ----------------------------------------------------------------------------------------------
# Sphere framing (SphereView::new)


def _normalised(a):
    a = np.asarray(a, dtype=np.float64)
    n = math.sqrt(float(a @ a))
    return a / n if n > 0.0 and math.isfinite(n) else None


def sphere_view(theta_deg, phi_deg):
    """(view_dir, right, up) exactly as hdrflow's SphereView::new(direction_deg(theta, phi))."""
    v = _normalised(direction(math.radians(theta_deg), math.radians(phi_deg)))
    if v is None:
        v = np.array([0.0, 0.0, 1.0])
    forward = -v
    vy = v[1]
    projected = np.array([-vy * v[0], 1.0 - vy * v[1], -vy * v[2]])
    if math.sqrt(float(projected @ projected)) > 1e-9:
        up_hint = _normalised(projected)
        if up_hint is None:
            up_hint = np.array([0.0, 1.0, 0.0])
    elif vy > 0.0:
        up_hint = np.array([0.0, 0.0, -1.0])
    else:
        up_hint = np.array([0.0, 0.0, 1.0])
    right = _normalised(np.cross(forward, up_hint))
    if right is None:
        right = np.array([1.0, 0.0, 0.0])
    up = _normalised(np.cross(right, forward))
    if up is None:
        up = up_hint
    return v, right, up


def screen_coords(size):
    """(sx, sy) pixel-centre screen coordinates, each (S, S), row 0 at the top."""
    c = 2.0 * (np.arange(size) + 0.5) / size - 1.0
    sx = np.broadcast_to(c[None, :], (size, size))
    sy = np.broadcast_to(-c[:, None], (size, size))
    return sx, sy


def disc_normals(size, view):
    """(mask (S, S) bool, normals (M, 3) float64) of the disc pixels, row-major order."""
    v, right, up = view
    sx, sy = screen_coords(size)
    r2 = sx * sx + sy * sy
    mask = r2 <= 1.0
    sxm, sym = sx[mask], sy[mask]
    sz = np.sqrt(np.maximum(1.0 - (sxm * sxm + sym * sym), 0.0))
    n = sxm[:, None] * right[None, :] + sym[:, None] * up[None, :] + sz[:, None] * v[None, :]
    return mask, n


def inner_mask(size, r2_max=0.9):
    sx, sy = screen_coords(size)
    return sx * sx + sy * sy <= r2_max


# ----------------------------------------------------------------------------------------------
# Exact reference and error


def reference_sphere(env, size, view, albedo, chunk=1024):
    """The exact answer of hdrflow's ReferenceSphere: (a / pi) sum_i L_i dOmega_i max(n.d_i, 0)
    over every texel, float64, chunked over normals. O(pixels x texels): small inputs only."""
    h, w = env.shape[:2]
    d, sa = texel_directions(w, h)
    lw = env.astype(np.float64) * sa[:, None, None]  # L dOmega
    keep = np.any(lw != 0.0, axis=2)
    dirs = d[keep]  # (T, 3)
    lw = lw[keep]  # (T, 3)
    mask, normals = disc_normals(size, view)
    out = np.zeros((normals.shape[0], 3))
    for i in range(0, normals.shape[0], chunk):
        c = np.maximum(normals[i : i + chunk] @ dirs.T, 0.0)
        out[i : i + chunk] = c @ lw
    out *= np.asarray(albedo, dtype=np.float64)[None, :] / math.pi
    img = np.zeros((size, size, 3))
    img[mask] = out
    return img


def relative_rmse(img, ref, mask):
    """sqrt(sum (img - ref)^2) / sqrt(sum ref^2) over the pixels of `mask`, all three channels."""
    a = np.asarray(img, dtype=np.float64)[mask]
    b = np.asarray(ref, dtype=np.float64)[mask]
    den = math.sqrt(float(np.sum(b * b)))
    return math.sqrt(float(np.sum((a - b) ** 2))) / den if den > 0 else float("nan")


# ----------------------------------------------------------------------------------------------
# Test map and small CLI helpers


def make_test_map(w=256, h=128, spot=(0.35, 0.30), spot_texels=2, spot_radiance=(2000.0, 1800.0, 1500.0)):
    """A smooth sky (brighter towards the zenith, a blue-ish gradient varying with azimuth so the
    map is asymmetric) with a small bright spot of spot_texels x spot_texels texels whose top-left
    texel is at fractional position `spot` = (x / W, y / H). float32 (H, W, 3)."""
    theta = math.pi * (np.arange(h) + 0.5) / h
    phi = 2.0 * math.pi * (np.arange(w) + 0.5) / w
    t, p = np.meshgrid(theta, phi, indexing="ij")
    sky = 0.2 + 0.8 * np.clip(np.cos(t), 0.0, 1.0) + 0.3 * (1.0 + np.cos(p - 1.0)) * np.sin(t)
    ground = np.where(t > math.pi / 2, 0.3, 1.0)
    img = np.stack([0.6 * sky, 0.8 * sky, 1.2 * sky], axis=-1) * ground[..., None]
    x0, y0 = int(spot[0] * w), int(spot[1] * h)
    img[y0 : y0 + spot_texels, x0 : x0 + spot_texels] = np.asarray(spot_radiance)
    return img.astype(np.float32)


def parse_counts(s):
    return [int(c) for c in s.split(",") if c.strip()]


def parse_seeds(seeds, seed):
    """The seeds to render: `--seeds 1,2,3` if given (the first one is timed), else [--seed]."""
    if seeds:
        out = [int(x) for x in seeds.split(",") if x.strip()]
        if out:
            return out
    return [seed]


def parse_pair(s):
    a, b = s.split(",")
    return float(a), float(b)


def parse_triple(s):
    parts = [float(p) for p in s.split(",")]
    if len(parts) == 1:
        parts = parts * 3
    if len(parts) != 3:
        raise ValueError(f"expected 1 or 3 comma-separated numbers, got {s!r}")
    return parts


def write_results(out_dir, results):
    os.makedirs(out_dir, exist_ok=True)
    path = os.path.join(out_dir, "results.json")
    with open(path, "w") as f:
        json.dump(results, f, indent=2)
        f.write("\n")
    return path


def eprint(*a):
    print(*a, file=sys.stderr, flush=True)


if __name__ == "__main__":
    # `python3 pfm_common.py --test-map OUT.pfm [W H]`: writes the --check test map.
    import argparse

    ap = argparse.ArgumentParser(description="write the peers' --check test map (smooth sky + bright spot)")
    ap.add_argument("--test-map", required=True, metavar="OUT.pfm")
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--height", type=int, default=128)
    args = ap.parse_args()
    write_pfm(args.test_map, make_test_map(args.width, args.height))
    print(args.test_map)
