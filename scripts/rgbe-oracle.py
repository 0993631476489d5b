#!/usr/bin/env python3
"""Expected values for tests/radiance_conformance.rs, computed ONCE with two independent readers,
so that CI compares without either installed:

1. Radiance's own reader, the format's reference implementation: `getheader`, `fgetsresolu`,
   `freadcolrs` (`src/common/{header,resolu,color}.c` of https://github.com/LBNL-ETA/Radiance)
   and `pix2loc` (`src/common/image.c`, which places a pixel of the file in the image), compiled
   here with the small driver below. It reads every file, old-style RLE included.
2. OpenImageIO (Python bindings; 3.2.2 was used), which also reports header attributes and
   orientation.

    python3 -m venv /tmp/v && /tmp/v/bin/pip install OpenImageIO numpy
    git clone https://github.com/LBNL-ETA/Radiance /tmp/Radiance   # master; see README.md
    /tmp/v/bin/python scripts/rgbe-oracle.py tests/data/radiance /tmp/Radiance/src/common \\
        > tests/data/radiance/expected.json

What the readers do (checked on these files; see also the test's doc comment):
- Radiance's driver returns raw RGBE bytes (COLR), converted here with m * 2^(E - 136) (E = 0 ->
  0), the convention of OpenImageIO, stb_image and ours; Radiance's own `colr_color` adds 0.5 to
  m: its channel means are recorded too (`colr_color_means`), for the record.
- OpenImageIO: m * 2^(E - 136) from a table of rounded decimal constants (off by 1 ulp of f32 at
  some exponents, e.g. in `scale.hdr`); EXPOSURE lines are NOT applied (values as stored) and
  `hdr:exposure` reports the LAST EXPOSURE line only (not the product Radiance defines); the
  resolution line becomes the `Orientation` attribute (1-8) with the pixels left in file order:
  `ImageBufAlgo.reorient` gives the image as displayed, which is what is recorded. It cannot read
  old-style RLE scanlines ("Read error reading pixels on scanline N" on `old-rle.hdr`,
  `cabin.hdr`: recorded as `oiio.error`), and it refuses a header without a `FORMAT=` line ("no
  FORMAT specifier found"), which Radiance reads as RGBE: for those (`cabin.hdr`, `rgbw.pic`) it
  reads a copy with `FORMAT=32-bit_rle_rgbe` inserted before the empty line that ends the header
  (pixel bytes unchanged; `oiio.input` says so). `.pic` is Softimage PIC to OpenImageIO, so every
  file is read through a temporary copy named `.hdr`.
- Where both read a file, they agree to 1 ulp of f32 (asserted here), except for two transposed
  layouts: OpenImageIO maps `+X n +Y m` to Orientation 6 and `-X n -Y m` to 8, while Radiance's
  `pix2loc` puts the first scanline at the left and its first pixel at the bottom for `+X +Y`
  (EXIF 8) and the reverse for `-X -Y` (EXIF 6): OpenImageIO's image is rotated by 180 degrees
  there (`layouts[...].oiio_vs_radiance`).

For every file and reader: width, height, and per channel R, G, B of the image as displayed:
mean (float64 over finite values), min, max, and the values at a fixed 7x5 grid; the header as
parsed here (signature, EXPOSURE lines and their product, PRIMARIES, FORMAT, resolution line).
`layouts`: both readers on each of the 8 resolution-line layouts written over a file's
resolution line (the test makes the same edit to the same bytes).
"""
import json
import math
import os
import sys
import subprocess
import tempfile

import numpy as np
import OpenImageIO as oiio

FILES = [
    "rgbr4x4.hdr",
    "old-rle.hdr",
    "scale.hdr",
    "mesh_cyl.hdr",
    "Earth.hdr",
    "cabin.hdr",
    "macbeth_pub.pic",
    "rgbw.pic",
]
# Files whose bytes are re-read with each of the eight resolution-line layouts.
LAYOUT_FILES = ["mesh_cyl.hdr", "scale.hdr"]

