#!/usr/bin/env python3
"""skylibs' resampling calls that hdrflow's toolkit operators replace, timed alone: `EnvironmentMap.rotate`
(bilinear; the peer of `Rotate`) and `convertTo('sphere', size)` (the peer of `LatLongToMirrorBall`).

For every map matching --maps and every rotation of --rotations (yaw/pitch/roll in degrees, hdrflow's
R = R_y R_x R_z, which skylibs' `rotate(dcm)` takes as dcm = R^T: see dataset_skylibs.py), the median
of --repeats calls on a fresh copy of the map (the copy is not timed). Prints one JSON object.

    pip install skylibs opencv-python-headless
    python3 bench/peers/rotate_skylibs.py --maps 'assets/maps/*.hdr' --rotations '12.5,0,0;33,21,-12'
"""
import argparse
import glob
import json
import statistics
import time

import cv2
import numpy as np
from envmap import EnvironmentMap

from dataset_skylibs import rotation


def load(path):
    bgr = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if bgr is None:
        raise RuntimeError(f"cannot read {path}")
    return bgr[..., ::-1].astype(np.float64)


def timed(fn, repeats):
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e3


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", required=True)
    ap.add_argument("--rotations", default="12.5,0,0;0,30,0;33,21,-12")
    ap.add_argument("--ball", type=int, default=768, help="the mirror ball's size (0: none)")
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    rows = []
    for path in sorted(glob.glob(a.maps)):
        data = load(path)
        for text in a.rotations.split(";"):
            yaw, pitch, roll = (float(v) for v in text.split(","))
            dcm = rotation(yaw, pitch, roll).T
            envs = [EnvironmentMap(data.copy(), "latlong") for _ in range(a.repeats)]
            ms = timed(lambda: envs.pop().rotate(dcm), a.repeats)
            rows.append({"map": path, "op": "rotate", "yaw": yaw, "pitch": pitch, "roll": roll, "ms": ms})
        if a.ball:
            envs = [EnvironmentMap(data.copy(), "latlong") for _ in range(a.repeats)]
            ms = timed(lambda: envs.pop().convertTo("sphere", a.ball), a.repeats)
            rows.append({"map": path, "op": "sphere", "size": a.ball, "ms": ms})
    print(json.dumps({"repeats": a.repeats, "rows": rows}))


if __name__ == "__main__":
    main()
