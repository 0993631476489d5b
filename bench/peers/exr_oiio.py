#!/usr/bin/env python3
"""The EXR decoding peer of `hdrflow bench --targets-only`: OpenImageIO (`pip install OpenImageIO`)
reads each file to float RGB(A), the way a studio tool would; prints a JSON list of warm-median
milliseconds, one per file (the first read of each file is a warm-up, not timed).

    python3 bench/peers/exr_oiio.py --repeats 9 a.exr b.exr

With `--make DIR SOURCE.exr`, it first writes the files the target decodes that our own writer
does not produce, from SOURCE (a float RGB map), with OpenImageIO: DIR/tiled_piz.exr and
DIR/tiled_zip.exr (half, 64x64 tiles), DIR/dwaa_oiio.exr (half, DWAA scan lines) and
DIR/large_zip.exr (SOURCE resized to 4096x2048, half, ZIP scan lines); it prints their paths
as a JSON list and exits.
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


def make(folder, source):
    src = oiio.ImageBuf(source)
    large = oiio.ImageBufAlgo.resize(src, roi=oiio.ROI(0, 4096, 0, 2048, 0, 1, 0, src.nchannels))
    jobs = [
        ("tiled_piz.exr", src, "piz", True),
        ("tiled_zip.exr", src, "zip", True),
        ("dwaa_oiio.exr", src, "dwaa", False),
        ("large_zip.exr", large, "zip", False),
    ]
    paths = []
    for name, buf, compression, tiled in jobs:
        path = f"{folder}/{name}"
        spec = oiio.ImageSpec(buf.spec())
        spec.set_format(oiio.HALF)
        spec.attribute("compression", compression)
        if tiled:
            spec.tile_width, spec.tile_height = 64, 64
        out = oiio.ImageOutput.create(path)
        if out is None or not out.open(path, spec):
            raise SystemExit(f"OpenImageIO cannot write {path}: {oiio.geterror()}")
        if not buf.write(out):
            raise SystemExit(f"OpenImageIO cannot write {path}: {buf.geterror()}")
        out.close()
        paths.append(path)
    print(json.dumps(paths))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--make", nargs=2, metavar=("DIR", "SOURCE"))
    ap.add_argument("files", nargs="*")
    args = ap.parse_args()
    if args.make:
        make(*args.make)
        return
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