# The driver: Radiance's header, resolution and scanline readers, and Radiance's `pix2loc`
# (copied at build time from `src/common/image.c`: it maps a pixel's file position to its place in
# the image, "origin at the lower left corner, x to the right, y up", `resolu.h`). Prints
# "xr yr" and then the image as displayed (top row first) as raw COLR bytes.
DRIVER = r"""
#include <stdio.h>
#include <stdlib.h>
#include "rtio.h"
#include "color.h"
#include "resolu.h"
#include "fvect.h"
PIX2LOC
static int hline(char *s, void *p) { (void)s; (void)p; return 0; }
int main(int argc, char **argv) {
    FILE *fp = fopen(argv[1], "rb");
    RESOLU rs;
    RREAL loc[2];
    if (!fp || getheader(fp, hline, NULL) < 0 || !fgetsresolu(&rs, fp)) return 1;
    int n = numscans(&rs), len = scanlen(&rs);
    COLR *sl = malloc(sizeof(COLR) * len), *img = calloc((size_t)n * len, sizeof(COLR));
    for (int py = 0; py < n; py++) {
        if (freadcolrs(sl, len, fp) < 0) { fprintf(stderr, "read error at scanline %d\n", py); return 1; }
        for (int px = 0; px < len; px++) {
            pix2loc(loc, &rs, px, py);
            int x = (int)(loc[0] * rs.xr), y = rs.yr - 1 - (int)(loc[1] * rs.yr);
            copycolr(img[(size_t)y * rs.xr + x], sl[px]);
        }
    }
    printf("%d %d\n", rs.xr, rs.yr);
    fflush(stdout);
    fwrite(img, sizeof(COLR), (size_t)n * len, stdout);
    return 0;
}
"""


def build_driver(radiance_common, folder):
    image_c = open(os.path.join(radiance_common, "image.c")).read()
    i = image_c.index("void\npix2loc(")
    pix2loc = image_c[i : image_c.index("\n}\n", i) + 3]
    c = os.path.join(folder, "radread.c")
    with open(c, "w") as f:
        f.write(DRIVER.replace("PIX2LOC", pix2loc))
    exe = os.path.join(folder, "radread")
    srcs = [os.path.join(radiance_common, n) for n in ("color.c", "header.c", "resolu.c")]
    subprocess.run(["cc", "-O1", "-I", radiance_common, "-o", exe, c, *srcs, "-lm"], check=True)
    return exe


def radiance_read(exe, data):
    """Radiance's reader on `data`: (image as displayed, h x w x 3, m * 2^(E-136); colr_color
    channel means)."""
    with tempfile.NamedTemporaryFile(suffix=".hdr", delete=False) as t:
        t.write(data)
    try:
        out = subprocess.run([exe, t.name], capture_output=True, check=True).stdout
    finally:
        os.unlink(t.name)
    first, raw = out.split(b"\n", 1)
    w, h = map(int, first.split())
    c = np.frombuffer(raw, dtype=np.uint8).reshape(h, w, 4).astype(np.float64)
    scale = np.where(c[:, :, 3] > 0, np.ldexp(1.0, c[:, :, 3].astype(np.int64) - 136), 0.0)
    a = c[:, :, :3] * scale[:, :, None]
    colr_color = (c[:, :, :3] + 0.5) * scale[:, :, None]
    return a, [float(colr_color[:, :, k].mean()) for k in range(3)]


def grid(h, w):
    return [(int(x), int(y)) for y in np.linspace(0, h - 1, 5) for x in np.linspace(0, w - 1, 7)]


def split_header(data):
    """(header lines, resolution line, offset of the resolution line) by Radiance's rules."""
    end = data.index(b"\n\n")
    lines = data[:end].split(b"\n")
    res_start = end + 2
    res_end = data.index(b"\n", res_start)
    return lines, data[res_start:res_end].decode(), res_start, res_end


def header_info(data):
    lines, res, _, _ = split_header(data)
    exposures = [float(l.split(b"=", 1)[1]) for l in lines if l.startswith(b"EXPOSURE=")]
    primaries = [l for l in lines if l.startswith(b"PRIMARIES=")]
    fmt = [l.split(b"=", 1)[1].strip().decode() for l in lines if l.startswith(b"FORMAT=")]
    return {
        "signature": lines[0].decode() if lines[0].startswith(b"#?") else None,
        "exposure_lines": exposures,
        "exposure_product": math.prod(exposures),
        "primaries": [float(v) for v in primaries[-1].split(b"=", 1)[1].split()] if primaries else None,
        "format": fmt[-1] if fmt else None,
        "resolution": res,
    }


