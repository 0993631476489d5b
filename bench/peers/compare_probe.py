# Compares two renders of a probe sphere (RGBA EXR, premultiplied, transparent film), e.g.
# hdrflow's ProbeSphere against Blender's, or Blender's against itself with another seed (its noise):
#
#   blender --background --factory-startup --python bench/peers/compare_probe.py -- A.exr B.exr [LABEL]
#
# Prints one tab-separated line: label, coverage area of A and of B (sum of alpha, pixels), the mean
# absolute alpha difference, then over the pixels where both alphas are 1: their count, B's mean
# RGB, the RMSE of A - B, the mean of A - B (the bias), and the RMSE relative to B's mean RGB.
#
#   blender --background --factory-startup --python bench/peers/compare_probe.py -- A.exr B0.exr B1.exr LABEL
#
# With three files (A against two renders of another seed): A against the seeds' mean M over the
# pixels all three cover, as the ratio of RMSE(A - M) to the noise of M, RMSE(B0 - B1) / 2 (1: A is
# as close as the noise allows), the same ratio of median absolute differences, and A's mean
# difference from M relative to M's mean.
# Blender's Python reads the files (so no OpenEXR module is needed); numpy comes from python3-numpy.
import sys

import bpy
import numpy as np


def load(path):
    img = bpy.data.images.load(path, check_existing=False)
    w, h = img.size
    px = np.array(img.pixels[:], dtype=np.float64).reshape(h, w, img.channels)
    bpy.data.images.remove(img)
    return px[::-1]  # Blender's rows run bottom-up; the file's top row first


args = sys.argv[sys.argv.index("--") + 1:]
if len(args) == 4:
    a, b0, b1 = (load(p) for p in args[:3])
    inside = (a[..., 3] >= 1.0) & (b0[..., 3] >= 1.0) & (b1[..., 3] >= 1.0)
    mean = 0.5 * (b0 + b1)
    d = (a - mean)[..., :3][inside]
    noise = 0.5 * (b0 - b1)[..., :3][inside]
    rmse, noise_rmse = np.sqrt((d ** 2).mean()), np.sqrt((noise ** 2).mean())
    med, noise_med = np.median(np.abs(d)), np.median(np.abs(noise))
    print("\t".join([
        args[3],
        "ratio_rmse=%.2f" % (rmse / noise_rmse),
        "ratio_median=%.2f" % (med / noise_med),
        "rmse=%.4g" % rmse,
        "noise_rmse=%.4g" % noise_rmse,
        "mean_diff=%+.2f%%" % (100.0 * d.mean() / mean[..., :3][inside].mean()),
    ]))
    sys.exit(0)
a, b = load(args[0]), load(args[1])
label = args[2] if len(args) > 2 else "%s vs %s" % (args[0], args[1])
if a.shape != b.shape:
    raise SystemExit("sizes differ: %s vs %s" % (a.shape, b.shape))
alpha_a, alpha_b = a[..., 3], b[..., 3]
inside = (alpha_a >= 1.0) & (alpha_b >= 1.0)
d = a[..., :3][inside] - b[..., :3][inside]
mean_b = b[..., :3][inside].mean()
rmse = np.sqrt((d ** 2).mean())
print("\t".join([
    label,
    "area_a=%.2f" % alpha_a.sum(),
    "area_b=%.2f" % alpha_b.sum(),
    "alpha_mad=%.5f" % np.abs(alpha_a - alpha_b).mean(),
    "inside=%d" % inside.sum(),
    "mean_b=%.6g" % mean_b,
    "rmse=%.6g" % rmse,
    "bias=%.6g" % d.mean(),
    "rel_rmse=%.5f" % (rmse / mean_b),
]))
