#!/usr/bin/env python3
"""NumPy peer of hdrflow's seed pipeline: the vectorised script a competent user would write.

    luminance (Rec. 709) -> 2D CDF weighted by sin(theta) (marginal of row sums + conditional per
    row, np.cumsum in float64) -> N samples (np.random.default_rng(seed) + np.searchsorted) at
    texel centres with solid-angle pdf p(x, y) / dOmega(y) -> one shared sample set relights every
    disc pixel of a diffuse sphere with the unbiased estimator
        Lo(n) = (albedo / pi) (1 / N) sum_j L_j max(n . w_j, 0) / pdf_j
    as chunked float32 BLAS products: (k x 3) normals @ (3 x N) dirs, np.maximum(., 0),
    @ (N x 3) weights.

Conventions are hdrflow's (pfm_common.py); the output is comparable pixel for pixel with
`RelightSphere(estimator: Unbiased)` and `ReferenceSphere`.

BLAS threads: OpenBLAS uses every core by default. On a machine that is busy with something
else its threads spin-wait for each other at every chunk's product and the script becomes many
times slower (seen here: 4096 samples at 512 x 512, 0.6 s with 1 thread, 3.4-5.2 s with 2 while
another process was compiling). Benchmark on an idle machine, or pass --threads 1.

Seeds: `--seeds 1,2,...` renders every count once per seed (default: the single `--seed`), one
image and one results.json entry per (count, seed), each with its `seed`.

Timing: the map load is timed once (`load_ms`); each count is run once untimed (warm-up), then
`--repeats` times, on the FIRST seed only, and the median of CDF + sampling + relighting is
reported (`ms`), with the median of its relighting part alone (`relight_ms`: normals + the
chunked products). The other seeds are rendered once, untimed: their `ms` and `relight_ms` are
null (timing does not depend on the seed).
--relight-only times the relighting alone (samples drawn once, untimed): then ms = relight_ms.

--check: also computes the exact reference (sum over every texel; small maps only) and reports
the relative RMSE of each result over the inner disc (sx^2 + sy^2 <= 0.9) and the full disc.
"""

import argparse
import math
import os
import sys
import time


def _early_threads():
    """--threads N must take effect before NumPy (and its OpenBLAS) is imported."""
    for i, a in enumerate(sys.argv):
        val = None
        if a.startswith("--threads="):
            val = a.split("=", 1)[1]
        elif a == "--threads" and i + 1 < len(sys.argv):
            val = sys.argv[i + 1]
        if val is not None:
            for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
                os.environ[var] = val


_early_threads()

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pfm_common as pc  # noqa: E402


def build_cdf(env):
    """Luminance, sin(theta)-weighted 2D CDF. Returns (lum*sin func, total, marginal cdf (H+1,),
    conditional cdf (H, W+1))."""
    h, w = env.shape[:2]
    lum = 0.2126 * env[:, :, 0].astype(np.float64) + 0.7152 * env[:, :, 1] + 0.0722 * env[:, :, 2]
    sin_t = np.sin(math.pi * (np.arange(h) + 0.5) / h)
    func = lum * sin_t[:, None]
    row_sums = func.sum(axis=1)
    total = row_sums.sum()
    marginal = np.concatenate([[0.0], np.cumsum(row_sums)]) / total
    marginal[-1] = 1.0
    cond = np.zeros((h, w + 1))
    cond[:, 1:] = np.cumsum(func, axis=1)
    safe = np.where(row_sums > 0.0, row_sums, 1.0)
    cond /= safe[:, None]
    cond[:, -1] = 1.0
    return func, total, marginal, cond


def sample(env, func, total, marginal, cond, n, seed):
    """n texel-centre samples: (dirs (n, 3) float32, weights L / pdf (n, 3) float32)."""
    h, w = env.shape[:2]
    rng = np.random.default_rng(seed)
    u = rng.random((n, 2))
    y = np.minimum(np.searchsorted(marginal[1:], u[:, 0], side="right"), h - 1)
    # All conditional CDFs in one sorted array: row y's entries shifted by y.
    flat = (cond[:, 1:] + np.arange(h)[:, None]).ravel()
    x = np.clip(np.searchsorted(flat, y + u[:, 1], side="right") - y * w, 0, w - 1)
    theta = math.pi * (y + 0.5) / h
    phi = 2.0 * math.pi * (x + 0.5) / w
    dirs = pc.direction(theta, phi)
    solid_angle = (2.0 * math.pi / w) * (math.pi / h) * np.sin(theta)
    pdf = func[y, x] / total / solid_angle
    weights = env[y, x].astype(np.float64) / pdf[:, None]
    return dirs.astype(np.float32), weights.astype(np.float32)


