#!/usr/bin/env python3
"""The dataset job of examples/dataset/dataset.ron, written as a researcher would without hdrflow:
skylibs' EnvironmentMap for the rotation and the perspective crops, NumPy for the SH projection,
SciPy for a spherical-Gaussian least-squares fit and for a threshold + connected-components light
extraction, a process pool over the (map, azimuth) items.

For every map matching --maps and every azimuth of --yaws: rotate the map (skylibs `rotate`,
bilinear), cut the 4 crops of dataset.ron (skylibs `project`, 60 degrees, 256 x 256), compute SH
order 2, 12 spherical Gaussians and up to 3 lights on the rotated map, and write
OUT/<map stem>/yaw=<azimuth>/crop_<k>.exr (float32, ZIP, skylibs' ezexr) and crop_<k>.json, a label
with the keys hdrflow's CropLabel writes. Prints one JSON line: items, crops, seconds.

    pip install skylibs scipy opencv-python-headless OpenEXR
    python3 bench/peers/dataset_skylibs.py --maps 'assets/maps/*.hdr' --out /tmp/peer --workers 2

Conventions are hdrflow's, which are skylibs' too (world +Y up, -Z at the lat-long map's centre
column, +X at 3/4 of its width): a rotation R (yaw, pitch, roll in degrees, R = R_y R_x R_z,
right-handed) moves the content seen in direction v to R v, so skylibs' `rotate(dcm)` (which
samples the source at dcm d) gets dcm = R^T; a crop whose camera is turned by R sees along R c for
the camera ray c, which skylibs' `project(rotation_matrix)` takes as the world-to-camera matrix R^T.

Not hdrflow's choices, but what the libraries do (see docs/src/benchmarks/dataset.md, "Dataset preparation"):
skylibs' crops put the first and last pixel centres on the field of view's edges (a grid
W / (W - 1) times coarser than hdrflow's) and interpolate bilinearly; its rotation interpolates
too; SH integrate with skylibs' per-texel solid angles; the SG fit is SciPy's trust-region
least squares (analytic Jacobian, the `lsmr` trust-region solver SciPy suggests for large
problems, 30 evaluations) from a greedy start; the lights' regions wrap
across the seam but not around the poles.
"""
import argparse
import functools
import glob
import json
import math
import os
import pathlib
import sys
import time
from concurrent.futures import ProcessPoolExecutor

# One BLAS thread per worker process: the pool is the parallelism (set before NumPy loads).
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(var, "1")

import cv2  # noqa: E402
import numpy as np  # noqa: E402
import ezexr  # noqa: E402
from envmap import EnvironmentMap  # noqa: E402
from scipy import ndimage  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

# The crops of examples/dataset/dataset.ron: (yaw, pitch) in degrees, roll 0.
CROPS = [(-16.875, 0.0), (-5.625, 10.0), (5.625, -10.0), (16.875, 5.0)]
REC709 = np.array([0.2126, 0.7152, 0.0722])
SH_BASIS = ("real SH, orthonormal, no Condon-Shortley phase, index l(l+1)+m; (x, y, z) = hdrflow world "
            "(X right, Y up, Z back: forward is -Z); Y_1-1 = 0.488603 y, Y_10 = 0.488603 z, "
            "Y_11 = 0.488603 x, as three.js SphericalHarmonics3")


def rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rotation(yaw, pitch=0.0, roll=0.0):
    """R = R_y(yaw) R_x(pitch) R_z(roll), degrees, right-handed about the world axes."""
    return rot_y(math.radians(yaw)) @ rot_x(math.radians(pitch)) @ rot_z(math.radians(roll))


@functools.lru_cache(maxsize=4)
def load(path):
    """The map as float64 RGB (OpenCV reads Radiance .hdr as BGR float32)."""
    bgr = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if bgr is None:
        raise RuntimeError(f"cannot read {path}")
    return bgr[..., ::-1].astype(np.float64)


def directions_and_solid_angles(e):
    x, y, z, _ = e.worldCoordinates()
    d = np.stack([x, y, z], axis=-1).reshape(-1, 3).astype(np.float64)
    return d, e.solidAngles().reshape(-1)


def sh_order2(f, d, w):
    """L_lm = sum_t f_t Y_lm(d_t) w_t, the 9 real SH of hdrflow's World frame (three.js's basis)."""
    x, y, z = d[:, 0], d[:, 1], d[:, 2]
    basis = np.stack([
        np.full_like(x, 0.282095), 0.488603 * y, 0.488603 * z, 0.488603 * x,
        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1), 1.092548 * x * z,
        0.546274 * (x * x - y * y)], axis=1)
    return (basis * w[:, None]).T @ f


