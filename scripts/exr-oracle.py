#!/usr/bin/env python3
"""Expected values for tests/exr_conformance.rs, computed ONCE with the official OpenEXR Python
bindings (PyPI `OpenEXR`, 3.5.3 was used), so that CI compares without the oracle installed.

    python3 -m venv /tmp/v && /tmp/v/bin/pip install OpenEXR numpy
    /tmp/v/bin/python scripts/exr-oracle.py tests/data/openexr > tests/data/openexr/expected.json

For every file: data and display windows, chromaticities, and per channel (raw stored values, in
the channel's own sample grid, i.e. a 2x2-subsampled RY has half the rows and columns): sampling,
mean (float64 over finite values), min, max, and the values at a fixed 7x5 grid of sample positions.
The bindings do no luminance/chroma -> RGB conversion: the YC files' RGB expectations come from
their RGB siblings (README of the Chromaticities set: "all four images should look the same").
"""
import json
import os
import sys

import numpy as np
import OpenEXR

FILES = ["Rec709.exr", "Rec709_YC.exr", "XYZ.exr", "XYZ_YC.exr", "t08.exr"]


def grid(h, w):
    return [(int(x), int(y)) for y in np.linspace(0, h - 1, 5) for x in np.linspace(0, w - 1, 7)]


def main(folder):
    out = {"oracle": f"OpenEXR Python bindings {OpenEXR.__version__}", "files": {}}
    for name in FILES:
        with OpenEXR.File(os.path.join(folder, name), separate_channels=True) as f:
            h = f.header()
            (dx0, dy0), (dx1, dy1) = (h["dataWindow"][0].tolist(), h["dataWindow"][1].tolist())
            (px0, py0), (px1, py1) = (h["displayWindow"][0].tolist(), h["displayWindow"][1].tolist())
            entry = {
                "data_window": [dx0, dy0, dx1, dy1],
                "display_window": [px0, py0, px1, py1],
                "chromaticities": [float(v) for v in h["chromaticities"]] if "chromaticities" in h else None,
                "channels": {},
            }
            for cname, ch in f.channels().items():
                a = np.asarray(ch.pixels, dtype=np.float64)
                fin = a[np.isfinite(a)]
                entry["channels"][cname] = {
                    "sampling": [int(ch.xSampling), int(ch.ySampling)],
                    "shape": [int(a.shape[1]), int(a.shape[0])],
                    "mean": float(fin.mean()),
                    "min": float(fin.min()),
                    "max": float(fin.max()),
                    "samples": [[x, y, float(a[y, x])] for (x, y) in grid(*a.shape)],
                }
            out["files"][name] = entry
    json.dump(out, sys.stdout, indent=1, sort_keys=True)
    print()


if __name__ == "__main__":
    main(sys.argv[1])