def relight(size, view, albedo, dirs, weights, n_draws, chunk=None):
    """Shared-sample relighting of every disc pixel, chunked BLAS. float32 (S, S, 3) image."""
    mask, normals = pc.disc_normals(size, view)
    normals = normals.astype(np.float32)
    m, n = normals.shape[0], dirs.shape[0]
    if chunk is None:
        chunk = max(64, (1 << 20) // max(n, 1))
    out = np.empty((m, 3), dtype=np.float32)
    dirs_t = np.ascontiguousarray(dirs.T)
    for i in range(0, m, chunk):
        c = normals[i : i + chunk] @ dirs_t
        np.maximum(c, 0.0, out=c)
        out[i : i + chunk] = c @ weights
    out *= (np.asarray(albedo, dtype=np.float32) / np.float32(math.pi * n_draws))[None, :]
    img = np.zeros((size, size, 3), dtype=np.float32)
    img[mask] = out
    return img


def run(env, size, view, albedo, count, seed):
    """The timed pipeline: (image, total ms, relighting ms)."""
    t0 = time.perf_counter()
    func, total, marginal, cond = build_cdf(env)
    dirs, weights = sample(env, func, total, marginal, cond, count, seed)
    t1 = time.perf_counter()
    img = relight(size, view, albedo, dirs, weights, count)
    t2 = time.perf_counter()
    return img, (t2 - t0) * 1e3, (t2 - t1) * 1e3


def run_relight_only(env, size, view, albedo, count, seed, samples):
    """--relight-only: the samples are drawn once (cached in `samples`, untimed)."""
    if (count, seed) not in samples:
        func, total, marginal, cond = build_cdf(env)
        samples[(count, seed)] = sample(env, func, total, marginal, cond, count, seed)
    dirs, weights = samples[(count, seed)]
    t0 = time.perf_counter()
    img = relight(size, view, albedo, dirs, weights, count)
    ms = (time.perf_counter() - t0) * 1e3
    return img, ms, ms


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", required=True, help="lat-long map, PFM (as written by hdrflow)")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--counts", default="16,64,256,1024,4096")
    ap.add_argument("--view", default="90,90", help="theta,phi in degrees")
    ap.add_argument("--albedo", default="0.8", help="one value or r,g,b")
    ap.add_argument("--seed", type=int, default=1, help="the seed when --seeds is not given")
    ap.add_argument("--seeds", help="comma-separated seeds, one image each (the first is timed); overrides --seed")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out-dir", required=True)
    ap.add_argument("--check", action="store_true", help="compare with the exact reference (small maps)")
    ap.add_argument(
        "--relight-only",
        action="store_true",
        help="time the relighting alone (samples drawn once, untimed); ms = relight_ms",
    )
    ap.add_argument(
        "--threads", type=int, help="BLAS threads (sets OPENBLAS_NUM_THREADS etc.); default: OpenBLAS's own choice"
    )
    args = ap.parse_args()

    counts = pc.parse_counts(args.counts)
    seeds = pc.parse_seeds(args.seeds, args.seed)
    view = pc.sphere_view(*pc.parse_pair(args.view))
    albedo = pc.parse_triple(args.albedo)
    os.makedirs(args.out_dir, exist_ok=True)

    t0 = time.perf_counter()
    env = pc.read_pfm(args.env)
    load_ms = (time.perf_counter() - t0) * 1e3
    if env.shape[2] == 1:
        env = np.repeat(env, 3, axis=2)
    env = env[:, :, :3]
    pc.eprint(f"numpy {np.__version__}: map {env.shape[1]}x{env.shape[0]} loaded in {load_ms:.1f} ms")

    ref = inner = None
    if args.check:
        t = time.perf_counter()
        ref = pc.reference_sphere(env, args.size, view, albedo)
        pc.write_pfm(os.path.join(args.out_dir, "reference.pfm"), ref)
        inner = pc.inner_mask(args.size)
        disc = pc.inner_mask(args.size, 1.0)
        pc.eprint(f"reference: {(time.perf_counter() - t) * 1e3:.0f} ms")

    results = []
    cache = {}
    for count in counts:
        for i, seed in enumerate(seeds):
            if args.relight_only:
                go = lambda: run_relight_only(env, args.size, view, albedo, count, seed, cache)  # noqa: E731
            else:
                go = lambda: run(env, args.size, view, albedo, count, seed)  # noqa: E731
            ms = relight_ms = None
            if i == 0:
                go()  # warm-up, untimed
                times, relight_times = [], []
                img = None
                for _ in range(max(args.repeats, 1)):
                    img, t, relight_t = go()
                    times.append(t)
                    relight_times.append(relight_t)
                ms, relight_ms = float(np.median(times)), float(np.median(relight_times))
            else:
                img = go()[0]  # untimed: timing does not depend on the seed
            name = f"numpy_shared_random_{count}_seed{seed}.pfm"
            pc.write_pfm(os.path.join(args.out_dir, name), img)
            strategy = "numpy shared random" + (" (relight only)" if args.relight_only else "")
            r = {
                "strategy": strategy,
                "count": count,
                "seed": seed,
                "ms": ms,
                "relight_ms": relight_ms,
                "image": name,
            }
            if ms is not None:
                line = f"{strategy}  N={count:6d}  seed {seed}  {ms:9.2f} ms (relighting {relight_ms:.2f} ms)"
            else:
                line = f"{strategy}  N={count:6d}  seed {seed}  (untimed)"
            if ref is not None:
                r["rel_rmse_inner"] = pc.relative_rmse(img, ref, inner)
                r["rel_rmse_disc"] = pc.relative_rmse(img, ref, disc)
                line += f"  rel RMSE inner {r['rel_rmse_inner']:.4%}  disc {r['rel_rmse_disc']:.4%}"
            print(line, flush=True)
            results.append(r)

    out = {
        "peer": "numpy",
        "version": np.__version__,
        "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS", "default"),
        "load_ms": load_ms,
        "seeds": seeds,
        "results": results,
    }
    if ref is not None:
        out["reference"] = "reference.pfm"
    pc.write_results(args.out_dir, out)


if __name__ == "__main__":
    main()
