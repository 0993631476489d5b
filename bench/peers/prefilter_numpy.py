#!/usr/bin/env python3
"""GGX specular prefiltering written the way a user writes it in NumPy: the peer of hdrflow's
`PrefilterSpecular` (docs/src/guides/ibl.md; docs/src/benchmarks/ibl.md, "Image-based lighting").

Same conventions as hdrflow: n = v = r, alpha = roughness^2, level k of `levels` has face size
max(1, size >> k) and roughness k / (levels - 1); faces +X -X +Y -Y +Z -Z in hdrflow's axes
(`src/geometry/cubemap.rs`), written as one 6S x S PFM strip per level like `Save` does; every
texel is sum L(l) (n.l)+ / sum (n.l)+ over N GGX half vectors of a Hammersley set (i/N, radical
inverse of i), pdf D(h)(n.h) (Karis 2013), l = 2 (n.h) h - n, the same N points for every texel
(1024 like cmgen and glTF-IBL-Sampler). What it does NOT do, like most hand-written prefilters:
no filtered importance sampling (no mip pyramid of the source), no cube resampling: it reads the
lat-long map directly, bilinearly (phi wraps, theta clamps), at every sample. Level 0 (roughness
0) is one bilinear read at the texel's direction.

    python3 prefilter_numpy.py ENV.pfm OUT_DIR --size 64 --levels 5 --samples 1024 [--only 1,2,3]
    python3 prefilter_numpy.py --compare A_{level}.pfm REF_{level}.pfm --levels-list 1,2,3

The first writes OUT_DIR/numpy_{k}.pfm and OUT_DIR/results.json (per level: size, roughness, time
in seconds; the PFM load apart); the second prints, per level, the RMS over every value of
(a - ref) / max(|ref|, 1e-6), the measure of `benches/ibl.rs`.
"""

import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pfm_common import read_pfm, write_pfm  # noqa: E402


def face_directions(size):
    """(6, S, S, 3) float64 unit directions of the texel centres (hdrflow's face_direction)."""
    c = 2.0 * (np.arange(size) + 0.5) / size - 1.0
    a, b = np.meshgrid(c, c)  # a along x (columns), b along y (rows)
    one = np.ones_like(a)
    n = np.sqrt(a * a + b * b + 1.0)
    x, y, z = a / n, b / n, one / n
    faces = [
        (z, -y, -x),
        (-z, -y, x),
        (x, z, y),
        (x, -z, -y),
        (x, -y, z),
        (-x, -y, -z),
    ]
    return np.stack([np.stack(f, axis=-1) for f in faces])


def hammersley(n):
    i = np.arange(n, dtype=np.uint64)
    r = np.zeros(n, dtype=np.float64)
    f = 0.5
    v = i.copy()
    while v.any():
        r += f * (v & 1).astype(np.float64)
        v >>= np.uint64(1)
        f *= 0.5
    return np.arange(n) / n, r


def bilinear(env, d):
    """Bilinear read of the lat-long map (H, W, 3) at directions d (..., 3)."""
    h, w = env.shape[:2]
    theta = np.arccos(np.clip(d[..., 1], -1.0, 1.0))
    phi = np.arctan2(-d[..., 0], d[..., 2])
    phi = np.where(phi < 0.0, phi + 2.0 * math.pi, phi)
    fx = phi * (w / (2.0 * math.pi)) - 0.5
    fy = np.clip(theta * (h / math.pi) - 0.5, 0.0, h - 1.0)
    x0 = np.floor(fx)
    y0 = np.floor(fy)
    tx = (fx - x0)[..., None].astype(np.float32)
    ty = (fy - y0)[..., None].astype(np.float32)
    x0 = x0.astype(np.int64) % w
    x1 = (x0 + 1) % w
    y0 = y0.astype(np.int64)
    y1 = np.minimum(y0 + 1, h - 1)
    top = env[y0, x0] * (1 - tx) + env[y0, x1] * tx
    bottom = env[y1, x0] * (1 - tx) + env[y1, x1] * tx
    return top * (1 - ty) + bottom * ty