def read(data):
    """OpenImageIO's hdr reader on `data`: (ImageBuf as displayed, attributes) or error text."""
    with tempfile.NamedTemporaryFile(suffix=".hdr", delete=False) as t:
        t.write(data)
    try:
        inp = oiio.ImageInput.open(t.name)  # the temporary file is named .hdr
        if inp is None:
            return None, oiio.geterror()
        spec = inp.spec()
        attribs = {a.name: a.value for a in spec.extra_attribs}
        px = inp.read_image(oiio.FLOAT)
        if px is None:
            return None, inp.geterror()
        inp.close()
        buf = oiio.ImageBuf(oiio.ImageSpec(spec.width, spec.height, 3, oiio.FLOAT))
        buf.set_pixels(oiio.ROI(), px)
        buf.specmod().attribute("Orientation", int(attribs.get("Orientation", 1)))
        return oiio.ImageBufAlgo.reorient(buf), attribs
    finally:
        os.unlink(t.name)


def stats(a):
    """Statistics of an h x w x 3 float64 array (the image as displayed)."""
    h, w = a.shape[:2]
    out = {"width": w, "height": h, "channels": {}}
    for k, c in enumerate("RGB"):
        ch = a[:, :, k]
        fin = ch[np.isfinite(ch)]
        out["channels"][c] = {
            "mean": float(fin.mean()),
            "min": float(fin.min()),
            "max": float(fin.max()),
            "samples": [[x, y, float(ch[y, x])] for (x, y) in grid(h, w)],
        }
    return out


def pixels(buf):
    return np.asarray(buf.get_pixels(oiio.FLOAT), dtype=np.float64)


def with_format_line(data):
    end = data.index(b"\n\n")
    return data[:end] + b"\nFORMAT=32-bit_rle_rgbe" + data[end:]


def layouts(exe, data):
    """Both readers on the eight layouts of one file's scanlines, keyed by resolution line."""
    _, res, start, end = split_header(data)
    t = res.split()
    scans, scanlen = t[1], t[3]
    out = {}
    for outer, inner in [("Y", "X"), ("X", "Y")]:
        for s1 in "-+":
            for s2 in "+-":
                line = f"{s1}{outer} {scans} {s2}{inner} {scanlen}"
                edited = data[:start] + line.encode() + data[end:]
                rad, _ = radiance_read(exe, edited)
                buf, attribs = read(edited)
                a = pixels(buf)
                same = a.shape == rad.shape and close(a, rad)
                rotated = a.shape == rad.shape and close(a[::-1, ::-1], rad)
                out[line] = {
                    "radiance": stats(rad),
                    "oiio": stats(a),
                    "oiio_orientation": int(attribs["Orientation"]),
                    "oiio_vs_radiance": "same" if same else "rotated 180" if rotated else "different",
                }
    return out


def close(a, b):
    """Equal to 1 ulp of f32 (OpenImageIO's exponent table is rounded at some exponents)."""
    return bool((np.abs(a - b) <= 2.0**-23 * np.abs(b)).all())


def main(folder, radiance_common):
    tmp = tempfile.mkdtemp()
    exe = build_driver(radiance_common, tmp)
    out = {
        "oracles": {
            "radiance": "Radiance's getheader/fgetsresolu/freadcolrs (LBNL-ETA/Radiance src/common), "
            "values m * 2^(E-136)",
            "oiio": f"OpenImageIO {oiio.__version__} (Python bindings), ImageBufAlgo.reorient",
        },
        "files": {},
    }
    for name in FILES:
        path = os.path.join(folder, name)
        data = open(path, "rb").read()
        rad, colr_color_means = radiance_read(exe, data)
        entry = {"header": header_info(data), "radiance": stats(rad)}
        entry["radiance"]["colr_color_means"] = colr_color_means
        oi = {"input": "as is"}
        buf, attribs = read(data)
        if buf is None and "FORMAT" in attribs:
            oi["error_as_is"] = attribs
            oi["input"] = "FORMAT=32-bit_rle_rgbe inserted before the end of the header"
            buf, attribs = read(with_format_line(data))
        if buf is None:
            oi["error"] = attribs
        else:
            a = pixels(buf)
            oi["attributes"] = dict(attribs)
            oi.update(stats(a))
            assert a.shape == rad.shape and close(a, rad), name
        entry["oiio"] = oi
        if name in LAYOUT_FILES:
            entry["layouts"] = layouts(exe, data)
        out["files"][name] = entry
    json.dump(out, sys.stdout, indent=1, sort_keys=True)
    print()


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
