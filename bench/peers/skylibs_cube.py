#!/usr/bin/env python3
"""skylibs' `cube` layout, the peer of hdrflow's `SkylibsCube` (tests/skylibs_cube.rs runs it with
the peer Python of scripts/peer-venv.sh):

    python skylibs_cube.py to-cube LATLONG.pfm FACE OUT.pfm     # latlong -> cube, 3 x 4 faces
    python skylibs_cube.py to-latlong CUBE.pfm HEIGHT OUT.pfm   # cube -> latlong, 2 H x H

Each is one `EnvironmentMap(image, format).convertTo(target, size)` (bilinear, `order=1`, its
default), as a skylibs user writes it: `convertTo('cube', 4 FACE)` gives a 3 FACE x 4 FACE image,
`convertTo('latlong', HEIGHT)` a 2 HEIGHT x HEIGHT one. Prints the skylibs version as JSON.
"""
import json
import os
import sys
from importlib.metadata import version

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pfm_common import read_pfm, write_pfm  # noqa: E402

from envmap import EnvironmentMap  # noqa: E402


def main(argv):
    if len(argv) != 4 or argv[0] not in ("to-cube", "to-latlong"):
        sys.exit(__doc__)
    mode, src, size, out = argv[0], argv[1], int(argv[2]), argv[3]
    image = read_pfm(src).astype("float64")
    if mode == "to-cube":
        env = EnvironmentMap(image, "latlong").convertTo("cube", 4 * size)
    else:
        env = EnvironmentMap(image, "cube").convertTo("latlong", size)
    write_pfm(out, env.data)
    print(json.dumps({"skylibs": version("skylibs"), "shape": list(env.data.shape)}))


if __name__ == "__main__":
    main(sys.argv[1:])