def axis_of(theta, phi):
    """The lat-long convention's direction of polar angle theta and azimuth phi."""
    st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    return np.stack([-st * sp, ct, st * cp], axis=-1)


def fit_sg(f, d, w, lobes=12, iterations=30):
    """Lobes a exp(lambda (mu . d - 1)) fitted by solid-angle-weighted least squares."""
    lum = f @ REC709
    residual = f.copy()
    x0 = []
    axes = []
    lam0 = 100.0
    theta_t = np.arccos(np.clip(d[:, 1], -1, 1))
    phi_t = np.arctan2(-d[:, 0], d[:, 2])
    for _ in range(lobes):
        # Greedy start: the brightest residual texel at least 20 degrees from earlier lobes.
        lum = np.maximum(residual @ REC709, 0.0)
        for a in axes:
            lum[d @ a > math.cos(math.radians(20))] = -1.0
        t = int(np.argmax(lum))
        axes.append(d[t])
        g = np.exp(lam0 * (d @ d[t] - 1.0))
        amp = np.maximum(residual[t], 0.0)
        residual -= g[:, None] * amp
        x0 += [theta_t[t], phi_t[t], math.log(lam0), *amp]
    x0 = np.array(x0)
    sw = np.sqrt(w)

    def unpack(p):
        p = p.reshape(lobes, 6)
        return p[:, 0], p[:, 1], np.exp(p[:, 2]), p[:, 3:]

    def model_parts(p):
        theta, phi, lam, amp = unpack(p)
        mu = axis_of(theta, phi)                      # (K, 3)
        cosines = d @ mu.T                            # (N, K)
        g = np.exp(lam * (cosines - 1.0))             # (N, K)
        return theta, phi, lam, amp, mu, cosines, g

    def fun(p):
        *_, amp, _, _, g = model_parts(p)
        return (sw[:, None] * (g @ amp - f)).ravel()

    def jac(p):
        theta, phi, lam, amp, _, cosines, g = model_parts(p)
        st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
        dmu_dtheta = np.stack([-ct * sp, -st, ct * cp], axis=-1)
        dmu_dphi = np.stack([-st * cp, np.zeros_like(st), -st * sp], axis=-1)
        n = d.shape[0]
        jm = np.zeros((n, 3, lobes, 6))
        gw = g * sw[:, None]                          # (N, K)
        for c in range(3):
            common = gw * amp[:, c] * lam              # (N, K)
            jm[:, c, :, 0] = common * (d @ dmu_dtheta.T)
            jm[:, c, :, 1] = common * (d @ dmu_dphi.T)
            jm[:, c, :, 2] = common * (cosines - 1.0)
            jm[:, c, :, 3 + c] = gw
        return jm.reshape(n * 3, lobes * 6)

    lo = np.tile([-np.inf, -np.inf, math.log(0.01), 0.0, 0.0, 0.0], lobes)
    hi = np.tile([np.inf, np.inf, math.log(6640.0), np.inf, np.inf, np.inf], lobes)
    x0 = np.clip(x0, lo + 1e-12, hi - 1e-12)
    result = least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac", tr_solver="lsmr",
                           max_nfev=iterations)
    theta, phi, lam, amp = unpack(result.x)
    mu = axis_of(theta, phi)
    err = np.sum(result.fun ** 2)
    rmse = math.sqrt(err / max(np.sum(w[:, None] * f * f), 1e-300))
    order = np.argsort(-(amp @ REC709) * 2 * np.pi * (1 - np.exp(-2 * lam)) / lam)
    lobes_json = [{"axis": mu[k].tolist(), "sharpness": float(lam[k]), "amplitude": amp[k].tolist()}
                  for k in order]
    return lobes_json, rmse