def prefilter_level(env, size, roughness, samples, chunk_values=1 << 21):
    """One level: a (6, S, S, 3) float32 array."""
    dirs = face_directions(size).reshape(-1, 3)
    if roughness == 0.0:
        return bilinear(env, dirs).reshape(6, size, size, 3).astype(np.float32)
    alpha = roughness * roughness
    u1, u2 = hammersley(samples)
    a2 = alpha * alpha
    cos_t = np.sqrt(np.maximum((1.0 - u1) / (1.0 + (a2 - 1.0) * u1), 0.0))
    sin_t = np.sqrt(np.maximum(1.0 - cos_t * cos_t, 0.0))
    phi = 2.0 * math.pi * u2
    hx, hy, hz = sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t
    out = np.empty((dirs.shape[0], 3), dtype=np.float32)
    step = max(1, chunk_values // samples)
    for s in range(0, dirs.shape[0], step):
        n = dirs[s : s + step]
        up = np.where(np.abs(n[:, 2:3]) < 0.999, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
        tx = np.cross(up, n)
        tx /= np.linalg.norm(tx, axis=1, keepdims=True)
        ty = np.cross(n, tx)
        # h (k, N, 3) in world space, l = 2 (n.h) h - n.
        h = tx[:, None, :] * hx[None, :, None] + ty[:, None, :] * hy[None, :, None] + n[:, None, :] * hz[None, :, None]
        noh = hz[None, :, None]
        l = 2.0 * noh * h - n[:, None, :]
        nol = np.maximum(np.einsum("kj,knj->kn", n, l), 0.0)
        radiance = bilinear(env, l)
        w = nol.astype(np.float32)[..., None]
        out[s : s + step] = (radiance * w).sum(axis=1) / np.maximum(w.sum(axis=1), 1e-30)
    return out.reshape(6, size, size, 3)


def to_strip(level):
    """(6, S, S, 3) -> (S, 6S, 3): the faces side by side, +X at the left."""
    return np.concatenate(list(level), axis=1)


def rms_relative(a, ref):
    e = (a.astype(np.float64) - ref) / np.maximum(np.abs(ref.astype(np.float64)), 1e-6)
    return float(np.sqrt(np.mean(e * e)))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("env", nargs="?")
    ap.add_argument("out", nargs="?")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--levels", type=int, default=5)
    ap.add_argument("--samples", type=int, default=1024)
    ap.add_argument("--only", default=None, help="comma-separated levels to compute (default: all)")
    ap.add_argument("--compare", nargs=2, metavar=("A", "REF"), help="two {level} templates of PFM strips")
    ap.add_argument("--levels-list", default="1,2,3")
    args = ap.parse_args()

    if args.compare:
        for k in [int(x) for x in args.levels_list.split(",")]:
            a = read_pfm(args.compare[0].replace("{level}", str(k)))
            ref = read_pfm(args.compare[1].replace("{level}", str(k)))
            print(f"level {k}: RMS relative error {rms_relative(a, ref):.4f}")
        return

    t = time.perf_counter()
    env = read_pfm(args.env)
    load_s = time.perf_counter() - t
    os.makedirs(args.out, exist_ok=True)
    only = None if args.only is None else {int(x) for x in args.only.split(",")}
    results = {"env": args.env, "env_size": [env.shape[1], env.shape[0]], "samples": args.samples, "load_s": load_s, "levels": []}
    total = 0.0
    for k in range(args.levels):
        if only is not None and k not in only:
            continue
        size = max(1, args.size >> k)
        roughness = k / (args.levels - 1) if args.levels > 1 else 0.0
        t = time.perf_counter()
        level = prefilter_level(env, size, roughness, args.samples)
        dt = time.perf_counter() - t
        total += dt
        write_pfm(os.path.join(args.out, f"numpy_{k}.pfm"), to_strip(level))
        results["levels"].append({"level": k, "size": size, "roughness": roughness, "time_s": dt})
        print(f"level {k}: size {size}, roughness {roughness:.2f}: {dt:.2f} s", flush=True)
    results["total_s"] = total
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(results, f, indent=2)
    print(f"total {total:.2f} s (load {load_s:.2f} s)")


if __name__ == "__main__":
    main()
