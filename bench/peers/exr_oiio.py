#!/usr/bin/env python3
"""The EXR decoding peer of `hdrflow bench --targets-only`: OpenImageIO (`pip install OpenImageIO`)
reads each file to float RGB(A), the way a studio tool would; prints a JSON list of warm-median
milliseconds, one per file (the first read of each file is a warm-up, not timed).

    python3 bench/peers/exr_oiio.py --repeats 9 a.exr b.exr
"""
import argparse
import json
import statistics
import time

import OpenImageIO as oiio


def read(path):
    inp = oiio.ImageInput.open(path)
    if inp is None:
        raise SystemExit(f"OpenImageIO cannot open {path}: {oiio.geterror()}")
    pixels = inp.read_image(0, 0, 0, inp.spec().nchannels, "float")
    inp.close()
    return pixels


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("files", nargs="+")
    args = ap.parse_args()
    out = []
    for f in args.files:
        read(f)
        times = []
        for _ in range(max(1, args.repeats)):
            t0 = time.perf_counter()
            read(f)
            times.append((time.perf_counter() - t0) * 1e3)
        out.append(statistics.median(times))
    print(json.dumps({"version": oiio.__version__, "ms": out}))


if __name__ == "__main__":
    main()