def extract_lights(f, d, w, shape, max_lights=3, threshold_stops=8.0):
    """The brightest connected regions above median x 2^stops (8-connected, wrapping across the
    seam), the max_lights most energetic, and the ambient: the mean radiance of the rest."""
    h, wd = shape
    lum = f @ REC709
    level = float(np.median(lum))
    if level <= 0:
        level = float(np.sum(lum * w) / np.sum(w))
    mask = (lum > level * 2 ** threshold_stops).reshape(h, wd)
    labels, count = ndimage.label(mask, structure=np.ones((3, 3)))
    # Merge the regions that touch across the seam (column W-1 next to column 0).
    parent = list(range(count + 1))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for y in range(h):
        a = labels[y, wd - 1]
        if not a:
            continue
        for yy in (y - 1, y, y + 1):
            if 0 <= yy < h and labels[yy, 0]:
                parent[find(a)] = find(labels[yy, 0])
    roots = np.array([find(i) for i in range(count + 1)])
    region = roots[labels].reshape(-1)
    lights = []
    if count:
        ids = np.unique(region[region > 0])
        energy = ndimage.sum(lum * w, region, ids)
        chosen = ids[np.argsort(-energy)[:max_lights]]
        in_light = np.isin(region, chosen)
        rest_w = np.sum(w[~in_light])
        ambient = (w[~in_light] @ f[~in_light]) / rest_w if rest_w > 0 else np.zeros(3)
        for r in chosen:
            sel = region == r
            sa = float(np.sum(w[sel]))
            mean = (w[sel] @ f[sel]) / sa
            centroid = (lum[sel] * w[sel]) @ d[sel]
            lights.append({"direction": (centroid / np.linalg.norm(centroid)).tolist(), "solid_angle": sa,
                           "radiance": np.maximum(mean - ambient, 0.0).tolist()})
    else:
        ambient = (w @ f) / np.sum(w)
    return {"lights": lights, "ambient": ambient.tolist()}


def run_item(job):
    path, yaw, out, size, lobes, iterations = job
    stem = pathlib.Path(path).stem
    folder = pathlib.Path(out) / stem / f"yaw={yaw:g}"
    folder.mkdir(parents=True, exist_ok=True)
    seconds = {}
    clock = [time.perf_counter()]

    def lap(stage):
        now = time.perf_counter()
        seconds[stage] = seconds.get(stage, 0.0) + now - clock[0]
        clock[0] = now

    e = EnvironmentMap(load(path), "latlong")
    lap("load")
    e.rotate(rotation(yaw).T)
    lap("rotate")
    d, w = directions_and_solid_angles(e)
    f = e.data.reshape(-1, 3)
    sh = sh_order2(f, d, w)
    lap("sh")
    small = e.copy().resize(128)
    ds, ws = directions_and_solid_angles(small)
    sg, rmse = fit_sg(small.data.reshape(-1, 3), ds, ws, lobes, iterations)
    lap("sg")
    lights = extract_lights(f, d, w, e.data.shape[:2])
    lap("lights")
    for k, (cyaw, cpitch) in enumerate(CROPS):
        world_to_camera = rotation(cyaw, cpitch).T
        crop = e.project(vfov=60.0, rotation_matrix=world_to_camera, ar=1.0, resolution=(size, size))
        lap("crops")
        ezexr.imwrite(str(folder / f"crop_{k}.exr"), crop.astype(np.float32), compression="ZIP")
        label = {
            "camera": {"model": "Perspective", "fov": 60.0, "width": size, "height": size, "yaw": cyaw,
                       "pitch": cpitch, "roll": 0.0, "world_to_camera": world_to_camera.tolist()},
            "sh": {"frame": "World", "order": 2, "basis": SH_BASIS, "coefficients": sh.tolist()},
            "spherical_gaussians": {"lobes": sg},
            "lights": lights,
        }
        (folder / f"crop_{k}.json").write_text(json.dumps(label, indent=2) + "\n")
        lap("write")
    return {"item": f"{stem}/yaw={yaw:g}", "sg_relative_rmse": rmse, "seconds": seconds}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--maps", required=True, help="a glob of lat-long .hdr maps")
    ap.add_argument("--out", required=True)
    ap.add_argument("--yaws", default="0,45,90,135,180,225,270,315")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--lobes", type=int, default=12)
    ap.add_argument("--iterations", type=int, default=30)
    ap.add_argument("--workers", type=int, default=os.cpu_count())
    a = ap.parse_args()
    maps = sorted(glob.glob(a.maps))
    if not maps:
        sys.exit(f"no map matches {a.maps}")
    yaws = [float(v) for v in a.yaws.split(",")]
    jobs = [(m, y, a.out, a.size, a.lobes, a.iterations) for m in maps for y in yaws]
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=a.workers) as pool:
        rows = list(pool.map(run_item, jobs))
    seconds = time.perf_counter() - start
    print(json.dumps({"maps": len(maps), "items": len(jobs), "crops": len(jobs) * len(CROPS),
                      "seconds": seconds, "workers": a.workers, "rows": rows}))


if __name__ == "__main__":
    main()
