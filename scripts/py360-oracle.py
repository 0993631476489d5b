#!/usr/bin/env python3
"""Expected layouts for tests/cube_layouts.rs, computed ONCE with py360convert, so that CI compares
without it installed:

    python3 -m venv /tmp/v && /tmp/v/bin/pip install py360convert   # 1.0.4 was used (numpy, scipy)
    /tmp/v/bin/python scripts/py360-oracle.py tests/data/cube_layouts

Writes, as little-endian RGB PFM (rows bottom to top, as PFM stores them):
- `latlong.pfm`: a 64 x 32 lat-long map in hdrflow's convention whose texel (x, y) is
  d + 2, d = (-sin t sin p, cos t, sin t cos p), t = pi (y + 0.5) / 32, p = 2 pi (x + 0.5) / 64
  (the centre column looks down -Z, +X at 3/4 of the width): each channel is one axis of the
  direction, so a face put in the wrong cell or the wrong way round shows as a difference of
  order 1;
- `py360_dice.pfm` (64 x 48) and `py360_horizon.pfm` (96 x 16): `py360convert.e2c(latlong,
  face_w=16, mode="bilinear", cube_format=...)`.

py360convert reads the same image with its own convention (u = atan2(x, z) with the centre
column +z and +x right of it), i.e. its axes are hdrflow's (X, Y, -Z); the test compares these
layouts with hdrflow's `Dice` and `Horizon` of `LatLongToCubemap(latlong, 16)`.
"""
import os
import sys

import numpy as np
import py360convert

W, H, FACE = 64, 32, 16


def write_pfm(path, img):
    h, w, _ = img.shape
    with open(path, "wb") as f:
        f.write(f"PF\n{w} {h}\n-1.0\n".encode())
        f.write(np.ascontiguousarray(img[::-1].astype("<f4")).tobytes())


def main(out):
    y, x = np.mgrid[0:H, 0:W].astype(np.float64)
    t = np.pi * (y + 0.5) / H
    p = 2 * np.pi * (x + 0.5) / W
    d = np.stack([-np.sin(t) * np.sin(p), np.cos(t), np.sin(t) * np.cos(p)], axis=-1)
    latlong = (d + 2.0).astype(np.float32)
    os.makedirs(out, exist_ok=True)
    write_pfm(os.path.join(out, "latlong.pfm"), latlong)
    for fmt in ["dice", "horizon"]:
        cube = py360convert.e2c(latlong, face_w=FACE, mode="bilinear", cube_format=fmt)
        write_pfm(os.path.join(out, f"py360_{fmt}.pfm"), np.asarray(cube, dtype=np.float32))
    print("py360convert", getattr(py360convert, "__version__", "(version not exported)"))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "tests/data/cube_layouts")
