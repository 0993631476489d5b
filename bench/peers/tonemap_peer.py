"""The lighting-estimation protocol's tonemap, computed by the protocol's own class, for
tests/evaluation_metrics.rs to compare hdrflow's ProtocolTonemap with.

`TonemapHDR` below is copied verbatim from `stylelight/util.py` of
DiffusionLight/DiffusionLight-evaluation (MIT License, Copyright (c) 2023 Pakkapon Phongthawee);
the rest of util.py (which imports torch, OpenEXR, vtk and more) is not needed. The call is
`stylelight/tonemap.py`'s: `TonemapHDR(gamma=2.4, percentile=50, max_mapping=0.5)` with
`clip=False`.

    python tonemap_peer.py IN.pfm OUT.pfm

writes the tonemapped image and prints {"alpha": ...}.
"""

import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pfm_common import read_pfm, write_pfm  # noqa: E402


# ---- verbatim from stylelight/util.py ---------------------------------------------------------
class TonemapHDR(object):
    """
        Tonemap HDR image globally. First, we find alpha that maps the (max(numpy_img) * percentile) to max_mapping.
        Then, we calculate I_out = alpha * I_in ^ (1/gamma)
        input : nd.array batch of images : [H, W, C]
        output : nd.array batch of images : [H, W, C]
    """

    def __init__(self, gamma=2.4, percentile=99, max_mapping=0.99):
        self.gamma = gamma
        self.percentile = percentile
        self.max_mapping = max_mapping  # the value to which alpha will map the (max(numpy_img) * percentile) to

    def __call__(self, numpy_img, clip=True, alpha=None, gamma=True):
        # if False:
        #     numpy_img = np.clip(numpy_img, 0, 1)
        #     print('lwq')
        if gamma:
            power_numpy_img = np.power(numpy_img, 1 / self.gamma)
        else:
            power_numpy_img = numpy_img
        non_zero = power_numpy_img > 0
        if non_zero.any():
            r_percentile = np.percentile(power_numpy_img[non_zero], self.percentile)
        else:
            r_percentile = np.percentile(power_numpy_img, self.percentile)
        if alpha is None:
            alpha = self.max_mapping / (r_percentile + 1e-10)
        tonemapped_img = np.multiply(alpha, power_numpy_img)

        if clip:
            tonemapped_img = np.clip(tonemapped_img, 0, 1)

        return tonemapped_img.astype('float32'), alpha
# ---- end of the verbatim part -----------------------------------------------------------------


def main(argv):
    src, dst = argv[1:3]
    tone = TonemapHDR(gamma=2.4, percentile=50, max_mapping=0.5)
    img, alpha = tone(read_pfm(src), clip=False)
    write_pfm(dst, img)
    print(json.dumps({"alpha": float(alpha)}))


if __name__ == "__main__":
    main(sys.argv)
